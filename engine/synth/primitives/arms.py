"""Arm gestures: punch, wave, clap, raise arms. Used as actions (standing legs) and as
upper-body layers ("walks while waving the right hand")."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.synth.physics import smoothstep
from engine.synth.primitives.base import Context, Event, Result, end_state
from engine.synth.primitives.body import base_stand
from engine.synth.program import Segment
from engine.synth.rig import SIDE_SIGN, Channels


@dataclass
class ArmLayer:
    hand: np.ndarray  # (T, 2, 3) chest frame, relative to the shoulder
    pole: np.ndarray  # (T, 2, 3)
    busy: np.ndarray  # (T, 2) weight of the layer per arm
    spine_yaw: np.ndarray  # (T,) trunk twist
    events: list[Event]


def _sides(side: str) -> list[int]:
    return {"left": [0], "right": [1], "both": [0, 1]}.get(side, [1])


def _ramp(n: int, ramp: float) -> np.ndarray:
    t = np.arange(n, dtype=np.float64)
    w = np.minimum(np.clip(t / ramp, 0, 1), np.clip((n - 1 - t) / ramp, 0, 1))
    return smoothstep(w)


def gesture_layer(seg: Segment, n: int, fps: float) -> ArmLayer:
    """The arm layer of a gesture segment over ``n`` frames."""
    s = SIDE_SIGN
    hand = np.zeros((n, 2, 3))
    pole = np.zeros((n, 2, 3))
    busy = np.zeros((n, 2))
    twist = np.zeros(n)
    events: list[Event] = []
    t = np.arange(n, dtype=np.float64)
    ramp = min(0.45 * fps, n / 4)
    env = _ramp(n, ramp)
    count = seg.count
    amp = seg.intensity
    inner0, inner1 = ramp, n - 1 - ramp
    span = max(inner1 - inner0, 1.0)
    if seg.action == "wave":
        sides = _sides(seg.side)
        period = span / count
        ph = np.clip((t - inner0) / period, 0, count)
        osc = np.sin(2 * np.pi * ph)
        for side in sides:
            hand[:, side] = (s[side] * 0.27, 0.34, 0.15)
            hand[:, side, 0] += s[side] * 0.11 * amp * osc
            hand[:, side, 1] += 0.02 * amp * np.abs(osc)
            pole[:, side] = (s[side] * 0.5, -1.0, 0.0)
            busy[:, side] = env
        for k in range(count):
            f = inner0 + (k + 0.25) * period
            events.append(Event(kind="wave", frame=int(round(f)), start=int(inner0 + k * period),
                                end=int(inner0 + (k + 1) * period), side=seg.side))
    elif seg.action == "clap":
        period = span / count
        ph = np.clip((t - inner0) / period, 0, count)
        # hands meet at whole periods + 0.5: closeness 1 at contact
        close = 0.5 - 0.5 * np.cos(2 * np.pi * ph)
        close = np.where((t >= inner0) & (t <= inner1), close, 0.0)
        for side in (0, 1):
            apart = np.array([s[side] * 0.02, -0.12, 0.3])
            together = np.array([-s[side] * 0.165, -0.1, 0.36])
            hand[:, side] = apart + (together - apart) * close[:, None] ** 0.7
            pole[:, side] = (s[side] * 0.7, -1.0, -0.2)
            busy[:, side] = env
        for k in range(count):
            f = inner0 + (k + 0.5) * period
            events.append(Event(kind="clap", frame=int(round(f)), start=int(inner0 + k * period),
                                end=int(inner0 + (k + 1) * period), side="both"))
    elif seg.action == "punch":
        sides = _sides(seg.side)
        period = span / count
        for side in (0, 1):
            hand[:, side] = (-s[side] * 0.1, 0.07, 0.22)
            pole[:, side] = (s[side] * 0.5, -1.0, -0.3)
            busy[:, side] = env
        for k in range(count):
            side = sides[k % len(sides)] if seg.side != "both" else (k + (0 if seg.lead == "left" else 1)) % 2
            t0 = inner0 + k * period + 0.15 * period
            out_t = min(0.12 * fps, 0.25 * period)
            back_t = min(0.3 * fps, 0.5 * period)
            w = smoothstep((t - t0) / out_t) * (1 - smoothstep((t - t0 - out_t - 0.05 * period) / back_t))
            reach = np.array([-s[side] * 0.09, 0.03, 0.24 + 0.28 * min(amp, 1.0)])
            hand[:, side] += (reach - hand[:, side]) * w[:, None]
            twist += -s[side] * 0.28 * min(amp, 1.3) * w
            events.append(Event(kind="punch", frame=int(round(t0 + out_t)), start=int(t0),
                                end=int(min(n - 1, t0 + out_t + back_t)), side=("left", "right")[side]))
    elif seg.action == "raise_arms":
        sides = _sides(seg.side if seg.side != "none" else "both")
        period = span / count
        lift = np.zeros(n)
        for k in range(count):
            t0 = inner0 + k * period
            up = 0.3 * period
            w = smoothstep((t - t0) / up) * (1 - smoothstep((t - t0 - 0.65 * period) / (0.3 * period)))
            lift = np.maximum(lift, w)
            events.append(Event(kind="raise", frame=int(round(t0 + up)), start=int(t0),
                                end=int(t0 + 0.95 * period), side=seg.side if seg.side != "none" else "both"))
        for side in sides:
            low = np.array([s[side] * 0.06, -0.5, 0.04])
            high = np.array([s[side] * (0.1 + 0.05 * (amp < 1)), 0.49 * min(amp, 1.0) + 0.03, 0.07])
            hand[:, side] = low + (high - low) * lift[:, None]
            pole[:, side] = (s[side] * 1.0, 0.0, -0.4)
            busy[:, side] = np.maximum(lift, env * 0.999) if count > 1 else env
        if len(sides) == 1:
            twist += 0.0
    else:
        raise ValueError(f"not a gesture: {seg.action}")
    return ArmLayer(hand=hand, pole=pole, busy=busy, spine_yaw=twist * env, events=events)


def apply_layer(ch: Channels, layer: ArmLayer) -> None:
    """Blend an arm layer into channels in place (gesture arms move with the chest)."""
    w = layer.busy[..., None]
    ch.hand = ch.hand * (1 - w) + layer.hand * w
    ch.elbow_pole = ch.elbow_pole * (1 - w) + layer.pole * w
    ch.hand_frame = ch.hand_frame * (1 - layer.busy) + layer.busy
    ch.spine[:, :, 1] += layer.spine_yaw[:, None] * np.array([0.3, 0.35, 0.35])


def gesture(ctx: Context) -> Result:
    seg = ctx.segment
    n = seg.frames
    ch = base_stand(ctx, idle=0.5)
    layer = gesture_layer(seg, n, ctx.fps)
    apply_layer(ch, layer)
    return Result(channels=ch, state=end_state(ch), events=layer.events, arm_busy=layer.busy,
                  gait_phase=np.arange(n) / ctx.fps * 0.8, posture=np.ones(n))
