"""Leg actions on planted feet: squats and kicks."""
from __future__ import annotations

import numpy as np

from engine.synth.physics import smoothstep
from engine.synth.primitives.base import Context, Event, Result, arm_angles, end_state, feet_center
from engine.synth.primitives.body import base_stand
from engine.synth.rig import ANKLE_HEIGHT, SIDE_SIGN, forward_vector, left_vector


def squat(ctx: Context) -> Result:
    seg = ctx.segment
    n = seg.frames
    fps = ctx.fps
    ch = base_stand(ctx, idle=0.2)
    t = np.arange(n, dtype=np.float64)
    period = n / seg.count
    depth = float(np.clip(0.1 + 0.28 * seg.intensity, 0.12, 0.5))
    w = np.zeros(n)
    events = []
    for k in range(seg.count):
        t0 = k * period + 0.08 * period
        down = min(0.7 * fps / seg.speed, 0.4 * period)
        hold = min(0.15 * fps, 0.08 * period)
        up = min(0.7 * fps / seg.speed, 0.4 * period)
        wk = smoothstep((t - t0) / down) * (1 - smoothstep((t - t0 - down - hold) / up))
        w = np.maximum(w, wk)
        events.append(Event(kind="squat", frame=int(round(t0 + down + hold / 2)), start=int(t0),
                            end=int(min(n - 1, t0 + down + hold + up))))
    fwd = forward_vector(np.float64(ctx.state.heading))
    ch.root[:, 1] -= depth * w
    back = -0.16 * (depth / 0.38) * w
    ch.root[:, 0] += fwd[0] * back
    ch.root[:, 2] += fwd[2] * back
    ch.pelvis[:, 0] += 0.45 * w * (depth / 0.38)
    ch.spine[:, :, 0] += (0.25 * w)[:, None] * np.array([0.4, 0.3, 0.3])
    ch.neck[:, 0] -= 0.45 * w
    ch.knee_out += 0.25 * w[:, None]
    swing = np.stack([1.35 * w, 1.35 * w], -1)
    hand, pole = arm_angles(swing, 0.15 + 0.1 * w[:, None] * np.ones(2), abduct=0.1)
    ch.hand, ch.elbow_pole = hand, pole
    return Result(channels=ch, state=end_state(ch), events=events, arm_busy=np.zeros((n, 2)),
                  gait_phase=np.arange(n) / fps * 0.8, posture=1.0 - 0.6 * w, params={"depth": depth})


def kick(ctx: Context) -> Result:
    seg = ctx.segment
    n = seg.frames
    fps = ctx.fps
    side = 0 if seg.side == "left" else 1
    stance = 1 - side
    ch = base_stand(ctx, idle=0.2)
    heading = np.float64(ctx.state.heading)
    fwd = forward_vector(heading)
    lat = left_vector(heading)
    t = np.arange(n, dtype=np.float64)
    period = n / seg.count
    height = float(np.clip(0.35 + 0.35 * seg.intensity, 0.35, 1.0))
    plant = ctx.state.feet[side].copy()
    stance_foot = ctx.state.feet[stance]
    shift_w = np.zeros(n)
    lift_w = np.zeros(n)
    ext_w = np.zeros(n)
    events = []
    sp = 1.0 / max(seg.speed, 0.4)
    for k in range(seg.count):
        t0 = k * period + 0.05 * period
        shift = min(0.25 * fps * sp, 0.15 * period)
        lift = min(0.2 * fps * sp, 0.15 * period)
        ext = min(0.15 * fps * sp, 0.12 * period)
        hold = min(0.08 * fps, 0.05 * period)
        ret = min(0.2 * fps * sp, 0.15 * period)
        down = min(0.22 * fps * sp, 0.15 * period)
        a = t0 + shift
        b = a + lift
        c = b + ext + hold
        d = c + ret
        e = d + down
        sw = smoothstep((t - t0) / shift) * (1 - smoothstep((t - e) / shift))
        lw = smoothstep((t - a) / lift) * (1 - smoothstep((t - d) / down))
        xw = smoothstep((t - b) / ext) * (1 - smoothstep((t - c) / ret))
        shift_w = np.maximum(shift_w, sw)
        lift_w = np.maximum(lift_w, lw)
        ext_w = np.maximum(ext_w, xw)
        events.append(Event(kind="kick", frame=int(round(b + ext)), start=int(t0), end=int(min(n - 1, e + shift)),
                            side=("left", "right")[side]))
    # weight over the stance foot
    mid = feet_center(ctx.state.feet)
    over = stance_foot[[0, 2]] * 0.8 + mid * 0.2
    ch.root[:, 0] += (over[0] - mid[0]) * shift_w
    ch.root[:, 2] += (over[1] - mid[1]) * shift_w
    hip = ch.root[:, [0, 2]] + lat[[0, 2]] * SIDE_SIGN[side] * 0.08
    chamber = np.stack([hip[:, 0] + fwd[0] * 0.28, np.full(n, 0.42), hip[:, 1] + fwd[2] * 0.28], -1)
    extend = np.stack([hip[:, 0] + fwd[0] * 0.62, np.full(n, height), hip[:, 1] + fwd[2] * 0.62], -1)
    raised = chamber + (extend - chamber) * ext_w[:, None]
    foot = plant + (raised - plant) * lift_w[:, None]
    foot[:, 1] = np.maximum(foot[:, 1], ANKLE_HEIGHT)
    ch.ankle[:, side] = foot
    ch.foot_pitch[:, side] = 0.45 * lift_w
    ch.contact[:, side, :] = (lift_w <= 1e-6)[:, None]
    ch.pelvis[:, 0] -= 0.25 * seg.intensity * ext_w
    ch.pelvis[:, 2] += -SIDE_SIGN[side] * 0.06 * shift_w
    ch.spine[:, :, 0] -= (0.1 * ext_w)[:, None]
    ch.root[:, 1] -= 0.03 * shift_w
    swing = np.zeros((n, 2))
    swing[:, stance] = 0.7 * ext_w
    swing[:, side] = -0.4 * ext_w
    hand, pole = arm_angles(swing, 0.4 + 0.5 * lift_w[:, None] * np.ones(2), abduct=0.15 + 0.35 * shift_w[:, None])
    ch.hand, ch.elbow_pole = hand, pole
    return Result(channels=ch, state=end_state(ch), events=events, arm_busy=np.zeros((n, 2)),
                  gait_phase=np.arange(n) / fps * 0.8, posture=1.0 - 0.5 * ext_w,
                  params={"height": height})
