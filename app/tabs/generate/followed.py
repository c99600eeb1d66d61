"""The Generate box's "followed" lines: what the shown motion followed of its prompt (engine.analysis.followed).

One line per part of the prompt ("asked: hop ×3 (left) · seen: jump ×2 ✗"), ✓ in green, ✗ in red and
"not checked" in grey; the tokenized prompt's notes ("left out: stiffly") under them. Only a motion
generated in the Generate box has them: any other motion shown clears them.
"""
from __future__ import annotations

import html

from engine.analysis.followed import FOLLOWED, MISSED, NOT_CHECKED, FollowPart, FollowReport, FollowRow

FOLLOWED_CSS = """
.followed { font-size: 12px; color: #223; margin: 2px 0 4px 0; line-height: 1.45; }
.followed-title { font-weight: 600; color: #335; }
.followed-part { margin-left: 2px; }
.followed-yes { color: #1a7f37; font-weight: 700; }
.followed-no { color: #c62828; font-weight: 700; }
.followed-unchecked { color: #8a8a8a; }
.followed-notes { color: #555; font-style: italic; }
"""

_CLASS = {FOLLOWED: "followed-yes", MISSED: "followed-no", NOT_CHECKED: "followed-unchecked"}


def _mark(verdict: str) -> str:
    return f'<span class="{_CLASS[verdict]}">{html.escape(verdict)}</span>'


def _details(rows) -> str:
    """The per-attribute rows, for the line's tooltip."""
    out = []
    for r in rows:
        seen = r.seen if r.verdict != NOT_CHECKED else NOT_CHECKED
        out.append(f"{r.attribute}: asked {r.asked}, seen {seen} {r.verdict if r.verdict != NOT_CHECKED else ''}")
    return html.escape("\n".join(s.strip() for s in out), quote=True)


def _part_html(part: FollowPart) -> str:
    body = f"asked: {html.escape(part.asked_line)} · seen: "
    if part.verdict == NOT_CHECKED:
        body += _mark(NOT_CHECKED)
    else:
        body += f"{html.escape(part.seen)} {_mark(part.verdict)}"
        if part.not_checked:
            body += f' <span class="followed-unchecked">({html.escape(", ".join(part.not_checked))} not checked)</span>'
    return f'<div class="followed-part" title="{_details(part.rows)}">{body}</div>'


def _extra_html(row: FollowRow) -> str:
    if row.verdict == NOT_CHECKED:
        body = f'{html.escape(row.attribute)} {html.escape(row.asked)}: {_mark(NOT_CHECKED)}'
    else:
        body = f"{html.escape(row.attribute)}: asked {html.escape(row.asked)} · seen: {html.escape(row.seen)} " \
               f"{_mark(row.verdict)}"
    return f'<div class="followed-part">{body}</div>'


def followed_html(follow, notes=()) -> str:
    """HTML of a motion's report (a FollowReport, or why it could not be read) and its prompt's notes; "" for
    neither."""
    if follow is None and not notes:
        return ""
    lines = []
    if isinstance(follow, FollowReport):
        if not follow.parts:
            lines.append(f'<div class="followed-part">{_mark(NOT_CHECKED)}: no action of the lexicon recognised'
                         "</div>")
        lines += [_part_html(p) for p in follow.parts]
        lines += [_extra_html(r) for r in follow.extra]
        if follow.intent.unplaced:
            lines.append(f'<div class="followed-part followed-unchecked">not read: '
                         f'{html.escape(", ".join(follow.intent.unplaced))}</div>')
    elif follow is not None:
        lines.append(f'<div class="followed-part followed-unchecked">{html.escape(str(follow))}</div>')
    if notes:
        lines.append(f'<div class="followed-notes">{html.escape("; ".join(notes))}</div>')
    title = '<div class="followed-title" title="the prompt as parsed, beside what the motion detectors saw; a ' \
            'detector not validated on corpus motions for an attribute leaves it not checked">followed:</div>'
    return f'<div class="followed">{title}{"".join(lines)}</div>'


def item_followed_html(item) -> str:
    """The report of a shown motion item (generated in the Generate box), "" for any other motion."""
    if item is None:
        return ""
    return followed_html(item.info.get("followed"), item.info.get("notes", ()))
