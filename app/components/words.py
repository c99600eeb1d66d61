"""A prompt's words as chips (unknown ones flagged) and what the prompt asks for: every prompt box shows these."""
from __future__ import annotations

import html

from engine.intent import parse_intent


def word_chips(words: list[str], unknown: list[str], read_as: dict[str, str] | None = None) -> str:
    """A prompt's words as chips, unknown ones flagged (with ``WORD_CSS``); shared by every prompt box.
    ``read_as``: typed words the model reads as another form of a known word ("jump" -> "jumps")."""
    if not words:
        return '<span class="prompt-empty">type a prompt</span>'
    bad, read_as = set(unknown), read_as or {}

    def chip(w: str) -> str:
        if w in bad:
            return f'<span class="word-unknown" title="not in the vocabulary">{html.escape(w)}</span>'
        if w in read_as:
            return f'<span class="word-known" title="read as {html.escape(read_as[w])}">{html.escape(w)}</span>'
        return f'<span class="word-known">{html.escape(w)}</span>'

    note = f'<div class="unknown-note">unknown: {", ".join(html.escape(w) for w in unknown)}</div>' if unknown else ""
    if read_as:
        forms = ", ".join(f"{html.escape(w)} → {html.escape(k)}" for w, k in read_as.items())
        note += f'<div class="read-as-note">read as: {forms}</div>'
    return f'<div class="prompt-chips">{" ".join(chip(w) for w in words)}</div>{note}'


def intent_line(prompt: str, unknown=()) -> str:
    """The parsed intent of a prompt: what the model is asked for ("wave (left side, ×2) → walk");
    ``unknown``: the prompt's words the model does not know."""
    if not prompt.strip():
        return ""
    intent = parse_intent(prompt)
    if not intent.segments and not set(intent.unplaced) & set(unknown):
        # no action of the lexicon, but the model knows every word (one trained on a real dataset reads words far
        # beyond the corpus lexicon): no line, rather than an amber "no action recognised" under its prompts
        return ""
    cls = "intent-partial" if not intent.complete else "intent-full"
    return f'<div class="{cls}" title="what this prompt asks for">asked for: {html.escape(intent.describe())}</div>'


WORD_CSS = """
.intent-full, .intent-partial { font-size: 12px; color: #335; margin-top: 2px; }
.intent-partial { color: #8a5a00; }
.word-unknown { background: #ffd6d6; color: #a00; border-bottom: 2px wavy #d00; padding: 0 3px; border-radius: 3px; }
.word-known { background: #e7f0ff; padding: 0 3px; border-radius: 3px; }
.unknown-note { color: #a00; font-size: 12px; margin-top: 2px; }
.read-as-note { color: #446; font-size: 12px; margin-top: 2px; }
"""
