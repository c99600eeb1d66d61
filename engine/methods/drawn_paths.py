"""Paths a person would draw: root paths on the floor and letters written in the air with a wrist.

The control benchmark measures the control models on these beside the corpus's own paths, and the
studio's path editor can offer them as presets. Everything is in the canonical frame the
representation uses (Y up, metres, 20 fps; the body starts at the XZ origin facing +Z, +X is the
person's left):

- root paths start at the origin heading +Z and are walked at walking speed (the corpus walk,
  ``GAITS["walk"].speed`` = 1.3 m/s) with a short speed-up and slow-down, along S-curves, circles and
  zig-zags (corners rounded, as a person walks them);
- letters ("L", "Z", "O", "S", "W", ...) are polylines about 0.4 m tall centred at shoulder height,
  0.3-0.4 m in front of the body and in front of the writing hand's shoulder, as the writer sees them
  (the writer's right is -X). Each stroke between sharp corners is timed like a hand movement
  (minimum jerk: the hand slows into every corner), with a short hold before and after.

Each generator returns a :class:`DrawnPath`, whose ``controls()`` goes through
:class:`engine.methods.paths.RootPath` / :class:`~engine.methods.paths.WristPath`, so the same checks
apply (a too-fast path is refused there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.generate import FPS
from engine.methods.paths import RootPath, WristPath, root_controls
from engine.skeleton import JOINT_INDEX, Skeleton

WALK_SPEED = 1.3  # m/s: the corpus walk (engine/synth/primitives/locomotion.py, GAITS["walk"])
SPEED_UP = 0.6  # s to reach walking speed from standing (and to stop again)
LETTER_HEIGHT = 0.4  # m
LETTER_DEPTH = 0.35  # m in front of the body (the ric frame's z)
LETTER_SIDE = 0.15  # m from the body's midline toward the writing hand
HOLD = 0.5  # s the hand rests at the letter's first point before drawing, and at its last point after
_STEP = 0.01  # m between points while building a root path


@dataclass(frozen=True)
class DrawnPath:
    """A drawn path and its timing: ``points`` (x, z) for the root, (x, y, z) body frame for a wrist."""

    name: str  # e.g. "circle_left", "letter_L_right"
    shape: str  # "s_curve", "circle", "zigzag" or the letter
    control: str  # "root", "left_wrist" or "right_wrist"
    points: tuple[tuple[float, ...], ...]
    times: tuple[float, ...]  # seconds per point, from 0
    seconds: float  # the motion's length: the drawing and its holds

    def path(self) -> RootPath | WristPath:
        return (RootPath if self.control == "root" else WristPath)(points=self.points, times=self.times)

    def controls(self, seconds: float | None = None) -> tuple[np.ndarray, dict | None]:
        """(T, 3) raw control features for a motion of ``seconds`` (default: the path's own) and, for the
        root, the frame of :func:`engine.methods.paths.root_controls` (its ``target`` = root xz per pose)."""
        seconds = self.seconds if seconds is None else seconds
        if self.control == "root":
            return root_controls(self.path(), seconds)
        return self.path().controls(seconds), None


# ----------------------------------------------------------------------------- root paths
def _along_heading(heading, length: float) -> np.ndarray:
    """Floor points (N, 2) of a path of ``length`` m whose heading (rad, 0 = +Z, + = toward +X, the
    person's left) at arc length s is ``heading(s)``; starts at the origin."""
    n = max(2, int(math.ceil(length / _STEP)) + 1)
    s = np.linspace(0.0, length, n)
    h = heading(s)
    mid = 0.5 * (h[1:] + h[:-1])  # midpoint rule: second-order accurate
    ds = np.diff(s)
    xz = np.concatenate([[[0.0, 0.0]], np.cumsum(np.stack([np.sin(mid) * ds, np.cos(mid) * ds], -1), axis=0)])
    return xz


def walk_times(points: np.ndarray, speed: float = WALK_SPEED, speed_up: float = SPEED_UP) -> np.ndarray:
    """Seconds at each point walking the polyline at ``speed``, speeding up from standing over ``speed_up``
    seconds (a smooth ramp) and slowing to a stop the same way; the speed never exceeds ``speed``."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    total = arc[-1]
    ramp = min(speed_up, total / speed)  # a short path: ramps that meet in the middle
    # distance covered while ramping with v(t) = speed * smoothstep(t / ramp): speed * ramp / 2
    cruise = max(total - speed * ramp, 0.0) / speed
    duration = 2 * ramp + cruise
    t = np.linspace(0.0, duration, int(math.ceil(duration * 200)) + 2)

    def ramp_dist(u):  # distance after u seconds of the ramp: ∫ speed * (3x² - 2x³) dt, x = t / ramp
        x = np.clip(u / ramp, 0.0, 1.0)
        return speed * ramp * (x**3 - 0.5 * x**4)

    dist = np.where(t < ramp, ramp_dist(t),
                    np.where(t < ramp + cruise, speed * ramp / 2 + speed * (t - ramp),
                             speed * ramp / 2 + speed * cruise + speed * ramp / 2 - ramp_dist(duration - t)))
    dist = dist * (total / dist[-1])  # exact end (the ramps are exact; this only absorbs rounding)
    return np.interp(arc, np.maximum.accumulate(dist), t)


def _root(name: str, shape: str, xz: np.ndarray, speed: float) -> DrawnPath:
    keep = np.unique(np.concatenate([np.arange(0, len(xz), max(1, int(round(0.05 / _STEP)))), [len(xz) - 1]]))
    xz = xz[keep]  # ~5 cm between the stored points, the true end point kept
    times = walk_times(xz, speed)
    seconds = math.ceil(times[-1] * FPS) / FPS
    return DrawnPath(name=name, shape=shape, control="root", points=tuple(map(tuple, xz.round(4).tolist())),
                     times=tuple(times.round(4).tolist()), seconds=seconds)


def s_curve(*, length: float = 6.0, swing_deg: float = 50.0, first: str = "left",
            speed: float = WALK_SPEED) -> DrawnPath:
    """An S: a bend to the ``first`` side, then one back, ending heading +Z again, shifted sideways. The
    heading swings up to ``swing_deg`` and back smoothly (no curvature jump where the path leaves +Z)."""
    sign = 1.0 if first == "left" else -1.0
    amp = math.radians(swing_deg) * sign
    xz = _along_heading(lambda s: amp * 0.5 * (1 - np.cos(2 * np.pi * s / length)), length)
    return _root(f"s_curve_{first}", "s_curve", xz, speed)


def circle(*, radius: float = 1.2, turn: str = "left", speed: float = WALK_SPEED) -> DrawnPath:
    """One full circle of ``radius`` back to the origin, turning to the person's ``turn``."""
    sign = 1.0 if turn == "left" else -1.0
    length = 2 * math.pi * radius
    xz = _along_heading(lambda s: sign * s / radius, length)
    return _root(f"circle_{turn}", "circle", xz, speed)


def zigzag(*, legs: int = 4, leg: float = 1.4, angle_deg: float = 45.0, lead_in: float = 0.8,
           corner: float = 0.5, first: str = "left", speed: float = WALK_SPEED) -> DrawnPath:
    """A straight lead-in along +Z, then ``legs`` straight legs alternating ±``angle_deg`` from +Z; each
    corner is rounded over ``corner`` metres of path (as a person walks it), then a short lead-out along +Z."""
    sign = 1.0 if first == "left" else -1.0
    a = math.radians(angle_deg)
    targets = [0.0] + [sign * a * (1 if k % 2 == 0 else -1) for k in range(legs)] + [0.0]
    edges = np.array([lead_in + k * leg for k in range(legs + 1)])  # where the heading changes
    length = float(edges[-1] + lead_in)

    def heading(s):
        h = np.full_like(s, targets[0])
        for k, e in enumerate(edges):
            x = np.clip((s - (e - corner / 2)) / corner, 0.0, 1.0)
            h = h + (targets[k + 1] - targets[k]) * (x * x * (3 - 2 * x))
        return h

    return _root(f"zigzag_{first}", "zigzag", _along_heading(heading, length), speed)


ROOT_SHAPES = ("s_curve", "circle", "zigzag")


def drawn_root_paths(n: int) -> list[DrawnPath]:
    """``n`` distinct root paths: S-curves, circles and zig-zags in turn, mirrored and resized as n grows,
    at speeds 1.3, 1.2 and 1.4 m/s (walking)."""
    out = []
    for k in range(n):
        shape, round_ = ROOT_SHAPES[k % 3], k // 3
        side = ("left", "right")[round_ % 2]
        speed = (WALK_SPEED, 1.2, 1.4)[round_ % 3]
        size = (1.0, 0.85, 1.15)[(round_ // 2) % 3]
        if shape == "s_curve":
            p = s_curve(length=6.0 * size, first=side, speed=speed)
        elif shape == "circle":
            p = circle(radius=1.2 * size, turn=side, speed=speed)
        else:
            p = zigzag(leg=1.4 * size, first=side, speed=speed)
        out.append(_renamed(p, f"{p.name}_{k}" if round_ else p.name))
    return out


def _renamed(p: DrawnPath, name: str) -> DrawnPath:
    return DrawnPath(name=name, shape=p.shape, control=p.control, points=p.points, times=p.times, seconds=p.seconds)


# ----------------------------------------------------------------------------- letters in the air
def _ellipse(cx, cy, rx, ry, a0, a1, n=24):
    a = np.radians(np.linspace(a0, a1, n))
    return np.stack([cx + rx * np.cos(a), cy + ry * np.sin(a)], -1)


# strokes in letter units as the writer sees them: u to the writer's right, v up; height 1
LETTERS: dict[str, np.ndarray] = {
    "L": np.array([[0.0, 1.0], [0.0, 0.0], [0.6, 0.0]]),
    "Z": np.array([[0.0, 1.0], [0.7, 1.0], [0.0, 0.0], [0.7, 0.0]]),
    "O": _ellipse(0.35, 0.5, 0.35, 0.5, 90, 450, 40),  # from the top, anticlockwise (as O is written)
    "S": np.concatenate([_ellipse(0.35, 0.75, 0.35, 0.25, 20, 270, 20),  # the top bowl, anticlockwise
                         _ellipse(0.35, 0.25, 0.35, 0.25, 90, -160, 20)[1:]]),  # the bottom bowl, clockwise
    "W": np.array([[0.0, 1.0], [0.2, 0.0], [0.4, 0.7], [0.6, 0.0], [0.8, 1.0]]),
    "N": np.array([[0.0, 0.0], [0.0, 1.0], [0.6, 0.0], [0.6, 1.0]]),
    "V": np.array([[0.0, 1.0], [0.35, 0.0], [0.7, 1.0]]),
    "C": _ellipse(0.4, 0.5, 0.4, 0.5, 60, 300, 30),
    "M": np.array([[0.0, 0.0], [0.0, 1.0], [0.35, 0.4], [0.7, 1.0], [0.7, 0.0]]),
    "U": np.concatenate([[[0.0, 1.0]], _ellipse(0.3, 0.3, 0.3, 0.3, 180, 360, 16), [[0.6, 1.0]]]),
}
LETTER_ORDER = ("L", "Z", "O", "S", "W", "N", "V", "C", "M", "U")


def _stroke_times(points: np.ndarray, *, corner_deg: float = 60.0, base: float = 0.3, per_m: float = 1.2) -> np.ndarray:
    """Seconds at each point: the polyline splits into strokes at sharp corners; each stroke takes
    ``base + per_m * length`` seconds along a minimum-jerk profile (the hand stops at every corner)."""
    seg = np.diff(points, axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    cut = [0]
    for i in range(1, len(points) - 1):
        a, b = seg[i - 1], seg[i]
        cos = float(a @ b / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-12))
        if cos < math.cos(math.radians(corner_deg)):
            cut.append(i)
    cut.append(len(points) - 1)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    times, t0 = np.zeros(len(points)), 0.0
    for i, j in zip(cut[:-1], cut[1:]):
        length = arc[j] - arc[i]
        dur = base + per_m * length
        # invert the minimum-jerk position profile x(τ) = 10τ³ - 15τ⁴ + 6τ⁵ (τ in [0, 1])
        tau = np.linspace(0.0, 1.0, 401)
        x = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        frac = (arc[i:j + 1] - arc[i]) / max(length, 1e-12)
        times[i:j + 1] = t0 + dur * np.interp(frac, x, tau)
        t0 += dur
    return times


def _densified(points: np.ndarray, step: float) -> np.ndarray:
    """The polyline with points inserted so no segment is longer than ``step`` (the vertices kept): the
    timing lives on the points, and paths are resampled linearly between them."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:]):
        k = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (b - a) * (np.arange(1, k + 1)[:, None] / k))
    return np.concatenate(out)


def shoulder_height() -> float:
    rest = Skeleton().rest_pose()
    return float(rest[JOINT_INDEX["left_shoulder"], 1] - rest[:, 1].min())


def letter_outline(char: str, *, side: str = "right", height: float = LETTER_HEIGHT, centre_y: float | None = None,
                   offset: float = LETTER_SIDE) -> np.ndarray:
    """The letter ``char``'s polyline (N, 2) as (x, y) in the body frame, written with the ``side`` wrist:
    ``height`` m tall, centred at ``centre_y`` (default: shoulder height) and ``offset`` m toward the writing hand.
    Its corners only (what a person would click in the studio's front view; :func:`letter` densifies and times it)."""
    if char not in LETTERS:
        raise ValueError(f"no drawn letter {char!r}: choose from {', '.join(LETTER_ORDER)}")
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    uv = LETTERS[char]
    centre_y = shoulder_height() if centre_y is None else centre_y
    hand_x = offset if side == "left" else -offset  # the left hand is at +X
    width = uv[:, 0].max() - uv[:, 0].min()
    u = (uv[:, 0] - uv[:, 0].min() - width / 2) * height
    v = (uv[:, 1] - 0.5) * height
    # the writer's right is -X: a letter read by the writer is mirrored for someone facing them
    return np.stack([hand_x - u, centre_y + v], -1)


def letter(char: str, *, side: str = "right", height: float = LETTER_HEIGHT, depth: float = LETTER_DEPTH,
           centre_y: float | None = None, offset: float = LETTER_SIDE, pace: float = 1.0) -> DrawnPath:
    """The letter ``char`` written in the air with the ``side`` wrist: ``height`` m tall, centred at
    ``centre_y`` (default: shoulder height), ``depth`` m in front of the body and ``offset`` m toward the
    writing hand; ``pace`` > 1 writes it more slowly."""
    xy = letter_outline(char, side=side, height=height, centre_y=centre_y, offset=offset)
    xyz = _densified(np.concatenate([xy, np.full((len(xy), 1), depth)], -1), 0.015)
    times = _stroke_times(xyz) * pace
    # hold the first point, draw, hold the last point
    times = np.concatenate([[0.0], times + HOLD])
    xyz = np.concatenate([xyz[:1], xyz])
    seconds = math.ceil((times[-1] + HOLD) * FPS) / FPS
    return DrawnPath(name=f"letter_{char}_{side}", shape=char, control=f"{side}_wrist",
                     points=tuple(map(tuple, xyz.round(4).tolist())), times=tuple(times.round(4).tolist()),
                     seconds=seconds)


def drawn_letters(n: int, side: str) -> list[DrawnPath]:
    """``n`` letters written with the ``side`` wrist: L, Z, O, S, W, N, V, C, M, U in turn, then again a
    little larger / nearer / slower."""
    out = []
    for k in range(n):
        char, round_ = LETTER_ORDER[k % len(LETTER_ORDER)], k // len(LETTER_ORDER)
        p = letter(char, side=side, height=LETTER_HEIGHT * (1.0, 1.1, 0.9)[round_ % 3],
                   depth=(LETTER_DEPTH, 0.3, 0.4)[round_ % 3], pace=(1.0, 1.25, 0.9)[round_ % 3])
        out.append(_renamed(p, f"{p.name}_{k}" if round_ else p.name))
    return out
