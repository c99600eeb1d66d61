"""What a generated motion followed of its prompt: the parsed intent beside what the detectors saw.

``followed(intent, joints)`` gives a :class:`FollowReport`: per intended segment (a "while ..." gesture
is a part of its own), one row per attribute the prompt states (action, count, side, direction,
speed, intensity) with what was asked, what the detectors saw and a verdict, ✓ (followed), ✗ (not followed)
or ``not checked``; then the order of a sequence and its style. Its :meth:`FollowReport.describe`
is one line, a part per segment::

    asked: hop ×3 (left) · seen: jump ×2 ✗

The comparison is the adherence benchmark's own (``engine.evaluation.adherence.check_segments``).
A check is only made where its detector agreed with corpus ground truth on at least 95 % of the
corpus test motions (:func:`detector_reliability`, the benchmark's validation, run once per process);
every other stated attribute (and speed and style, which have no detector) reads ``not checked``,
and what the detector made of it is not shown: never a guess.

``moattn generate`` prints the line after writing the motion; the studio's Generate box shows it
under the result (``app.tabs.generate.followed``).
"""
from __future__ import annotations

import threading
from collections import Counter, defaultdict
from dataclasses import dataclass, field

import numpy as np

from engine.analysis.detectors import DETECTORS, Detected, MotionSignals, detect
from engine.evaluation.adherence import Reliability, check_order, check_segments, reliability, validate
from engine.intent import COUNTED_ACTIONS, Intent, IntentSegment, parse_intent
from engine.synth.program import FPS

FOLLOWED = "\u2713"  # ✓
MISSED = "\u2717"  # ✗
NOT_CHECKED = "not checked"
VALIDATION_MOTIONS = 1000  # corpus test motions the detectors are validated on (as `moattn bench --adherence`)
# a direction a prompt states that the action's own detector already requires ("kicks forward": a kick is a foot
# raised in front), so it is not a check of its own
_IMPLIED_DIRECTION = {"kick": "forward", "punch": "forward", "jump_forward": "forward",
                      "walk_backward": "backward"}
_NOT_INSTEAD = ("stand",)  # a gesture stands on still legs: "seen: stand" says nothing about what was asked

_lock = threading.Lock()
_reliable: dict[int, Reliability] = {}


def detector_reliability(motions: int = VALIDATION_MOTIONS) -> Reliability:
    """(attribute, action) -> whether that check agrees with corpus ground truth (>= 95 %, the adherence
    benchmark's validation on ``motions`` corpus test motions). Computed once per process (a few seconds)."""
    with _lock:
        if motions not in _reliable:
            _reliable[motions] = reliability(validate(motions=motions))
        return _reliable[motions]


@dataclass(frozen=True)
class FollowRow:
    """One stated attribute of one part: what was asked, what was seen, and the verdict."""

    attribute: str  # action | count | side | direction | speed | intensity | order | style
    asked: str
    seen: str  # "" when not checked (what an unreliable detector read is not shown)
    verdict: str  # FOLLOWED | MISSED | NOT_CHECKED

    def to_json(self) -> dict:
        return {"attribute": self.attribute, "asked": self.asked, "seen": self.seen, "verdict": self.verdict}


@dataclass(frozen=True)
class FollowPart:
    """One intended segment (or a "while ..." gesture) against the motion."""

    asked: str  # "hop ×3 (left)"
    seen: str  # "jump ×2", "hop ×3 (left)", "no hop", "not checked"
    rows: tuple[FollowRow, ...]
    overlay: str = ""  # a gesture made while another action: that action ("walk")

    @property
    def verdict(self) -> str:
        verdicts = [r.verdict for r in self.rows]
        if MISSED in verdicts:
            return MISSED
        return FOLLOWED if FOLLOWED in verdicts else NOT_CHECKED

    @property
    def not_checked(self) -> tuple[str, ...]:
        """Stated attributes left unchecked (all of them: the part's verdict says so)."""
        return tuple(r.attribute for r in self.rows if r.verdict == NOT_CHECKED)

    @property
    def asked_line(self) -> str:
        """What was asked, a gesture with the action it is made during ("wave while walking")."""
        return f"{self.asked} while {_gerund(self.overlay)}" if self.overlay else self.asked

    def describe(self) -> str:
        asked = self.asked_line
        verdict = self.verdict
        if verdict == NOT_CHECKED:
            return f"asked: {asked} · seen: not checked"
        text = f"asked: {asked} · seen: {self.seen} {verdict}"
        if self.not_checked:
            text += f" ({', '.join(self.not_checked)} not checked)"
        return text

    def to_json(self) -> dict:
        return {"asked": self.asked, "seen": self.seen, "verdict": self.verdict, "overlay": self.overlay,
                "rows": [r.to_json() for r in self.rows]}


@dataclass(frozen=True)
class FollowReport:
    """What a motion followed of an intent: a part per segment, then the order and the style rows."""

    intent: Intent
    parts: tuple[FollowPart, ...]
    extra: tuple[FollowRow, ...] = field(default=())  # order (sequences), style (stated)

    @property
    def verdict(self) -> str:
        verdicts = [p.verdict for p in self.parts] + [r.verdict for r in self.extra]
        if MISSED in verdicts:
            return MISSED
        return FOLLOWED if FOLLOWED in verdicts else NOT_CHECKED

    @property
    def rows(self) -> list[tuple[int | None, FollowRow]]:
        """Every row with its part's index (None: order and style)."""
        return [(k, r) for k, p in enumerate(self.parts) for r in p.rows] + [(None, r) for r in self.extra]

    def describe(self) -> str:
        if not self.parts:
            return "asked: no action recognised · nothing checked"
        bits = [p.describe() for p in self.parts]
        for r in self.extra:
            if r.verdict == NOT_CHECKED:
                bits.append(f"{r.attribute} {r.asked}: not checked")
            else:
                bits.append(f"{r.attribute}: {r.seen} {r.verdict}")
        if self.intent.unplaced:
            bits.append(f"not read: {', '.join(self.intent.unplaced)}")
        return " | ".join(bits)

    def to_json(self) -> dict:
        return {"verdict": self.verdict, "line": self.describe(), "parts": [p.to_json() for p in self.parts],
                "extra": [r.to_json() for r in self.extra], "unplaced": list(self.intent.unplaced)}


# ------------------------------------------------------------------------------------------------ wording
def _label(action: str) -> str:
    return action.replace("_", " ")


_GERUNDS = {"walk": "walking", "stand": "standing", "side_step": "stepping sideways", "turn": "turning",
            "run": "running", "jog": "jogging"}  # the actions a "while ..." gesture is made during (engine.intent)


def _gerund(action: str) -> str:
    return _GERUNDS.get(action, _label(action))


def _asked(seg: IntentSegment) -> str:
    text = _label(seg.action)
    if seg.count is not None:
        text += f" \u00d7{seg.count}"
    bits = [b for b in (seg.side, _direction(seg), seg.speed, seg.intensity) if b]
    return text + (f" ({', '.join(bits)})" if bits else "")


def _direction(seg: IntentSegment) -> str | None:
    if seg.direction is None or _IMPLIED_DIRECTION.get(seg.action) == seg.direction:
        return None
    return seg.direction.replace("_", " ")


def _sides(events: tuple[Detected, ...]) -> str:
    """The sides the events were made with: "left", "left ×2, right ×1", or "none read"."""
    counts = Counter(e.side for e in events if e.side in ("left", "right", "both"))
    if not counts:
        return "none read"
    if len(counts) == 1:
        return next(iter(counts))
    return ", ".join(f"{s} \u00d7{n}" for s, n in counts.most_common())


def _ways(events: tuple[Detected, ...]) -> str:
    ways = list(dict.fromkeys(e.side.replace("_", " ") for e in events if e.side != "none"))
    return ", ".join(ways) if ways else "none read"


def _checked(reliable: Reliability, attribute: str, action: str) -> bool:
    return bool(reliable.get((attribute, action), False))


# ------------------------------------------------------------------------------------------------ report
def followed(intent: Intent | str, joints: np.ndarray | MotionSignals, fps: float = FPS, *,
             reliable: Reliability | None = None) -> FollowReport:
    """The intent (or a prompt, parsed) against a motion ((T, 22, 3) joints in metres, Y up, at ``fps``).
    ``reliable``: the checks to make (default: :func:`detector_reliability`)."""
    if isinstance(intent, str):
        intent = parse_intent(intent)
    reliable = detector_reliability() if reliable is None else reliable
    m = joints if isinstance(joints, MotionSignals) else MotionSignals(joints, fps=fps)
    if not intent.segments:
        return FollowReport(intent=intent, parts=())
    checks = check_segments(m, intent)
    overlays = {id(s.overlay): s.action for s in intent.segments if s.overlay is not None}
    totals: dict[str, int] = defaultdict(int)
    for c in checks:
        if c.segment.count is not None:
            totals[c.segment.action] += c.segment.count
    asked_actions = {c.segment.action for c in checks}
    parts = [_part(c, m, reliable, totals, asked_actions, overlay=overlays.get(id(c.segment), "")) for c in checks]
    extra = []
    mains = [s for s in intent.segments if s.action != "stand"]
    if len(mains) >= 2:
        extra.append(_order_row(checks, intent, reliable))
    if intent.style:
        extra.append(FollowRow("style", _label(intent.style), "", NOT_CHECKED))
    return FollowReport(intent=intent, parts=tuple(parts), extra=tuple(extra))


def _part(check, m: MotionSignals, reliable: Reliability, totals: dict[str, int], asked_actions: set[str], *,
          overlay: str) -> FollowPart:
    seg: IntentSegment = check.segment
    events: tuple[Detected, ...] = check.events
    result = check.result
    rows: list[FollowRow] = []

    def row(attribute: str, asked: str, seen: str) -> FollowRow:
        value = result.get(attribute)
        if value is None or not _checked(reliable, attribute, seg.action):
            return FollowRow(attribute, asked, "", NOT_CHECKED)
        return FollowRow(attribute, asked, seen, FOLLOWED if value else MISSED)

    found = bool(events)
    action_row = row("action", _label(seg.action), _label(seg.action) if found else f"no {_label(seg.action)}")
    rows.append(action_row)
    count_row = side_row = direction_row = intensity_row = None
    if seg.count is not None:
        n, total = len(events), totals[seg.action]
        asked = f"\u00d7{seg.count}" + (f" ({total} in all)" if total != seg.count else "")
        count_row = row("count", asked, f"\u00d7{n}" + (" in all" if total != seg.count else ""))
        rows.append(count_row)
    if seg.side is not None:
        side_row = row("side", seg.side, _sides(events))
        rows.append(side_row)
    if _direction(seg) is not None:
        direction_row = row("direction", _direction(seg), _ways(events))
        rows.append(direction_row)
    if seg.speed is not None:
        rows.append(FollowRow("speed", seg.speed, "", NOT_CHECKED))
    if seg.intensity is not None:  # how big the action is, against the corpus's levels (where validated)
        seen_level = check.intensity
        intensity_row = row("intensity", seg.intensity,
                            "" if seen_level is None else f"{seen_level[0]} {seen_level[1]:.2f} m")
        rows.append(intensity_row)

    # the part's "seen": the checked attributes only, in the asked wording's order
    if action_row.verdict == MISSED:
        seen = _seen_instead(m, reliable, asked_actions) or f"no {_label(seg.action)}"
    else:
        seen = _label(seg.action) if action_row.verdict == FOLLOWED else ""
        if count_row is not None and count_row.verdict != NOT_CHECKED:
            seen = f"{seen} {count_row.seen}".strip()
        bits = [r.seen for r in (side_row, direction_row, intensity_row) if r is not None and r.verdict != NOT_CHECKED]
        if bits:
            seen = f"{seen} ({', '.join(bits)})".strip()
        seen = seen or NOT_CHECKED
    return FollowPart(asked=_asked(seg), seen=seen, rows=tuple(rows), overlay=overlay)


def _seen_instead(m: MotionSignals, reliable: Reliability, asked_actions: set[str], limit: int = 3) -> str:
    """What the motion does instead of a missing action: other actions whose detectors were validated
    ("jump ×2, walk"), in the order they happen; "" when none."""
    found = []
    for action in DETECTORS:
        if action in asked_actions or action in _NOT_INSTEAD or not _checked(reliable, "action", action):
            continue
        if action in ("run", "jog") and asked_actions & {"run", "jog"}:
            continue  # a run asked as a jog (or the reverse) is the same gait to the detectors
        events = detect(m, action)
        if not events:
            continue
        text = _label(action)
        if action in COUNTED_ACTIONS and _checked(reliable, "count", action):
            text += f" \u00d7{len(events)}"
        found.append((events[0].frame, text))
    return ", ".join(text for _, text in sorted(found)[:limit])


def _order_row(checks, intent: Intent, reliable: Reliability) -> FollowRow:
    mains = [c for c in checks if any(c.segment is s for s in intent.segments) and c.segment.action != "stand"]
    asked = " \u2192 ".join(_label(c.segment.action) for c in mains)
    scored = _checked(reliable, "order", "*") and all(_checked(reliable, "action", c.segment.action) for c in checks)
    value = check_order(checks, intent) if scored else None
    if value is None:
        return FollowRow("order", asked, "", NOT_CHECKED)
    seen = " \u2192 ".join(_label(c.segment.action) for c in sorted(mains, key=lambda c: c.events[0].frame))
    return FollowRow("order", asked, seen, FOLLOWED if value else MISSED)


# ------------------------------------------------------------------------------------------------ prompt notes
def prompt_notes(tokenized) -> tuple[str, ...]:
    """What the model's reading of the prompt says it changed ("left out: stiffly", "read 'skips' as 'hops'"):
    ``TokenizedPrompt.notes()`` where the tokenizer gives them, else nothing."""
    notes = getattr(tokenized, "notes", None)
    if notes is None:
        return ()
    try:
        values = notes() if callable(notes) else notes
        return tuple(str(n) for n in values if str(n).strip())
    except Exception:  # notes are a courtesy: never the reason a generation fails
        return ()


#: a report that could not be read counts as missing more than any motion that could
UNREADABLE = 1_000


def misses(report: FollowReport | str) -> int:
    """How many checked attributes a motion did not follow (✗ rows); a report that could not be read (a string)
    counts :data:`UNREADABLE`."""
    if isinstance(report, str):
        return UNREADABLE
    return sum(r.verdict == MISSED for _, r in report.rows)


def best_try(reports) -> int:
    """Of several tries at one prompt, the one to keep: the first that followed every checked attribute, else the
    one with the fewest misses (the earliest of those). ``reports``: their follow reports, in the order tried."""
    reports = list(reports)
    if not reports:
        raise ValueError("no tries to choose from")
    counts = [misses(r) for r in reports]
    return counts.index(min(counts))


def take_tries(make, *, seed: int, tries: int, report) -> tuple[int, list]:
    """Up to ``tries`` takes from ``seed`` on (``make(seed)`` -> a take; ``report(take)`` -> its follow report),
    stopping at the first that followed every checked attribute. Returns (the index of the take to keep, by
    :func:`best_try`; the takes made). What ``moattn generate --tries`` and the studio's Generate box run."""
    takes = []
    for k in range(tries):
        takes.append(make(seed + k))
        if misses(report(takes[-1])) == 0:
            break
    return best_try(report(t) for t in takes), takes


def follow_generated(prompt: str, joints: np.ndarray, tokenized=None,
                     fps: float = FPS) -> tuple[FollowReport | str, tuple[str, ...]]:
    """(the report, or why the motion could not be read; the prompt's notes) of a generated motion: what
    ``moattn generate`` prints and the studio's Generate box shows."""
    notes = prompt_notes(tokenized)
    # the intent of what the model was asked: words it left out are not asked for, typos and words read by
    # meaning are read as it read them
    intent = parse_intent(prompt, tokenized) if hasattr(tokenized, "left_out") else prompt
    try:
        return followed(intent, joints, fps), notes
    except ValueError as exc:  # a motion too short or broken to read: say so, the motion itself stands
        return f"could not be read ({exc})", notes
