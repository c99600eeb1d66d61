"""Physics helpers: easing curves, C1 bridges, ballistic flight and planted-foot step tracks.

Times are in frames (floats allowed) unless a name says seconds. Gravity is 9.81 m/s².
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.synth.rig import ANKLE_HEIGHT, ankle_from_toe, toe_from_ankle

GRAVITY = 9.81
FPS = 20.0


def smoothstep(u: np.ndarray) -> np.ndarray:
    """C1 ease 3u²-2u³ on [0, 1] (clipped outside)."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def minjerk(u: np.ndarray) -> np.ndarray:
    """C2 ease 10u³-15u⁴+6u⁵ on [0, 1] (clipped outside)."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u))


def ramp_profile(n: int, ramp: float) -> np.ndarray:
    """Normalised distance (n,) from 0 to 1 with a smooth trapezoid speed (ramps of ``ramp`` of
    the duration at both ends): zero speed at both ends, C1."""
    if n < 2:
        return np.zeros(n)
    u = np.linspace(0.0, 1.0, n)
    r = max(min(ramp, 0.5), 1e-3)
    speed = smoothstep(u / r) * smoothstep((1.0 - u) / r)
    pos = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]))])
    return pos / pos[-1]


def hermite(p0, m0, p1, m1, u):
    """Cubic Hermite on u ∈ [0, 1]; m0, m1 are derivatives with respect to u."""
    u2 = u * u
    u3 = u2 * u
    return ((2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1)


def bridge(x: np.ndarray, start: int, stop: int) -> None:
    """Replace x[start:stop] (in place, along axis 0) by the cubic Hermite that matches value and
    slope of x at start-1 and stop, making x C1 across a seam inside the window."""
    n = x.shape[0]
    a, b = max(start - 1, 0), min(stop, n - 1)
    if b - a < 2:
        return
    pa, pb = x[a], x[b]
    ma = (x[a] - x[a - 1]) if a >= 1 else np.zeros_like(pa)
    mb = (x[b + 1] - x[b]) if b + 1 < n else np.zeros_like(pb)
    span = b - a
    u = (np.arange(a + 1, b) - a) / span
    u = u.reshape((-1,) + (1,) * (x.ndim - 1))
    x[a + 1:b] = hermite(pa, ma * span, pb, mb * span, u)


def takeoff_speed(height: float) -> float:
    """Vertical take-off speed (m/s) for a ballistic rise of ``height`` metres."""
    return float(np.sqrt(2.0 * GRAVITY * max(height, 0.0)))


def flight_time(height: float) -> float:
    """Seconds in the air for a rise of ``height`` (take-off and landing at the same level)."""
    return 2.0 * takeoff_speed(height) / GRAVITY


def height_for_flight(seconds: float) -> float:
    return GRAVITY * seconds * seconds / 8.0


# --------------------------------------------------------------------------- foot step tracks
@dataclass
class StepPlan:
    """Steps of one foot: swing k lifts at lift[k] and lands on plant k (frames, increasing)."""

    start_ankle: np.ndarray  # (3,) flat-foot ankle position before the first step
    start_yaw: float
    lift: np.ndarray  # (K,) frames
    land: np.ndarray  # (K,)
    plant: np.ndarray  # (K, 3) flat-foot ankle positions (y = ANKLE_HEIGHT)
    yaw: np.ndarray  # (K,)
    height: np.ndarray  # (K,) extra ankle lift at mid-swing (m)
    toe_off: float = 0.55  # foot pitch at toe-off (rad, heel up)
    heel_strike: float = -0.25  # foot pitch at landing (rad, toe up)
    roll_off: float = 4.0  # frames of heel rise before the lift
    roll_on: float = 2.0  # frames of toe coming down after landing
    lift_peak: float = 0.4  # where in the swing the foot is highest (0..1)


def foot_track(plan: StepPlan, frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ankle positions (T, 3), yaw (T,), pitch (T,), contacts (T, 2) [ankle, toe] for one foot.

    Planted feet do not move: the ankle is fixed while the heel is down and the foot pivots on
    the toe (toe fixed) while the heel rises before a lift.
    """
    t = np.arange(frames, dtype=np.float64)
    K = len(plan.lift)
    plants = np.concatenate([plan.start_ankle[None], plan.plant], 0)  # index k+1 = after swing k
    yaws = np.concatenate([[plan.start_yaw], plan.yaw])
    yaws = np.unwrap(yaws)
    if K == 0:
        ankle = np.broadcast_to(plants[0], (frames, 3)).copy()
        return ankle, np.full(frames, yaws[0]), np.zeros(frames), np.ones((frames, 2), dtype=bool)
    k = np.searchsorted(plan.lift, t, side="right") - 1  # last swing started at or before t
    kk = np.maximum(k, 0)
    in_swing = (k >= 0) & (t < plan.land[kk])
    # ---- stance: which plant, time since landing, time to the next lift
    plant_idx = k + 1  # plant reached after swing k (0 = start)
    land_prev = np.where(k >= 0, plan.land[kk], -np.inf)
    next_lift = np.where(k + 1 < K, plan.lift[np.minimum(k + 1, K - 1)], np.inf)
    since_land = t - land_prev
    to_lift = next_lift - t
    p_idx = np.clip(plant_idx, 0, K)
    stance_ankle = plants[p_idx]
    stance_yaw = yaws[p_idx]
    heel_up = np.clip(1.0 - to_lift / max(plan.roll_off, 1e-6), 0.0, 1.0)
    toe_up = np.clip(1.0 - since_land / max(plan.roll_on, 1e-6), 0.0, 1.0)
    pitch_off = plan.toe_off * smoothstep(heel_up)
    pitch_on = plan.heel_strike * smoothstep(toe_up)
    stance_pitch = pitch_off + pitch_on
    toe_plant = toe_from_ankle(stance_ankle, stance_yaw, np.zeros_like(stance_yaw))
    pivot = ankle_from_toe(toe_plant, stance_yaw, pitch_off)
    stance_ankle = np.where((heel_up > 0)[:, None], pivot, stance_ankle)
    # ---- swing
    lift_t = plan.lift[kk]
    land_t = plan.land[kk]
    u = np.clip((t - lift_t) / np.maximum(land_t - lift_t, 1e-6), 0.0, 1.0)
    a0_flat = plants[kk]
    y0 = yaws[kk]
    a0 = ankle_from_toe(toe_from_ankle(a0_flat, y0, np.zeros_like(y0)), y0, np.full_like(y0, plan.toe_off))
    a1 = plants[kk + 1]
    y1 = yaws[kk + 1]
    s = smoothstep(u)
    swing = a0 + (a1 - a0) * s[:, None]
    bump = np.sin(np.pi * u ** (np.log(0.5) / np.log(plan.lift_peak))) ** 2
    swing[:, 1] += plan.height[kk] * bump
    swing_yaw = y0 + (y1 - y0) * s
    lead = smoothstep(u * 1.6)
    swing_pitch = plan.toe_off + (plan.heel_strike - plan.toe_off) * lead
    ankle = np.where(in_swing[:, None], swing, stance_ankle)
    yaw = np.where(in_swing, swing_yaw, stance_yaw)
    pitch = np.where(in_swing, swing_pitch, stance_pitch)
    contact = np.empty((frames, 2), dtype=bool)
    contact[:, 0] = ~in_swing & (heel_up <= 0)
    contact[:, 1] = ~in_swing & (toe_up <= 0)
    return ankle, yaw, pitch, contact


def flat_ankle(xz: np.ndarray) -> np.ndarray:
    """Flat-foot ankle positions from floor points (..., 2 or 3) -> (..., 3)."""
    out = np.empty(xz.shape[:-1] + (3,))
    out[..., 0] = xz[..., 0]
    out[..., 1] = ANKLE_HEIGHT
    out[..., 2] = xz[..., -1]
    return out
