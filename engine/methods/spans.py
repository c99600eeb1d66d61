"""Frame spans: the [start, end) intervals an edit touches, one or several (grounding a word to four chosen jumps).

Torch-free: the CLI parses ``--frames 10:20,40:50`` with it before loading anything, the Edit tab checks a dragged
span with it, and the grounding edit turns the spans into its per-frame mask.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

Span = tuple[int, int]

EXAMPLE = "10:20,40:50"


def _text(span: Span) -> str:
    return f"{span[0]}:{span[1]}"


def spans_text(spans: Iterable[Span]) -> str:
    """((10, 20), (40, 50)) -> '10:20,40:50' (what ``--frames`` takes)."""
    return ",".join(_text(s) for s in spans)


def parse_spans(text: str) -> tuple[Span, ...]:
    """'10:20' or '10:20,40:50,...' -> ((10, 20), (40, 50), ...), sorted and checked (see :func:`check_spans`)."""
    parts = [p.strip() for p in str(text).split(",")]
    if not any(parts):
        raise ValueError(f"no frame span given: write START:END, several separated by commas (e.g. {EXAMPLE})")
    spans = []
    for part in parts:
        if not part:
            raise ValueError(f"an empty frame span in {text!r}: write START:END, several separated by commas "
                             f"(e.g. {EXAMPLE})")
        pieces = part.split(":")
        try:
            if len(pieces) != 2:
                raise ValueError
            spans.append((int(pieces[0]), int(pieces[1])))
        except ValueError:
            raise ValueError(f"{part!r} is not a frame span START:END (e.g. {EXAMPLE})") from None
    return check_spans(spans)


def as_spans(frames) -> tuple[Span, ...]:
    """One span ``(start, end)`` or several ``((start, end), ...)`` -> a tuple of spans (not yet checked)."""
    if frames is None:
        return ()
    items = list(frames)
    if len(items) == 2 and all(isinstance(v, (int, float)) or hasattr(v, "__index__") for v in items):
        items = [items]  # a single (start, end)
    out = []
    for s in items:
        try:
            start, end = s
        except (TypeError, ValueError):
            raise ValueError(f"a frame span is (start, end), got {s!r}") from None
        if int(start) != start or int(end) != end:
            raise ValueError(f"frame spans are whole frames, got {start}:{end}")
        out.append((int(start), int(end)))
    return tuple(out)


def check_spans(spans: Sequence[Span], *, frames: int | None = None) -> tuple[Span, ...]:
    """Spans sorted by start; each 0 <= start < end (<= ``frames`` when given), none overlapping another."""
    out = sorted(as_spans(spans))
    for start, end in out:
        if not 0 <= start < end:
            raise ValueError(f"the frame span {start}:{end} must satisfy 0 <= start < end")
        if frames is not None and end > frames:
            raise ValueError(f"the frame span {start}:{end} runs past the motion's end: it has {frames} frames "
                             f"(0:{frames})")
    for a, b in zip(out, out[1:]):
        if b[0] < a[1]:
            raise ValueError(f"the frame spans {_text(a)} and {_text(b)} overlap: give separate spans")
    return tuple(out)


def spans_mask(spans: Sequence[Span], frames: int) -> tuple[bool, ...]:
    """Per frame: inside one of the (checked) spans."""
    spans = check_spans(spans, frames=frames)
    return tuple(any(a <= i < b for a, b in spans) for i in range(frames))


def mask_spans(mask: Sequence[bool]) -> tuple[Span, ...]:
    """The runs of True of a per-frame mask as [start, end) spans."""
    out, start = [], None
    for i, on in enumerate(list(mask) + [False]):
        if on and start is None:
            start = i
        elif not on and start is not None:
            out.append((start, i))
            start = None
    return tuple(out)
