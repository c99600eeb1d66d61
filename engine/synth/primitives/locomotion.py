"""Gaits: walk, jog, run, walk backwards, side-step and turning in place.

The root follows a path with a smooth speed profile; a stride phase drives alternating
footsteps. Each foot lands where the root will be at that foot's mid-stance (plus half the
stance width), stays planted (heel-strike / flat / heel-off on the toe), and swings with a
minimum-jerk arc to its next plant. Pelvis bob, sway, rotation and list, torso
counter-rotation and the arm swing are derived from the phase and the realised feet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.synth.physics import StepPlan, foot_track, gradient, ramp_profile, unwrap
from engine.synth.primitives.base import (STANCE_HALF, TOE_OUT, Context, Event, Result, arm_angles, end_state,
                                          feet_center)
from engine.synth.rig import ANKLE_HEIGHT, SIDE_SIGN, STAND_PELVIS, Channels, forward_vector, left_vector


@dataclass(frozen=True)
class GaitParams:
    speed: float  # m/s
    cadence: float  # steps/s
    duty: float  # share of a stride a foot is on the ground
    lift: float  # swing height of the ankle (m)
    bob: float  # pelvis vertical oscillation (m); negative = lowest at mid-stance (running)
    knee: float  # pelvis lowered to bend the knees (m)
    arm_gain: float  # arm swing (rad per metre of foot separation)
    elbow: float  # elbow flexion (rad)
    lean: float  # trunk lean (rad)
    toe_off: float
    heel_strike: float
    stance: float  # stance width multiplier
    heading_offset: float  # facing minus direction of travel (rad)


GAITS: dict[str, GaitParams] = {
    "walk": GaitParams(1.3, 1.85, 0.62, 0.09, 0.022, 0.01, 0.65, 0.25, 0.03, 0.55, -0.25, 1.0, 0.0),
    "jog": GaitParams(2.2, 2.6, 0.42, 0.16, -0.035, 0.05, 0.7, 1.35, 0.1, 0.6, -0.12, 0.9, 0.0),
    "run": GaitParams(2.9, 2.8, 0.36, 0.22, -0.045, 0.06, 0.75, 1.45, 0.16, 0.7, -0.1, 0.85, 0.0),
    "walk_backward": GaitParams(0.75, 1.7, 0.64, 0.07, 0.015, 0.03, 0.5, 0.3, -0.02, 0.25, 0.0, 1.05, np.pi),
    "side_step": GaitParams(0.5, 2.1, 0.62, 0.06, 0.012, 0.05, 0.0, 0.3, 0.04, 0.2, 0.0, 1.9, 0.0),
    "turn": GaitParams(0.0, 1.7, 0.64, 0.05, 0.01, 0.02, 0.2, 0.3, 0.02, 0.25, -0.05, 1.0, 0.0),
}
WALK_DUTY = 0.64


def _path_points(ctx: Context, distance: float, heading_offset: float) -> tuple[np.ndarray, float, float]:
    """Polyline (M, 2) of the root on the floor, total length, heading offset to use."""
    seg = ctx.segment
    h0 = ctx.state.heading
    r0 = ctx.state.root_xz
    M = 48
    if seg.action == "side_step":  # the body faces across its travel, with a path too
        heading_offset = np.pi / 2 if seg.direction != "right" else -np.pi / 2
    if seg.path is not None and len(seg.path) >= 2:
        pts = np.asarray(seg.path, dtype=np.float64)
        c, s = np.cos(h0), np.sin(h0)
        world = np.stack([pts[:, 0] * c + pts[:, 1] * s, -pts[:, 0] * s + pts[:, 1] * c], -1) + r0
        seglen = np.linalg.norm(np.diff(world, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seglen)])
        q = np.linspace(0.0, cum[-1], M)
        world = np.stack([np.interp(q, cum, world[:, 0]), np.interp(q, cum, world[:, 1])], -1)
        # smooth corners a little (keep the end points)
        k = np.array([0.25, 0.5, 0.25])
        for _ in range(3):
            inner = world[:-2] * k[0] + world[1:-1] * k[1] + world[2:] * k[2]
            world = np.concatenate([world[:1], inner, world[-1:]], 0)
        length = float(np.linalg.norm(np.diff(world, axis=0), axis=1).sum())
        return world, length, heading_offset
    travel = h0 + heading_offset
    turn_total = {"left": np.pi / 2, "right": -np.pi / 2, "circle_left": 2 * np.pi,
                  "circle_right": -2 * np.pi}.get(seg.direction, 0.0)
    if seg.action in ("side_step", "walk_backward"):
        turn_total = 0.0
    if abs(turn_total) >= 2 * np.pi - 1e-6 and distance / (2 * np.pi) < 0.5:
        # too short for a full circle at this pace: walk the arc of a 0.5 m circle
        turn_total = np.sign(turn_total) * distance / 0.5
    s = np.linspace(0.0, distance, M)
    alpha = travel + turn_total * s / max(distance, 1e-9)
    ds = distance / (M - 1)
    steps = np.stack([np.sin(alpha), np.cos(alpha)], -1) * ds
    pts = np.concatenate([[r0], r0 + np.cumsum(0.5 * (steps[1:] + steps[:-1]), 0)], 0)
    if ctx.style.wobble > 0 and distance > 0 and abs(turn_total) < np.pi:
        rng = np.random.default_rng(ctx.seed + 7)
        normal = np.stack([np.cos(alpha), -np.sin(alpha)], -1)
        env = np.sin(np.pi * s / distance)
        wob = ctx.style.wobble * env * np.sin(2 * np.pi * s / rng.uniform(2.0, 3.0) + rng.uniform(0, 2 * np.pi))
        pts = pts + normal * wob[:, None]
    return pts, float(distance), heading_offset


def _along(pts: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 2) and tangent angles (n,) at arc lengths s along a polyline."""
    seg = np.diff(pts, axis=0)
    cum = np.empty(len(pts))
    cum[0] = 0.0
    np.cumsum(np.sqrt(seg[:, 0] ** 2 + seg[:, 1] ** 2), out=cum[1:])
    out = np.empty((len(s), 2))
    out[:, 0] = np.interp(s, cum, pts[:, 0])
    out[:, 1] = np.interp(s, cum, pts[:, 1])
    ang = unwrap(np.arctan2(seg[:, 0], seg[:, 1]))
    mids = 0.5 * (cum[1:] + cum[:-1])
    tangent = np.interp(s, mids, ang)
    return out, tangent


@dataclass
class _Stride:
    """A gait segment's timing and path: cadence (steps/s), step length (m), step count K, the root's
    progress profile ``s_prof`` (0 -> 1) and speed envelope ``env``, the root on the floor and heading,
    and the stride phase ``phi`` (half a unit per step) from ``phi0`` to ``phi_end``."""

    g: GaitParams
    cadence: float
    step_len: float
    K: int
    s_prof: np.ndarray
    env: np.ndarray
    distance: float
    root_xz: np.ndarray  # (n, 2)
    heading: np.ndarray  # (n,)
    phi: np.ndarray
    phi0: float
    phi_end: float


def _plan_stride(ctx: Context) -> _Stride:
    seg, style, person = ctx.segment, ctx.style, ctx.person
    n = seg.frames
    fps = ctx.fps
    g = GAITS[seg.action]
    dur = n / fps
    speed_mult = min(seg.speed, 1.15) if seg.action in ("run", "jog") else seg.speed
    tempo = style.tempo * person.tempo * np.sqrt(speed_mult)
    cadence = seg.cadence if seg.cadence > 0 else g.cadence * tempo
    cadence = float(min(cadence, 2.9 if g.duty < 0.5 else 2.4))
    step_len = g.speed / g.cadence * np.sqrt(speed_mult) * style.stride
    K = max(2, int(round(dur * cadence)))
    ramp_s = min(0.45, (0.55 if seg.action in ("walk", "walk_backward", "side_step", "turn") else 0.8) / dur)
    # the root settles one step before the end, so the last step closes the feet beside it
    settle = int(min(fps / cadence, n / 4)) if seg.action != "turn" else 0
    ramp_m = min(0.45, ramp_s * n / max(n - settle, 1))
    s_prof = np.concatenate([ramp_profile(n - settle, ramp_m), np.ones(settle)])
    move_s = (n - settle) / fps * (1.0 - ramp_m)
    distance = min(step_len * cadence * move_s, step_len * 0.85 * K) if seg.action != "turn" else 0.0
    env = gradient(s_prof)
    env = env / max(env.max(), 1e-9)
    root_xz, heading, distance = _root_track(ctx, g, s_prof, distance)
    phi0 = 0.25
    # the phase follows the distance walked (even steps) plus a share of time (steps also
    # happen while starting, stopping and turning in place)
    time_prof = ramp_profile(n, min(0.3, 0.3 / dur))
    phi = phi0 + 0.5 * K * ((0.7 * s_prof + 0.3 * time_prof) if seg.action != "turn" else time_prof)
    return _Stride(g=g, cadence=cadence, step_len=step_len, K=K, s_prof=s_prof, env=env, distance=distance,
                   root_xz=root_xz, heading=heading, phi=phi, phi0=phi0, phi_end=phi0 + 0.5 * K)


def _root_track(ctx: Context, g: GaitParams, s_prof: np.ndarray, distance: float):
    """(root (n, 2) on the floor, heading (n,), distance walked): turning in place, or along the path."""
    n = len(s_prof)
    if ctx.segment.action == "turn":
        heading = ctx.state.heading + ctx.segment.turn * s_prof
        root_xz = np.broadcast_to(ctx.state.root_xz, (n, 2)).copy()
        root_xz = root_xz + (feet_center(ctx.state.feet) - ctx.state.root_xz) * 1.0
        return root_xz, heading, distance
    pts, distance, h_off = _path_points(ctx, distance, g.heading_offset)
    root_xz, tangent = _along(pts, distance * s_prof)
    heading = tangent - h_off
    # same branch of the angle as the state (compose bridges any small residue)
    heading = heading - 2 * np.pi * np.round((heading[0] - ctx.state.heading) / (2 * np.pi))
    return root_xz, heading, distance


def _footsteps(ctx: Context, sp: _Stride, offsets: np.ndarray):
    """Both feet's tracks from their plants: (ankle (n, 2, 3), yaw (n, 2), pitch (n, 2), contact (n, 2, 2),
    step events sorted by frame). ``offsets``: each foot's phase offset (the lead foot 0)."""
    seg, style, person = ctx.segment, ctx.style, ctx.person
    n, fps, g = seg.frames, ctx.fps, sp.g
    t = np.arange(n, dtype=np.float64)
    phi, env, heading, root_xz = sp.phi, sp.env, sp.heading, sp.root_xz
    half = STANCE_HALF * g.stance * style.stance * person.stance
    lift = min(g.lift * style.lift * (0.7 + 0.3 * seg.intensity), 0.26 if g.duty < 0.5 else 0.3)
    rng = np.random.default_rng(ctx.seed + 11) if style.wobble > 0 else None
    feet_ankle = np.empty((n, 2, 3))
    feet_yaw = np.empty((n, 2))
    feet_pitch = np.empty((n, 2))
    contact = np.empty((n, 2, 2), dtype=bool)
    events: list[Event] = []
    for side in (0, 1):
        o = offsets[side]
        k0 = int(np.floor(sp.phi0 + o + 0.5))
        k_last = int(np.floor(sp.phi_end + o + 0.5))
        ks = np.arange(k0 + 1, k_last + 1)
        t_k = np.interp(ks - o, phi, t)
        env_k = np.interp(t_k, t, env)
        duty_k = WALK_DUTY + (g.duty - WALK_DUTY) * env_k
        duty_prev = np.concatenate([[WALK_DUTY], duty_k[:-1]])
        lift_t = np.interp(ks - 1 + duty_prev / 2 - o, phi, t)
        land_t = np.interp(ks - duty_k / 2 - o, phi, t)
        land_t = np.maximum(land_t, lift_t + 2.0)
        land_t = np.minimum(land_t, n - 1.0)
        h_k = np.interp(t_k, t, heading)
        lat = left_vector(h_k)
        plant = np.empty((len(ks), 3))
        plant[:, 0] = np.interp(t_k, t, root_xz[:, 0]) + lat[:, 0] * SIDE_SIGN[side] * half
        plant[:, 1] = ANKLE_HEIGHT
        plant[:, 2] = np.interp(t_k, t, root_xz[:, 1]) + lat[:, 2] * SIDE_SIGN[side] * half
        if rng is not None and len(ks) > 1:
            jitter = rng.normal(0, 0.025, len(ks))
            jitter[-1] = 0.0
            plant[:, 0] += lat[:, 0] * jitter
            plant[:, 2] += lat[:, 2] * jitter
        yaw = h_k + SIDE_SIGN[side] * TOE_OUT
        roll_scale = style.roll * np.minimum(np.maximum(env_k, 0.3), 1.0)
        plan = StepPlan(
            start_ankle=ctx.state.feet[side].copy(), start_yaw=float(ctx.state.feet_yaw[side]),
            lift=lift_t, land=land_t, plant=plant, yaw=yaw, height=lift * (0.5 + 0.5 * env_k),
            toe_off=g.toe_off * float(roll_scale.sum() / len(roll_scale)) if len(ks) else g.toe_off,
            heel_strike=g.heel_strike * style.roll,
            roll_off=max(2.0, 0.2 * fps / sp.cadence * 2), roll_on=max(1.5, 0.1 * fps / sp.cadence * 2),
        )
        a, y, p, c = foot_track(plan, n)
        feet_ankle[:, side] = a
        feet_yaw[:, side] = y
        feet_pitch[:, side] = p
        contact[:, side] = c
        for lt, ld in zip(lift_t.tolist(), land_t.tolist()):
            events.append(Event(kind="step", frame=round(ld), start=math.floor(lt), end=math.ceil(ld),
                                side=("left", "right")[side]))
    events.sort(key=lambda e: e.frame)
    return feet_ankle, feet_yaw, feet_pitch, contact, events


def _pelvis_root(ctx: Context, sp: _Stride, cyc: np.ndarray, lat_all: np.ndarray) -> np.ndarray:
    """The root (n, 3): the path plus a lateral sway, lowered for bent knees, bobbing twice a stride."""
    seg, style, g, env = ctx.segment, ctx.style, sp.g, sp.env
    root = np.empty((seg.frames, 3))
    sway = (0.018 if g.duty > 0.5 else 0.008) * np.cos(cyc) * env
    root[:, 0] = sp.root_xz[:, 0] + lat_all[:, 0] * sway
    root[:, 2] = sp.root_xz[:, 1] + lat_all[:, 2] * sway
    bob = g.bob * style.bounce * (0.5 + 0.5 * seg.intensity)
    root[:, 1] = STAND_PELVIS - g.knee * env - style.crouch + bob * np.cos(2 * cyc) * env - abs(bob) * env * 0.5
    return root


def _trunk(ctx: Context, sp: _Stride, sep: np.ndarray, lifted: np.ndarray):
    """(pelvis (n, 3), spine (n, 3, 3), neck (n, 3)): counter-rotation against the feet's separation
    ``sep`` along the heading, pelvis list with the lifted foot, the gait's lean."""
    style, person, g, env = ctx.style, ctx.person, sp.g, sp.env
    n = len(sep)
    pelvis = np.zeros((n, 3))
    cr = style.counter_rotation
    pelvis[:, 1] = -0.22 * sep * cr
    pelvis[:, 2] = -0.5 * (lifted[:, 0] - lifted[:, 1]) * cr
    pelvis[:, 0] = 0.3 * g.lean * env
    spine = np.zeros((n, 3, 3))
    spine[:, :, 1] = (0.36 * sep * cr)[:, None] * np.array([0.25, 0.35, 0.4])
    spine[:, :, 0] = (g.lean * env + person.lean)[:, None] * np.array([0.35, 0.35, 0.3])
    neck = np.zeros((n, 3))
    neck[:, 0] = -0.6 * g.lean * env + person.head
    neck[:, 1] = -0.5 * spine[:, :, 1].sum(1) - pelvis[:, 1]
    return pelvis, spine, neck


def _arm_swing(ctx: Context, sp: _Stride, sep: np.ndarray):
    """(hand, elbow pole): arms swing against the legs (saturating for long strides), elbows bent by the gait."""
    seg, style, person, g, env = ctx.segment, ctx.style, ctx.person, sp.g, sp.env
    n = len(sep)
    gain = g.arm_gain * style.swing * person.arm_swing * (0.8 + 0.2 * seg.intensity)
    limit = 0.35 + 0.25 * (g.duty < 0.5)  # saturate the swing (rad) for long strides
    sat = limit * np.tanh(gain * sep / limit)
    swing = np.stack([-sat, sat], -1) * max(style.swing, 1.0) ** 0.5
    if seg.action == "side_step":
        swing = np.zeros((n, 2))
    flex_base = g.elbow * env + 0.25 * (1 - env) + style.elbow * env + person.elbow
    flex = flex_base[:, None] + 0.35 * np.maximum(swing, 0.0) + np.zeros((n, 2))
    return arm_angles(swing, np.minimum(np.maximum(flex, 0.05), 2.3), abduct=0.12 + 0.05 * env[:, None])


def gait(ctx: Context) -> Result:
    """Plan the stride (timing, path, phase), place and track the feet, then the pelvis, trunk and arms."""
    seg = ctx.segment
    n = seg.frames
    sp = _plan_stride(ctx)
    lead = 0 if seg.lead != "right" else 1
    offsets = np.zeros(2)
    offsets[1 - lead] = 0.5
    lat_all = left_vector(sp.heading)
    feet_ankle, feet_yaw, feet_pitch, contact, events = _footsteps(ctx, sp, offsets)
    root = _pelvis_root(ctx, sp, 2 * np.pi * (sp.phi + offsets[0]), lat_all)
    fwd = forward_vector(sp.heading)
    sep = ((feet_ankle[:, 0] - feet_ankle[:, 1]) * fwd).sum(-1)
    pelvis, spine, neck = _trunk(ctx, sp, sep, feet_ankle[:, :, 1] - ANKLE_HEIGHT)
    hand, pole = _arm_swing(ctx, sp, sep)
    ch = Channels(
        root=root, heading=sp.heading, pelvis=pelvis, spine=spine, neck=neck, collar=np.zeros((n, 2, 3)),
        ankle=feet_ankle, foot_yaw=feet_yaw, foot_pitch=feet_pitch, knee_out=np.zeros((n, 2)),
        hand=hand, elbow_pole=pole, hand_frame=np.zeros((n, 2)), contact=contact,
    )
    return Result(
        channels=ch, state=end_state(ch), events=events, arm_busy=np.zeros((n, 2)),
        gait_phase=sp.phi - sp.phi0, posture=np.ones(n),
        params={"cadence": float(sp.cadence), "step_length": float(sp.step_len), "distance": float(sp.distance),
                "steps": len(events)},
    )
