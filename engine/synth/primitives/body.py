"""Whole-body actions without stepping: standing (idle) and bowing."""
from __future__ import annotations

import numpy as np

from engine.synth.physics import smoothstep
from engine.synth.primitives.base import Context, Event, Result, end_state, feet_center
from engine.synth.rig import STAND_PELVIS, Channels, forward_vector, left_vector, standing_channels


def base_stand(ctx: Context, *, idle: float = 1.0) -> Channels:
    """Standing on the state's feet with a little idle motion (weight shift, breathing)."""
    n = ctx.segment.frames
    st = ctx.state
    mid = feet_center(st.feet)
    ch = standing_channels(n, root_xz=mid, heading=st.heading, feet=st.feet, feet_yaw=st.feet_yaw)
    t = np.arange(n) / ctx.fps
    rng = np.random.default_rng(ctx.seed + 3)
    ph = rng.uniform(0, 2 * np.pi, 3)
    lat = left_vector(np.float64(st.heading))
    shift = idle * 0.012 * np.sin(2 * np.pi * 0.22 * t + ph[0])
    ch.root[:, 0] += lat[0] * shift
    ch.root[:, 2] += lat[2] * shift
    ch.root[:, 1] -= ctx.style.crouch
    ch.pelvis[:, 2] += idle * 0.02 * np.sin(2 * np.pi * 0.22 * t + ph[0])
    ch.spine[:, 2, 0] += idle * 0.015 * np.sin(2 * np.pi * 0.3 * t + ph[1])
    ch.neck[:, 1] += idle * 0.08 * np.sin(2 * np.pi * 0.12 * t + ph[2])
    ch.spine[:, :, 0] += ctx.person.lean / 3
    ch.neck[:, 0] += ctx.person.head
    ch.hand[:, :, 2] += 0.01 * np.sin(2 * np.pi * 0.3 * t + ph[1])[:, None]
    return ch


def stand(ctx: Context) -> Result:
    n = ctx.segment.frames
    ch = base_stand(ctx)
    return Result(channels=ch, state=end_state(ch), events=[], arm_busy=np.zeros((n, 2)),
                  gait_phase=np.arange(n) / ctx.fps * 0.8, posture=np.ones(n))


def bow(ctx: Context) -> Result:
    seg = ctx.segment
    n = seg.frames
    ch = base_stand(ctx, idle=0.3)
    fps = ctx.fps
    count = seg.count
    period = n / count
    depth = np.clip(0.85 * seg.intensity, 0.35, 1.3)
    t = np.arange(n, dtype=np.float64)
    bend = np.zeros(n)
    events = []
    tempo = 1.0 / max(seg.speed, 0.3)
    for k in range(count):
        t0 = k * period + 0.1 * period
        down = min(0.55 * fps * tempo, 0.3 * period)
        hold = min(0.35 * fps * tempo, 0.15 * period)
        up = min(0.6 * fps * tempo, 0.35 * period)
        w = smoothstep((t - t0) / down) * (1 - smoothstep((t - t0 - down - hold) / up))
        bend = np.maximum(bend, w)
        events.append(Event(kind="bow", frame=int(round(t0 + down + hold / 2)), start=int(t0),
                            end=int(min(n - 1, t0 + down + hold + up))))
    angle = depth * bend
    fwd = forward_vector(np.float64(ctx.state.heading))
    ch.pelvis[:, 0] += 0.7 * angle
    ch.spine[:, :, 0] += angle[:, None] * np.array([0.12, 0.1, 0.08])
    ch.neck[:, 0] += 0.35 * angle
    back = -0.16 * angle
    ch.root[:, 0] += fwd[0] * back
    ch.root[:, 2] += fwd[2] * back
    ch.root[:, 1] = np.minimum(ch.root[:, 1], STAND_PELVIS) - 0.02 * angle
    return Result(channels=ch, state=end_state(ch), events=events, arm_busy=np.zeros((n, 2)),
                  gait_phase=np.arange(n) / fps * 0.8, posture=1.0 - 0.7 * bend,
                  params={"depth_rad": float(depth)})
