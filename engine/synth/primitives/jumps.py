"""Jumps: in place, forward, hopping on one leg, jumping jacks.

Every airborne phase is ballistic (g = 9.81): the take-off speed v0 = sqrt(2 g h) gives a
flight of 2 v0 / g seconds in which the feet keep their take-off pose relative to the
pelvis vertically, so the lowest foot joint rises exactly ``h`` at the apex. Take-off times
are placed so that every apex falls on a whole frame. Before take-off the body crouches and
extends (cubic Hermite reaching v0), rolling onto the toes; landing mirrors it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.synth.physics import GRAVITY, clip, flight_time, hermite, smooth5, smoothstep, takeoff_speed
from engine.synth.primitives.base import STANCE_HALF, Context, Event, Result, arm_angles, end_state, feet_center
from engine.synth.primitives.body import base_stand
from engine.synth.rig import (ANKLE_HEIGHT, HIP_DROP, LEG, SIDE_SIGN, STAND_PELVIS, ankle_from_toe,
                              forward_vector, left_vector, pitch_for_ankle_height, toe_from_ankle)

LEG_EXT = 0.955 * LEG  # hip-ankle distance used on the toes before take-off / after landing
TAKEOFF_PITCH = 0.8


def frame_span(n: int, start: float, stop: float, *, after_start: bool = False,
               through_stop: bool = False) -> slice:
    """The frames t = 0..n-1 with start <= t < stop as a slice (start < t with ``after_start``,
    t <= stop with ``through_stop``): a cheaper stand-in for the boolean mask."""
    lo = math.floor(start) + 1 if after_start else math.ceil(start)
    hi = math.floor(stop) + 1 if through_stop else math.ceil(stop)
    return slice(min(max(lo, 0), n), min(max(hi, 0), n))


def ankle_height_at(pitch: float) -> float:
    from engine.synth.rig import TOE_ANGLE, TOE_LENGTH
    return float(TOE_LENGTH * np.sin(TOE_ANGLE + pitch))


@dataclass
class Rep:
    """One airborne phase: feet toes before/after (2, 3), rise h (m), crouch depth (m)."""

    before: np.ndarray
    after: np.ndarray
    height: float
    crouch: float
    kind: str
    lean: float = 0.0  # pelvis ahead of the feet at take-off (m, along the heading)
    spread_after: float = 0.0  # jacks: 1 when landing wide


def _pelvis_takeoff_height(toes: np.ndarray, center: np.ndarray, lifted: int | None) -> float:
    """Pelvis height at take-off/landing with the planted toes on the floor and heels up."""
    a = ankle_height_at(TAKEOFF_PITCH)
    hz = []
    for side in (0, 1):
        if side == lifted:
            continue
        horiz = max(abs(toes[side, 0] - center[0]), abs(toes[side, 2] - center[1]))
        horiz = np.hypot(toes[side, 0] - center[0], toes[side, 2] - center[1])
        off = max(horiz - 0.08, 0.0)
        hz.append(np.sqrt(max(LEG_EXT**2 - off**2, 0.3)))
    return a + HIP_DROP + float(min(hz))


@dataclass
class _Flight:
    """One repetition planned on the frame axis: the phase times (frames) and the pelvis targets.

    tA0 -> tA1 crouch, tA1 -> t_to push off, t_to -> t_land airborne (apex in between, on a whole
    frame), t_land -> tD1 absorb, tD1 -> tE1 recover. Heights in metres, ``vxz`` in m/s."""

    v0: float
    tf: float
    center0: np.ndarray  # feet centre (x, z) at take-off
    center1: np.ndarray  # and after landing
    y_to: float
    y_land: float
    y_low: float
    y_low2: float
    tA0: float
    tA1: float
    t_to: float
    apex: int
    t_land: float
    tD1: float
    tE1: float
    P_to: np.ndarray  # pelvis (x, z) at take-off and landing
    P_land: np.ndarray
    vxz: np.ndarray

    @property
    def times(self) -> tuple:
        return (self.tA0, self.tA1, self.t_to, self.apex, self.t_land, self.tD1, self.tE1)


def _plan_flight(ctx: Context, rep: Rep, k: int, *, count: int, period: float, y_stand: float, tempo: float,
                 lifted: int | None) -> _Flight:
    """Rep ``k`` of ``count`` placed in its share (``period`` s) of the segment; ValueError when it cannot fit."""
    seg, fps = ctx.segment, ctx.fps
    heading = float(ctx.state.heading)
    v0 = takeoff_speed(rep.height)
    tf = flight_time(rep.height)
    center0 = feet_center(rep.before) if lifted is None else rep.before[1 - lifted, [0, 2]] + 0.0
    center1 = feet_center(rep.after) if lifted is None else rep.after[1 - lifted, [0, 2]] + 0.0
    if lifted is not None:
        inward = left_vector(np.float64(heading))[[0, 2]] * SIDE_SIGN[lifted] * 0.03
        center0 = center0 + inward
        center1 = center1 + inward
    y_to = _pelvis_takeoff_height(rep.before, center0, lifted)
    y_land = _pelvis_takeoff_height(rep.after, center1, lifted)
    y_low = y_stand - rep.crouch
    y_low2 = y_stand - 0.7 * rep.crouch
    # durations (s)
    dp = float(np.clip(2.0 * (y_to - y_low) / max(v0, 1e-3), 0.12, 0.4))
    dl = float(np.clip(2.0 * (y_land - y_low2) / max(v0, 1e-3), 0.12, 0.4))
    prep = 0.32 * tempo
    rec = 0.28 * tempo
    need = prep + dp + tf + dl + rec
    if need > period:
        squeeze = max((period - dp - tf - dl) / max(prep + rec, 1e-6), 0.05)
        prep *= squeeze
        rec *= squeeze
        need = prep + dp + tf + dl + rec
    if need > period + 1e-6:  # still too long: the phases would overlap, so the segment is invalid
        raise ValueError(f"{seg.action}: {count} repetitions do not fit in {seg.frames} frames")
    slack = max(period - need, 0.0)
    t_to = (k * period + slack * 0.5 + prep + dp) * fps
    apex = int(round(t_to + tf * fps / 2))
    t_to = apex - tf * fps / 2
    t_land = t_to + tf * fps
    tD1 = t_land + dl * fps
    lean = rep.lean * forward_vector(np.float64(heading))[[0, 2]]
    P_to = center0 + lean
    P_land = center1 + lean
    return _Flight(v0=v0, tf=tf, center0=center0, center1=center1, y_to=y_to, y_land=y_land, y_low=y_low,
                   y_low2=y_low2, tA0=t_to - (prep + dp) * fps, tA1=t_to - dp * fps, t_to=t_to, apex=apex,
                   t_land=t_land, tD1=tD1, tE1=tD1 + rec * fps, P_to=P_to, P_land=P_land, vxz=(P_land - P_to) / tf)


def _pelvis_height(y: np.ndarray, fl: _Flight, t: np.ndarray, fps: float, y_stand: float) -> None:
    """Write one flight's pelvis height into ``y``: crouch, push off, ballistic arc, absorb, recover."""
    n = len(y)
    m = frame_span(n, fl.tA0, fl.tA1)
    u = (t[m] - fl.tA0) / max(fl.tA1 - fl.tA0, 1e-6)
    y[m] = hermite(y_stand, 0.0, fl.y_low, 0.0, u)
    m = frame_span(n, fl.tA1, fl.t_to)
    D = fl.t_to - fl.tA1
    u = (t[m] - fl.tA1) / D
    y[m] = hermite(fl.y_low, 0.0, fl.y_to, fl.v0 * D / fps, u)
    air = frame_span(n, fl.t_to, fl.t_land, through_stop=True)
    tau = (t[air] - fl.t_to) / fps
    uu = tau * fps / (fl.t_land - fl.t_to)
    y[air] = fl.y_to + (fl.y_land - fl.y_to) * smoothstep(uu) + fl.v0 * tau - 0.5 * GRAVITY * tau * tau
    m = frame_span(n, fl.t_land, fl.tD1, after_start=True)
    D = fl.tD1 - fl.t_land
    u = (t[m] - fl.t_land) / D
    y[m] = hermite(fl.y_land, -fl.v0 * D / fps, fl.y_low2, 0.0, u)
    m = frame_span(n, fl.tD1, fl.tE1)
    u = (t[m] - fl.tD1) / max(fl.tE1 - fl.tD1, 1e-6)
    y[m] = hermite(fl.y_low2, 0.0, y_stand, 0.0, u)


def _pelvis_travel(pxz: np.ndarray, fl: _Flight, t: np.ndarray, fps: float) -> None:
    """Write one flight's pelvis (x, z) into ``pxz``: eased to take-off, straight in the air, eased to rest."""
    n = len(pxz)
    m = frame_span(n, fl.tA0, fl.t_to)
    D = fl.t_to - fl.tA0
    u = ((t[m] - fl.tA0) / D)[:, None]
    pxz[m] = hermite(fl.center0, 0.0, fl.P_to, fl.vxz * D / fps, u)
    air = frame_span(n, fl.t_to, fl.t_land, through_stop=True)
    u = ((t[air] - fl.t_to) / (fl.t_land - fl.t_to))[:, None]
    pxz[air] = fl.P_to + (fl.P_land - fl.P_to) * u
    m = frame_span(n, fl.t_land, fl.tE1, after_start=True)
    D = fl.tE1 - fl.t_land
    u = ((t[m] - fl.t_land) / D)[:, None]
    pxz[m] = hermite(fl.P_land, fl.vxz * D / fps, fl.center1, 0.0, u)
    pxz[frame_span(n, fl.tE1, n)] = fl.center1


def _flight_event(rep: Rep, fl: _Flight) -> Event:
    return Event(kind=rep.kind, frame=fl.apex, start=int(np.floor(fl.tA0)), end=int(np.ceil(fl.tE1)),
                 height=float(rep.height),
                 extra={"takeoff": round(float(fl.t_to), 3), "landing": round(float(fl.t_land), 3),
                        "flight_s": round(float(fl.tf), 4)})


def _feet(reps: list[Rep], flights: list[_Flight], plants: np.ndarray, y: np.ndarray, yaw_b: np.ndarray,
          t: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ankle (n, 2, 3), pitch (n, 2), contact (n, 2, 2)): on the ground each foot stands on the toe plant
    of the last landing, heels up as far as the pelvis height needs; in the air both keep the take-off
    pose and rise with the body. ``plants``: the toes (c + 1, 2, 3) before the first jump and after each."""
    n = len(t)
    ankle = np.empty((n, 2, 3))
    pitch = np.zeros((n, 2))
    contact = np.ones((n, 2, 2), dtype=bool)
    # which ground interval / flight each frame is in
    to_times = np.array([fl.t_to for fl in flights])
    land_times = np.array([fl.t_land for fl in flights])
    k_after = np.searchsorted(land_times, t, side="right")  # landings at or before t
    in_air = np.zeros(n, dtype=bool)
    air_k = np.zeros(n, dtype=int)
    for k in range(len(flights)):
        m = frame_span(n, to_times[k], land_times[k], after_start=True)
        in_air[m] = True
        air_k[m] = k
    # ground: toe plant index = number of landings at or before t
    ground_toe = plants[k_after]  # (n, 2, 3)
    need = np.maximum(y[:, None] - HIP_DROP - LEG_EXT * np.ones((n, 2)), ANKLE_HEIGHT)
    # horizontal offset between hip and ankle reduces the available vertical reach
    g_pitch = pitch_for_ankle_height(need)
    g_pitch = np.where(need <= ANKLE_HEIGHT + 1e-6, 0.0, g_pitch)
    g_pitch = np.minimum(g_pitch, TAKEOFF_PITCH)
    ankle[:] = ankle_from_toe(ground_toe, yaw_b, g_pitch)
    pitch[:] = g_pitch
    if in_air.any():
        ka = air_k[in_air]
        ta = t[in_air]
        u = (ta - to_times[ka]) / (land_times[ka] - to_times[ka])
        tau = (ta - to_times[ka]) / fps
        v0s = np.array([takeoff_speed(r.height) for r in reps])[ka]
        rise = v0s * tau - 0.5 * GRAVITY * tau * tau
        pitch_air = np.full((len(ta), 2), TAKEOFF_PITCH)
        a_to = ankle_from_toe(plants[ka], yaw_b[in_air], pitch_air)
        a_land = ankle_from_toe(plants[ka + 1], yaw_b[in_air], pitch_air)
        shift = a_land - a_to
        common = ((shift[:, 0] + shift[:, 1]) / 2)[:, None]  # mean over the feet
        a = a_to + common * u[:, None, None] + (shift - common) * smoothstep(u)[:, None, None]
        a[..., 1] += rise[:, None]
        ankle[in_air] = a
        pitch[in_air] = TAKEOFF_PITCH
    contact[:, :, 1] = ~in_air[:, None]
    contact[:, :, 0] = (~in_air[:, None]) & (pitch < 1e-3)
    return ankle, pitch, contact


def _free_leg(ctx: Context, root: np.ndarray, flights: list[_Flight], plants: np.ndarray, lifted: int, free_offset,
              ankle: np.ndarray, pitch: np.ndarray, contact: np.ndarray, t: np.ndarray) -> None:
    """Hops: the free leg lifted behind and carried with the pelvis (``root`` + ``free_offset``); it lifts
    before the first hop and lands after the last. Writes the ``lifted`` side of ankle, pitch and contact."""
    n, fps = len(t), ctx.fps
    carried = root[:, :] + free_offset
    first = flights[0].tA0
    last = flights[-1].tE1
    t_up0, t_up1 = max(first - 0.35 * fps, 0.0), max(first - 0.05 * fps, 1.0)
    t_dn0, t_dn1 = min(last + 0.05 * fps, n - 2.0), min(last + 0.4 * fps, n - 1.0)
    w = smoothstep((t - t_up0) / max(t_up1 - t_up0, 1e-6)) * (1 - smoothstep((t - t_dn0) / max(t_dn1 - t_dn0, 1e-6)))
    plant = ctx.state.feet[lifted]
    end_plant = plant + (plants[-1][1 - lifted] - plants[0][1 - lifted])
    end_plant[1] = ANKLE_HEIGHT
    base = np.where((t < t_dn0)[:, None], plant, end_plant)
    ankle[:, lifted] = base + (carried - base) * w[:, None]
    pitch[:, lifted] = 0.5 * w
    free_contact = w <= 1e-6
    contact[:, lifted, 0] = free_contact
    contact[:, lifted, 1] = free_contact
    ankle[:, lifted, 1] = np.maximum(ankle[:, lifted, 1], ANKLE_HEIGHT + 0.0)


def _trunk_and_arms(ch, reps: list[Rep], flights: list[_Flight], *, arms: str, y: np.ndarray, y_stand: float,
                    heading: float, t: np.ndarray) -> np.ndarray:
    """Trunk bend from the crouch depth and arms from the rising/airborne state (``arms``: swing | jacks |
    balance); returns the crouch (n,)."""
    n = len(t)
    crouch = clip((y_stand - y) / 0.18, 0.0, 1.2)
    rising = np.zeros(n)
    for fl, rep in zip(flights, reps):
        k = np.interp(t, list(fl.times), [0.0, -0.8, 0.9, 1.2, 0.7, 0.2, 0.0], left=0.0, right=0.0)
        rising += k * min(1.0, 0.5 + rep.height / 0.3)
    rising = smooth5(rising)
    ch.spine[:, :, 0] += (0.35 * crouch)[:, None] * np.array([0.4, 0.35, 0.25])
    ch.pelvis[:, 0] += 0.3 * crouch
    ch.neck[:, 0] -= 0.35 * crouch
    if arms == "swing":
        swing = np.stack([rising, rising], -1)
        hand, pole = arm_angles(swing, 0.35 + 0.2 * np.abs(swing), abduct=0.15)
        ch.hand, ch.elbow_pole = hand, pole
    elif arms == "jacks":
        ankle = ch.ankle
        feet_lat = np.abs(((ankle[:, 0] - ankle[:, 1]) * left_vector(np.float64(heading))).sum(-1))
        spread = clip((feet_lat - 2 * STANCE_HALF) / 0.4, 0.0, 1.0)
        hand, pole = arm_angles(np.zeros((n, 2)), 0.15 + 0.25 * spread[:, None] * np.ones(2),
                                abduct=(0.15 + 2.75 * spread)[:, None] * np.ones(2))
        ch.hand, ch.elbow_pole = hand, pole
    elif arms == "balance":
        out_ = np.stack([np.full(n, 0.6), np.full(n, 0.6)], -1)
        hand, pole = arm_angles(0.25 + 0.3 * np.stack([rising, rising], -1), 0.6 + np.zeros((n, 2)), abduct=out_)
        ch.hand, ch.elbow_pole = hand, pole
    return crouch


def ballistic_reps(ctx: Context, reps: list[Rep], *, lifted: int | None = None, free_offset=None,
                   arms: str = "swing") -> Result:
    """Airborne repetitions laid evenly over the segment: plan each flight, drive the pelvis through it,
    then the feet (and a hop's free leg), trunk and arms."""
    n = ctx.segment.frames
    fps = ctx.fps
    ch = base_stand(ctx, idle=0.2)
    t = np.arange(n, dtype=np.float64)
    y_stand = STAND_PELVIS - ctx.style.crouch
    tempo = 1.0 / max(ctx.segment.speed, 0.4)
    period = n / fps / len(reps)
    flights = [_plan_flight(ctx, rep, k, count=len(reps), period=period, y_stand=y_stand, tempo=tempo,
                            lifted=lifted) for k, rep in enumerate(reps)]
    y = np.full(n, y_stand)
    pxz = ch.root[:, [0, 2]].copy()
    for fl in flights:
        _pelvis_height(y, fl, t, fps, y_stand)
        _pelvis_travel(pxz, fl, t, fps)
    ch.root[:, 1] = y
    ch.root[:, 0] = pxz[:, 0]
    ch.root[:, 2] = pxz[:, 1]

    yaw_b = np.broadcast_to(ctx.state.feet_yaw.copy(), (n, 2))
    plants = np.stack([np.asarray(reps[0].before)] + [np.asarray(rep.after) for rep in reps], 0)  # (c+1, 2, 3)
    ankle, pitch, contact = _feet(reps, flights, plants, y, yaw_b, t, fps)
    if lifted is not None:
        _free_leg(ctx, ch.root, flights, plants, lifted, free_offset, ankle, pitch, contact, t)
    ch.ankle = ankle
    ch.foot_pitch = pitch
    ch.foot_yaw = yaw_b.copy()
    ch.contact = contact

    crouch = _trunk_and_arms(ch, reps, flights, arms=arms, y=y, y_stand=y_stand,
                             heading=float(ctx.state.heading), t=t)
    return Result(channels=ch, state=end_state(ch), events=[_flight_event(rep, fl) for rep, fl in zip(reps, flights)],
                  arm_busy=np.zeros((n, 2)), gait_phase=np.arange(n) / fps * 0.8,
                  posture=np.ones(n) - 0.5 * clip(crouch, 0, 1))


def _toes(ctx: Context) -> np.ndarray:
    st = ctx.state
    return toe_from_ankle(st.feet, st.feet_yaw, np.zeros(2))


def jump_height(ctx: Context, base: float) -> float:
    """Monotone in intensity: the emphasis benchmark relies on it."""
    return float(np.clip(base * ctx.segment.intensity * ctx.style.jump, 0.05, 0.6))


def jump(ctx: Context) -> Result:
    seg = ctx.segment
    forward = seg.action == "jump_forward"
    h = jump_height(ctx, 0.2 if forward else 0.25)
    d = 0.55 * seg.intensity ** 0.5 * ctx.style.stride if forward else 0.0
    fwd = forward_vector(np.float64(ctx.state.heading))
    toes = _toes(ctx)
    reps = []
    for k in range(seg.count):
        after = toes + fwd * d
        reps.append(Rep(before=toes, after=after, height=h, crouch=0.1 + 0.25 * h + 0.05 * forward,
                        kind="jump", lean=0.07 if forward else 0.0))
        toes = after
    res = ballistic_reps(ctx, reps)
    res.params = {"height": h, "distance": d}
    return res


def hop(ctx: Context) -> Result:
    seg = ctx.segment
    stance = 0 if seg.side == "left" else 1
    lifted = 1 - stance
    h = jump_height(ctx, 0.12)
    toes = _toes(ctx)
    reps = [Rep(before=toes, after=toes, height=h, crouch=0.05 + 0.2 * h, kind="hop") for _ in range(seg.count)]
    heading = np.float64(ctx.state.heading)
    off = (forward_vector(heading) * -0.18 + left_vector(heading) * SIDE_SIGN[lifted] * 0.1
           + np.array([0.0, -(STAND_PELVIS - ctx.style.crouch - 0.3), 0.0]))
    res = ballistic_reps(ctx, reps, lifted=lifted, free_offset=off, arms="balance")
    res.params = {"height": h, "stance_leg": ("left", "right")[stance]}
    return res


def jumping_jacks(ctx: Context) -> Result:
    seg = ctx.segment
    h = jump_height(ctx, 0.08)
    heading = np.float64(ctx.state.heading)
    lat = left_vector(heading)
    toes = _toes(ctx)
    center = (toes[0] + toes[1]) / 2
    narrow = np.stack([center + lat * STANCE_HALF, center - lat * STANCE_HALF])
    wide_half = STANCE_HALF + 0.22 * min(seg.intensity, 1.3)
    wide = np.stack([center + lat * wide_half, center - lat * wide_half])
    narrow[:, 1] = toes[:, 1]
    wide[:, 1] = toes[:, 1]
    reps = []
    cur = toes
    for k in range(seg.count):
        reps.append(Rep(before=cur, after=wide, height=h, crouch=0.04 + 0.2 * h, kind="jack"))
        reps.append(Rep(before=wide, after=narrow, height=h, crouch=0.04 + 0.2 * h, kind="jack_in"))
        cur = narrow
    res = ballistic_reps(ctx, reps, arms="jacks")
    res.params = {"height": h}
    return res
