"""DDIM inversion of real motions: motion -> noise that the model maps back to the motion."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from engine.attention.context import BatchRoles, WordIndex
from engine.checkpoint import LoadedModel
from engine.diffusion import ClassifierFreeGuidance, CosineSchedule, ddim, ddim_invert, final
from engine.diffusion.sampler import CLEAN
from engine.io.window import pick_window
from engine.methods.inversion_options import InversionConfig  # noqa: F401 (declared torch-free; its home here)
from engine.model.denoiser import Condition
from engine.representation import features_to_joints, joints_to_features


@dataclass
class Inverted:
    noise: torch.Tensor  # (1, T, 263)
    x0: torch.Tensor  # (1, T, 263) normalised features of the input
    features: np.ndarray  # (T, 263) the input's features
    cond: Condition
    # timestep -> latent (1, T, 263) on the inversion's path (CLEAN -> x0): what a sampler with the
    # same number of steps should see at each timestep to rebuild the motion exactly
    trajectory: dict[int, torch.Tensor] = field(default_factory=dict)


def motion_condition(loaded: LoadedModel, prompt: str, frames: int, *, role: str = "out") -> Condition:
    if prompt.strip():
        tokens = loaded.tokenizer.encode(prompt)
        ids, mask = loaded.tokenizer.batch([tokens])
        words = WordIndex(words=(tokens.words,))
        use_text = torch.ones(1, dtype=torch.bool)
    else:
        ids, mask = torch.zeros(1, 1, dtype=torch.long), torch.zeros(1, 1, dtype=torch.bool)
        words = WordIndex(words=((),))
        use_text = torch.zeros(1, dtype=torch.bool)
    # the inversion and the rebuild from its noise keep their input through the prediction's skip, where the model
    # has one (ModelConfig.skip_sigma): the round trip of a motion unlike the corpus survives the last steps
    return Condition(text_ids=ids, text_mask=mask, frame_mask=torch.ones(1, frames, dtype=torch.bool),
                     use_text=use_text, roles=BatchRoles.of(role), words=words).keeping_input()


def invert(loaded: LoadedModel, joints: np.ndarray, config: InversionConfig = InversionConfig()) -> Inverted:
    pick_window(joints, max_frames=loaded.model.config.max_frames)  # a motion over the model's limit: one-line hint
    with np.errstate(invalid="ignore", divide="ignore"):
        features = joints_to_features(joints)
    if not np.isfinite(features).all():
        raise ValueError(_DEGENERATE + " (its features are NaN)")
    x0 = torch.from_numpy(loaded.normalizer.normalize(features)).float()[None]
    cond = motion_condition(loaded, config.prompt, x0.shape[1])
    denoiser = _denoiser(loaded, config)
    trajectory = {CLEAN: x0}
    state = None
    for state in ddim_invert(denoiser, x0, cond, schedule=CosineSchedule(), num_steps=config.steps, refine=config.refine,
                              landing=config.landing):
        trajectory.setdefault(state.t, state.x_t)  # the first: the latent at the smallest t (the landing's)
        trajectory[state.t_next] = state.x_prev
    if not torch.isfinite(state.x_prev).all():
        raise ValueError(_DEGENERATE + " (the inverted noise is NaN or infinite)")
    return Inverted(noise=state.x_prev, x0=x0, features=features, cond=cond, trajectory=trajectory)


_DEGENERATE = ("this motion cannot be inverted: it is degenerate, e.g. every joint at one point or a body without "
               "length")


def reconstruct(loaded: LoadedModel, inverted: Inverted, config: InversionConfig = InversionConfig()) -> np.ndarray:
    """Sample back from the inverted noise -> joints (T, 22, 3)."""
    state = final(ddim(_denoiser(loaded, config), inverted.noise, inverted.cond, schedule=CosineSchedule(),
                       num_steps=config.steps))
    features = loaded.normalizer.denormalize(state.x_prev[0].numpy())
    return features_to_joints(features)


def roundtrip_error(loaded: LoadedModel, joints: np.ndarray, config: InversionConfig = InversionConfig()) -> dict:
    """Invert ``joints``, sample back from the noise and measure the round trip (:func:`roundtrip_figures`)."""
    inverted = invert(loaded, joints, config)
    return roundtrip_figures(inverted, reconstruct(loaded, inverted, config))


def roundtrip_figures(inverted: Inverted, back: np.ndarray) -> dict:
    """Mean and max joint position error (m) of the motion sampled back from the inverted noise (``back``, (T, 22,
    3)) against the input's own feature decoding (so the representation's rounding is not counted); ``pose_mean_m``,
    the mean error of the joints relative to the root (the pose, without the root's path, which integrates the root's
    velocities and drifts); and the standard deviation of the inverted noise (``noise_std``; the Gaussian noise the
    model samples from has 1)."""
    target = features_to_joints(inverted.features)
    err = np.linalg.norm(back - target, axis=-1)
    if not np.isfinite(err).all():
        raise ValueError(_DEGENERATE + " (the round trip gave NaN or infinite positions)")
    pose = np.linalg.norm((back - back[:, :1]) - (target - target[:, :1]), axis=-1)  # (T, J) the root's path taken out
    return {"mean_m": float(err.mean()), "max_m": float(err.max()), "pose_mean_m": float(pose.mean()),
            "frames": int(len(target)), "noise_std": float(inverted.noise.std())}


def _denoiser(loaded: LoadedModel, config: InversionConfig):
    if config.guidance != 1.0:
        return ClassifierFreeGuidance(loaded.model, scale=config.guidance)
    return loaded.model
