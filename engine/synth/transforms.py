"""Program transforms that produce ground truth for the editing methods.

All return new programs (programs are immutable); synthesise them with
``engine.synth.make_sample`` to get the true motion and labels.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from engine.synth.compose import synthesize
from engine.synth.program import FPS, INTENSITIES, MAX_FRAMES, Program, Segment, family
from engine.synth.splits import compatible


def _seg(program: Program, segment: int) -> Segment:
    if not -len(program.segments) <= segment < len(program.segments):
        raise IndexError(f"segment {segment} out of range")
    return program.segments[segment]


def replace_action(program: Program, segment: int, new_action: str, **params) -> Program:
    """Same time line, another action in ``segment`` (MotionCLR in-place replacement).

    The segment keeps its frames, count, speed and intensity; extra keyword arguments set
    other fields (e.g. ``side="left"``). Locomotion keeps the direction where it applies.
    """
    old = _seg(program, segment)
    fields = dict(old.__dict__)
    fields.update(action=new_action, cadence=0.0)
    if family(new_action) != "locomotion":
        fields.update(direction="none", path=None, turn=0.0)
    if new_action in ("kick", "punch", "wave", "hop") and fields["side"] not in ("left", "right", "both"):
        fields["side"] = "right"
    if new_action == "walk_backward":
        fields["direction"] = "backward"
    elif new_action == "side_step" and fields["direction"] not in ("left", "right"):
        fields["direction"] = "left"
    elif new_action in ("walk", "run", "jog") and fields["direction"] in ("none", "backward"):
        fields["direction"] = "forward"
    elif new_action == "turn" and fields["turn"] == 0.0:
        fields.update(turn=float(np.pi), direction="around")
    fields.update(params)
    segs = list(program.segments)
    segs[segment] = Segment(**fields)
    return program.with_segments(segs)


def shift(program: Program, *, order: list[int] | None = None, rotate: int = 0) -> Program:
    """Reorder segments (``order``: a permutation) or rotate them (``rotate`` positions to the
    left: the first ``rotate`` segments move to the end; MotionCLR's sequence shifting)."""
    segs = list(program.segments)
    if order is not None:
        if sorted(order) != list(range(len(segs))):
            raise ValueError("order must be a permutation of the segment indices")
        segs = [segs[i] for i in order]
    if rotate:
        r = rotate % len(segs)
        segs = segs[r:] + segs[:r]
    return program.with_segments(segs)


def shift_frames(joints: np.ndarray, fraction: float = 0.5) -> np.ndarray:
    """Circular time shift of a motion (the first ``fraction`` moved to the end) — the frame-level
    ground truth of MotionCLR's shifting with r = fraction."""
    k = int(round(fraction * joints.shape[0]))
    return np.concatenate([joints[k:], joints[:k]], 0)


def with_count(program: Program, n: int, *, segment: int | None = None, keep_frames: bool = False) -> Program:
    """Set the repetition count of ``segment`` (default: the first counted segment). The
    segment is lengthened/shortened in proportion unless ``keep_frames``."""
    if n < 1:
        raise ValueError("count must be >= 1")
    idx = segment
    if idx is None:
        idx = next((i for i, s in enumerate(program.segments)
                    if s.action not in ("walk", "run", "jog", "walk_backward", "side_step", "turn", "stand", "dance")),
                   0)
    old = _seg(program, idx)
    frames = old.frames if keep_frames else int(round(old.frames * (n + 0.6) / (old.count + 0.6)))
    other = program.frames - old.frames
    frames = max(12, min(frames, MAX_FRAMES - other))
    segs = list(program.segments)
    segs[idx] = replace(old, count=n, frames=frames)
    return program.with_segments(segs)


def with_path(program: Program, path, *, segment: int = 0) -> Program:
    """Make ``segment`` (a gait) follow a root path: waypoints (x, z) in metres relative to its
    start, in its start heading frame (z ahead, x to the body's left)."""
    old = _seg(program, segment)
    if family(old.action) != "locomotion" or old.action == "turn":
        raise ValueError("with_path needs a gait segment (walk, run, jog, walk_backward, side_step)")
    pts = tuple((float(x), float(z)) for x, z in np.asarray(path, dtype=np.float64))
    if len(pts) < 2:
        raise ValueError("a path needs at least two points")
    segs = list(program.segments)
    segs[segment] = replace(old, path=pts)
    return program.with_segments(segs)


def with_intensity(program: Program, value: float, *, segment: int | None = None) -> Program:
    """Set the intensity multiplier (jump height, kick height, squat depth, wave amplitude).

    Jump height is strictly increasing in ``value`` over [0.2, 2.2] (the emphasis benchmark's
    ground truth: a larger weight should give higher jumps)."""
    word = min(INTENSITIES, key=lambda k: abs(INTENSITIES[k] - value))
    segs = []
    for i, s in enumerate(program.segments):
        if segment is None or i == segment:
            s = replace(s, intensity=float(value), intensity_word=word)
        segs.append(s)
    return program.with_segments(segs)


def with_style(program: Program, style: str, strength: float = 1.0) -> Program:
    return replace(program, style=style, style_strength=float(strength))


def combine(*, outline_of: Program, motifs_of: Program, transfer_action: bool = True,
            stride_of: str = "leader") -> Program:
    """MoMo's ground truth: the leader's outline with the follower's motifs.

    Outline (from ``outline_of``): segment timing, counts, paths/directions, speed, cadence (the
    leader's step rhythm), leading foot. Motifs (from ``motifs_of``): style and strength,
    person (posture habits), gestures layered on the body. With ``transfer_action`` a leader
    gait segment takes the follower's gait kind (walk -> run keeps the leader's rhythm).

    ``stride_of``: whose stride length a segment whose gait kind changed (walk -> run, run -> walk) takes:
    ``"leader"`` (default): the leader's path as it is, so the run covers the walk's distance at the walk's speed;
    ``"follower"``: the paper's reading ("the type of step (walk, run, hop) belongs to the motifs", the outline
    is the sequence and pace of steps): the leader's path shape and step times with the follower gait's stride,
    i.e. the path scaled by the ratio of the two gaits' strides (``GAITS`` speed / cadence), so a walk -> run
    runs faster than the leader walked and a run -> walk walks slower. Segments that keep their gait kind are
    the same either way.
    """
    if stride_of not in ("leader", "follower"):
        raise ValueError(f"stride_of must be 'leader' or 'follower', got {stride_of!r}")
    leader, follower = outline_of, motifs_of
    lead_syn = synthesize(leader)
    f_gaits = [s for s in follower.segments if family(s.action) == "locomotion" and s.action != "turn"]
    f_gestures = [s.overlay if s.overlay is not None else s for s in follower.segments
                  if s.overlay is not None or family(s.action) == "gesture"]
    segs = []
    for i, s in enumerate(leader.segments):
        fields = dict(s.__dict__)
        fields["cadence"] = float(lead_syn.segment_params[i].get("cadence", 0.0) or 0.0)
        a, b = lead_syn.segment_ranges[i]
        if family(s.action) == "locomotion" and s.action != "turn" and s.path is None:
            fields["path"] = _relative_path(lead_syn.channels.root[a:b, [0, 2]], float(lead_syn.channels.heading[a]))
        if transfer_action and f_gaits and family(s.action) == "locomotion" and s.action in ("walk", "run", "jog"):
            fa = f_gaits[0].action
            if fa in ("walk", "run", "jog"):
                fields["action"] = fa
                if stride_of == "follower" and fa != s.action and fields["path"] is not None:
                    ratio = _stride(fa) / _stride(s.action)
                    fields["path"] = tuple((x * ratio, z * ratio) for x, z in fields["path"])
        if f_gestures and s.overlay is None and s.action in ("walk", "stand", "side_step", "turn"):
            g = f_gestures[0]
            fields["overlay"] = replace(g, frames=s.frames)
        segs.append(Segment(**fields))
    style = follower.style
    if any(not compatible(s.action, style) for s in segs):
        style = "none"
    return replace(leader, segments=tuple(segs), style=style, style_strength=follower.style_strength,
                   person=follower.person)


def _stride(action: str) -> float:
    """A gait's base step length (m): its speed over its cadence."""
    from engine.synth.primitives.locomotion import GAITS

    return GAITS[action].speed / GAITS[action].cadence


def _relative_path(root_xz: np.ndarray, heading: float, points: int = 16) -> tuple[tuple[float, float], ...]:
    """Root waypoints (world x, z) -> segment path (x left, z ahead) in the start heading frame."""
    idx = np.linspace(0, len(root_xz) - 1, points).round().astype(int)
    d = root_xz[idx] - root_xz[0]
    c, s = np.cos(heading), np.sin(heading)
    x = d[:, 0] * c - d[:, 1] * s
    z = d[:, 0] * s + d[:, 1] * c
    keep = [0] + [k for k in range(1, points) if np.hypot(x[k] - x[k - 1], z[k] - z[k - 1]) > 1e-3]
    if len(keep) < 2:
        return ((0.0, 0.0), (0.0, 0.01))
    return tuple((float(x[k]), float(z[k])) for k in keep)


@dataclass(frozen=True)
class Interval:
    """One DoubleTake interval: a prompt's program and its length in frames."""

    program: Program
    frames: int


def interval_sequence(intervals: list[tuple[Program, int]], *, blend: int = 10) -> tuple[Program, list[dict]]:
    """Chain single-segment programs into one long program with exact transitions.

    Returns the program (every interval's first segment resized to its length; style from the
    first) and one dict per transition: ``{"boundary", "start", "end"}`` frames of the blend.
    Long programs may exceed 196 frames: synthesise them directly (``synthesize``), the model
    limit does not apply to the ground truth.
    """
    segs = []
    for prog, n in intervals:
        seg = prog.segments[0]
        if seg.overlay is not None:
            seg = replace(seg, overlay=replace(seg.overlay, frames=int(n)))
        segs.append(replace(seg, frames=int(n)))
    program = Program(segments=tuple(segs), style=intervals[0][0].style, style_strength=intervals[0][0].style_strength,
                      person=intervals[0][0].person, blend=blend, seed=intervals[0][0].seed)
    half = blend // 2
    trans = [{"boundary": b, "start": b - half, "end": b + blend - half} for b in program.boundaries]
    return program, trans


def seconds(frames: int) -> float:
    return frames / FPS
