"""Styles (motifs) layered onto every action: gait knobs read by the primitives, and a
posture/arm layer applied to the composed channels (:func:`apply_style`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.synth.rig import SIDE_SIGN, Channels

STYLES: tuple[str, ...] = (
    "none", "zombie", "chicken", "hands_up", "crouched", "old", "happy", "sad", "robot",
    "drunk", "gorilla", "proud",
)


@dataclass(frozen=True)
class StyleSpec:
    """Numeric knobs of a style (1 / 0 = no change)."""

    name: str = "none"
    tempo: float = 1.0  # cadence multiplier
    stride: float = 1.0  # step length multiplier
    lift: float = 1.0  # swing-foot height multiplier
    stance: float = 1.0  # stance width multiplier
    crouch: float = 0.0  # pelvis lowered (m)
    bounce: float = 1.0  # pelvis bob multiplier
    swing: float = 1.0  # arm swing multiplier
    elbow: float = 0.0  # extra elbow flexion in gaits (rad)
    trunk_pitch: float = 0.0  # forward lean of the trunk (rad)
    neck_pitch: float = 0.0  # head down (+) / up (-)
    shrug: float = 0.0  # collar raise (+) / slump (-)
    knee_out: float = 0.0  # knees pointing outward (rad)
    sway: float = 0.0  # side-to-side trunk roll (rad)
    sway_hz: float = 0.0
    counter_rotation: float = 1.0
    roll: float = 1.0  # heel-toe roll multiplier
    jump: float = 1.0  # jump height multiplier
    arms: str = "free"  # arm layer: free | zombie | up | chicken | gorilla
    stepped: bool = False  # robot: stepped (sample-and-hold) upper body
    wobble: float = 0.0  # drunk: lateral path wobble (m)
    head_bob: float = 0.0  # chicken: head forward/back with the steps (m-ish)
    bob_hz: float = 0.0

    def scaled(self, strength: float) -> "StyleSpec":
        """Interpolate every knob toward neutral (strength 0) or beyond (> 1)."""
        if strength == 1.0:
            return self
        out = dict(self.__dict__)
        for name, value in out.items():
            if isinstance(value, float):
                ref = _NEUTRAL_VALUES[name]
                out[name] = ref + (value - ref) * strength
        return StyleSpec(**out)


_NEUTRAL_VALUES = dict(StyleSpec().__dict__)  # read-only: the knobs' neutral values

SPECS: dict[str, StyleSpec] = {
    "none": StyleSpec(),
    "zombie": StyleSpec(name="zombie", tempo=0.72, stride=0.6, lift=0.35, stance=1.15, crouch=0.03,
                        bounce=0.4, swing=0.0, trunk_pitch=0.12, neck_pitch=0.25, counter_rotation=0.3,
                        roll=0.3, jump=0.6, arms="zombie", sway=0.07, sway_hz=0.45),
    "chicken": StyleSpec(name="chicken", tempo=1.2, stride=0.6, lift=1.3, stance=1.2, crouch=0.05,
                         bounce=1.2, swing=0.0, trunk_pitch=0.2, neck_pitch=-0.15, knee_out=0.25,
                         arms="chicken", head_bob=0.06),
    "hands_up": StyleSpec(name="hands_up", swing=0.0, arms="up", counter_rotation=0.5, neck_pitch=-0.1),
    "crouched": StyleSpec(name="crouched", tempo=0.8, stride=0.7, lift=1.2, stance=1.2, crouch=0.2,
                          bounce=0.4, swing=0.3, elbow=0.9, trunk_pitch=0.45, neck_pitch=-0.3,
                          knee_out=0.1, jump=0.7),
    "old": StyleSpec(name="old", tempo=0.75, stride=0.55, lift=0.5, stance=1.15, crouch=0.04,
                     bounce=0.5, swing=0.45, elbow=0.35, trunk_pitch=0.35, neck_pitch=-0.2,
                     shrug=-0.05, counter_rotation=0.5, roll=0.5, jump=0.5),
    "happy": StyleSpec(name="happy", tempo=1.15, stride=1.05, lift=1.5, bounce=2.2, swing=1.8,
                       elbow=0.3, trunk_pitch=-0.06, neck_pitch=-0.15, shrug=0.05, jump=1.3, sway=0.05,
                       sway_hz=1.0),
    "sad": StyleSpec(name="sad", tempo=0.78, stride=0.75, lift=0.6, bounce=0.5, swing=0.35,
                     trunk_pitch=0.18, neck_pitch=0.45, shrug=-0.12, counter_rotation=0.5, jump=0.6),
    "robot": StyleSpec(name="robot", tempo=0.9, stride=0.85, lift=1.1, bounce=0.0, swing=1.3,
                       elbow=1.45, counter_rotation=0.0, roll=0.15, stepped=True, neck_pitch=0.0),
    "drunk": StyleSpec(name="drunk", tempo=0.85, stride=0.75, lift=0.8, stance=1.4, bounce=0.7,
                       swing=0.8, trunk_pitch=0.05, sway=0.12, sway_hz=0.5, wobble=0.25,
                       neck_pitch=0.1, jump=0.7),
    "gorilla": StyleSpec(name="gorilla", tempo=0.85, stride=0.75, lift=1.0, stance=1.7, crouch=0.12,
                         bounce=0.8, swing=0.6, trunk_pitch=0.5, neck_pitch=-0.35, knee_out=0.35,
                         arms="gorilla", sway=0.09, sway_hz=0.0, shrug=0.1),
    "proud": StyleSpec(name="proud", tempo=0.95, stride=0.95, lift=2.6, bounce=1.0, swing=2.0,
                       elbow=-0.1, trunk_pitch=-0.1, neck_pitch=-0.15, shrug=0.04, roll=0.6),
}


def style_spec(name: str, strength: float = 1.0) -> StyleSpec:
    if name not in SPECS:
        raise ValueError(f"unknown style {name!r}")
    return SPECS[name].scaled(strength)


# ---------------------------------------------------------------------------- arm layers
def _arm_layer(name: str, T: int, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hand (T,2,3), pole (T,2,3), hand_frame (T,2)) of an arm style."""
    hand = np.empty((T, 2, 3))
    pole = np.empty((T, 2, 3))
    s = SIDE_SIGN
    if name == "zombie":  # arms stretched forward at shoulder height, slowly drifting
        drift = 0.03 * np.sin(2 * np.pi * 0.4 * np.arange(T) / 20.0)
        hand[:, :, 0] = -s * 0.06
        hand[:, :, 1] = -0.04 + drift[:, None] * s
        hand[:, :, 2] = 0.52
        pole[:] = (0.0, -1.0, 0.0)
        pole[:, :, 0] = s * 0.4
        frame = np.full((T, 2), 0.7)
    elif name == "up":  # both hands up above the head
        hand[:, :, 0] = s * 0.12
        hand[:, :, 1] = 0.5
        hand[:, :, 2] = 0.06
        pole[:, :, 0] = s * 1.0
        pole[:, :, 1] = 0.0
        pole[:, :, 2] = -0.3
        frame = np.ones((T, 2))
    elif name == "chicken":  # hands tucked at the armpits, elbows flapping
        flap = 0.5 + 0.5 * np.sin(2 * np.pi * phase)
        hand[:, :, 0] = s * 0.02
        hand[:, :, 1] = -0.08
        hand[:, :, 2] = 0.12
        pole[:, :, 0] = s * (0.6 + 1.2 * flap[:, None])
        pole[:, :, 1] = -0.6 + 1.0 * flap[:, None]
        pole[:, :, 2] = -0.5
        frame = np.ones((T, 2))
    elif name == "gorilla":  # long arms hanging low and wide, in front of the knees
        hand[:, :, 0] = s * 0.16
        hand[:, :, 1] = -0.5
        hand[:, :, 2] = 0.12
        pole[:, :, 0] = s * 1.0
        pole[:, :, 1] = 0.0
        pole[:, :, 2] = -0.6
        frame = np.zeros((T, 2))
    else:
        raise ValueError(name)
    return hand, pole, frame


def _stepped(x: np.ndarray, hold: int) -> np.ndarray:
    """Robot look: hold values for ``hold`` frames and snap quickly (2-frame ramps) in between."""
    T = x.shape[0]
    if T < 3:
        return x
    t = np.arange(T)
    knots = np.arange(0, T + hold, hold)
    k = np.minimum(t // hold, len(knots) - 1)
    frac = np.clip((t - knots[k]) / 2.0, 0.0, 1.0)
    frac = frac * frac * (3 - 2 * frac)
    prev = x[np.maximum(knots[k] - 1, 0)]
    cur = x[np.minimum(knots[k] + hold - 1, T - 1)]
    f = frac.reshape((-1,) + (1,) * (x.ndim - 1))
    return prev + (cur - prev) * f


def apply_style(ch: Channels, spec: StyleSpec, *, arm_free: np.ndarray, gait_phase: np.ndarray,
                posture_weight: np.ndarray, fps: float = 20.0, seed: int = 0, in_place: bool = False) -> Channels:
    """Layer the style's posture and arms onto composed channels (returns a new object unless
    ``in_place``).

    arm_free (T, 2): 1 where an arm is not used by a gesture (the style may take it over).
    gait_phase (T,): stride phase (used by flapping / head bob). posture_weight (T,): 1 where the
    posture offsets apply fully (0 for actions that need their own trunk, e.g. a bow).
    """
    out = ch if in_place else ch.copy()
    T = ch.frames
    t = np.arange(T) / fps
    w = posture_weight
    # trunk posture spread over the spine; head compensates part of the lean
    out.spine[:, :, 0] += (spec.trunk_pitch * w)[:, None] * np.array([0.45, 0.35, 0.2])
    out.neck[:, 0] += (spec.neck_pitch - 0.4 * spec.trunk_pitch) * w
    out.collar[:, :, 2] += (spec.shrug * w)[:, None] * -SIDE_SIGN
    out.knee_out += spec.knee_out
    if spec.sway:
        hz = spec.sway_hz if spec.sway_hz > 0 else None
        if hz is None:
            sway = np.sin(2 * np.pi * gait_phase)  # side to side with the stride
        else:
            rng = np.random.default_rng(seed)
            sway = np.sin(2 * np.pi * hz * t + rng.uniform(0, 2 * np.pi))
            sway += 0.4 * np.sin(2 * np.pi * hz * 1.7 * t + rng.uniform(0, 2 * np.pi))
        out.spine[:, :, 2] += (spec.sway * sway)[:, None] * np.array([0.3, 0.4, 0.3])
        out.neck[:, 2] -= 0.3 * spec.sway * sway
    if spec.head_bob:
        bob = np.sin(4 * np.pi * gait_phase) * w
        out.neck[:, 0] += 4.0 * spec.head_bob * bob
    if spec.arms != "free":
        hand, pole, frame = _arm_layer(spec.arms, T, 2 * gait_phase)
        a = arm_free[..., None]
        out.hand = out.hand * (1 - a) + hand * a
        out.elbow_pole = out.elbow_pole * (1 - a) + pole * a
        out.hand_frame = out.hand_frame * (1 - arm_free) + frame * arm_free
    if spec.stepped:
        out.spine = _stepped(out.spine, 4)
        out.neck = _stepped(out.neck, 4)
        out.hand = _stepped(out.hand, 4)
        out.pelvis = _stepped(out.pelvis, 4)
    return out
