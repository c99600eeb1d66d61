"""MoMo's transfer settings (the step and layer window, the root, the footwork): one declaration, read by the method,
the CLI's flags and the studio's Transfer tab. Torch-free, so a command line's parser can read its defaults."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

ROOT_MODES = ("trajectory", "rotation", "none")


@dataclass(frozen=True)
class TransferConfig:
    """Where the output mixes, and how.

    ``start``/``end``: fractions of the sampling steps (paper: steps 90 -> 10 of 100 = 0.1 -> 0.9).
    ``layers``: 0-based blocks that mix; None = every layer but the first (paper: 2-12 of 12).
    ``root``: what the output takes from the leader's root
      - "trajectory" (default): the root's rotation and linear velocity are inpainted from the
        leader at every step, so the output follows the leader's path on the floor and the body is
        generated for it (the root height stays the output's: a crouched follower stays low);
      - "rotation": the paper's fix, the leader's root angular velocity copied into the finished
        output (keeps the direction, the output's own speed and path shape);
      - "none": the output's own root.
    ``hard``: arg-max instead of softmax (the latent nearest-neighbour baseline).
    ``feet``: also keep the leader's footwork (not in the paper): its foot-contact labels and the feet and
      ankles' root-relative positions are inpainted into the outputs at every step, so the output steps
      exactly where and when the leader does and the follower shows in the rest of the body (its own
      gait style and walk -> run changes are given up).
    """

    start: float = 0.1
    end: float = 0.9
    layers: tuple[int, ...] | None = None
    root: Literal["trajectory", "rotation", "none"] = "trajectory"
    hard: bool = False
    feet: bool = False

    def __post_init__(self) -> None:
        if self.root not in ROOT_MODES:
            raise ValueError(f"root must be 'trajectory', 'rotation' or 'none', got {self.root!r}")
        from engine.methods.windows import Window

        Window(self.start, self.end)  # validates the step window

    def window(self, n_layers: int):
        from engine.methods.windows import Window

        layers = tuple(range(1, n_layers)) if self.layers is None else tuple(self.layers)
        if not layers:
            raise ValueError("mixed attention needs at least one layer")
        return Window(self.start, self.end, layers=layers).check_layers(n_layers)
