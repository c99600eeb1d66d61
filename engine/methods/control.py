"""Control features (PriorMDM): which feature dims a control model receives noise-free.

- ``root``: the root trajectory, dims 0-2 (rotation velocity and the XZ linear velocity, no height);
- ``left_wrist`` / ``right_wrist``: that wrist's root-relative position (its 3 ric dims).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from engine.checkpoint import LoadedModel, load_model
from engine.diffusion import CLEAN, CosineSchedule, StepState
from engine.generate import Generation, Request, SampleConfig, denoiser_for, frames_for, generate
from engine.diffusion.feet import PlantedFeet
from engine.methods.control_options import CONTROLS, ControlOptions, blend_shares, option_info
from engine.paths import CONTROL_PRIOR_DIR, shown_folder
from engine.representation import SLICES, ric_dims
from engine.runtime import CPU, Runtime
from engine.skeleton import JOINT_INDEX


def control_dims(name: str) -> np.ndarray:
    if name == "root":
        return np.arange(SLICES["root_lin_vel"].stop)
    if name in ("left_wrist", "right_wrist"):
        return np.array(ric_dims(JOINT_INDEX[name]))
    raise ValueError(f"unknown control {name!r}: choose from {', '.join(CONTROLS)}")


# ----------------------------------------------------------------------------- sampling (Algorithm 2)
@dataclass(frozen=True)
class Control:
    """Raw feature values (T, 3) that the control's dims must take on the first T frames."""

    name: str
    values: np.ndarray

    def __post_init__(self) -> None:
        control_dims(self.name)
        v = np.asarray(self.values)
        if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
            raise ValueError(f"{self.name} control values must be finite, shape (T, 3), got {v.shape}")


@dataclass
class KnownFeatures:
    """Normalised known values on a set of (frame, dim) cells, shared by every slot of the batch."""

    values: torch.Tensor  # (T, D) normalised, zero where unknown
    mask: torch.Tensor  # (T, D) bool

    @classmethod
    def of(cls, controls: list[Control], normalizer, *, frames: int, dim: int) -> "KnownFeatures":
        values, mask = torch.zeros(frames, dim), torch.zeros(frames, dim, dtype=torch.bool)
        for c in controls:
            dims = control_dims(c.name)
            n = min(frames, len(c.values))
            raw = np.asarray(c.values[:n], dtype=np.float64)
            values[:n, dims] = torch.from_numpy((raw - normalizer.mean[dims]) / normalizer.std[dims]).float()
            mask[:n, dims] = True
        return cls(values=values, mask=mask)

    def put(self, x: torch.Tensor, known: torch.Tensor) -> torch.Tensor:
        """x (B, T, D) with the known cells replaced by ``known`` (T, D)."""
        t = min(x.shape[1], known.shape[0])
        m = self.mask[:t]
        out = x.clone()
        out[:, :t] = torch.where(m, known[:t], out[:, :t])
        return out


@dataclass
class Inpaint:
    """Denoiser wrapper: the prediction's known cells are set to the controls (x̂0[control] = c)."""

    denoiser: Callable
    known: KnownFeatures

    def __call__(self, x, t, cond, *, step: int = 0, controller=None):
        x0 = self.denoiser(x, t, cond, step=step, controller=controller)
        return self.known.put(x0, self.known.values.to(x0.dtype))


@dataclass
class KnownLatents:
    """Step-end hook: x_prev's known cells follow the controls at the next noise level.

    ``noise_free`` (PriorMDM Algorithm 2, control models): sqrt(alpha_bar)·c with ε[control] = 0.
    Otherwise (plain MDM inpainting) sqrt(alpha_bar)·c + sqrt(1 - alpha_bar)·ε with fresh noise.
    """

    known: KnownFeatures
    schedule: CosineSchedule
    noise_free: bool = True
    generator: torch.Generator | None = None

    def latent(self, t: int, shape) -> torch.Tensor:
        if t == CLEAN:
            return self.known.values
        ab = self.schedule.alpha_bar(torch.tensor(t)).item()
        noise = 0.0 if self.noise_free else torch.randn(shape, generator=self.generator)
        return ab**0.5 * self.known.values + (1 - ab) ** 0.5 * noise

    def __call__(self, state: StepState) -> StepState:
        return replace(state, x_prev=self.known.put(state.x_prev, self.latent(state.t_next, self.known.values.shape)))


@dataclass
class DiffusionBlending:
    """Denoiser wrapper: Σ sₙ Gₙ(x, t, cond) over control models (each guidance-wrapped), Σ sₙ = 1."""

    denoisers: list
    weights: list[float]

    def __post_init__(self) -> None:
        if not self.denoisers or len(self.denoisers) != len(self.weights):
            raise ValueError("give one weight per control model")
        w = np.asarray(self.weights, dtype=np.float64)
        if not np.isfinite(w).all() or abs(w.sum() - 1.0) > 1e-6:
            raise ValueError(f"blend weights must sum to 1, got {list(self.weights)}")

    def __call__(self, x, t, cond, *, step: int = 0, controller=None):
        out = None
        for g, w in zip(self.denoisers, self.weights):
            x0 = g(x, t, cond, step=step, controller=controller)
            out = w * x0 if out is None else out + w * x0
        return out


def normalized_weights(weights, n: int) -> list[float]:
    """Equal weights by default; given weights (one per control) are scaled to sum to 1 by the one blend-weight rule,
    :func:`engine.methods.control_options.blend_shares` (finite, none negative, not all 0)."""
    return blend_shares(weights, [f"control {i + 1}" for i in range(n)])


@dataclass(frozen=True)
class ControlPlan:
    """What sampling under controls adds to a plain generation: the starting noise with the controls' cells in it,
    the wrapped denoiser and the step-end hook (:func:`control_plan`). Any sampling of the loop takes it."""

    noise: torch.Tensor | None  # (1, T, 263) the seed's noise, the controls' cells at the first timestep's level
    denoiser: Callable | None
    hooks: tuple


#: sampling without controls: the seed's own noise, the model's own prediction, no hook
PLAIN_PLAN = ControlPlan(noise=None, denoiser=None, hooks=())


def control_plan(loaded: LoadedModel, controls: list[Control], *, frames: int,
                 models: dict[str, LoadedModel] | None = None, weights=None, sample: SampleConfig = SampleConfig(),
                 planted_feet: bool = option_info(ControlOptions, "planted_feet").default) -> ControlPlan:
    """The noise, denoiser and hook that make a generation of ``frames`` follow ``controls`` (see
    :func:`controlled`, which samples with them)."""
    if not controls:
        raise ValueError("give at least one control (a root or wrist path)")
    names = [c.name for c in controls]
    if len(set(names)) != len(names):
        raise ValueError(f"each control at most once, got {names}")
    if models is None and weights is not None:
        raise ValueError("blend weights apply to blending (the fine-tuned control models), not to inpainting")
    known = KnownFeatures.of(controls, loaded.normalizer, frames=frames, dim=loaded.model.config.feature_dim)
    schedule = CosineSchedule()
    g = torch.Generator().manual_seed(sample.seed)
    noise = torch.randn(1, frames, loaded.model.config.feature_dim, generator=g)
    if models is not None:
        missing = [n for n in names if n not in models]
        if missing:
            raise FileNotFoundError(f"no control model for {', '.join(missing)}")
        denoisers = [denoiser_for(models[n], sample) for n in names]
        base = DiffusionBlending(denoisers, blend_shares(ControlOptions().weights() if weights is None else weights,
                                                         names))
        noise_free = True
    else:
        base = denoiser_for(loaded, sample)
        noise_free = False
    hook = KnownLatents(known, schedule, noise_free=noise_free, generator=g)
    noise = known.put(noise, hook.latent(schedule.timesteps(sample.steps)[0], known.values.shape))
    denoiser = Inpaint(base, known)
    if planted_feet:
        denoiser = PlantedFeet(denoiser, loaded.normalizer)
    return ControlPlan(noise=noise, denoiser=denoiser, hooks=(hook,))


def controlled(loaded: LoadedModel, prompt: str, controls: list[Control], *, seconds: float,
               models: dict[str, LoadedModel] | None = None, weights=None,
               sample: SampleConfig = SampleConfig(), on_step=None,
               planted_feet: bool = option_info(ControlOptions, "planted_feet").default) -> Generation:
    """Text + controls -> motion. With ``models`` (name -> fine-tuned control model): each control's
    model, blended (DiffusionBlending) with ``weights`` (None: the declared defaults, ``ControlOptions``'s: the root 1,
    a wrist 1/4; one per control in order, or control name -> raw weight; scaled to sum 1 by
    :func:`~engine.methods.control_options.blend_shares`), controls noise-free
    (Algorithm 2). Without: plain inpainting with ``loaded`` (the baseline), which takes no weights.
    ``planted_feet``: either method's prediction is wrapped in :class:`~engine.diffusion.feet.PlantedFeet` (the legs
    move so feet on the floor stay put; the root and the wrists, the controlled cells, are left as they are)."""
    frames = frames_for(seconds)
    plan = control_plan(loaded, controls, frames=frames, models=models, weights=weights, sample=sample,
                        planted_feet=planted_feet)
    return generate(loaded, Request(prompts=[prompt], frames=[frames], noise=plan.noise), sample, hooks=plan.hooks,
                    denoiser=plan.denoiser, on_step=on_step)


def control_name(loaded: LoadedModel) -> str:
    """The control a model folder was fine-tuned for ("" for a base model)."""
    return str(loaded.config.get("train", {}).get("control", "") or "")


def load_controls(folder, *, runtime: Runtime = CPU) -> dict[str, LoadedModel]:
    """Every control model under ``folder`` (one sub-folder per control), on ``runtime``'s device."""
    out = {}
    root = Path(folder)
    for name in CONTROLS:
        if (root / name / "config.json").exists():
            m = load_model(root / name, runtime=runtime)
            if control_name(m) != name:
                raise ValueError(f"{root / name} holds a model fine-tuned for {control_name(m)!r}, not {name!r}")
            out[name] = m
    return out


def same_base(base: LoadedModel, model: LoadedModel) -> bool:
    """Whether a control model was fine-tuned from ``base`` (same vocabulary and feature statistics):
    only such models can be blended, and only they read the base's normalised features."""
    try:
        return (tuple(base.tokenizer.words) == tuple(model.tokenizer.words)
                and np.allclose(base.normalizer.mean, model.normalizer.mean, atol=1e-5)
                and np.allclose(base.normalizer.std, model.normalizer.std, atol=1e-5))
    except (AttributeError, ValueError):
        return False


# ----------------------------------------------------------------------------- the base control runs on
RETRAIN = "moattn train control --control NAME --init-from assets/model --out assets/control/NAME"


def prior_folder(controls_folder) -> Path:
    """Where a controls folder ships its own copy of the base model its control models were fine-tuned on."""
    return Path(controls_folder) / CONTROL_PRIOR_DIR.name


def load_prior(controls_folder, *, runtime: Runtime = CPU) -> LoadedModel | None:
    """The base model shipped beside the control models in ``controls_folder`` (``prior/``), or None."""
    folder = prior_folder(controls_folder)
    return load_model(folder, runtime=runtime) if (folder / "config.json").exists() else None


@dataclass
class ControlBase:
    """The base model control runs on (inpainting and blending alike) and the control models that blend with it."""

    loaded: LoadedModel
    models: dict[str, LoadedModel]
    note: str = ""  # one line when ``loaded`` is the control models' own prior, not the given base; "" otherwise
    odd: tuple[str, ...] = ()  # control models found that blend with neither (other vocabulary or statistics)

    @property
    def on_prior(self) -> bool:
        return bool(self.note)


def prior_note(prior: LoadedModel, folder) -> str:
    """The visible line saying control runs on the control models' own base, and how to end that."""
    return (f"control runs on the step-{prior.config.get('step', '?')} base its control models belong to "
            f"({shown_folder(folder)}), not the loaded one; re-fine-tune them on the new base with `{RETRAIN}`")


def control_base(base: LoadedModel, models: dict[str, LoadedModel], *, folder,
                 prior: LoadedModel | None | Callable[[], LoadedModel | None] = None) -> ControlBase:
    """Which base model control runs on, given the loaded ``base`` and the control ``models`` found in ``folder``.

    ``base`` itself when every control model blends with it (same vocabulary and feature statistics: nothing
    changes). Otherwise the base shipped beside them (``folder/prior``, issue #32: the base model moved on to a
    grown vocabulary before the control models were re-fine-tuned) when more of them blend with that one; then
    inpainting runs on it too, and ``note`` says so. ``prior``: that model already loaded, or a callable loading it
    (default: :func:`load_prior` on ``base``'s runtime), read only when ``base`` does not fit.
    """
    fits = {n: m for n, m in models.items() if same_base(base, m)}
    if len(fits) == len(models):
        return ControlBase(base, dict(models))
    if prior is None:
        prior = load_prior(folder, runtime=base.runtime)
    elif callable(prior):
        prior = prior()
    if prior is not None:
        own = {n: m for n, m in models.items() if same_base(prior, m)}
        if len(own) > len(fits):
            return ControlBase(prior, own, note=prior_note(prior, prior_folder(folder)),
                               odd=tuple(n for n in models if n not in own))
    return ControlBase(base, fits, odd=tuple(n for n in models if n not in fits))
