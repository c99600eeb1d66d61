"""Shared types of the primitives: body state between segments, context, results, events."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from engine.synth.program import Person, Segment
from engine.rotations import cross
from engine.synth.rig import ANKLE_HEIGHT, ARM, FOREARM, SIDE_SIGN, UPPER_ARM, Channels, left_vector, vector3
from engine.synth.styles import StyleSpec

STANCE_HALF = 0.095  # half the distance between the ankles when standing (m)
TOE_OUT = 0.08  # feet turned outward (rad)


@dataclass
class State:
    """Where a segment starts: root on the floor, heading, flat-foot ankle positions and yaws."""

    root_xz: np.ndarray  # (2,)
    heading: float
    feet: np.ndarray  # (2, 3)
    feet_yaw: np.ndarray  # (2,)

    @classmethod
    def initial(cls, *, stance: float = 1.0) -> "State":
        heading = 0.0
        feet = np.zeros((2, 3))
        lat = left_vector(np.float64(heading))
        for side in (0, 1):
            feet[side] = lat * SIDE_SIGN[side] * STANCE_HALF * stance
        feet[:, 1] = ANKLE_HEIGHT
        return cls(root_xz=np.zeros(2), heading=heading, feet=feet,
                   feet_yaw=heading + SIDE_SIGN * TOE_OUT)


@dataclass
class Event:
    """A countable moment inside a segment (frame indices are global once composed)."""

    kind: str  # jump | hop | jack | step | kick | punch | wave | clap | squat | bow | raise | beat
    frame: int  # the peak / apex frame
    start: int
    end: int
    side: str = "none"
    height: float = 0.0  # jumps: apex height of the lowest foot joint above the floor (m)
    extra: dict = field(default_factory=dict)

    def shifted(self, offset: int) -> "Event":
        return Event(kind=self.kind, frame=self.frame + offset, start=self.start + offset,
                     end=self.end + offset, side=self.side, height=self.height, extra=dict(self.extra))

    def to_json(self) -> dict:
        return {"kind": self.kind, "frame": self.frame, "start": self.start, "end": self.end,
                "side": self.side, "height": round(self.height, 5), **self.extra}


@dataclass
class Context:
    segment: Segment
    state: State
    style: StyleSpec
    person: Person
    fps: float = 20.0
    seed: int = 0


@dataclass
class Result:
    channels: Channels
    state: State  # the end state
    events: list[Event]
    arm_busy: np.ndarray  # (T, 2) 1 where a gesture drives the arm
    gait_phase: np.ndarray  # (T,) stride phase (0 when not stepping)
    posture: np.ndarray  # (T,) weight of the style's posture layer
    params: dict = field(default_factory=dict)  # resolved numbers worth labelling


def feet_center(feet: np.ndarray) -> np.ndarray:
    """Floor point (x, z) midway between the two feet: (..., 2, 3) -> (..., 2)."""
    return (feet[..., 0, ::2] + feet[..., 1, ::2]) / 2


def end_state(ch: Channels) -> State:
    """The state a segment leaves behind (last frame)."""
    return State(root_xz=ch.root[-1, [0, 2]].copy(), heading=float(ch.heading[-1]),
                 feet=ch.ankle[-1].copy(), feet_yaw=ch.foot_yaw[-1].copy())


def arm_angles(swing: np.ndarray, flex: np.ndarray, *, abduct: float | np.ndarray = 0.1,
               twist: float | np.ndarray = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Arm targets from angles, per side: swing (T, 2) forward (+), flex (T, 2) elbow, abduct
    outward, twist turns the elbow's bending plane upward. Returns hand, pole (T, 2, 3)."""
    swing = np.asarray(swing, dtype=np.float64)
    T = swing.shape[0]
    ab = np.multiply(abduct, SIDE_SIGN)  # broadcasts against (T, 2)
    cs, ss = np.cos(swing), np.sin(swing)
    ca, sa = np.cos(ab), np.sin(ab)
    # u = Rz(ab) Rx(-swing) (0,-1,0); b = Rz(ab) Rx(-swing) (0,0,1)
    u = vector3(sa * cs, -ca * cs, ss)
    b = vector3(-sa * ss, ca * ss, cs)
    if isinstance(twist, np.ndarray) or twist != 0.0:
        tw = -np.broadcast_to(twist, (T, 2)) * SIDE_SIGN
        ub = cross(u, b)
        b = b * np.cos(tw)[..., None] + ub * np.sin(tw)[..., None]
    f = np.cos(flex)[..., None] * u + np.sin(flex)[..., None] * b
    hand = UPPER_ARM * u + FOREARM * f
    pole = -b
    pole[..., 0] += 0.3 * SIDE_SIGN
    return hand, pole


def blend_in_out(frames: int, start: float, stop: float, ramp: float) -> np.ndarray:
    """Weight (frames,) rising smoothly from 0 to 1 over ``ramp`` frames at ``start`` and back
    to 0 at ``stop``."""
    t = np.arange(frames, dtype=np.float64)
    up = np.clip((t - start) / max(ramp, 1e-6), 0, 1)
    down = np.clip((stop - t) / max(ramp, 1e-6), 0, 1)
    w = np.minimum(up, down)
    return w * w * (3 - 2 * w)


__all__ = ["ARM", "Context", "Event", "Result", "State", "arm_angles", "blend_in_out", "end_state", "feet_center"]
