"""Duet spacing: two generated people never start inside each other (issue #35, item 5).

Measured on the torsos (``engine.analysis.duet_pose.torso_distance``: the horizontal distance between the two
people's pelvis-and-spine centres), the rule a duet from a prompt keeps is the ground truth's, the corpus duets of
``engine.synth.duet`` (``TRUTH``, measured by :func:`truth_minimums`):

- in the first second, the torsos are at least as far apart as the truth ever has them at the start of that
  interaction;
- at every frame, they are at least as far apart as the truth ever has them in any interaction (``FLOOR``: a
  hug, chests together) and, in an interaction without contact (sparring, dancing together, walking side by side,
  following), as far apart as the truth has that interaction anywhere in the clip;
- a prompt that reads as no interaction keeps ``FLOOR`` at every frame;
- and at every frame the torsos never interpenetrate (``duet_pose.torso_reach``: seen from above, each torso is
  an ellipse as wide as its shoulders, so people side by side need more room than people face to face).

Where a duet breaks it, person b moves away from person a along the line between their torsos at the first
frame, by the least amount that keeps the rule, changing by at most ``PUSH_SPEED`` and eased (b drifts rather
than jumps). So people who start too close keep their distance through the first second, and in an interaction
with contact (handshake, high five, hug, push) b then drifts back towards where the model put it (no closer
than ``FLOOR`` and never into a), so hands can still meet. Where the model walks b through a, b is held on its
side of a (the push grows, at most ``PUSH_SPEED``, as b walks on) rather than let into a: a sample that bad
keeps its people apart, not its path. A duet that keeps the rule comes back untouched, bit for bit. Person a
never moves.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from engine.analysis.duet_pose import torso_centres, torso_distance, torso_reach
from engine.representation import facing_direction
from engine.units import FPS

START_SECONDS = 1.0  # the start the interaction's own minimum holds over
PUSH_SPEED = 0.5  # m/s: how fast the push may grow or shrink (a slow shuffle)
EASE_FRAMES = 3  # the push's corners are rounded over 2 * EASE_FRAMES + 1 frames
CLEARANCE = 0.01  # m kept between torsos that would otherwise just touch
REACH_PASSES = 4  # moves tried while the torsos' reach, measured where b ends up, still overlaps

# the truth's smallest torso distances (m), per interaction: (in its first second, anywhere in the clip), rounded
# down to the centimetre: ``truth_minimums`` over 1,120 corpus duets (60 per interaction from make_duet and the
# first 80 of the train and test splits; tests/test_duet_spacing.py checks a fresh few against it)
TRUTH: dict[str, tuple[float, float]] = {
    "handshake": (0.75, 0.75), "high_five": (0.80, 0.80), "hug": (0.36, 0.36), "push": (0.60, 0.59),
    "sparring": (1.25, 1.25), "dance_together": (1.19, 1.17), "side_by_side": (0.53, 0.53),
    "following": (1.18, 0.67),
}
FLOOR = min(anywhere for _, anywhere in TRUTH.values())  # no interaction of the truth comes closer (a hug)
# interactions whose people touch (their truth carries contact labels): only their start keeps its own minimum
CONTACT = ("handshake", "high_five", "hug", "push")


@dataclass(frozen=True)
class SpacingRule:
    """The torso distances (m) a duet keeps: ``start`` over its first ``START_SECONDS``, ``anywhere`` at every
    frame."""

    interaction: str | None
    start: float
    anywhere: float

    @classmethod
    def of(cls, interaction: str | None) -> "SpacingRule":
        if interaction is None:
            return cls(None, FLOOR, FLOOR)
        if interaction not in TRUTH:
            raise ValueError(f"unknown interaction {interaction!r}; known: {', '.join(TRUTH)}")
        start, anywhere = TRUTH[interaction]
        return cls(interaction, start, FLOOR if interaction in CONTACT else anywhere)

    def minimum(self, frames: int, fps: float = FPS) -> np.ndarray:
        """(frames,) the torso distance each frame keeps."""
        need = np.full(frames, self.anywhere)
        need[: int(round(START_SECONDS * fps))] = max(self.start, self.anywhere)
        return need


@dataclass(frozen=True)
class Spacing:
    """What keeping the rule did: person b moved by ``push`` (T,) metres along ``direction`` (x, z)."""

    rule: SpacingRule
    push: np.ndarray
    direction: np.ndarray

    @property
    def moved(self) -> bool:
        return bool(self.push.any())

    @property
    def offset(self) -> np.ndarray:
        """(T, 3): what was added to each of person b's joints."""
        return self.push[:, None] * np.array([self.direction[0], 0.0, self.direction[1]])


def push_direction(joints: np.ndarray) -> np.ndarray:
    """Unit (x, z) from person a's torso to person b's at the first frame (person a's facing if they coincide)."""
    v = np.diff(torso_centres(joints[:, :1]), axis=0)[0, 0]
    norm = float(np.hypot(*v))
    if norm < 1e-6:
        v = facing_direction(np.asarray(joints[0, 0], dtype=np.float64))[[0, 2]]
        norm = float(np.hypot(*v))
    return v / norm


def forbidden_pushes(joints: np.ndarray, minimum: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), each (T,): per frame, moving person b by p along ``direction`` with lo < p < hi puts the torsos
    closer than ``minimum`` (an empty interval where no move does). Moving b by p: |v + p u|^2 = |v_perp|^2 +
    (v.u + p)^2."""
    v = np.diff(torso_centres(joints), axis=0)[0]  # (T, 2) a -> b
    along = v @ direction
    room2 = minimum ** 2 - ((v ** 2).sum(-1) - along ** 2)
    room = np.where(room2 > 0.0, np.sqrt(np.maximum(room2, 0.0)), -np.inf)
    return -along - room, -along + room


def required_push(joints: np.ndarray, minimum: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(T,): per frame, the least move of person b along ``direction`` that puts the torsos ``minimum`` apart
    (0 where they already are)."""
    lo, hi = forbidden_pushes(joints, minimum, direction)
    return np.where((lo < 0.0) & (0.0 < hi), hi, 0.0)


def push_profile(required: np.ndarray, fps: float = FPS) -> np.ndarray:
    """The least push >= ``required`` (T,) that changes by at most ``PUSH_SPEED``, its corners eased: the
    cone envelope (a Lipschitz upper bound), widened by a running maximum and averaged over the same window
    (which keeps it above ``required`` and as steep at most)."""
    required = np.asarray(required, dtype=np.float64)
    if not (required > 0).any():
        return np.zeros_like(required)
    t = np.arange(len(required), dtype=np.float64)
    rate = PUSH_SPEED / fps
    cone = (required[None, :] - rate * np.abs(t[:, None] - t[None, :])).max(1)
    h = EASE_FRAMES
    padded = np.pad(cone, h, mode="edge")
    widened = np.lib.stride_tricks.sliding_window_view(padded, 2 * h + 1).max(1)
    eased = np.lib.stride_tricks.sliding_window_view(np.pad(widened, h, mode="edge"), 2 * h + 1).mean(1)
    return np.maximum(eased, 0.0)


def least_push(joints: np.ndarray, minimum: np.ndarray, direction: np.ndarray, fps: float = FPS) -> np.ndarray:
    """(T,): the push profile (``push_profile``) that keeps the torsos ``minimum`` apart at every frame, and does
    not carry person b into person a where b was clear of a (b on a's other side along ``direction``)."""
    lo, hi = forbidden_pushes(joints, minimum, direction)
    need = np.where((lo < 0.0) & (0.0 < hi), hi, 0.0)
    push = push_profile(need, fps)
    for _ in range(len(need)):
        into = (lo < push - 1e-9) & (push + 1e-9 < hi)
        if not into.any():
            break
        need = np.where(into, np.maximum(need, hi), need)
        push = push_profile(need, fps)
    return push


def keep_apart(joints: np.ndarray, interaction: str | None, *, fps: float = FPS) -> tuple[np.ndarray, Spacing]:
    """Two people (2, T, 22, 3) in one frame -> (the same with person b moved where the rule needs it, what was
    done). Whatever the interaction, torsos never interpenetrate (``duet_pose.torso_reach`` + ``CLEARANCE``;
    how far they reach towards each other depends on where b ends up, so it is measured again after the move).
    Joints that keep the rule come back as the very array given."""
    rule = SpacingRule.of(interaction)
    direction = push_direction(joints)
    minimum = rule.minimum(joints.shape[1], fps)
    reach = torso_reach(joints)
    out = joints
    for _ in range(REACH_PASSES):
        push = least_push(joints, np.maximum(minimum, reach + CLEARANCE), direction, fps)
        spacing = Spacing(rule=rule, push=push, direction=direction)
        if not spacing.moved:
            return joints, spacing
        out = np.array(joints, copy=True)
        out[1] = out[1] + spacing.offset[:, None, :].astype(out.dtype)
        now = torso_reach(out)
        if (torso_distance(out) >= now).all():
            break
        reach = np.maximum(reach, now)
    return out, spacing


def truth_minimums(samples: Iterable) -> dict[str, tuple[float, float]]:
    """Duet samples (``interaction``, ``joints_a``, ``joints_b``) -> per interaction, the smallest torso distance
    (m) in the first second and anywhere in the clip."""
    start = int(round(START_SECONDS * FPS))
    out: dict[str, tuple[float, float]] = {}
    for s in samples:
        d = torso_distance(np.stack([s.joints_a, s.joints_b]))
        first, anywhere = out.get(s.interaction, (np.inf, np.inf))
        out[s.interaction] = (min(first, float(d[:start].min())), min(anywhere, float(d.min())))
    return dict(sorted(out.items()))
