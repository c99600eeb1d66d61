"""Two-person interactions (ComMDM): handshake, high five, hug, push, sparring, dancing
together, walking side by side, following. Both people are synthesised with the same
engine; hands that touch are driven to shared world targets (a second arm-IK pass), so the
contact labels are exact. Joints of both are given in person A's canonical frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from engine.synth.compose import Synthesis, synthesize
from engine.synth.corpus import canonical_transform
from engine.synth.physics import smoothstep
from engine.synth.primitives.base import STANCE_HALF, TOE_OUT, State
from engine.synth.program import FPS, Program, Segment
from engine.synth.rig import ANKLE_HEIGHT, SIDE_SIGN, left_vector, solve, yaw_rotation
from engine.synth.splits import SPLIT_IDS, random_person

INTERACTIONS = ("handshake", "high_five", "hug", "push", "sparring", "dance_together", "side_by_side", "following")

DUET_CAPTIONS = {
    "handshake": ("two people shake hands", "a person shakes hands with another person",
                  "two people greet each other with a handshake", "someone shakes the hand of another person"),
    "high_five": ("two people give each other a high five", "a person high fives another person",
                  "two people slap their hands together above their heads"),
    "hug": ("two people hug", "a person hugs another person", "two people embrace each other"),
    "push": ("a person pushes another person", "someone shoves another person backwards",
             "one person pushes the other who steps back"),
    "sparring": ("two people are sparring", "two people box with each other", "two people throw punches at each other"),
    "dance_together": ("two people dance together", "a couple dances facing each other",
                       "two people dance from side to side together"),
    "side_by_side": ("two people walk side by side", "two people walk forward next to each other",
                     "a person walks beside another person"),
    "following": ("a person follows another person", "one person walks behind another person",
                  "someone follows another person walking forward"),
}


def state_at(x: float, z: float, heading: float, stance: float = 1.0) -> State:
    lat = left_vector(np.float64(heading))
    feet = np.zeros((2, 3))
    for side in (0, 1):
        feet[side] = np.array([x, 0.0, z]) + lat * SIDE_SIGN[side] * STANCE_HALF * stance
    feet[:, 1] = ANKLE_HEIGHT
    return State(root_xz=np.array([x, z], dtype=np.float64), heading=float(heading), feet=feet,
                 feet_yaw=heading + SIDE_SIGN * TOE_OUT)


def drive_hands(syn: Synthesis, targets: np.ndarray, weight: np.ndarray) -> Synthesis:
    """Re-solve ``syn`` with world wrist targets (T, 2, 3) blended in by ``weight`` (T, 2)."""
    ch = syn.channels.copy()
    shoulders = syn.joints[:, [16, 17]]
    rot = yaw_rotation(ch.heading)  # heading frame
    rel_world = targets - shoulders
    rel = (np.swapaxes(rot, -1, -2)[:, None] @ rel_world[..., None])[..., 0]
    w = weight[..., None]
    # express the current targets in the heading frame too, so blending is continuous
    ch.hand = ch.hand * (1 - w) + rel * w
    ch.hand_frame = ch.hand_frame * (1 - weight)
    ch.elbow_pole = ch.elbow_pole * (1 - w) + np.array([0.0, -1.0, -0.3]) * w + \
        np.stack([SIDE_SIGN * 0.6, np.zeros(2), np.zeros(2)], -1)[None] * w
    solved = solve(ch)
    return replace(syn, channels=ch, solved=solved, _local=None)


def _window(n: int, a: float, b: float, ramp: float) -> np.ndarray:
    t = np.arange(n, dtype=np.float64)
    return smoothstep((t - a) / ramp) * (1 - smoothstep((t - b) / ramp))


@dataclass
class DuetSample:
    interaction: str
    joints_a: np.ndarray  # (T, 22, 3) float32, A's canonical frame
    joints_b: np.ndarray
    captions: list[str]
    labels: dict
    programs: tuple[Program, Program] = field(repr=False)

    @property
    def joints(self) -> tuple[np.ndarray, np.ndarray]:
        return self.joints_a, self.joints_b


FACING = ("handshake", "high_five", "hug", "push", "sparring", "dance_together")  # people face each other
# pelvis-to-pelvis distance (m) at the start of the interactions where the two face each other
FACING_DIST = {"handshake": 0.75, "high_five": 0.8, "hug": 0.36, "push": 0.6, "sparring": 1.25, "dance_together": 1.2}


def _starts(interaction: str, rng: np.random.Generator, pa, pb) -> tuple[State, State]:
    """Where A and B stand: A at the origin facing +Z; B facing A, beside A or behind A."""
    start_a = state_at(0.0, 0.0, 0.0, pa.stance)
    if interaction in FACING:
        return start_a, state_at(0.0, FACING_DIST[interaction], np.pi, pb.stance)
    if interaction == "side_by_side":
        gap = float(rng.uniform(0.55, 0.8))
        return start_a, state_at(-gap, 0.0, 0.0, pb.stance)
    behind = float(rng.uniform(1.2, 1.8))  # following
    return start_a, state_at(0.0, -behind, 0.0, pb.stance)


def _programs(interaction: str, n: int, rng: np.random.Generator, pa, pb, seed: int) -> tuple[Program, Program]:
    """A's and B's programs of ``n`` frames."""
    def prog(segs, person, style="none"):
        return Program(segments=tuple(segs), person=person, seed=seed, style=style)

    if interaction in ("handshake", "high_five", "hug"):
        return prog([Segment("stand", n)], pa), prog([Segment("stand", n)], pb)
    if interaction == "push":
        t_push = int(n * 0.4)
        return prog([Segment("stand", n)], pa), prog([Segment("stand", t_push), Segment(
            "walk_backward", n - t_push, direction="backward", speed=1.2)], pb)
    if interaction == "sparring":
        ca, cb = int(rng.integers(2, 5)), int(rng.integers(2, 5))
        return (prog([Segment("punch", n, count=ca, side="both")], pa),
                prog([Segment("punch", n, count=cb, side="both", lead="right")], pb))
    if interaction == "dance_together":
        return prog([Segment("dance", n)], pa), prog([Segment("dance", n)], pb)
    lead = "left" if rng.random() < 0.5 else "right"
    walk = Segment("walk", n, direction="forward", lead=lead, speed=float(rng.uniform(0.85, 1.15)))
    return prog([walk], pa), prog([replace(walk, lead="right" if lead == "left" else "left")], pb)


def _handshake(syn_a: Synthesis, syn_b: Synthesis, T: int):
    meet = np.array([0.0, 1.08, FACING_DIST["handshake"] / 2])
    a0, a1 = 0.25 * T, 0.75 * T
    w = _window(T, a0, a1, 0.5 * FPS)
    shake = 0.04 * np.sin(2 * np.pi * 2.2 * np.arange(T) / FPS) * _window(T, a0 + 10, a1 - 8, 4)
    tgt = np.broadcast_to(meet, (T, 2, 3)).copy()
    tgt[:, :, 1] += shake[:, None]
    tgt_a, tgt_b = tgt.copy(), tgt.copy()
    tgt_a[:, 1, 0] -= 0.02
    tgt_b[:, 1, 0] += 0.02
    wa = np.stack([np.zeros(T), w], -1)
    return (drive_hands(syn_a, tgt_a, wa), drive_hands(syn_b, tgt_b, wa),
            {"kind": "right_hands", "start": int(np.ceil(a0 + 10)), "end": int(a1)})


def _high_five(syn_a: Synthesis, syn_b: Synthesis, T: int):
    t_hit = 0.5 * T
    meet = np.array([0.0, 1.68, FACING_DIST["high_five"] / 2])
    w = _window(T, t_hit - 0.6 * FPS, t_hit + 0.1 * FPS, 0.55 * FPS)
    tgt = np.broadcast_to(meet, (T, 2, 3)).copy()
    wa = np.stack([np.zeros(T), w], -1)
    ta = tgt.copy()
    ta[:, 1, 2] -= 0.02
    tb = tgt.copy()
    tb[:, 1, 2] += 0.02
    full = np.flatnonzero(w > 0.97)
    return (drive_hands(syn_a, ta, wa), drive_hands(syn_b, tb, wa),
            {"kind": "right_hands", "start": int(full[0]), "end": int(full[-1]) + 1})


def _hug(syn_a: Synthesis, syn_b: Synthesis, T: int):
    facing_dist = FACING_DIST["hug"]
    a0, a1 = 0.2 * T, 0.8 * T
    w = _window(T, a0, a1, 0.6 * FPS)
    ta = np.zeros((T, 2, 3))
    ta[:, 0] = (0.13, 1.2, facing_dist + 0.08)  # A's hands on B's back
    ta[:, 1] = (-0.13, 1.2, facing_dist + 0.08)
    tb = np.zeros((T, 2, 3))
    tb[:, 0] = (-0.13, 1.2, -0.08)  # B faces -Z: its left hand is on the -X side
    tb[:, 1] = (0.13, 1.2, -0.08)
    ww = np.stack([w, w], -1)
    full = np.flatnonzero(w > 0.97)
    return (drive_hands(syn_a, ta, ww), drive_hands(syn_b, tb, ww),
            {"kind": "bodies", "start": int(full[0]), "end": int(full[-1]) + 1})


def _push(syn_a: Synthesis, syn_b: Synthesis, T: int):
    t_push = int(T * 0.4)
    w = _window(T, t_push - 0.5 * FPS, t_push + 0.15 * FPS, 0.45 * FPS)
    chest_b = syn_b.joints[:, 9]
    tgt = np.stack([chest_b + np.array([0.14, -0.05, -0.12]), chest_b + np.array([-0.14, -0.05, -0.12])], 1)
    full = np.flatnonzero(w > 0.97)
    return (drive_hands(syn_a, tgt, np.stack([w, w], -1)), syn_b,
            {"kind": "hands_on_chest", "start": int(full[0]), "end": int(full[-1]) + 1})


_TOUCHES = {"handshake": _handshake, "high_five": _high_five, "hug": _hug, "push": _push}  # hands driven together


def _labels(interaction: str, T: int, syn_a: Synthesis, syn_b: Synthesis, ja: np.ndarray, jb: np.ndarray,
            contacts: list[dict], programs: tuple[Program, Program]) -> dict:
    yaw_a = float(syn_a.channels.heading[0])
    yaw_b = float(syn_b.channels.heading[0])
    off = jb[0, 0, [0, 2]] - ja[0, 0, [0, 2]]
    return {
        "interaction": interaction,
        "frames": T,
        "placement": {"offset_xz": [round(float(off[0]), 4), round(float(off[1]), 4)],
                      "facing": round(float((yaw_b - yaw_a + np.pi) % (2 * np.pi) - np.pi), 4)},
        "contacts": contacts,
        "programs": [programs[0].to_json(), programs[1].to_json()],
        "events_a": [e.to_json() for e in syn_a.events],
        "events_b": [e.to_json() for e in syn_b.events],
    }


def make_duet(interaction: str, rng: np.random.Generator) -> DuetSample:
    """One duet: two people and their starts, both programs synthesised, touching hands driven together,
    both put in A's canonical frame."""
    if interaction not in INTERACTIONS:
        raise ValueError(f"unknown interaction {interaction!r}")
    pa, pb = random_person(rng), random_person(rng)
    seed = int(rng.integers(2**31))
    n = int(rng.integers(80, 121))
    start_a, start_b = _starts(interaction, rng, pa, pb)
    a_prog, b_prog = _programs(interaction, n, rng, pa, pb, seed)
    syn_a = synthesize(a_prog, start=start_a)
    syn_b = synthesize(b_prog, start=start_b)
    contacts: list[dict] = []
    if interaction in _TOUCHES:
        syn_a, syn_b, contact = _TOUCHES[interaction](syn_a, syn_b, n)
        contacts.append(contact)
    rot, shift = canonical_transform(syn_a.joints)
    ja = ((syn_a.joints + shift) @ rot.T).astype(np.float32)
    jb = ((syn_b.joints + shift) @ rot.T).astype(np.float32)
    labels = _labels(interaction, n, syn_a, syn_b, ja, jb, contacts, (a_prog, b_prog))
    caps = list(DUET_CAPTIONS[interaction])
    order = rng.permutation(len(caps))
    return DuetSample(interaction=interaction, joints_a=ja, joints_b=jb, captions=[caps[i] for i in order],
                      labels=labels, programs=(a_prog, b_prog))


class DuetCorpus:
    """Deterministic two-person samples: ``DuetCorpus(split).sample(i)``."""

    def __init__(self, split: str = "train", *, seed: int = 0) -> None:
        if split not in SPLIT_IDS:
            raise ValueError(f"unknown split {split!r}")
        self.split, self.seed = split, int(seed)

    def sample(self, index: int) -> DuetSample:
        rng = np.random.default_rng([self.seed, 100 + SPLIT_IDS[self.split], int(index)])
        interaction = INTERACTIONS[int(rng.integers(len(INTERACTIONS)))]
        return make_duet(interaction, rng)

    __getitem__ = sample
