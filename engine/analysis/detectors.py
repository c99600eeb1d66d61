"""What a motion does, read from its joints alone: one detector per action, each giving the
events of that action (frame and side) the way the corpus labels count them.

Each detector follows the corpus's own definition of its label (``engine.synth.labels``,
``engine.synth.primitives``): a jump is a flight phase (both feet off the floor), a hop a
flight phase with the other foot held up, a kick a foot raised high in front of the body, a
wave a raised wrist swinging side to side, a clap the wrists meeting in front of the chest,
a squat the pelvis lowered with both feet planted, a bow the trunk pitched forward, and so on.
Locomotion is read from the root path in the body's own frame (forward, backward, sideways),
turns from the facing direction.

joints: (T, 22, 3) in metres, Y up, 20 fps; the floor is estimated from the feet, so a
generated motion that floats a little is read the same way as one on the floor.
``moattn bench --adherence`` validates every detector on corpus ground truth before it scores
a model with it (``engine.evaluation.adherence``).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.ndimage import gaussian_filter1d, uniform_filter1d
from scipy.signal import find_peaks

from engine.representation import facing_direction
from engine.skeleton import FOOT_JOINTS, JOINT_INDEX
from engine.synth.program import FPS

SIDES = ("left", "right")
AIR = 0.045  # m above the floor: a foot joint this high is off the ground
FLIGHT_MARGIN = 3  # frames either side of a flight that take off or land (the body stretched, not standing)


@dataclass(frozen=True)
class Detected:
    """One detected event: an action's countable moment (a jump's apex, a kick's peak...)."""

    action: str
    frame: int
    side: str = "none"  # left | right | both; for travel and turns the way taken (forward, left, circle_right...)


def _runs(mask: np.ndarray, min_len: int = 1) -> list[tuple[int, int]]:
    """[start, end) runs of True at least ``min_len`` long."""
    padded = np.concatenate([[False], np.asarray(mask, bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b - a >= min_len]


class MotionSignals:
    """Per-frame signals of a motion in its own body frame (computed once, shared by detectors)."""

    def __init__(self, joints: np.ndarray, *, fps: float = FPS) -> None:
        joints = np.asarray(joints, dtype=np.float64)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3):
            raise ValueError(f"joints must be (T, 22, 3), got {joints.shape}")
        if len(joints) < 4:
            raise ValueError("a motion needs at least 4 frames to be read")
        if not np.isfinite(joints).all():
            raise ValueError("the motion has NaN or infinite joint positions")
        self.fps = float(fps)
        feet = [*FOOT_JOINTS["left"], *FOOT_JOINTS["right"]]
        self.floor = float(np.percentile(joints[:, feet, 1].min(1), 3))
        self.joints = joints - np.array([0.0, self.floor, 0.0])
        self.T = len(joints)

    # ---------------------------------------------------------------- basic signals
    def j(self, name: str) -> np.ndarray:
        return self.joints[:, JOINT_INDEX[name]]

    @cached_property
    def foot_height(self) -> dict[str, np.ndarray]:
        """Height of each foot's lowest joint (ankle or toe) above the floor, (T,)."""
        return {side: self.joints[:, list(FOOT_JOINTS[side]), 1].min(1) for side in SIDES}

    @cached_property
    def forward(self) -> np.ndarray:
        """Unit facing direction per frame (T, 3), smoothed."""
        f = gaussian_filter1d(facing_direction(self.joints), 2.0, axis=0, mode="nearest")
        f[:, 1] = 0
        return f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-9)

    @cached_property
    def left(self) -> np.ndarray:
        """Unit left direction per frame (T, 3): up x forward."""
        return np.cross(np.array([0.0, 1.0, 0.0]), self.forward)

    def body(self, v: np.ndarray) -> np.ndarray:
        """World vectors (T, 3) in the body frame (T, 3): (left, up, forward)."""
        return np.stack([(v * self.left).sum(1), v[:, 1], (v * self.forward).sum(1)], 1)

    @cached_property
    def root_velocity(self) -> np.ndarray:
        """Pelvis velocity in the body frame (T, 3) in m/s, smoothed over ~0.5 s."""
        p = self.j("pelvis")
        v = np.gradient(p, axis=0) * self.fps
        v = uniform_filter1d(v, max(3, int(0.5 * self.fps)), axis=0, mode="nearest")
        return self.body(v)

    @cached_property
    def heading(self) -> np.ndarray:
        """Unwrapped yaw of the facing direction (rad, positive = turning left), (T,)."""
        f = self.forward
        return np.unwrap(np.arctan2(f[:, 0], f[:, 2]))

    @cached_property
    def standing_pelvis(self) -> float:
        """The pelvis height of this body standing (its tall frames). A motion with jumps counts its flights too,
        which the jump's crouch threshold (:func:`detect_jumps`) was set with; :attr:`grounded_pelvis` does not."""
        return float(np.percentile(self.j("pelvis")[:, 1], 90))

    @cached_property
    def grounded_pelvis(self) -> float:
        """The pelvis height of this body standing on the floor: its tall frames, leaving out the flights and the
        take-off and landing frames beside them (:data:`FLIGHT_MARGIN`). Three jumps are a tenth of a motion's
        frames, and with them :attr:`standing_pelvis` put the pelvis of a bow before the jumps 0.2 m "below
        standing", so no bow was seen (the corpus's own "bows, then jumps three times, then waves" in 0 of 4 draws,
        session 43)."""
        grounded = np.ones(self.T, dtype=bool)
        for a, b in self.flights:
            grounded[max(0, a - FLIGHT_MARGIN):b + FLIGHT_MARGIN] = False
        heights = self.j("pelvis")[:, 1]
        return float(np.percentile(heights[grounded] if grounded.sum() >= 0.25 * self.T else heights, 90))

    @cached_property
    def trunk_pitch(self) -> np.ndarray:
        """Forward lean of the pelvis -> neck line from vertical (rad), (T,)."""
        v = self.j("neck") - self.j("pelvis")
        b = self.body(v)
        return np.arctan2(b[:, 2], np.maximum(b[:, 1], 1e-6))

    def wrist(self, side: str) -> np.ndarray:
        """Wrist relative to its shoulder in the body frame (T, 3): (left, up, forward)."""
        return self.body(self.j(f"{side}_wrist") - self.j(f"{side}_shoulder"))

    @cached_property
    def flights(self) -> list[tuple[int, int]]:
        """Airborne runs: both feet off the floor for at least 2 frames."""
        h = self.foot_height
        return _runs((h["left"] > AIR) & (h["right"] > AIR), 2)

    @cached_property
    def contact(self) -> dict[str, np.ndarray]:
        return {side: self.foot_height[side] < AIR for side in SIDES}

    # ---------------------------------------------------------------- derived helpers
    @cached_property
    def pelvis_drop(self) -> np.ndarray:
        """How far the pelvis is below its standing height (m), (T,)."""
        return self.standing_pelvis - self.j("pelvis")[:, 1]

    def near_flight(self, frame: int, seconds: float) -> bool:
        w = seconds * self.fps
        return any(a - w <= frame < b + w for a, b in self.flights)

    @cached_property
    def leg_speed(self) -> np.ndarray:
        """Fastest pelvis or leg joint speed per frame (m/s, ~0.25-s smoothing), (T,)."""
        legs = [JOINT_INDEX[n] for n in ("pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
                                          "right_ankle", "left_foot", "right_foot")]
        v = np.linalg.norm(np.gradient(self.joints[:, legs], axis=0), axis=-1).max(1) * self.fps
        return uniform_filter1d(v, max(3, int(0.25 * self.fps)), mode="nearest")


# -------------------------------------------------------------------------------- detectors
def _peaks(x: np.ndarray, *, height: float, prominence: float, distance: int = 4) -> np.ndarray:
    """Peaks of a lightly smoothed signal; a peak at either end counts (the signal is padded with its minimum)."""
    x = gaussian_filter1d(np.asarray(x, dtype=np.float64), 1.0, mode="nearest")
    floor = float(x.min()) - 1e-6
    peaks, _ = find_peaks(np.concatenate([[floor], x, [floor]]), height=height, prominence=prominence,
                          distance=distance)
    return peaks - 1


def _jump_flights(m: MotionSignals) -> list[dict]:
    """Every flight with its kind (jump, jump_forward, hop, jack) and side (hops: the landing foot)."""
    out = []
    h = m.foot_height
    low = np.minimum(h["left"], h["right"])
    up_l, up_r = m.wrist("left")[:, 1], m.wrist("right")[:, 1]
    for a, b in m.flights:
        apex = a + int(np.argmax(low[a:b]))
        lo, hi = max(0, a - int(0.6 * m.fps)), min(m.T, b + int(0.6 * m.fps))
        # hop: one foot stays up from before the take-off until after the landing
        held = {s: float(h[s][max(0, a - 3):min(m.T, b + 3)].min()) for s in SIDES}
        arms = np.minimum(up_l[lo:hi], up_r[lo:hi])
        arms_up = float(arms.max()) if np.ptp(arms) > 0.4 else 0.0  # raised and lowered, not held up
        travel = float(m.root_velocity[apex, 2])
        if max(held.values()) > 0.1 and min(held.values()) < 0.1 + 1e-9 or max(held.values()) > 0.15:
            kind, side = "hop", min(held, key=held.get)
        elif arms_up > 0.3:
            kind, side = "jack", "none"
        elif travel > 0.45:
            kind, side = "jump_forward", "none"
        else:
            kind, side = "jump", "none"
        crouch = float(m.pelvis_drop[lo:apex + 1].max()) if apex >= lo else 0.0
        # both feet leave (and land) together: frames one foot was already up before take-off / still up after
        lead = max(_up_before(h[s], a) for s in SIDES)
        trail = max(_up_after(h[s], b) for s in SIDES)
        out.append({"kind": kind, "apex": apex, "start": a, "end": b, "side": side, "crouch": crouch,
                    "together": max(lead, trail) <= 3})
    return out


def _up_before(h: np.ndarray, a: int) -> int:
    """Frames a foot had been off the floor when the flight began at ``a``."""
    k = a - 1
    while k >= 0 and h[k] > AIR:
        k -= 1
    return a - 1 - k


def _up_after(h: np.ndarray, b: int) -> int:
    """Frames a foot stays off the floor after the flight ended at ``b``."""
    k = b
    while k < len(h) and h[k] > AIR:
        k += 1
    return k - b


def detect_jumps(m: MotionSignals, kind: str) -> list[Detected]:
    """Flights of one kind. A jump leaves and lands on both feet together after a crouch (a dance's
    step-hop leaves one foot at a time)."""
    flights = [f for f in _jump_flights(m) if f["kind"] == kind]
    if kind in ("jump", "jump_forward"):
        flights = [f for f in flights if f["crouch"] > 0.08 and f["together"]]
    action = kind
    return [Detected(action, f["apex"], f["side"]) for f in flights]


def jack_peaks(m: MotionSignals) -> list[int]:
    """Frames where both arms are overhead while the feet are wide apart: the open position of a jumping jack
    (read from the pose, so a tired jack whose hops barely leave the floor still counts)."""
    arms = np.minimum(m.wrist("left")[:, 1], m.wrist("right")[:, 1])
    width = np.abs(m.body(m.j("left_ankle") - m.j("right_ankle"))[:, 0])
    wide = width > np.median(width) + 0.12
    return [int(p) for p in _peaks(arms, height=0.3, prominence=0.4) if wide[max(0, p - 4):p + 5].any()]


def detect_kicks(m: MotionSignals) -> list[Detected]:
    """A foot swung high in front of the body while the other foot stands."""
    out = []
    h = m.foot_height
    pelvis = m.j("pelvis")
    for side, other in (("left", "right"), ("right", "left")):
        ankle_fwd = m.body(m.j(f"{side}_ankle") - pelvis)[:, 2]
        for p in _peaks(h[side], height=0.3, prominence=0.2, distance=6):
            if h[other][p] < AIR and ankle_fwd[p] > 0.15:
                out.append(Detected("kick", int(p), side))
    return sorted(out, key=lambda d: d.frame)


def detect_squats(m: MotionSignals) -> list[Detected]:
    """The pelvis lowered a quarter metre or more with both feet planted, away from any flight."""
    out = []
    for p in _peaks(m.pelvis_drop, height=0.22, prominence=0.15, distance=8):
        if m.contact["left"][p] and m.contact["right"][p] and not m.near_flight(p, 0.8) and \
                m.trunk_pitch[p] < np.radians(60):
            out.append(Detected("squat", int(p)))
    return out


def detect_bows(m: MotionSignals) -> list[Detected]:
    """The trunk pitched forward 30 degrees or more while the pelvis stays high."""
    out = []
    for p in _peaks(m.trunk_pitch, height=np.radians(24), prominence=np.radians(12), distance=8):
        if m.grounded_pelvis - m.j("pelvis")[p, 1] < 0.15 and not m.near_flight(p, 0.8):  # not a squat's lean
            out.append(Detected("bow", int(p)))
    return out


def detect_punches(m: MotionSignals) -> list[Detected]:
    """A wrist thrust forward to near arm's length at shoulder height, fast."""
    out = []
    for side, other in (("left", "right"), ("right", "left")):
        w = m.wrist(side)
        guard = m.wrist(other)[:, 2]  # a punch's other hand stays up in front; a running arm swings back
        fwd = w[:, 2]
        speed = np.gradient(fwd) * m.fps
        for p in _peaks(fwd, height=0.4, prominence=0.15, distance=4):
            rise = speed[max(0, p - 5):p + 1].max()
            feet_low = max(m.foot_height["left"][p], m.foot_height["right"][p]) < 0.15  # not a kick's arm swing
            if abs(w[p, 1]) < 0.3 and rise > 1.5 and feet_low and not m.near_flight(p, 0.5) and guard[p] > 0.05:
                out.append(Detected("punch", int(p), side))
    return sorted(out, key=lambda d: d.frame)


def detect_waves(m: MotionSignals) -> list[Detected]:
    """A wrist raised above the shoulder (below overhead) swinging side to side: one per inward swing
    (the corpus's wave oscillates out and back once per count; raising and lowering the arm add an outward
    swing of their own at either end, never an inward one)."""
    out = []
    sign = {"left": 1.0, "right": -1.0}
    for side in SIDES:
        w = m.wrist(side)
        raised = (w[:, 1] > 0.15) & (w[:, 1] < 0.45)
        lateral = np.where(raised, sign[side] * w[:, 0], np.nan)
        for a, b in _runs(raised, int(0.5 * m.fps)):
            seg = -lateral[a:b]
            for p in _peaks(seg, height=-np.inf, prominence=0.04, distance=3):
                if p == 0 or p == b - a - 1:
                    continue
                out.append(Detected("wave", int(a + p), side))
    return sorted(out, key=lambda d: d.frame)


def detect_claps(m: MotionSignals) -> list[Detected]:
    """The wrists meeting in front of the chest."""
    d = np.linalg.norm(m.j("left_wrist") - m.j("right_wrist"), axis=1)
    mid = m.body((m.j("left_wrist") + m.j("right_wrist")) / 2 - m.j("spine3"))
    out = []
    for p in _peaks(-d, height=-0.14, prominence=0.1, distance=3):
        if mid[p, 2] > 0.1:
            out.append(Detected("clap", int(p), "both"))
    return out


def detect_raises(m: MotionSignals) -> list[Detected]:
    """A wrist lifted well above the shoulder (overhead), away from jumping jacks' flights."""
    out = []
    ups = {side: m.wrist(side)[:, 1] for side in SIDES}
    jacks = jack_peaks(m)
    found: dict[str, np.ndarray] = {
        side: np.array([p for p in _peaks(ups[side], height=0.38, prominence=0.3, distance=8)
                        if not m.near_flight(p, 0.5) and not any(abs(p - j) <= 6 for j in jacks)], dtype=int)
        for side in SIDES}
    used = set()
    for p in found["left"]:
        q = [r for r in found["right"] if abs(r - p) <= 1.0 * m.fps and r not in used]
        if q:
            used.add(q[0])
            out.append(Detected("raise_arms", int(p), "both"))
        else:
            out.append(Detected("raise_arms", int(p), "left"))
    out += [Detected("raise_arms", int(r), "right") for r in found["right"] if r not in used]
    return sorted(out, key=lambda d: d.frame)


def _sustained(mask: np.ndarray, m: MotionSignals, seconds: float) -> list[tuple[int, int]]:
    return _runs(mask, max(2, int(seconds * m.fps)))


def gait_runs(m: MotionSignals) -> list[dict]:
    """Stretches of forward travel (>= 1 s above 0.35 m/s) with their speed, turning and double support
    (the share of frames with both feet within 3 cm of the floor)."""
    out = []
    fwd = m.root_velocity[:, 2]
    h = m.foot_height
    for a, b in _sustained(fwd > 0.35, m, 1.0):
        out.append({"start": a, "end": b, "speed": float(np.median(fwd[a:b])),
                    "turned": float(m.heading[b - 1] - m.heading[a]),
                    "double_support": float(np.mean((h["left"][a:b] < 0.03) & (h["right"][a:b] < 0.03)))})
    return out


#: a gait slower than this is a walk whatever its double support: every corpus run and jog is faster (5th
#: percentiles 1.41 and 1.0 m/s; walks 0.51-1.75), and a person sees a body stepping forward at 0.5-0.8 m/s with a
#: foot always on the floor walk, not run (the generated walks the double support alone called runs, session 27)
MIN_RUN_SPEED = 0.9  # m/s


def gait_kind(run: dict) -> str:
    """walk or run (jogs count as runs). A walk keeps both feet on the floor (within 3 cm) part of every
    step (double support: 22-80 % of corpus walking frames); a run hardly ever does (4-18 %), and runs faster than
    :data:`MIN_RUN_SPEED`."""
    return "run" if run["double_support"] < 0.2 and run["speed"] >= MIN_RUN_SPEED else "walk"


def detect_gaits(m: MotionSignals, action: str) -> list[Detected]:
    target = "run" if action in ("run", "jog") else "walk"
    return [Detected(action, (r["start"] + r["end"]) // 2, _travel_direction(r))
            for r in gait_runs(m) if gait_kind(r) == target]


def _travel_direction(run: dict) -> str:
    t = np.degrees(run["turned"])
    if abs(t) > 270:
        return "circle_left" if t > 0 else "circle_right"
    if abs(t) > 45:
        return "left" if t > 0 else "right"
    return "forward"


def detect_backward(m: MotionSignals) -> list[Detected]:
    fwd = m.root_velocity[:, 2]
    return [Detected("walk_backward", (a + b) // 2, "backward") for a, b in _sustained(fwd < -0.2, m, 0.8)]


def detect_side_steps(m: MotionSignals) -> list[Detected]:
    v = m.root_velocity
    dances = dance_spans(m)
    out = []
    for sign, side in ((1.0, "left"), (-1.0, "right")):
        mask = (sign * v[:, 0] > 0.06) & (np.abs(v[:, 0]) > np.abs(v[:, 2]))
        for a, b in _sustained(mask, m, 0.6):
            if any(a < d1 and d0 < b for d0, d1 in dances):
                continue  # one leg of a side-to-side dance
            if sign * (m.j("pelvis")[b - 1] - m.j("pelvis")[a]) @ m.left[a] > 0.15:
                out.append(Detected("side_step", (a + b) // 2, side))
    return out


def detect_turns(m: MotionSignals) -> list[Detected]:
    """Turning 60 degrees or more on the spot (little travel) within 3 s. The event is the frame where the body has
    turned half of the way: the still stretch goes on through what follows on the spot (a bow after "turns around"),
    so its middle could fall after the next action's first event and read the order backwards."""
    still = np.linalg.norm(m.root_velocity[:, [0, 2]], axis=1) < 0.3
    out = []
    for a, b in _sustained(still, m, 0.6):
        turned = float(m.heading[b - 1] - m.heading[a])
        if abs(turned) > np.radians(60):
            direction = "around" if abs(turned) > np.radians(135) else ("left" if turned > 0 else "right")
            half = int(np.argmax(np.abs(m.heading[a:b] - m.heading[a]) >= abs(turned) / 2))
            out.append(Detected("turn", a + half, direction))
    return out


def detect_stands(m: MotionSignals) -> list[Detected]:
    """A second or more with the legs and pelvis nearly still (the arms may gesture: "stands while waving")."""
    return [Detected("stand", (a + b) // 2) for a, b in _sustained(m.leg_speed < 0.3, m, 1.0)]


def dance_spans(m: MotionSignals) -> list[tuple[int, int]]:
    """Stretches where the body's sideways position reverses three times or more (swings of 8 cm or more)
    within 4 s, with little travel: stepping from side to side."""
    lateral = np.cumsum(m.root_velocity[:, 0]) / m.fps  # sideways position in the body's own frame
    ext = sorted([int(p) for p in _peaks(lateral, height=-np.inf, prominence=0.08, distance=4)] +
                 [int(p) for p in _peaks(-lateral, height=-np.inf, prominence=0.08, distance=4)])
    out = []
    window = int(4 * m.fps)
    for k in range(len(ext) - 2):
        a, b = ext[k], ext[k + 2]
        if b - a <= window and np.linalg.norm(m.j("pelvis")[b, [0, 2]] - m.j("pelvis")[a, [0, 2]]) < 0.6:
            out.append((a, b))
    return out


def detect_dances(m: MotionSignals) -> list[Detected]:
    """A dance (one event: a dance has no count)."""
    spans = dance_spans(m)
    return [Detected("dance", (spans[0][0] + spans[0][1]) // 2)] if spans else []


DETECTORS = {
    "jump": lambda m: detect_jumps(m, "jump"),
    "jump_forward": lambda m: detect_jumps(m, "jump_forward"),
    "hop": lambda m: detect_jumps(m, "hop"),
    "jumping_jacks": lambda m: [Detected("jumping_jacks", p) for p in jack_peaks(m)],
    "kick": detect_kicks,
    "squat": detect_squats,
    "bow": detect_bows,
    "punch": detect_punches,
    "wave": detect_waves,
    "clap": detect_claps,
    "raise_arms": detect_raises,
    "walk": lambda m: detect_gaits(m, "walk"),
    "run": lambda m: detect_gaits(m, "run"),
    "jog": lambda m: detect_gaits(m, "jog"),
    "walk_backward": detect_backward,
    "side_step": detect_side_steps,
    "turn": detect_turns,
    "stand": detect_stands,
    "dance": detect_dances,
}


def detect(joints_or_signals, action: str) -> list[Detected]:
    """Events of ``action`` in a motion ((T, 22, 3) joints or its :class:`MotionSignals`)."""
    if action not in DETECTORS:
        raise ValueError(f"no detector for {action!r}; known: {', '.join(DETECTORS)}")
    m = joints_or_signals if isinstance(joints_or_signals, MotionSignals) else MotionSignals(joints_or_signals)
    return DETECTORS[action](m)
