"""Two people with ComMDM: text-to-duet and prefix completion (the CLI, the app and the bench call these).

A duet model folder holds ``config.json`` (the block's config, the new words, the prior's
fingerprint, the training mean placement, how it was trained) and ``weights.pt`` (fp16: the block
and the new word rows only). It runs only on the prior it was trained on; a folder may ship that prior
in ``prior/`` (a model folder), which it then runs on when it is given another base model (a newer one).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from engine.attention.context import WordIndex
from engine.checkpoint import TRAIN_STATE, WEIGHTS, LoadedModel, load_model, load_train_state, read_config
from engine.diffusion import CosineSchedule, StepState, ddim
from engine.generate import FPS, SampleConfig, frames_for
from engine.methods.commdm import (PLACE_DIMS, ComConfig, DuetDenoiser, Pose, PriorTwice, duet_roles,
                                   fingerprint, mean_pose, placements, unpack)
from engine.methods.control import Inpaint, KnownLatents
from engine.methods.duet_contact import ContactConfig, ContactGuidance, ContactPlan, plans_for
from engine.methods.duet_spacing import Spacing, keep_apart
from engine.model.denoiser import Condition
from engine.representation import features_to_joints, joints_to_features
from engine.text import TokenizedPrompt, Tokenizer

# a completion: the prefix given, the seconds completed; a duet from a prompt (one home: engine.units)
from engine.units import DUET_COMPLETE_SECONDS as COMPLETE_SECONDS, DUET_PREFIX_SECONDS as PREFIX_SECONDS  # noqa: E402
from engine.units import DUET_SECONDS as TEXT_SECONDS  # noqa: E402
PRIOR_FOLDER = "prior"  # a duet folder's own copy of the base model its block was trained on


@dataclass
class DuetModel:
    prior: LoadedModel
    denoiser: DuetDenoiser
    tokenizer: Tokenizer  # the prior's words, then the duet's
    mean_place: Pose  # the training set's mean placement (the baseline's guess)
    config: dict
    folder: Path | None = None

    @property
    def normalizer(self):
        return self.prior.normalizer

    @property
    def contact_table(self) -> dict:
        """What the training duets say touches and when (``duet_contact.learn_plans``); older
        models, saved without it, get it from their recorded few-shot set."""
        if "contacts" not in self.config:
            from engine.methods.duet_contact import learn_plans
            from engine.methods.duet_data import few_shot

            train = self.config.get("train", {})
            samples = few_shot("train", per_interaction=int(train.get("shots", 6)), seed=int(train.get("seed", 0)))
            self.config["contacts"] = learn_plans(samples)
        return self.config["contacts"]


def new_duet(prior: LoadedModel, words, *, config: ComConfig = ComConfig(), mean_place: Pose = Pose(0.0, 1.0, np.pi),
             seed: int = 0) -> DuetModel:
    """An untrained duet model on ``prior`` whose tokenizer also knows ``words``."""
    tokenizer = prior.tokenizer.extended(words)  # the duet's new words get ids after the prior's
    torch.manual_seed(seed)
    known = len(prior.tokenizer) - 1
    denoiser = DuetDenoiser(prior.model, known_words=known, new_words=len(tokenizer) - 1 - known, config=config)
    denoiser.to(prior.model.device)  # the block lives where its prior does
    # the block's layer as a number (not "0 = the last"): a folder records the layer it was trained after
    return DuetModel(prior=prior, denoiser=denoiser, tokenizer=tokenizer, mean_place=mean_place,
                     config={"com": config.resolved(prior.model.num_layers).to_json(),
                             "words": list(tokenizer.words[len(prior.tokenizer):]),
                             "prior": fingerprint(prior), "mean_place": mean_place.vector().tolist()})


def load_duet(folder: str | Path, prior: LoadedModel, *, prefer: str = "weights") -> DuetModel:
    """A trained duet model on its prior (clear errors for a missing folder or another prior), its block after the
    layer its ``config.json`` records (``com.after``; 0 = the last)."""
    folder = Path(folder)
    config = read_config(folder)
    if config.get("kind") != "commdm":
        raise ValueError(f"{folder} is not a ComMDM duet model")
    prior = _own_prior(folder, config, prior)
    model = new_duet(prior, config["words"], config=ComConfig.from_json(config["com"]),
                     mean_place=Pose.of_vector(config["mean_place"]))
    if prefer == "ema" and (folder / TRAIN_STATE).exists():
        state = load_train_state(folder)["ema"]
    elif (folder / WEIGHTS).exists():
        state = torch.load(folder / WEIGHTS, map_location="cpu", weights_only=True)
    else:
        raise FileNotFoundError(f"no {WEIGHTS} in {folder}")
    missing = set(model.denoiser.trainable()) - set(state)
    if missing:
        raise ValueError(f"{folder / WEIGHTS} lacks {sorted(missing)[:3]}")
    model.denoiser.load_state_dict({k: v.float() for k, v in state.items()}, strict=False)  # copied to its device
    model.denoiser.eval()
    for p in model.denoiser.parameters():
        p.requires_grad_(False)
    model.config, model.folder = config, folder
    return model


def _own_prior(folder: Path, config: dict, given: LoadedModel) -> LoadedModel:
    """``given`` when the block was trained on it, else the copy of its prior that ``folder`` ships."""
    if config["prior"] == fingerprint(given):
        return given
    shipped = folder / PRIOR_FOLDER
    if (shipped / WEIGHTS).exists():
        own = load_model(shipped, runtime=given.runtime)
        if config["prior"] == fingerprint(own):
            return own
        raise ValueError(f"{shipped} is not the base model the duet block in {folder} was trained on")
    raise ValueError(f"the duet model in {folder} was trained on another base model "
                     f"(step {config.get('prior_step', '?')}); retrain it with `moattn train --commdm`")


# ----------------------------------------------------------------------------- sampling
@dataclass
class Duet:
    """Two people in one frame (person a's canonical frame at frame 0)."""

    joints: np.ndarray  # (2, T, 22, 3) metres
    placement: Pose  # person b seen from person a
    features: np.ndarray  # (2, T, 263) each person in its own canonical frame, as sampled (before any spacing)
    prompt: str | None
    communicate: bool
    interaction: str | None = None  # what contact guidance read the prompt as (None: no guidance)
    contacts: tuple[ContactPlan, ...] = ()  # the contacts it guided
    spacing: Spacing | None = None  # how person b was moved to keep the spacing rule (None: not applied)

    @property
    def frames(self) -> int:
        return self.joints.shape[1]


def by_person(joints: np.ndarray) -> dict[str, np.ndarray]:
    """(2, T, 22, 3) -> {"person a": ..., "person b": ...} (how renders and scenes name the two)."""
    return {"person a": joints[0], "person b": joints[1]}


@dataclass
class KnownCells:
    """Per-slot known cells of duet states (the prefix and placement of a completion)."""

    values: torch.Tensor  # (B, T + 1, D)
    mask: torch.Tensor  # (B, T + 1, D) bool

    def put(self, x: torch.Tensor, known: torch.Tensor) -> torch.Tensor:
        reps = x.shape[0] // self.mask.shape[0]  # guidance doubles the batch
        return torch.where(self.mask.repeat(reps, 1, 1), known.repeat(reps, 1, 1), x)


def _condition(model: DuetModel, prompt: str | None, frames: int, pairs: int = 1) -> Condition:
    tok = model.tokenizer
    token = tok.encode(prompt) if prompt is not None else TokenizedPrompt(prompt="", words=(), ids=())
    tokens = [token] * (2 * pairs)
    ids, mask = tok.batch(tokens)
    frame_mask = torch.zeros(2 * pairs, frames + 1, dtype=torch.bool)
    frame_mask[:, :frames] = True
    return Condition(text_ids=ids, text_mask=mask, frame_mask=frame_mask,
                     use_text=torch.full((2 * pairs,), prompt is not None), roles=duet_roles(pairs),
                     words=WordIndex(words=tuple(t.words for t in tokens)))


def _denoiser(model: DuetModel, sample: SampleConfig, communicate: bool):
    inner = model.denoiser if communicate else PriorTwice(model.denoiser, torch.from_numpy(model.mean_place.vector()))
    return sample.guided(inner)


def _sample(model: DuetModel, cond: Condition, frames: int, sample: SampleConfig, *, communicate: bool,
            known: KnownCells | None, on_step: Callable[[StepState], None] | None,
            contacts: tuple[ContactPlan, ...] = (), contact: ContactConfig | None = None) -> torch.Tensor:
    """DDIM over duet states; known cells follow the truth noise-free when the block was trained so
    (``prefix_noise_free``), otherwise with fresh noise (plain MDM inpainting, what the prior alone knows)."""
    if sample.sampler != "ddim":
        raise ValueError("duets are sampled with DDIM")
    g = torch.Generator().manual_seed(sample.seed)
    schedule = CosineSchedule()
    noise = torch.randn(len(cond), frames + 1, model.prior.model.config.feature_dim, generator=g)
    denoiser = _denoiser(model, sample, communicate)
    if contacts and contact is not None and contact.active:
        denoiser = ContactGuidance(denoiser, contacts, model.normalizer, contact)
    hooks = []
    if known is not None:
        noise_free = communicate and bool(model.config.get("prefix_noise_free", False))
        hook = KnownLatents(known, schedule, noise_free=noise_free, generator=g)
        noise = known.put(noise, hook.latent(schedule.timesteps(sample.steps)[0], known.values.shape))
        hooks.append(hook)
        denoiser = Inpaint(denoiser, known)
    last = None
    for last in ddim(denoiser, noise, cond, schedule=schedule, num_steps=sample.steps, eta=sample.eta, hooks=hooks):
        if on_step is not None:
            on_step(last)
    return last.x_prev


def _finish(model: DuetModel, x0: torch.Tensor, *, prompt, communicate: bool, place: Pose | None = None) -> Duet:
    motion, places = unpack(x0)  # (2, T, D), (2, 4)
    feats = model.normalizer.denormalize(motion.detach().numpy())
    canon = features_to_joints(feats)  # (2, T, 22, 3)
    if place is None:
        place = combined_placement(places.detach().numpy())
    joints = np.stack([canon[0], place.place(canon[1])]).astype(np.float32)
    return Duet(joints=joints, placement=place, features=feats, prompt=prompt, communicate=communicate)


def combined_placement(places: np.ndarray) -> Pose:
    """One placement of b from both persons' predictions (b seen from a; a seen from b, inverted)."""
    seen_by_a = Pose.of_vector(_unit_yaw(places[0]))
    from_b = Pose.of_vector(_unit_yaw(places[1])).inverse()
    return mean_pose([seen_by_a, from_b])


def _unit_yaw(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64).copy()
    if np.hypot(v[2], v[3]) < 1e-6:
        v[2:] = (1.0, 0.0)
    return v


def text_to_duet(model: DuetModel, prompt: str, *, seconds: float = 5.0, sample: SampleConfig = SampleConfig(),
                 communicate: bool = True, contact: ContactConfig | None = ContactConfig(), spacing: bool = True,
                 on_step=None) -> Duet:
    """Two people from one prompt (both persons read it). With ``contact`` (and a prompt that reads
    as a training interaction with contacts) the hands are guided to touch when the examples do
    (``duet_contact``); ``contact=None`` samples the block alone. With ``spacing`` person b is moved
    apart where the two would start inside each other (``duet_spacing``; ``Duet.spacing`` says how)."""
    frames = frames_for(seconds)
    cond = _condition(model, prompt, frames)
    interaction, plans = plans_for(model.contact_table, prompt) if contact is not None or spacing else (None, [])
    guided = tuple(plans) if contact is not None else ()
    x0 = _sample(model, cond, frames, sample, communicate=communicate, known=None, on_step=on_step,
                 contacts=guided, contact=contact)
    duet = _finish(model, x0, prompt=prompt, communicate=communicate)
    if contact is not None and contact.active:
        duet.interaction, duet.contacts = interaction, guided
    return space_apart(duet, interaction) if spacing else duet


def space_apart(duet: Duet, interaction: str | None) -> Duet:
    """``duet`` with person b moved apart where the two break the spacing rule of ``interaction`` (None: a prompt
    that reads as no interaction), its placement following b's first frame; ``features`` stay as sampled."""
    joints, spacing = keep_apart(duet.joints, interaction)
    duet.spacing = spacing
    if spacing.moved:
        dx, _, dz = spacing.offset[0]
        p = duet.placement
        duet.joints, duet.placement = joints, Pose(x=p.x + float(dx), z=p.z + float(dz), yaw=p.yaw)
    return duet


def check_prefix(joints: np.ndarray, what: str) -> np.ndarray:
    j = np.asarray(joints, dtype=np.float32)
    if j.ndim != 3 or j.shape[1:] != (22, 3):
        raise ValueError(f"{what} must be joints (T, 22, 3), got shape {j.shape}")
    if not np.isfinite(j).all():
        raise ValueError(f"{what} has non-finite values")
    return j


def complete(model: DuetModel, prefix_a: np.ndarray, prefix_b: np.ndarray, *, prefix_seconds: float = PREFIX_SECONDS,
             seconds: float = COMPLETE_SECONDS, prompt: str | None = None, sample: SampleConfig = SampleConfig(guidance=1.0),
             communicate: bool = True, on_step=None) -> Duet:
    """Given ``prefix_seconds`` of both people (joints in one frame, at least that long plus one frame),
    complete the next ``seconds``. Text is masked unless a prompt is given (as in the paper).
    Joints come back in person a's canonical frame at the prefix's first frame."""
    a, b = check_prefix(prefix_a, "person a's prefix"), check_prefix(prefix_b, "person b's prefix")
    given = int(round(prefix_seconds * FPS))
    if given < 2:
        raise ValueError("the prefix must be at least 0.1 s")
    if len(a) < given + 1 or len(b) < given + 1:
        raise ValueError(f"a {prefix_seconds:g} s prefix needs {given + 1} frames of both people, "
                         f"got {len(a)} and {len(b)}")
    frames = given + frames_for(seconds)
    if frames > model.prior.model.config.max_frames:
        raise ValueError(f"{prefix_seconds:g} s + {seconds:g} s is longer than the model's "
                         f"{model.prior.model.config.max_frames / FPS:g} s")
    a, b = a[: given + 1], b[: given + 1]
    b_from_a, a_from_b = placements(a, b)
    feats = np.stack([joints_to_features(a), joints_to_features(b)])  # (2, given, D)
    values = torch.zeros(2, frames + 1, model.prior.model.config.feature_dim)
    mask = torch.zeros_like(values, dtype=torch.bool)
    values[:, :given] = torch.from_numpy(model.normalizer.normalize(feats)).float()
    mask[:, :given] = True
    values[:, frames, :PLACE_DIMS] = torch.from_numpy(np.stack([b_from_a.vector(), a_from_b.vector()]))
    mask[:, frames, :PLACE_DIMS] = True
    cond = _condition(model, prompt, frames)
    x0 = _sample(model, cond, frames, sample, communicate=communicate, known=KnownCells(values, mask), on_step=on_step)
    duet = _finish(model, x0, prompt=prompt, communicate=communicate, place=b_from_a)
    # back from person a's canonical frame to the caller's, each person at its own floor height again
    pose_a = Pose.of_joints(a)
    floors = np.array([a[..., 1].min(), b[..., 1].min()], dtype=np.float32)
    duet.joints = np.stack([pose_a.place(j) for j in duet.joints]).astype(np.float32)
    duet.joints[..., 1] += floors[:, None, None]
    return duet
