"""MoMo ("Monkey See, Monkey Do"): leader -> follower motion transfer by mixed self-attention.

Three kinds of streams share one batch with named roles: the ``leader`` (what and when: outline,
timing), one ``follower`` per requested follower (how: motifs) and one ``out`` per follower. Each
``out`` starts from the leader's noise with its follower's prompt; inside the layer and step
window its self-attention takes Q from the leader and K, V from its follower (Eq. 4 of the
paper), elsewhere its own. A leader or follower is either generated from text or a real motion
DDIM-inverted and pinned to its inversion path (so it rebuilds the real motion exactly while the
model reads it). The output has the leader's length; what it takes from the leader's root is
``TransferConfig.root``: the leader's whole root path and speed ("trajectory", the default the bench chose) or,
as in the paper, only its root rotation ("rotation": the output's own speed, e.g. a walk -> run that runs).

The paper's direction trick (``TransferConfig.directions`` = N > 1): each out attends over N copies of its
follower, concatenated in time (K and V of N follower streams, see ``MixConfig.keys_per_target``), so each
leader frame attends most to the copy heading its way. As in the paper, a generated follower is sampled
with N seeds. An imported (inverted) follower is, in the paper, rotated about the vertical axis at several
angles and each copy inverted; but the HumanML3D features are heading-free (root angular and linear
velocity in the root's own frame, poses with the heading removed), so a motion rotated by a constant angle
has exactly the features of the original and inverts to the same noise: N identical copies, the same
output. Here each copy is *turned* instead (:func:`turned`): its heading turns steadily by 360/N degree
steps over the clip, so the copies differ where the model can see direction: in the root's angular velocity
(the channel the paper's root fix copies), while speed, height and root-relative pose stay (within a few cm;
HumanML3D's rotation features, whose IK takes shortest arcs in world axes, change as for any turning motion).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from engine.analysis.qk import analysis_sites, analyze_transfer
from engine.attention import AttentionStore, StoreConfig, stack
from engine.checkpoint import LoadedModel
from engine.generate import Request, SampleConfig, frames_for, generate
from engine.methods.edits import EditOutput, OnStep
from engine.methods.hooks import KeepDims, PinTrajectory
from engine.methods.inversion import InversionConfig, invert, reconstruct, roundtrip_figures
from engine.methods.mixing import MixConfig, MixedAttention
from engine.methods.transfer_config import ROOT_MODES, TransferConfig  # noqa: F401  (its home; read by the CLI)
from engine.representation import SLICES, features_to_joints, joints_to_features, ric_dims
from engine.skeleton import FOOT_JOINTS

LEADER, FOLLOWER, OUT = "leader", "follower", "out"
MAX_FOLLOWERS = 8
MAX_FOLLOWER_STREAMS = 16  # followers x direction copies in one batch


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
    error = roundtrip_figures(inverted, reconstruct(loaded, inverted, config)) if measure_inversion else None
    return Stream(source=source, prompt=prompt or None, noise=inverted.noise, frames=inverted.noise.shape[1],
                  path=inverted.trajectory, inversion=error)


def turned(joints: np.ndarray, angle: float) -> np.ndarray:
    """The motion with its heading turned steadily by ``angle`` radians over the clip (about the vertical axis).

    Frame t's pose and its step on the floor are rotated by ``angle * t / (T - 1)`` about the root: the same
    motion walking a path that bends by ``angle`` (same speed and root-relative pose, a turning heading). A
    constant rotation would change no feature at all (see the module docstring)."""
    joints = np.asarray(joints, dtype=np.float64)
    n = len(joints)
    phi = angle * np.arange(n) / max(n - 1, 1)
    c, s = np.cos(phi), np.sin(phi)

    def rot(xz: np.ndarray) -> np.ndarray:  # (n, ..., 2) rotated per frame about +Y (x, z)
        shape = (n,) + (1,) * (xz.ndim - 2)
        cc, ss = c.reshape(shape), s.reshape(shape)
        return np.stack([xz[..., 0] * cc + xz[..., 1] * ss, -xz[..., 0] * ss + xz[..., 1] * cc], -1)

    root = joints[:, 0, [0, 2]]
    steps = rot(np.diff(root, axis=0, prepend=root[:1]))  # step t (from t-1 to t) turned by frame t's angle
    new_root = root[0] + np.cumsum(steps, axis=0)
    out = joints.copy()
    out[..., [0, 2]] = rot(joints[..., [0, 2]] - root[:, None]) + new_root[:, None]
    return out.astype(np.float32)


def direction_copies(source: Source, count: int) -> list[Source]:
    """The ``count - 1`` extra copies of an imported follower for the direction trick: turned by k * 360/count
    degrees over the clip, k = 1 .. count-1, wrapped to (-180, 180] (so 2 copies: 0 and 180; 4: 0, 90, 180, -90).
    A generated follower's copies are the same prompt with other seeds (see :func:`transfer`)."""
    if source.joints is None:
        return [source] * (count - 1)
    out = []
    for k in range(1, count):
        angle = (2 * np.pi * k / count + np.pi) % (2 * np.pi) - np.pi
        angle = np.pi if abs(angle + np.pi) < 1e-9 else angle
        out.append(Source(prompt=source.prompt, joints=turned(source.joints, angle), seconds=source.seconds,
                          name=f"{source.label} (turned {np.degrees(angle):+.0f}°)"))
    return out


def pad_noise(noise: torch.Tensor, frames: int) -> torch.Tensor:
    if noise.shape[1] >= frames:
        return noise[:, :frames]
    return torch.cat([noise, torch.zeros(1, frames - noise.shape[1], noise.shape[2])], dim=1)


@dataclass
class Transfer:
    """The batch of a transfer and its result. ``copies[i]``: follower i's extra direction copies (the direction
    trick; empty lists without it); ``follower(i)`` is always the follower as given."""

    output: EditOutput
    leader: Stream
    followers: list[Stream]
    config: TransferConfig
    copies: list[list[Stream]] = field(default_factory=list)

    @property
    def per_follower(self) -> int:
        """Follower streams per out: 1, or the number of direction copies."""
        return 1 + (len(self.copies[0]) if self.copies else 0)

    def out(self, index: int = 0) -> np.ndarray:
        return self.output.joints(OUT, index)

    def follower(self, index: int = 0) -> np.ndarray:
        return self.output.joints(FOLLOWER, self.per_follower * index)

    def copy(self, index: int, k: int) -> np.ndarray:
        """Direction copy ``k`` (1-based; 0 is the follower itself) of follower ``index``."""
        if not 0 <= k < self.per_follower:
            raise IndexError(f"follower {index + 1} has {self.per_follower - 1} direction copies, not {k}")
        return self.output.joints(FOLLOWER, self.per_follower * index + k)

    def leader_joints(self) -> np.ndarray:
        return self.output.joints(LEADER)

    def slot(self, role: str, index: int = 0) -> int:
        """Batch slot of the ``index``-th leader / follower (as given, not its copies) / out."""
        if role == FOLLOWER:
            index *= self.per_follower
        return [i for i, r in enumerate(self.output.generation.roles.names) if r == role][index]


def transfer_streams(loaded: LoadedModel, leader: Stream, followers: Sequence[Stream],
                     config: TransferConfig = TransferConfig(), *, sample: SampleConfig = SampleConfig(),
                     record: StoreConfig | None = None, on_step: OnStep = None,
                     copies: Sequence[Sequence[Stream]] | None = None) -> Transfer:
    """Run leader, followers and outputs in one batch: [leader, follower 1, out 1, follower 2, out 2, ...].

    ``copies``: per follower, its extra direction copies (``config.directions - 1`` each, see :func:`transfer`);
    they sit after their follower ([leader, follower 1, its copies, out 1, ...]) and its out attends over all.
    """
    if not 1 <= len(followers) <= MAX_FOLLOWERS:
        raise ValueError(f"give between 1 and {MAX_FOLLOWERS} followers")
    copies = [list(c) for c in copies] if copies is not None else [[] for _ in followers]
    if len(copies) != len(followers) or any(len(c) != config.directions - 1 for c in copies):
        raise ValueError(f"directions={config.directions}: give {config.directions - 1} direction copies per "
                         f"follower (transfer() makes them)")
    if len(followers) * config.directions > MAX_FOLLOWER_STREAMS:
        raise ValueError(f"{len(followers)} followers x {config.directions} directions is more than "
                         f"{MAX_FOLLOWER_STREAMS} follower streams: use fewer followers or directions")
    for s in (leader, *followers, *(c for group in copies for c in group)):
        if s.inverted and sample.steps != len(s.path) - 1:
            raise ValueError(f"{s.source.label!r} was inverted with {len(s.path) - 1} steps; sample with the same number")
    roles, prompts, frames, noises = [LEADER], [leader.prompt], [leader.frames], [leader.noise]
    slot_streams: list[Stream | None] = [leader]
    for f, group in zip(followers, copies):
        for c in (f, *group):
            roles.append(FOLLOWER)
            prompts.append(c.prompt)
            frames.append(c.frames)
            noises.append(c.noise)
            slot_streams.append(c)
        roles.append(OUT)
        prompts.append(f.prompt)
        frames.append(leader.frames)
        noises.append(leader.noise)
        slot_streams.append(None)  # outputs are never pinned
    length = max(frames)
    noise = torch.cat([pad_noise(n, length) for n in noises])
    pins = {i: s.path for i, s in enumerate(slot_streams) if s is not None and s.inverted}
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER, target=OUT,
                                   window=config.window(loaded.model.config.layers), hard=config.hard,
                                   keys_per_target=config.directions),
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
    if config.flights:
        follow_flights(gen, leader_slot=0, out_slots=outs, frames=leader.frames)
    output = EditOutput(generation=gen, before_role=LEADER, after_role=OUT, store=store)
    return Transfer(output=output, leader=leader, followers=list(followers), config=config, copies=copies)


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


#: a foot over this height (m) above its motion's own floor is off the floor (:func:`flight_lift`)
FLIGHT_MARGIN = 0.05
_FEET = [j for pair in FOOT_JOINTS.values() for j in pair]  # ankles and toes


def flight_lift(leader: np.ndarray, out: np.ndarray, *, margin: float = FLIGHT_MARGIN) -> np.ndarray:
    """(T,) metres to lift ``out`` (T, 22, 3) by so it leaves the floor where ``leader`` (T', 22, 3) does.

    Each motion's floor is the 5th percentile of its lowest foot's height. Where the leader's lowest foot is over
    ``margin`` above its floor, the out is lifted until its lowest foot is as high above its own floor (never
    lowered); elsewhere 0; smoothed over a frame either side so the lift does not jump.
    """
    from scipy.ndimage import gaussian_filter1d

    n = min(len(leader), len(out))
    lead_low, out_low = leader[:, _FEET, 1].min(1), out[:, _FEET, 1].min(1)  # (T,) each
    lead_up = lead_low[:n] - np.percentile(lead_low, 5)
    out_up = out_low[:n] - np.percentile(out_low, 5)
    lift = np.where(lead_up > margin, np.maximum(lead_up - out_up, 0.0), 0.0)
    full = np.zeros(len(out))
    full[:n] = gaussian_filter1d(lift, 1.0) if n > 1 else lift
    return full


def follow_flights(gen, *, leader_slot: int, out_slots: Sequence[int], frames: int) -> None:
    """The outputs lifted with the leader's flights (:func:`flight_lift`): their root height and every joint's
    height feature move together, and their joints are rebuilt from the features."""
    lead = gen.joints[leader_slot][:frames]
    heights = [SLICES["root_height"].start] + [ric_dims(j)[1] for j in range(1, lead.shape[1])]
    for slot in out_slots:
        lift = flight_lift(lead, gen.joints[slot][:frames])
        if not lift.any():
            continue
        features = gen.features[slot]  # (T, D), a view
        features[:frames, heights] += lift[:, None].astype(features.dtype)
        gen.joints[slot] = features_to_joints(features[:frames])


def transfer(loaded: LoadedModel, leader: Source, followers: Sequence[Source], config: TransferConfig = TransferConfig(),
             *, sample: SampleConfig = SampleConfig(), record: StoreConfig | None = None, on_step: OnStep = None,
             measure_inversion: bool = True) -> Transfer:
    """Leader -> followers transfer from prompts or real motions (the function the CLI and the app call).

    With ``config.directions`` = N > 1 each follower also gets N - 1 direction copies: a generated follower its
    prompt with the seeds ``seed + 1 + i + k * MAX_FOLLOWERS`` (k = 1 .. N-1), an imported one turned copies
    (:func:`direction_copies`), each inverted."""
    if len(followers) * config.directions > MAX_FOLLOWER_STREAMS:  # before any inversion
        raise ValueError(f"{len(followers)} followers x {config.directions} directions is more than "
                         f"{MAX_FOLLOWER_STREAMS} follower streams: use fewer followers or directions")
    lead = prepare(loaded, leader, seed=sample.seed, steps=sample.steps, measure_inversion=measure_inversion)
    follow = [prepare(loaded, f, seed=sample.seed + 1 + i, steps=sample.steps, measure_inversion=measure_inversion)
              for i, f in enumerate(followers)]
    copies = []
    for i, f in enumerate(followers):
        group = []
        for k, c in enumerate(direction_copies(f, config.directions), start=1):
            seed = sample.seed + 1 + i + k * MAX_FOLLOWERS
            if c.joints is None:
                c = replace(c, name=f"{c.label} (seed {seed})")
            group.append(prepare(loaded, c, seed=seed, steps=sample.steps, measure_inversion=False))
        copies.append(group)
    return transfer_streams(loaded, lead, follow, config, sample=sample, record=record, on_step=on_step,
                            copies=copies)


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
