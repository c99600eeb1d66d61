"""Random programs per split, and the held-out (action, style) pairs and caption templates.

train and test draw from the same distribution with disjoint seeds; ``ood`` holds every
held-out (action, style) pair and caption template, which train and test never contain.
"""
from __future__ import annotations

import numpy as np

from engine.synth.program import FPS, GESTURES, INTENSITIES, MAX_FRAMES, SPEEDS, Person, Program, Segment

SPLITS = ("train", "test", "ood")
SPLIT_IDS = {"train": 0, "test": 1, "ood": 2}

# held-out pairs: each action and each style still appears in training in other pairs
HELD_OUT_COMBOS: frozenset[tuple[str, str]] = frozenset({
    ("run", "zombie"), ("dance", "gorilla"), ("jump", "old"), ("walk_backward", "drunk"),
    ("kick", "chicken"), ("jog", "proud"), ("squat", "robot"), ("side_step", "happy"),
    ("bow", "sad"), ("hop", "crouched"),
})
ARM_STYLES = ("zombie", "chicken", "hands_up", "gorilla")
STYLE_NAMES = ("zombie", "chicken", "hands_up", "crouched", "old", "happy", "sad", "robot", "drunk", "gorilla", "proud")

_ACTION_WEIGHTS = {
    "walk": 4.0, "run": 2.0, "jog": 1.5, "walk_backward": 1.2, "side_step": 1.2, "turn": 1.0, "stand": 0.8,
    "jump": 2.5, "jump_forward": 1.5, "hop": 1.2, "jumping_jacks": 1.2, "squat": 1.2, "kick": 1.5,
    "punch": 1.2, "wave": 1.5, "clap": 1.2, "raise_arms": 1.2, "bow": 1.0, "dance": 1.5,
}
_COUNTED = ("jump", "jump_forward", "hop", "jumping_jacks", "squat", "kick", "punch", "wave", "clap", "raise_arms", "bow")
_INTENSE = ("jump", "jump_forward", "hop", "kick", "squat", "bow", "wave")
_OVERLAY_BASES = ("walk", "stand", "side_step", "turn")


def compatible(action: str, style: str) -> bool:
    """Styles that would contradict the action (an arm style on a gesture) are not combined."""
    if style == "none":
        return True
    if style in ARM_STYLES and (action in GESTURES or action == "jumping_jacks"):
        return False
    return True


def program_pairs(program: Program) -> set[tuple[str, str]]:
    """(action, style) pairs of a program, overlays included."""
    out = set()
    for seg in program.segments:
        out.add((seg.action, program.style))
        if seg.overlay is not None:
            out.add((seg.overlay.action, program.style))
    return out


def is_held_out(program: Program) -> bool:
    return bool(program_pairs(program) & HELD_OUT_COMBOS)


def natural_seconds(seg: Segment, rng: np.random.Generator) -> float:
    """A plausible duration for a segment given its count and speed."""
    a, c, sp = seg.action, seg.count, seg.speed
    if a in ("walk", "run", "jog"):
        if seg.direction.startswith("circle"):
            return rng.uniform(5.5, 7.5)
        return rng.uniform(2.5, 5.5)
    if a in ("walk_backward", "side_step"):
        return rng.uniform(2.0, 4.0)
    if a == "turn":
        return rng.uniform(1.4, 2.4) * (1.3 if abs(seg.turn) > 2.5 else 1.0) / sp ** 0.5
    if a == "stand":
        return rng.uniform(1.2, 2.5)
    if a == "dance":
        return rng.uniform(3.0, 6.0)
    per = {"jump": 0.95, "jump_forward": 1.1, "hop": 0.65, "jumping_jacks": 1.4, "squat": 1.8, "kick": 1.5,
           "punch": 0.6, "wave": 0.6, "clap": 0.5, "raise_arms": 2.0, "bow": 2.0}[a]
    pad = {"hop": 0.9, "punch": 1.0, "wave": 1.0, "clap": 1.0, "raise_arms": 1.0}.get(a, 0.3)
    return (c * per + pad) * rng.uniform(0.95, 1.15) / max(sp, 0.5) ** 0.7


def _choice(rng: np.random.Generator, options, p=None):
    """``rng.choice(options, p=p)`` (the same draw) without turning the options into an array."""
    return options[int(rng.choice(len(options), p=p))]


def _count(rng) -> int:
    return _choice(rng, (1, 2, 3, 4, 5), p=[0.22, 0.32, 0.24, 0.13, 0.09])


def random_segment(rng: np.random.Generator, action: str) -> Segment:
    speed_word = "normal"
    if action not in ("stand",) and rng.random() < 0.35:
        speed_word = "slowly" if rng.random() < 0.5 else "quickly"
    intensity_word = "normal"
    if action in _INTENSE and rng.random() < 0.3:
        intensity_word = "high" if rng.random() < 0.5 else "a little"
    direction, side, turn, count = "none", "none", 0.0, 1
    if action in ("walk", "run", "jog"):
        direction = str(_choice(rng, ["forward", "forward", "forward", "left", "right", "circle_left", "circle_right"],
                                   p=[0.3, 0.15, 0.15, 0.1, 0.1, 0.1, 0.1]))
    elif action == "walk_backward":
        direction = "backward"
    elif action == "side_step":
        direction = str(_choice(rng, ["left", "right"]))
    elif action == "turn":
        direction = str(_choice(rng, ["around", "left", "right"]))
        turn = {"around": np.pi * (1 if rng.random() < 0.5 else -1), "left": np.pi / 2, "right": -np.pi / 2}[direction]
    if action in ("kick", "punch", "wave", "hop"):
        side = str(_choice(rng, ["left", "right"])) if action != "punch" or rng.random() < 0.8 else "both"
    elif action == "raise_arms":
        side = str(_choice(rng, ["both", "left", "right"], p=[0.5, 0.25, 0.25]))
    if action in _COUNTED:
        count = _count(rng)
        if action in ("raise_arms", "bow", "squat") and count > 3:
            count = 3
    speed = SPEEDS[speed_word] * float(rng.uniform(0.95, 1.05))
    intensity = INTENSITIES[intensity_word] * float(rng.uniform(0.92, 1.08))
    lead = "left" if rng.random() < 0.5 else "right"
    seg = Segment(action=action, frames=2, count=count, direction=direction, side=side, speed=speed,
                  speed_word=speed_word, intensity=intensity, intensity_word=intensity_word, lead=lead, turn=turn)
    return seg


def _choose_action(rng, style: str, split: str, exclude=()) -> str:
    names = [a for a in _ACTION_WEIGHTS if a not in exclude and compatible(a, style)]
    if split != "ood":
        names = [a for a in names if (a, style) not in HELD_OUT_COMBOS]
    w = np.array([_ACTION_WEIGHTS[a] for a in names])
    return str(_choice(rng, names, p=w / w.sum()))


def random_person(rng) -> Person:
    return Person(arm_swing=float(np.clip(rng.normal(1.0, 0.1), 0.75, 1.25)), stance=float(rng.uniform(0.9, 1.12)),
                  tempo=float(rng.uniform(0.93, 1.07)), lean=float(rng.uniform(-0.02, 0.06)),
                  head=float(rng.uniform(-0.05, 0.1)), elbow=float(rng.uniform(0.0, 0.15)))


def sample_program(rng: np.random.Generator, split: str, *, max_frames: int = MAX_FRAMES) -> tuple[Program, bool]:
    """A random program for ``split`` and whether its captions use the held-out templates."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}")
    held_templates = False
    forced = None
    if split == "ood":
        if rng.random() < 0.7:
            forced = sorted(HELD_OUT_COMBOS)[int(rng.integers(len(HELD_OUT_COMBOS)))]
        else:
            held_templates = True
    style = "none"
    if forced is not None:
        style = forced[1]
    elif rng.random() < 0.62:
        style = STYLE_NAMES[int(rng.integers(len(STYLE_NAMES)))]
    r = rng.random()
    n_seg = 1 if r < 0.55 else 2 if r < 0.88 else 3
    segments: list[Segment] = []
    for k in range(n_seg):
        if k == 0 and forced is not None:
            action = forced[0]
        else:
            prev = segments[-1].action if segments else None
            action = _choose_action(rng, style, split, exclude=(prev,) if prev else ())
        seg = random_segment(rng, action)
        if (action in _OVERLAY_BASES and style not in ARM_STYLES and rng.random() < 0.25):
            over_action = str(_choice(rng, ["wave", "clap", "raise_arms", "punch"], p=[0.45, 0.2, 0.2, 0.15]))
            if split == "ood" or (over_action, style) not in HELD_OUT_COMBOS:
                over = random_segment(rng, over_action)
                seg = Segment(**{**seg.__dict__, "overlay": over})
        segments.append(seg)
    # durations
    secs = [natural_seconds(s, rng) for s in segments]
    for s in segments:
        if s.overlay is not None:
            pass
    total = sum(secs)
    limit = (max_frames - 1) / FPS
    if total > limit:
        secs = [x * limit / total for x in secs]
    if sum(secs) < 2.0:
        secs = [x * 2.0 / sum(secs) for x in secs]
    frames = [max(int(round(x * FPS)), 12) for x in secs]
    while sum(frames) > max_frames:
        i = int(np.argmax(frames))
        frames[i] -= 1
    out = []
    for s, f in zip(segments, frames):
        if s.direction.startswith("circle") and f < 4.5 * FPS:
            s = Segment(**{**s.__dict__, "direction": "forward"})
        over = s.overlay
        if over is not None:
            # the gesture count must fit the layer's duration
            cap = max(1, int((f / FPS - 1.0) / 0.6))
            over = Segment(**{**over.__dict__, "frames": f, "count": min(over.count, cap)})
        if s.action in _COUNTED:
            per = {"raise_arms": 1.3, "bow": 1.4, "squat": 1.2, "kick": 1.0, "jump": 0.85, "jump_forward": 0.95,
                   "jumping_jacks": 1.25, "hop": 0.7}.get(s.action, 0.45)
            pad = 1.0 if s.action == "hop" else 0.3
            cap = max(1, int((f / FPS - pad) / per))
            s = Segment(**{**s.__dict__, "count": min(s.count, cap)})
        out.append(Segment(**{**s.__dict__, "frames": f, "overlay": over}))
    program = Program(segments=tuple(out), style=style, style_strength=float(rng.uniform(0.85, 1.1)) if style != "none" else 1.0,
                      person=random_person(rng), blend=int(rng.integers(6, 11)), seed=int(rng.integers(2**31)))
    return program, held_templates
