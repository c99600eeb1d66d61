"""A prompt's words as chips (as the engine reads them, with its notes) and what the prompt asks for: every prompt box
shows these."""
from __future__ import annotations

import html

from engine.intent import parse_intent


def word_chips(reading) -> str:
    """A prompt's words as chips, as the engine reads them (``reading``: an ``app.generation.PromptReading``), with
    its notes below ("read 'guy' as 'man'", "left out: over") or its one-line refusal; shared by every prompt box
    (with ``WORD_CSS``)."""
    if not reading.words:
        return '<span class="prompt-empty">type a prompt</span>'
    left_out, read_as, read_by = set(reading.left_out), reading.read_as, reading.read_by

    def chip(w: str) -> str:
        if w in left_out:
            return f'<span class="word-left-out" title="left out: the model does not know it">{html.escape(w)}</span>'
        if w in read_as:
            cls = "word-known" if read_by.get(w) == "form" else "word-read"
            return f'<span class="{cls}" title="read as {html.escape(read_as[w])}">{html.escape(w)}</span>'
        return f'<span class="word-known">{html.escape(w)}</span>'

    return f'<div class="prompt-chips">{" ".join(chip(w) for w in reading.words)}</div>{prompt_notes(reading)}'


def prompt_notes(reading) -> str:
    """HTML of what the engine will do with a prompt's words it does not know (its notes, one line each), or its
    one-line refusal; '' when there is nothing to say."""
    if reading.error:
        return f'<div class="prompt-refused">{html.escape(reading.error)}</div>'
    return "".join(f'<div class="prompt-note">{html.escape(n)}</div>' for n in reading.notes)


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
    text = intent.describe()
    if len(text) <= MAX_INTENT_CHARS:
        return f'<div class="{cls}" title="what this prompt asks for">asked for: {html.escape(text)}</div>'
    # a long prompt's intent is one line, opened on demand (a 2,000-character prompt filled the sidebar with ~30)
    short = text[:MAX_INTENT_CHARS].rsplit(" ", 1)[0].rstrip(" →,")
    steps = text.count("→") + 1
    return (f'<details class="{cls} intent-long"><summary title="what this prompt asks for: open for all of it">'
            f'asked for: {html.escape(short)} … ({steps} actions in all)</summary>'
            f'<div class="intent-rest">{html.escape(text)}</div></details>')


#: the longest intent shown in full; a longer one is cut to a line that opens to the rest
MAX_INTENT_CHARS = 90


WORD_CSS = """
.intent-full, .intent-partial { font-size: 12px; color: #335; margin-top: 2px; }
.intent-partial { color: #8a5a00; }
.intent-long summary { cursor: pointer; }
.intent-rest { max-height: 7.5em; overflow-y: auto; border-left: 2px solid #dde; padding-left: 6px; margin-top: 2px; }
.prompt-chips { max-height: 5.6em; overflow-y: auto; }
.word-left-out { background: #f1f1f1; color: #777; text-decoration: line-through; padding: 0 3px; border-radius: 3px; }
.word-read { background: #fff3d6; border-bottom: 1px dashed #b80; padding: 0 3px; border-radius: 3px; }
.word-known { background: #e7f0ff; padding: 0 3px; border-radius: 3px; }
.prompt-note { color: #7a5200; font-size: 12px; margin-top: 2px; }
.prompt-refused { color: #a00; background: #ffecec; border: 1px solid #f3b3b3; padding: 1px 6px; border-radius: 4px;
  font-size: 12px; margin-top: 2px; }
"""
