"""Step-end hooks shared by methods: pin slots to fixed latent paths, copy feature dims between slots."""
from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from engine.diffusion import StepState


@dataclass
class PinTrajectory:
    """Step-end hook: batch slots follow fixed latent paths (e.g. their inversion trajectories).

    ``paths[slot]`` maps timestep -> latent (1, T_slot, D); after each step the slot's x_prev (its
    first T_slot frames) is set to the latent at the step's target timestep. A pinned slot thus
    reproduces its real motion exactly whatever the guidance, while its attention (Q, K, V) is the
    model's reading of that motion at every step. Pinned slots must not be mixed into.
    """

    paths: dict[int, dict[int, torch.Tensor]]

    def __call__(self, state: StepState) -> StepState:
        x_prev = None
        for slot, path in self.paths.items():
            if state.t_next not in path:
                raise KeyError(f"the pinned path of slot {slot} has no latent for timestep {state.t_next}: "
                               "invert with the same number of steps as the sampler")
            latent = path[state.t_next]
            if x_prev is None:
                x_prev = state.x_prev.clone()
            n = latent.shape[1]
            x_prev[slot, :n] = latent[0].to(x_prev.dtype)
        return state if x_prev is None else replace(state, x_prev=x_prev)


@dataclass
class KeepDims:
    """Step-end hook: ``dims`` of the target slots <- those of the source slot (first ``frames``).

    Inpainting from a slot of the same batch: when the targets start from the source's noise, the
    source's latent at every step is exactly what the targets' kept dims should be.
    """

    source: int
    targets: tuple[int, ...]
    dims: torch.Tensor  # (K,) long feature indices
    frames: int

    def __call__(self, state: StepState) -> StepState:
        x_prev = state.x_prev.clone()
        for target in self.targets:
            x_prev[target, : self.frames, self.dims] = state.x_prev[self.source, : self.frames, self.dims]
        return replace(state, x_prev=x_prev)
