"""Does a motion do what its prompt says? Intent (``engine.intent``) against detectors
(``engine.analysis.detectors``), validated on corpus ground truth before they score a model.

Attributes, each True (matches), False (does not) or None (the prompt does not state it, or its
detector was found unreliable on ground truth):

- ``action``: every intended action (and "while ..." gesture) is detected in the motion;
- ``count``: the number of detected events of each counted action equals the prompt's count;
- ``side``: the detected events are made with the side the prompt names ("both": both sides);
- ``direction``: a walk/run/jog travels the stated way (forward, curving left/right, a circle),
  a turn turns the stated way, a side step goes the stated side;
- ``intensity``: a jump, hop, kick or wave said "high" or "a little" reads at that level
  (``engine.analysis.action_size.intensity_seen``: its size against the corpus's levels);
- ``order``: the segments' actions happen in the prompt's order.

``validate`` runs the same check on corpus motions with their true intent: the agreement it
reports per attribute and per action is how often the detectors read ground truth correctly.
Checks under 95 % agreement are listed as unreliable and left out of every score.
"""
from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from engine.analysis.action_size import intensity_seen
from engine.analysis.detectors import Detected, MotionSignals, detect
from engine.intent import COUNTED_ACTIONS, SIDES_OF, Intent, IntentSegment
from engine.synth.intents import program_for_intent
from engine.synth.program import Program, Segment

ATTRIBUTES = ("action", "count", "side", "direction", "intensity", "order")
RELIABLE = 0.95  # agreement with ground truth a check needs to be scored
MIN_VALIDATION = 5  # fewer ground-truth cases than this: the check cannot be called reliable
DIRECTED = ("walk", "run", "jog", "turn", "side_step")

Reliability = dict[tuple[str, str], bool]  # (attribute, action) -> reliable


def _same_action(a: str, b: str) -> bool:
    return a == b or {a, b} == {"run", "jog"}


def _direction_matches(wanted: str, got: str) -> bool:
    if wanted == "circle":
        return got.startswith("circle")
    return wanted == got


def _side_matches(wanted: str, events: list[Detected]) -> bool:
    sides = [e.side for e in events if e.side in ("left", "right", "both")]
    if not sides:
        return False
    if wanted == "both":
        return "both" in sides or {"left", "right"} <= set(sides)
    return sum(s == wanted for s in sides) > len(sides) / 2


@dataclass(frozen=True)
class SegmentCheck:
    """One intended segment against the motion: its events and per-attribute result."""

    segment: IntentSegment
    events: tuple[Detected, ...]
    result: dict  # attribute -> bool | None
    intensity: tuple[str, float] | None = None  # the level and size read, where the prompt states an intensity


def check_segments(joints: np.ndarray | MotionSignals, intent: Intent) -> list[SegmentCheck]:
    """Per intended segment (overlays as their own entries), the events found and the checks."""
    m = joints if isinstance(joints, MotionSignals) else MotionSignals(joints)
    flat: list[IntentSegment] = []
    for seg in intent.segments:
        flat.append(seg)
        if seg.overlay is not None:
            flat.append(seg.overlay)
    # a counted action stated in several segments: its events are shared, so counts add up
    totals: dict[str, int] = defaultdict(int)
    for seg in flat:
        if seg.count is not None:
            totals[seg.action] += seg.count
    stated_count = {a: all(s.count is not None for s in flat if s.action == a) for a in totals}
    out = []
    cache: dict[str, list[Detected]] = {}
    for seg in flat:
        if seg.action not in cache:
            cache[seg.action] = detect(m, seg.action)
        events = cache[seg.action]
        result: dict = {"action": bool(events)}
        result["count"] = (len(events) == totals[seg.action]) if seg.count is not None and \
            stated_count.get(seg.action) and seg.action in COUNTED_ACTIONS else None
        result["side"] = _side_matches(seg.side, events) if seg.side is not None else None
        if seg.direction is not None and seg.action in DIRECTED:
            result["direction"] = any(_direction_matches(seg.direction, e.side) for e in events)
        else:
            result["direction"] = None
        seen = intensity_seen(m.joints, seg.action, style=intent.style, events=[e.frame for e in events]) \
            if seg.intensity is not None else None
        result["intensity"] = None if seen is None else seen[0] == seg.intensity
        out.append(SegmentCheck(segment=seg, events=tuple(events), result=result, intensity=seen))
    return out


def check_order(checks: list[SegmentCheck], intent: Intent) -> bool | None:
    """The main segments' first events in the prompt's order (standing is everywhere: not ordered)."""
    mains = [c for c in checks if any(c.segment is s for s in intent.segments) and c.segment.action != "stand"]
    if len(mains) < 2 or len({c.segment.action for c in mains}) < len(mains):
        return None
    if not all(c.events for c in mains):
        return None  # a missing action is the action check's failure; order is judged among those found
    firsts = [c.events[0].frame for c in mains]
    return all(a < b for a, b in zip(firsts, firsts[1:]))


def check_motion(joints: np.ndarray, intent: Intent, *, reliable: Reliability | None = None) -> dict:
    """Per attribute: True / False / None for a motion against an intent (see the module docstring).
    ``reliable`` (from :func:`validate`) drops checks whose detector failed on ground truth."""
    checks = check_segments(joints, intent)
    out: dict = {}
    for attr in ATTRIBUTES[:-1]:
        vals = [c.result[attr] for c in checks
                if c.result[attr] is not None and (reliable is None or reliable.get((attr, c.segment.action), False))]
        out[attr] = all(vals) if vals else None
    # order is judged on detected actions: every action check and the order check itself must be reliable
    scored = reliable is None or (reliable.get(("order", "*"), False) and
                                  all(reliable.get(("action", c.segment.action), False) for c in checks))
    out["order"] = check_order(checks, intent) if scored else None
    return out


# ----------------------------------------------------------------------------------- ground truth
def intent_of_program(program: Program, text: str = "") -> Intent:
    """The full intent a corpus program realises (every attribute stated)."""
    def seg_intent(s: Segment) -> IntentSegment:
        direction = None
        if s.action in ("walk", "run", "jog"):
            direction = s.direction if s.direction != "none" else None
        elif s.action == "side_step":
            direction = "left" if s.direction != "right" else "right"
        elif s.action == "turn":
            direction = "around" if abs(s.turn) > 2.5 else ("left" if s.turn > 0 else "right")
        side = s.side if s.side in SIDES_OF.get(s.action, ()) else None
        if s.action == "raise_arms" and s.side == "none":
            side = "both"
        return IntentSegment(action=s.action, count=s.count if s.action in COUNTED_ACTIONS else None, side=side,
                             direction=direction,
                             speed=s.speed_word if s.speed_word in ("slowly", "quickly") else None,
                             intensity=s.intensity_word if s.intensity_word in ("high", "a little") else None,
                             overlay=seg_intent(s.overlay) if s.overlay is not None else None)

    return Intent(text=text, segments=tuple(seg_intent(s) for s in program.segments),
                  style=program.style if program.style != "none" else None)


def ground_truth_motion(intent: Intent, seed: int) -> np.ndarray:
    """Corpus joints (T, 22, 3) of a program realising ``intent`` (a few redraws if it does not fit)."""
    from engine.synth.corpus import make_sample

    rng = np.random.default_rng([seed, 7])
    last: Exception | None = None
    for _ in range(6):
        try:
            program = program_for_intent(intent, rng)
            return make_sample(program, captions=[intent.text], with_features=False).joints
        except ValueError as exc:  # repetitions that do not fit their duration: draw again
            last = exc
    raise ValueError(f"could not realise {intent.text!r} as a corpus motion: {last}")


# ----------------------------------------------------------------------------------- validation
def validate(*, motions: int = 500, split: str = "test", start: int = 0,
             log: Callable[[str], None] | None = None) -> dict:
    """Agreement of every check with corpus labels: per attribute (all actions pooled), per
    (attribute, action), and the specificity of the action checks (an action absent from a motion
    must not be detected). Returns ``{"agreement", "per_action", "absent", "reliable", "motions"}``."""
    from engine.synth import Corpus
    from engine.synth.program import ACTIONS

    corpus = Corpus(split)
    hits: dict[tuple[str, str], list[bool]] = defaultdict(list)
    absent: dict[str, list[bool]] = defaultdict(list)
    for k in range(motions):
        sample = corpus.sample(start + k, with_features=False)
        intent = intent_of_program(sample.program, sample.captions[0])
        m = MotionSignals(sample.joints)
        checks = check_segments(m, intent)
        for c in checks:
            for attr in ATTRIBUTES[:-1]:
                if c.result[attr] is not None and attr != "intensity":
                    hits[(attr, c.segment.action)].append(bool(c.result[attr]))
        # the intensity reading against every segment's true level, normal ones too: a reading that calls a
        # normal jump "high" must not pass for a check of "jumps high"
        for part in (p for seg in sample.program.segments for p in (seg, seg.overlay) if p is not None):
            found = next((c for c in checks if c.segment.action == part.action), None)
            seen = intensity_seen(m.joints, part.action, style=intent.style,
                                  events=[e.frame for e in found.events] if found is not None else None)
            if seen is not None:
                hits[("intensity", part.action)].append(seen[0] == part.intensity_word)
        order = check_order(checks, intent)
        if order is not None:
            hits[("order", "*")].append(order)
        present = {c.segment.action for c in checks}
        if present & {"punch", "wave", "clap", "raise_arms", "bow"} & {s.action for s in sample.program.segments}:
            present.add("stand")  # the corpus's standing gestures stand on still legs
        others = [a for a in ACTIONS if not any(_same_action(a, p) for p in present)]
        # every absent action once per motion would be slow; a rotating pair of them is enough
        for a in (others[k % len(others)], others[(k * 7 + 3) % len(others)]):
            absent[a].append(not detect(m, a))
        if log is not None and (k + 1) % 100 == 0:
            log(f"validated {k + 1}/{motions} corpus motions")
    per_action = {f"{attr}:{action}": {"agreement": float(np.mean(v)), "n": len(v)}
                  for (attr, action), v in sorted(hits.items())}
    agreement = {}
    for attr in ATTRIBUTES:
        pooled = [x for (a, _), v in hits.items() if a == attr for x in v]
        agreement[attr] = float(np.mean(pooled)) if pooled else None
    absent_rate = {a: {"agreement": float(np.mean(v)), "n": len(v)} for a, v in sorted(absent.items())}
    pooled_absent = [x for v in absent.values() for x in v]
    agreement["action_absent"] = float(np.mean(pooled_absent)) if pooled_absent else None
    reliable = {}
    for (attr, action), v in hits.items():
        ok = len(v) >= MIN_VALIDATION and np.mean(v) >= RELIABLE
        if attr == "action" and action in absent:
            ok = ok and np.mean(absent[action]) >= RELIABLE
        reliable[f"{attr}:{action}"] = bool(ok)
    return {"agreement": agreement, "per_action": per_action, "absent": absent_rate, "reliable": reliable,
            "motions": motions, "split": split}


def reliability(validation: dict) -> Reliability:
    return {tuple(k.split(":", 1)): v for k, v in validation["reliable"].items()}


def score(rows: Iterable[dict]) -> dict:
    """Totals over per-motion check dicts: per attribute, the share of applicable motions that match."""
    rows = list(rows)
    out = {}
    for attr in ATTRIBUTES:
        vals = [r[attr] for r in rows if r.get(attr) is not None]
        out[attr] = float(np.mean(vals)) if vals else None
        out[f"{attr}_n"] = len(vals)
    return out
