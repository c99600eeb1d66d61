"""Physics helpers: easing curves, C1 bridges, ballistic flight and planted-foot step tracks.

Times are in frames (floats allowed) unless a name says seconds. Gravity is 9.81 m/s².
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.synth.rig import ANKLE_HEIGHT, ankle_from_toe, toe_from_ankle
from engine.units import FPS

GRAVITY = 9.81
_BOX5 = np.ones(5) / 5


def clip(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """np.clip(x, lo, hi) without its call overhead (an order of magnitude on small arrays)."""
    return np.minimum(np.maximum(x, lo), hi)


def clip01(u: np.ndarray) -> np.ndarray:
    return clip(u, 0.0, 1.0)


def smooth5(x: np.ndarray) -> np.ndarray:
    """Moving average of a 1-D signal over 5 frames, its ends repeated (edge padding)."""
    padded = np.empty(len(x) + 4)
    padded[:2] = x[0]
    padded[2:-2] = x
    padded[-2:] = x[-1]
    return np.convolve(padded, _BOX5, mode="valid")


def smoothstep(u: np.ndarray) -> np.ndarray:
    """C1 ease 3u²-2u³ on [0, 1] (clipped outside)."""
    return ease(clip01(u))


def ease(u: np.ndarray) -> np.ndarray:
    """:func:`smoothstep` of values already within [0, 1]."""
    return u * u * (3.0 - 2.0 * u)


def minjerk(u: np.ndarray) -> np.ndarray:
    """C2 ease 10u³-15u⁴+6u⁵ on [0, 1] (clipped outside)."""
    u = clip01(u)
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u))


def unit_range(n: int) -> np.ndarray:
    """np.linspace(0, 1, n) (n >= 2), the same numbers without its overhead."""
    u = np.arange(n, dtype=np.float64) * (1.0 / (n - 1))
    u[-1] = 1.0
    return u


def gradient(x: np.ndarray) -> np.ndarray:
    """np.gradient of a 1-D array (unit spacing, first-order edges) without its overhead."""
    out = np.empty(len(x))
    out[1:-1] = (x[2:] - x[:-2]) / 2.0
    out[0] = x[1] - x[0]
    out[-1] = x[-1] - x[-2]
    return out


def unwrap(p: np.ndarray) -> np.ndarray:
    """np.unwrap of a 1-D array of angles, skipping its work when no step reaches pi (the usual case)."""
    if len(p) < 2 or (np.abs(np.diff(p)) < np.pi).all():
        return np.array(p, dtype=np.float64)
    return np.unwrap(p)


def ramp_profile(n: int, ramp: float) -> np.ndarray:
    """Normalised distance (n,) from 0 to 1 with a smooth trapezoid speed (ramps of ``ramp`` of
    the duration at both ends): zero speed at both ends, C1."""
    if n < 2:
        return np.zeros(n)
    u = unit_range(n)
    r = max(min(ramp, 0.5), 1e-3)
    speed = smoothstep(u / r) * smoothstep((1.0 - u) / r)
    pos = np.empty(n)
    pos[0] = 0.0
    np.cumsum(0.5 * (speed[1:] + speed[:-1]), out=pos[1:])
    return pos / pos[-1]


def hermite_basis(u):
    """The cubic Hermite basis (h00, h10, h01, h11) at u ∈ [0, 1]."""
    u2 = u * u
    u3 = u2 * u
    return 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2


def hermite(p0, m0, p1, m1, u):
    """Cubic Hermite on u ∈ [0, 1]; m0, m1 are derivatives with respect to u."""
    h00, h10, h01, h11 = hermite_basis(u)
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1


def bridge(x: np.ndarray, start: int, stop: int) -> None:
    """Replace x[start:stop] (in place, along axis 0) by the cubic Hermite that matches value and
    slope of x at start-1 and stop, making x C1 across a seam inside the window."""
    bridge_all([x], start, stop)


def bridge_all(xs: list[np.ndarray], start: int, stop: int) -> None:
    """:func:`bridge` for several arrays of the same length (sharing the Hermite basis)."""
    n = xs[0].shape[0]
    a, b = max(start - 1, 0), min(stop, n - 1)
    if b - a < 2:
        return
    span = b - a
    basis = hermite_basis((np.arange(a + 1, b) - a) / span)
    for x in xs:
        shape = (-1,) + (1,) * (x.ndim - 1)
        h00, h10, h01, h11 = (h.reshape(shape) for h in basis)
        pa, pb = x[a], x[b]
        ma = (x[a] - x[a - 1]) if a >= 1 else np.zeros_like(pa)
        mb = (x[b + 1] - x[b]) if b + 1 < n else np.zeros_like(pb)
        x[a + 1:b] = h00 * pa + h10 * (ma * span) + h01 * pb + h11 * (mb * span)


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
    yaws = unwrap(np.concatenate([[plan.start_yaw], plan.yaw]))
    if K == 0:
        ankle = np.empty((frames, 3))
        ankle[:] = plants[0]
        return ankle, np.full(frames, yaws[0]), np.zeros(frames), np.ones((frames, 2), dtype=bool)
    p_idx = np.searchsorted(plan.lift, t, side="right")  # plant reached by t (0 = start, k+1 after swing k)
    kk = np.maximum(p_idx - 1, 0)  # the last swing started (the first before any)
    # ---- stance: time since landing, time to the next lift (+-inf where there is none)
    land_prev = np.concatenate([[-np.inf], plan.land])[p_idx]
    next_lift = np.concatenate([plan.lift, [np.inf]])[p_idx]
    in_swing = t < land_prev
    since_land = t - land_prev
    to_lift = next_lift - t
    stance_ankle = plants[p_idx]
    stance_yaw = yaws[p_idx]
    heel_up = clip01(1.0 - to_lift / max(plan.roll_off, 1e-6))
    toe_up = clip01(1.0 - since_land / max(plan.roll_on, 1e-6))
    pitch_off = plan.toe_off * ease(heel_up)
    pitch_on = plan.heel_strike * ease(toe_up)
    stance_pitch = pitch_off + pitch_on
    toes = toe_from_ankle(plants, yaws, 0.0)  # per plant: the toe the heel rise pivots on
    pivot = ankle_from_toe(toes[p_idx], stance_yaw, pitch_off)
    stance_ankle = np.where((heel_up > 0)[:, None], pivot, stance_ankle)
    # ---- swing
    lift_t = plan.lift[kk]
    land_t = plan.land[kk]
    u = clip01((t - lift_t) / np.maximum(land_t - lift_t, 1e-6))
    y0 = yaws[kk]
    a0 = ankle_from_toe(toes, yaws, plan.toe_off)[kk]  # the foot on its toe at the lift
    a1 = plants[kk + 1]
    y1 = yaws[kk + 1]
    s = ease(u)
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
