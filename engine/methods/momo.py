"""MoMo ("Monkey See, Monkey Do"): leader -> follower motion transfer by mixed self-attention.

Three kinds of streams share one batch with named roles: the ``leader`` (what and when: outline,
timing), one ``follower`` per requested follower (how: motifs) and one ``out`` per follower. Each
``out`` starts from the leader's noise with its follower's prompt; inside the layer and step
window its self-attention takes Q from the leader and K, V from its follower (Eq. 4 of the
paper), elsewhere its own. A leader or follower is either generated from text or a real motion
DDIM-inverted and pinned to its inversion path (so it rebuilds the real motion exactly while the
model reads it). The output has the leader's length and, by default, the leader's root
trajectory (see ``TransferConfig.root``; the paper copies only the root rotation).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from engine.analysis.qk import analysis_sites, analyze_transfer
from engine.attention import AttentionStore, StoreConfig, stack
from engine.checkpoint import LoadedModel
from engine.generate import Request, SampleConfig, frames_for, generate
from engine.methods.edits import EditOutput, OnStep
from engine.methods.hooks import KeepDims, PinTrajectory
from engine.methods.inversion import InversionConfig, invert, reconstruct
from engine.methods.mixing import MixConfig, MixedAttention
from engine.methods.transfer_config import ROOT_MODES, TransferConfig  # noqa: F401  (its home; read by the CLI)
from engine.representation import SLICES, features_to_joints, joints_to_features, ric_dims
from engine.skeleton import FOOT_JOINTS

LEADER, FOLLOWER, OUT = "leader", "follower", "out"
MAX_FOLLOWERS = 8


@dataclass(frozen=True)
class Source:
    """A leader or follower: a prompt to generate from, or a real motion (joints) to invert.

    For a real motion ``prompt`` optionally describes it (guides the inversion and the stream);
    ``name`` labels it in figures and the app.
    """

    prompt: str | None = None
    joints: np.ndarray | None = None
    seconds: float = 5.0
    name: str = ""

    def __post_init__(self) -> None:
        if self.joints is None and not (self.prompt or "").strip():
            raise ValueError("a leader or follower needs a prompt or a motion")

    @property
    def label(self) -> str:
        return self.name or (self.prompt if self.joints is None else (self.prompt or "imported motion")) or ""


@dataclass
class Stream:
    """A source made ready for the batch."""

    source: Source
    prompt: str | None  # the prompt the stream is conditioned on (None = unconditional)
    noise: torch.Tensor  # (1, T, D)
    frames: int
    path: dict[int, torch.Tensor] | None = None  # pinned inversion trajectory (real motions)
    inversion: dict | None = None  # round-trip error of plain DDIM sampling from the inverted noise

    @property
    def inverted(self) -> bool:
        return self.path is not None


def prepare(loaded: LoadedModel, source: Source, *, seed: int, steps: int, measure_inversion: bool = True) -> Stream:
    """Noise (and for a real motion the pinned inversion path) for one leader or follower."""
    if source.joints is None:
        loaded.tokenizer.encode(source.prompt)  # unknown words fail here, with suggestions
        frames = frames_for(source.seconds)
        g = torch.Generator().manual_seed(seed)
        noise = torch.randn(1, frames, loaded.model.config.feature_dim, generator=g)
        return Stream(source=source, prompt=source.prompt, noise=noise, frames=frames)
    prompt = (source.prompt or "").strip()
    if prompt:
        loaded.tokenizer.encode(prompt)
    config = InversionConfig(prompt=prompt, steps=steps)
    inverted = invert(loaded, np.asarray(source.joints), config)
    error = None
    if measure_inversion:
        back = reconstruct(loaded, inverted, config)
        target = features_to_joints(inverted.features)
        err = np.linalg.norm(back - target, axis=-1)
        error = {"mean_m": float(err.mean()), "max_m": float(err.max())}
    return Stream(source=source, prompt=prompt or None, noise=inverted.noise, frames=inverted.noise.shape[1],
                  path=inverted.trajectory, inversion=error)


def pad_noise(noise: torch.Tensor, frames: int) -> torch.Tensor:
    if noise.shape[1] >= frames:
        return noise[:, :frames]
    return torch.cat([noise, torch.zeros(1, frames - noise.shape[1], noise.shape[2])], dim=1)


@dataclass
class Transfer:
    """The batch of a transfer and its result."""

    output: EditOutput
    leader: Stream
    followers: list[Stream]
    config: TransferConfig

    def out(self, index: int = 0) -> np.ndarray:
        return self.output.joints(OUT, index)

    def follower(self, index: int = 0) -> np.ndarray:
        return self.output.joints(FOLLOWER, index)

    def leader_joints(self) -> np.ndarray:
        return self.output.joints(LEADER)

    def slot(self, role: str, index: int = 0) -> int:
        return [i for i, r in enumerate(self.output.generation.roles.names) if r == role][index]


def transfer_streams(loaded: LoadedModel, leader: Stream, followers: Sequence[Stream],
                     config: TransferConfig = TransferConfig(), *, sample: SampleConfig = SampleConfig(),
                     record: StoreConfig | None = None, on_step: OnStep = None) -> Transfer:
    """Run leader, followers and outputs in one batch: [leader, follower 1, out 1, follower 2, out 2, ...]."""
    if not 1 <= len(followers) <= MAX_FOLLOWERS:
        raise ValueError(f"give between 1 and {MAX_FOLLOWERS} followers")
    for s in (leader, *followers):
        if s.inverted and sample.steps != len(s.path) - 1:
            raise ValueError(f"{s.source.label!r} was inverted with {len(s.path) - 1} steps; sample with the same number")
    roles, prompts, frames, noises = [LEADER], [leader.prompt], [leader.frames], [leader.noise]
    for f in followers:
        roles += [FOLLOWER, OUT]
        prompts += [f.prompt, f.prompt]
        frames += [f.frames, leader.frames]
        noises += [f.noise, leader.noise]
    length = max(frames)
    noise = torch.cat([pad_noise(n, length) for n in noises])
    slot_streams = [leader] + [x for f in followers for x in (f, None)]  # outputs are never pinned
    pins = {i: s.path for i, s in enumerate(slot_streams) if s is not None and s.inverted}
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER, target=OUT,
                                   window=config.window(loaded.model.config.layers), hard=config.hard),
                         num_steps=sample.steps)
    store = AttentionStore(record) if record is not None else None
    outs = tuple(i for i, r in enumerate(roles) if r == OUT)
    hooks = [PinTrajectory(pins)] if pins else []
    kept = kept_dims(config)
    if len(kept):
        hooks.append(KeepDims(source=0, targets=outs, dims=kept, frames=leader.frames))
    gen = generate(loaded, Request(prompts=prompts, frames=frames, roles=roles, noise=noise), sample,
                   controller=stack(store, mix), hooks=hooks, on_step=on_step)
    if config.root == "rotation":
        copy_root_rotation(gen, leader_slot=0, out_slots=outs, frames=leader.frames)
    output = EditOutput(generation=gen, before_role=LEADER, after_role=OUT, store=store)
    return Transfer(output=output, leader=leader, followers=list(followers), config=config)


def kept_dims(config: TransferConfig) -> torch.Tensor:
    """Feature dims the outputs take from the leader at every step: (K,) long, possibly empty."""
    dims: list[int] = []
    if config.root == "trajectory":
        dims += list(range(SLICES["root_lin_vel"].stop))  # root rotation and linear velocity
    if config.feet:
        for joints in FOOT_JOINTS.values():  # (ankle, toe) per side
            dims += [d for j in joints for d in ric_dims(j)]
        dims += list(range(SLICES["contacts"].start, SLICES["contacts"].stop))
    return torch.tensor(dims, dtype=torch.long)


def copy_root_rotation(gen, *, leader_slot: int, out_slots: Sequence[int], frames: int) -> None:
    """The outputs' root angular velocity <- the leader's; their joints are rebuilt from the features."""
    rot = SLICES["root_rot_vel"]
    for slot in out_slots:
        gen.features[slot, :frames, rot] = gen.features[leader_slot, :frames, rot]
        gen.joints[slot] = features_to_joints(gen.features[slot, :frames])


def transfer(loaded: LoadedModel, leader: Source, followers: Sequence[Source], config: TransferConfig = TransferConfig(),
             *, sample: SampleConfig = SampleConfig(), record: StoreConfig | None = None, on_step: OnStep = None,
             measure_inversion: bool = True) -> Transfer:
    """Leader -> followers transfer from prompts or real motions (the function the CLI and the app call)."""
    lead = prepare(loaded, leader, seed=sample.seed, steps=sample.steps, measure_inversion=measure_inversion)
    follow = [prepare(loaded, f, seed=sample.seed + 1 + i, steps=sample.steps, measure_inversion=measure_inversion)
              for i, f in enumerate(followers)]
    return transfer_streams(loaded, lead, follow, config, sample=sample, record=record, on_step=on_step)


def canonical(joints: np.ndarray) -> np.ndarray:
    """A motion as the model sees it: decoded from its own features (start at the origin, facing +Z)."""
    return features_to_joints(joints_to_features(joints))


def analyze(loaded: LoadedModel, result: Transfer, *, clusters, follower: int = 0, sample: SampleConfig = SampleConfig()):
    """Q/K clusters, correspondences and maps of a transfer recorded with :func:`qk_record`.

    ``clusters``: a fitted :class:`engine.analysis.qk.QKClusters` (see ``fit_clusters``); record with
    :func:`engine.analysis.qk.qk_record`.
    """
    if result.output.store is None:
        raise ValueError("the transfer was run without recording Q and K: pass record=qk_record()")
    _, corr, maps = analysis_sites(loaded.model.config.layers, sample.steps)
    slots = {LEADER: 0, FOLLOWER: result.slot(FOLLOWER, follower), OUT: result.slot(OUT, follower)}
    frames = {LEADER: result.leader.frames, FOLLOWER: result.followers[follower].frames, OUT: result.leader.frames}
    return analyze_transfer(result.output.store, frames=frames, slots=slots, clusters=clusters, correspondence=corr,
                            maps=maps)
