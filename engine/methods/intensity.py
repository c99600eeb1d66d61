"""A prompt said with the corpus's intensity word for one of its actions ("a person jumps" -> "a person jumps high").

Emphasis in "intensity" mode (``moattn edit emphasize --mode intensity``) guides the edited motion towards the
prompt said this way: the corpus scales an action's size by these words (``engine.synth.grammar.INTENSITY_WORDS``:
a "high" jump has 1.6x a normal one's intensity, "a little" 0.55x), and the model follows them
(``moattn bench --intensity``). The word goes at the end of the action's own clause, where the corpus's captions put
it ("a person walks forward then jumps twice" -> "... then jumps twice high"; "a person jumps and waves" ->
"a person jumps high and waves").
"""
from __future__ import annotations

import re

from engine.intent import INTENSITY_PHRASES, action_of_word, intensity_table
from engine.synth.grammar import INTENSITY_WORDS

#: words that end a clause: the intensity word goes before the first of them after the action's verb
_CLAUSE_END = re.compile(r",|;|\.|\b(?:then|and|while|after|before|followed)\b", re.IGNORECASE)
LEVELS = ("high", "a little")
#: the intensity words a clause may already say, longest first (they are replaced, not added to)
_INTENSITY_PHRASES = re.compile(r"\s*\b(?:" + "|".join(re.escape(p) for p in sorted(
    {p for levels in INTENSITY_WORDS.values() for phrases in levels.values() for p in phrases} | set(INTENSITY_PHRASES),
    key=len, reverse=True)) + r")\b", re.IGNORECASE)


def scales(word: str) -> bool:
    """Does the corpus scale the action ``word`` names ("jumps": yes; "punches", "walks": no)?"""
    action = action_of_word(word)
    return action is not None and intensity_table(action) is not None


def intensity_word(word: str, level: str) -> str:
    """The corpus's first ``level`` word ("high" | "a little") for the action ``word`` names ("jumps" -> "high",
    "waves" -> "energetically"). A clear error for a word whose action the corpus does not scale."""
    if level not in LEVELS:
        raise ValueError(f"intensity level must be one of {', '.join(LEVELS)}, got {level!r}")
    action = action_of_word(word)
    table = intensity_table(action) if action is not None else None
    if table is None:
        scaled = "jumps, hops, kicks, squats, bows and waves"
        raise ValueError(f"intensity mode needs a verb whose size the corpus scales ({scaled}); "
                         f"{word!r} has no intensity word")
    return table[level][0]


def with_intensity(prompt: str, word: str, *, level: str, occurrence: int = 0) -> str:
    """``prompt`` with ``word``'s action said at ``level``: the corpus's intensity word added at the end of the clause
    of the ``occurrence``-th ``word`` (at the prompt's end where the word is not written as such, e.g. a typo the
    tokenizer read)."""
    adverb = intensity_word(word, level)
    found = list(re.finditer(rf"\b{re.escape(word)}\b", prompt, re.IGNORECASE))
    if occurrence < len(found):
        after = found[occurrence].end()
        end = _CLAUSE_END.search(prompt, after)
        cut = end.start() if end is not None else len(prompt.rstrip())
    else:
        cut = len(prompt.rstrip())
    start = found[occurrence].end() if occurrence < len(found) else 0
    clause = _INTENSITY_PHRASES.sub("", prompt[start:cut])  # "jumps a little" said high: not "a little high"
    head, tail = (prompt[:start] + re.sub(r"\s+", " ", clause)).rstrip(), prompt[cut:]
    return f"{head} {adverb}" + (tail if tail.startswith((",", ";", ".")) or not tail else f" {tail.lstrip()}")
