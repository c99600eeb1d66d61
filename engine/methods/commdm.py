"""ComMDM (PriorMDM): two people from two copies of one frozen prior and a small trained block.

The block sits after layer ``after`` of the prior: by default the last, as in the paper ("placed after the last (8th)
layer"; its ablation finds higher layers better). A model folder records the layer its block was trained after
(``config.json``'s ``com.after``), and loads with that one: the shipped block follows layer 5 of 6. For each person it
merges the person's own
activations with the other's (Linear 2w -> w per frame), adds one placement token (both
persons' noisy placements and the timestep), runs one transformer encoder layer and returns a
correction ΔO of the person's activations (zero at initialisation) and the person's clean
placement D̂0. The block is symmetric: its weights are shared and the person being corrected
comes first.

The duet state is one tensor per person slot, x (B, T + 1, 263): rows :T are the person's
normalised features in the person's own canonical frame (the prior's representation); row T
holds the placement — where the *other* person stands and faces, seen from this person's
canonical frame — in its first four dims (x, z, cos yaw, sin yaw); the rest of that row is
unused (predicted 0). The sampling loop, guidance and inpainting need nothing new: the state
is just a tensor. Slots carry the roles ``person_a`` / ``person_b``; the k-th ``person_a`` slot
pairs with the k-th ``person_b`` slot (separately for conditional and unconditional slots).

Words the prior never saw ("hug", "shake" ...) get their own trained embedding rows; every
weight of the prior stays frozen, so the prior alone behaves exactly as before.
"""
from __future__ import annotations

import copy
import hashlib
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np
import torch
from torch import nn

from engine.attention.context import BatchRoles
from engine.checkpoint import LoadedModel
from engine.model.denoiser import Condition, Denoiser

ROLES = ("person_a", "person_b")
PLACE_DIMS = 4  # (x, z, cos yaw, sin yaw) of the other person in this person's canonical frame


def _option(default: int, *, help: str, low: int):  # noqa: A002 (help, as argparse)
    return field(default=default, metadata={"help": help, "bounds": (low, None)})


@dataclass(frozen=True, kw_only=True)
class ComConfig:
    """The communication block: where it sits and its size (each field's help and lower bound in its metadata)."""

    after: int = _option(0, low=0, help="the base layer the block follows, 1 to the base's number of layers; 0 = the "
                         "last (the paper's place)")
    heads: int = _option(4, low=1, help="attention heads of the block's encoder layer")
    ff: int = _option(512, low=1, help="feed-forward width of the block's encoder layer")

    def __post_init__(self) -> None:
        for f in fields(self):
            value, low = getattr(self, f.name), f.metadata["bounds"][0]
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"ComMDM {f.name} must be a whole number >= {low}, got {value!r}")

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> "ComConfig":
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown ComMDM config fields: {sorted(unknown)}")
        return cls(**data)

    def layer(self, layers: int) -> int:
        """The 1-based base layer the block follows in a base of ``layers`` layers."""
        after = self.after or layers
        if not 1 <= after <= layers:
            raise ValueError(f"the ComMDM block must follow a layer between 1 and {layers} (0 = the last), "
                             f"got {self.after}")
        return after

    def resolved(self, layers: int) -> "ComConfig":
        """This config with ``after`` as the layer number it means in a base of ``layers`` layers (what a model
        folder records, so it loads with its own layer)."""
        return replace(self, after=self.layer(layers))


# ----------------------------------------------------------------------------- placement geometry
def yaw_matrix(yaw: float) -> np.ndarray:
    """Rotation about +Y by ``yaw`` (column vectors): +Z turns towards +X."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass(frozen=True)
class Pose:
    """Where a person's canonical frame sits in a shared frame: world = R(yaw) · canonical + (x, 0, z)."""

    x: float
    z: float
    yaw: float

    @classmethod
    def of_joints(cls, joints: np.ndarray) -> "Pose":
        """The pose of ``joints``' own canonical frame (root at frame 0, facing +Z) in their frame."""
        from engine.synth.corpus import canonical_transform

        rot, shift = canonical_transform(np.asarray(joints, dtype=np.float64))
        return cls(x=float(-shift[0]), z=float(-shift[2]), yaw=float(-np.arctan2(rot[0, 2], rot[0, 0])))

    def place(self, canonical: np.ndarray) -> np.ndarray:
        """Canonical joints (..., 3) -> the shared frame."""
        return canonical @ yaw_matrix(self.yaw).T + np.array([self.x, 0.0, self.z])

    def seen_from(self, viewer: "Pose") -> "Pose":
        """This pose expressed in ``viewer``'s canonical frame."""
        d = yaw_matrix(-viewer.yaw) @ np.array([self.x - viewer.x, 0.0, self.z - viewer.z])
        return Pose(x=float(d[0]), z=float(d[2]), yaw=_wrap(self.yaw - viewer.yaw))

    def inverse(self) -> "Pose":
        """The shared frame's origin seen from this pose (for a placement: the viewer seen from the other)."""
        return Pose(0.0, 0.0, 0.0).seen_from(self)

    def vector(self) -> np.ndarray:
        return np.array([self.x, self.z, np.cos(self.yaw), np.sin(self.yaw)], dtype=np.float32)

    @classmethod
    def of_vector(cls, v) -> "Pose":
        v = np.asarray(v, dtype=np.float64)
        if v.shape != (PLACE_DIMS,) or not np.isfinite(v).all():
            raise ValueError(f"a placement is 4 finite numbers (x, z, cos, sin), got {v}")
        return cls(x=float(v[0]), z=float(v[1]), yaw=float(np.arctan2(v[3], v[2])))


def _wrap(angle: float) -> float:
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def mean_pose(poses: list[Pose]) -> Pose:
    """Average positions and (circular) yaw."""
    return Pose(x=float(np.mean([p.x for p in poses])), z=float(np.mean([p.z for p in poses])),
                yaw=float(np.arctan2(np.mean([np.sin(p.yaw) for p in poses]), np.mean([np.cos(p.yaw) for p in poses]))))


def placements(joints_a: np.ndarray, joints_b: np.ndarray) -> tuple[Pose, Pose]:
    """(B seen from A, A seen from B) for two people given in one shared frame."""
    pa, pb = Pose.of_joints(joints_a), Pose.of_joints(joints_b)
    return pb.seen_from(pa), pa.seen_from(pb)


# ----------------------------------------------------------------------------- the duet state
def pack(motion: torch.Tensor, place: torch.Tensor) -> torch.Tensor:
    """motion (B, T, D), place (B, 4) -> state (B, T + 1, D)."""
    row = torch.zeros(motion.shape[0], 1, motion.shape[2], dtype=motion.dtype, device=motion.device)
    row[:, 0, :PLACE_DIMS] = place
    return torch.cat([motion, row], dim=1)


def unpack(x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """state (B, T + 1, D) -> (motion (B, T, D), place (B, 4))."""
    return x[:, :-1], x[:, -1, :PLACE_DIMS]


def partners(roles: BatchRoles) -> torch.Tensor:
    """For each slot, the index of the other person of its pair."""
    other = [-1] * len(roles)
    for cond in (True, False):
        a, b = roles.slots(ROLES[0], cond=cond), roles.slots(ROLES[1], cond=cond)
        if len(a) != len(b):
            raise ValueError(f"a duet batch pairs person_a and person_b slots; got roles {roles.names}")
        for i, j in zip(a, b):
            other[i], other[j] = j, i
    if -1 in other:
        raise ValueError(f"every slot of a duet batch must be person_a or person_b, got {roles.names}")
    return torch.tensor(other)


def duet_roles(pairs: int) -> BatchRoles:
    return BatchRoles(names=(ROLES[0],) * pairs + (ROLES[1],) * pairs)


# ----------------------------------------------------------------------------- modules
class ComBlock(nn.Module):
    """(own (B, T, w), other (B, T, w), own and other noisy placements (B, 4), temb (B, w)) ->
    (ΔO (B, T, w), clean own placement (B, 4))."""

    def __init__(self, width: int, config: ComConfig):
        super().__init__()
        self.merge = nn.Linear(2 * width, width)
        self.place_in = nn.Linear(2 * PLACE_DIMS, width)
        self.time = nn.Linear(width, width)
        self.layer = nn.TransformerEncoderLayer(d_model=width, nhead=config.heads, dim_feedforward=config.ff,
                                                dropout=0.0, batch_first=True, norm_first=True)
        self.delta = nn.Linear(width, width)
        nn.init.zeros_(self.delta.weight)
        nn.init.zeros_(self.delta.bias)
        self.place_out = nn.Linear(width, PLACE_DIMS)

    def forward(self, own, other, place_own, place_other, temb, frame_mask):
        tokens = self.merge(torch.cat([own, other], dim=-1))  # (B, T, w)
        token = self.place_in(torch.cat([place_own, place_other], dim=-1)) + self.time(temb)  # (B, w)
        seq = torch.cat([token[:, None], tokens], dim=1)
        keep = torch.cat([torch.ones_like(frame_mask[:, :1]), frame_mask], dim=1)
        out = self.layer(seq, src_key_padding_mask=~keep)
        return self.delta(out[:, 1:]), self.place_out(out[:, 0])


class SplitEmbedding(nn.Module):
    """The prior's word table (frozen) followed by trainable rows for the duet's new words."""

    def __init__(self, known: torch.Tensor, new_words: int):
        super().__init__()
        self.register_buffer("known", known.detach().clone())
        self.new = nn.Parameter(torch.randn(new_words, known.shape[1]) * 0.02)

    def forward(self, ids: torch.Tensor) -> torch.Tensor:
        return nn.functional.embedding(ids, torch.cat([self.known, self.new]), padding_idx=0)


class DuetDenoiser(nn.Module):
    """The prior's signature on duet states: (x (B, T + 1, D), t, cond, *, step, controller) -> x̂0."""

    def __init__(self, prior: Denoiser, *, known_words: int, new_words: int, config: ComConfig = ComConfig()):
        super().__init__()
        self.prior = prior
        for p in prior.parameters():
            p.requires_grad_(False)
        self.config = config
        self.after = config.layer(prior.num_layers)
        self.text_encoder = copy.deepcopy(prior.text_encoder)
        for p in self.text_encoder.parameters():
            p.requires_grad_(False)
        # ids 0 … known_words are padding and the prior's words; the duet's new words follow
        self.text_encoder.embed = SplitEmbedding(prior.text_encoder.embed.weight[: known_words + 1], new_words)
        self.com = ComBlock(prior.config.width, config)

    def trainable(self) -> dict[str, torch.Tensor]:
        """What training changes (and a shipped duet model stores): the block and the new word rows."""
        return {k: v for k, v in self.state_dict().items() if k.startswith("com.") or k == "text_encoder.embed.new"}

    def start(self, x, t, cond: Condition, *, step: int = 0, controller=None):
        """The prior's pass over the persons' motions, set up with the duet's word rows:
        (motion embedded (B, T, w), noisy placements (B, 4), the layers' shared inputs)."""
        motion, place = unpack(x)  # (B, T, D), (B, 4)
        mcond = replace(cond, frame_mask=cond.frame_mask[:, :-1])
        run = self.prior.begin(t, mcond, step=step, controller=controller,
                               text=self.text_encoder(cond.text_ids, cond.text_mask))
        return self.prior.embed_frames(motion), place, run

    def forward(self, x, t, cond: Condition, *, step: int = 0, controller=None):
        home = x
        x, t, cond, cast = self.prior.enter(x, t, cond)  # onto the prior's device, with its autocast
        with cast:
            h, place, run = self.start(x, t, cond, step=step, controller=controller)
            prior = self.prior
            h = prior.layers(h, run, range(self.after))
            other = partners(cond.roles)
            delta, place0 = self.com(h, h[other], place, place[other], run.temb, run.cond.frame_mask)
            h = prior.layers(h + delta, run, range(self.after, prior.num_layers))
            out = pack(prior.head(h), place0)
        return out.to(home.device, home.dtype)


@dataclass
class PriorTwice:
    """The no-communication baseline: each person denoised by the prior alone (with the duet's word
    rows, so it reads the same prompts); the placement is a fixed guess (the training mean)."""

    duet: DuetDenoiser
    place: torch.Tensor  # (4,)

    def __call__(self, x, t, cond: Condition, *, step: int = 0, controller=None):
        home = x
        prior = self.duet.prior
        x, t, cond, cast = prior.enter(x, t, cond)
        with cast:
            h, _, run = self.duet.start(x, t, cond, step=step, controller=controller)
            h = prior.layers(h, run, range(prior.num_layers))
            motion = prior.head(h).to(home.device, home.dtype)
        return pack(motion, self.place.to(home.dtype).expand(home.shape[0], -1))


def fingerprint(loaded: LoadedModel) -> str:
    """A short hash of a prior's weights, vocabulary and statistics: a duet model only runs on its own prior. The
    skip path's weights (``ModelConfig.skip_path``) are left out: it acts only in inversion, never in a duet, so a
    base that gained one (v10 = v9 + skip path) is still the prior its blocks were trained on."""
    h = hashlib.sha256()
    for k, v in sorted(loaded.model.state_dict().items()):
        if k.startswith("skip_path."):
            continue
        h.update(k.encode())
        h.update(v.detach().to(torch.float16).cpu().numpy().tobytes())
    h.update("\n".join(loaded.tokenizer.words).encode())
    h.update(np.asarray(loaded.normalizer.mean, dtype=np.float32).tobytes())
    h.update(np.asarray(loaded.normalizer.std, dtype=np.float32).tobytes())
    return h.hexdigest()[:16]
