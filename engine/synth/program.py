"""Motion programs: a time line of segments (action + parameters), a style and a person.

A :class:`Program` fully determines its motion: every random choice is resolved into its
fields when it is sampled, so transforms (``engine.synth.transforms``) edit plain numbers and
synthesis (``engine.synth.compose.synthesize``) is a pure function of the program.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from engine.units import FPS, MAX_FRAMES


LOCOMOTION = ("walk", "run", "jog", "walk_backward", "side_step", "turn")
JUMPS = ("jump", "jump_forward", "hop", "jumping_jacks")
LEG_ACTIONS = ("squat", "kick")
GESTURES = ("punch", "wave", "clap", "raise_arms")
BODY_ACTIONS = ("stand", "bow", "dance")
ACTIONS: tuple[str, ...] = ("stand",) + LOCOMOTION + JUMPS + LEG_ACTIONS + GESTURES + ("bow", "dance")

DIRECTIONS = ("none", "forward", "backward", "left", "right", "circle_left", "circle_right", "around")
SIDES = ("none", "left", "right", "both")

# numeric values of the caption modifiers
SPEEDS = {"slowly": 0.7, "normal": 1.0, "quickly": 1.35}
INTENSITIES = {"a little": 0.55, "normal": 1.0, "high": 1.6}


def family(action: str) -> str:
    """Action family: locomotion, jump, legs, gesture or body."""
    if action in LOCOMOTION:
        return "locomotion"
    if action in JUMPS:
        return "jump"
    if action in LEG_ACTIONS:
        return "legs"
    if action in GESTURES:
        return "gesture"
    return "body"


@dataclass(frozen=True)
class Segment:
    """One action on the time line.

    frames: duration in frames (20 fps). count: repetitions (jumps, kicks, waves...; for
    gaits the number of steps is derived from cadence and duration). speed and intensity are
    multipliers (1 = normal); ``speed_word`` / ``intensity_word`` remember the caption words.
    cadence: steps per second for gaits (0 = the action's default x speed x style tempo).
    lead: the foot (or hand) that starts. path: root waypoints (x, z) in metres relative to
    the segment start, in the start heading frame (z ahead, x to the left); None = derived
    from ``direction``. turn: radians turned by "turn" (positive = to the left). overlay: an
    upper-body gesture layered on top ("walks while waving").
    """

    action: str
    frames: int
    count: int = 1
    direction: str = "none"
    side: str = "none"
    speed: float = 1.0
    speed_word: str = "normal"
    intensity: float = 1.0
    intensity_word: str = "normal"
    cadence: float = 0.0
    lead: str = "left"
    path: tuple[tuple[float, float], ...] | None = None
    turn: float = 0.0
    overlay: "Segment | None" = None

    def __post_init__(self) -> None:
        if self.action not in ACTIONS:
            raise ValueError(f"unknown action {self.action!r}")
        if self.frames < 2:
            raise ValueError("a segment needs at least 2 frames")
        if self.direction not in DIRECTIONS:
            raise ValueError(f"unknown direction {self.direction!r}")
        if self.side not in SIDES:
            raise ValueError(f"unknown side {self.side!r}")
        if self.count < 1:
            raise ValueError("count must be >= 1")

    def to_json(self) -> dict:
        out = dict(self.__dict__)  # every field holds a number, a string or None but these two
        out["overlay"] = self.overlay.to_json() if self.overlay is not None else None
        out["path"] = [list(p) for p in self.path] if self.path is not None else None
        return out

    @classmethod
    def from_json(cls, data: dict) -> "Segment":
        data = dict(data)
        if data.get("overlay") is not None:
            data["overlay"] = cls.from_json(data["overlay"])
        if data.get("path") is not None:
            data["path"] = tuple(tuple(float(v) for v in p) for p in data["path"])
        return cls(**data)


@dataclass(frozen=True)
class Person:
    """Small per-person variations (kept inside human ranges)."""

    arm_swing: float = 1.0
    stance: float = 1.0
    tempo: float = 1.0
    lean: float = 0.0  # rad, habitual forward lean
    head: float = 0.0  # rad, habitual head pitch
    elbow: float = 0.0  # rad, extra relaxed elbow bend

    def to_json(self) -> dict:
        return dict(self.__dict__)  # numbers only: no deep copy needed


@dataclass(frozen=True)
class Program:
    """A motion program: segments laid end to end, a style layered on all of them."""

    segments: tuple[Segment, ...]
    style: str = "none"
    style_strength: float = 1.0
    person: Person = field(default_factory=Person)
    blend: int = 8  # transition length in frames (0.3-0.5 s)
    seed: int = 0  # seed of the small noises (drunk sway, idle motion)

    def __post_init__(self) -> None:
        if not self.segments:
            raise ValueError("a program needs at least one segment")
        if not 6 <= self.blend <= 10:
            raise ValueError("blend must be 6-10 frames (0.3-0.5 s)")

    @property
    def frames(self) -> int:
        return int(sum(s.frames for s in self.segments))

    @property
    def boundaries(self) -> tuple[int, ...]:
        """Start frame of every segment after the first."""
        out, t = [], 0
        for s in self.segments[:-1]:
            t += s.frames
            out.append(t)
        return tuple(out)

    def segment_ranges(self) -> list[tuple[int, int]]:
        out, t = [], 0
        for s in self.segments:
            out.append((t, t + s.frames))
            t += s.frames
        return out

    def with_segments(self, segments) -> "Program":
        return replace(self, segments=tuple(segments))

    def to_json(self) -> dict:
        return {
            "segments": [s.to_json() for s in self.segments],
            "style": self.style,
            "style_strength": self.style_strength,
            "person": self.person.to_json(),
            "blend": self.blend,
            "seed": self.seed,
        }

    @classmethod
    def from_json(cls, data: dict) -> "Program":
        return cls(
            segments=tuple(Segment.from_json(s) for s in data["segments"]),
            style=data.get("style", "none"),
            style_strength=float(data.get("style_strength", 1.0)),
            person=Person(**data.get("person", {})),
            blend=int(data.get("blend", 8)),
            seed=int(data.get("seed", 0)),
        )
