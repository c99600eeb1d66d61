"""A simple dance: step-touch side to side on the beat with hip bounce and arm pumps."""
from __future__ import annotations

import numpy as np

from engine.synth.physics import StepPlan, foot_track, smooth5
from engine.synth.primitives.base import STANCE_HALF, Context, Event, Result, arm_angles, end_state, feet_center
from engine.synth.rig import ANKLE_HEIGHT, SIDE_SIGN, STAND_PELVIS, Channels, left_vector


def dance(ctx: Context) -> Result:
    seg = ctx.segment
    n = seg.frames
    fps = ctx.fps
    st = ctx.state
    heading = float(st.heading)
    lat = left_vector(np.float64(heading))
    bpm = 110.0 * seg.speed * ctx.style.tempo
    beat = fps * 60.0 / bpm  # frames per beat
    beats = max(2, int(n / beat) - 1)
    center = feet_center(st.feet)
    width = 0.28 * min(seg.intensity, 1.4)
    half = STANCE_HALF * ctx.style.stance
    # pattern: L out, R closes, R out, L closes (positions along the lateral axis)
    pos = {0: 0.0, 1: 0.0}  # lateral offset of the body centre per foot plant
    plans = {0: [], 1: []}
    events = []
    cur = 0.0
    for b in range(beats):
        phase = b % 4
        side = 0 if phase in (0, 3) else 1
        if phase == 0:
            cur = width / 2
        elif phase == 2:
            cur = -width / 2
        target_c = cur
        t_land = (b + 1) * beat - 1.0
        t_lift = t_land - 0.55 * beat
        xz = center + lat[[0, 2]] * (target_c + SIDE_SIGN[side] * half)
        plans[side].append((t_lift, t_land, xz))
        events.append(Event(kind="beat", frame=int(round(t_land)), start=int(t_lift), end=int(t_land),
                            side=("left", "right")[side]))
    # return to the centre at the end
    for side in (0, 1):
        last = plans[side][-1][1] if plans[side] else 0.0
        t_lift = max(last + 1.0, (beats + 0.2) * beat)
        if t_lift + 0.5 * beat < n - 1:
            xz = center + lat[[0, 2]] * SIDE_SIGN[side] * half
            plans[side].append((t_lift, t_lift + 0.5 * beat, xz))
    ankle = np.empty((n, 2, 3))
    yaw = np.empty((n, 2))
    pitch = np.empty((n, 2))
    contact = np.empty((n, 2, 2), dtype=bool)
    for side in (0, 1):
        steps = [p for p in plans[side] if p[1] < n - 1]
        lift = np.array([p[0] for p in steps])
        land = np.array([p[1] for p in steps])
        plant = np.array([[p[2][0], ANKLE_HEIGHT, p[2][1]] for p in steps]).reshape(-1, 3)
        plan = StepPlan(start_ankle=st.feet[side].copy(), start_yaw=float(st.feet_yaw[side]), lift=lift, land=land,
                        plant=plant, yaw=np.full(len(steps), st.feet_yaw[side]), height=np.full(len(steps), 0.07),
                        toe_off=0.3, heel_strike=-0.05, roll_off=2.0, roll_on=1.0)
        a, y, p, c = foot_track(plan, n)
        ankle[:, side], yaw[:, side], pitch[:, side], contact[:, side] = a, y, p, c
    t = np.arange(n, dtype=np.float64)
    bphase = t / beat
    mid = feet_center(ankle)
    root = np.empty((n, 3))
    root[:, 0] = smooth5(mid[:, 0])
    root[:, 2] = smooth5(mid[:, 1])
    amp = 0.035 * seg.intensity * ctx.style.bounce
    root[:, 1] = STAND_PELVIS - 0.03 - ctx.style.crouch - amp * (0.5 + 0.5 * np.cos(2 * np.pi * bphase))
    sway = np.sin(np.pi * bphase)
    pelvis = np.zeros((n, 3))
    pelvis[:, 2] = 0.08 * sway
    spine = np.zeros((n, 3, 3))
    spine[:, :, 2] = (-0.06 * sway)[:, None]
    spine[:, :, 1] = (0.08 * np.sin(np.pi * bphase + 0.5))[:, None] * np.array([0.3, 0.3, 0.4])
    neck = np.zeros((n, 3))
    neck[:, 0] = 0.08 * np.cos(2 * np.pi * bphase)
    pump = 0.5 + 0.5 * np.cos(np.pi * bphase)
    swing = np.stack([0.3 + 0.9 * pump, 0.3 + 0.9 * (1 - pump)], -1)
    hand, pole = arm_angles(swing, 1.3 + 0.3 * np.stack([pump, 1 - pump], -1), abduct=0.35)
    env = np.clip(np.minimum(t, n - 1 - t) / (0.4 * fps), 0, 1)
    env = env * env * (3 - 2 * env)
    hand = hand * env[:, None, None] + np.array([[0.05, -0.5, 0.04], [-0.05, -0.5, 0.04]]) * (1 - env[:, None, None])
    ch = Channels(root=root, heading=np.full(n, heading), pelvis=pelvis * env[:, None], spine=spine * env[:, None, None],
                  neck=neck * env[:, None], collar=np.zeros((n, 2, 3)), ankle=ankle, foot_yaw=yaw, foot_pitch=pitch,
                  knee_out=np.full((n, 2), 0.1), hand=hand, elbow_pole=pole, hand_frame=np.zeros((n, 2)),
                  contact=contact)
    return Result(channels=ch, state=end_state(ch), events=events, arm_busy=np.zeros((n, 2)),
                  gait_phase=bphase / 2, posture=np.ones(n), params={"bpm": bpm, "beats": beats})
