"""A prompt of several actions in order, cut into one prompt per action, as a person would say each alone.

``clause_prompts("a man waves, then kicks twice")`` gives ``("a man waves", "a man kicks twice")``: the subject of the
first clause is said again before the later ones. The cut is the intent parser's own reading
(:func:`engine.intent.parse_intent`): the prompt is split at its sequence marks ("then", "and then", "after that", ...),
commas and "and", pieces that name no action stay with the piece before them ("walks forward, slowly"), and the cut is
kept only where each piece reads as exactly one of the whole prompt's actions, in the prompt's order. Anything else
("claps after jumping", "walks while waving", "walks forward and turns left") is one clause: the whole prompt. After a
turn on the spot, a clause that goes "back" the way it came is said as the walk forward it is ("turns around, then walks
back" gives "a person walks forward" for its second clause: the corpus's "walks back" is a walk backwards).

Torch-free: the CLI, the studio and the benches plan a sequence with it before any model loads.
"""
from __future__ import annotations

import re
from functools import lru_cache

from engine import wordforms
from engine.intent import SEQUENCE_MARKS, as_return, parse_intent, says_return, turned_around

# where a prompt may be cut: a comma, a semicolon or a full stop, a sequence mark, or "and" (longest marks first)
_MARKS = sorted(SEQUENCE_MARKS + ("and",), key=len, reverse=True)
_CUT = re.compile(r"\s*[,;.]\s*(?:(?:" + "|".join(re.escape(m) for m in _MARKS) + r")\b\s*)?|\s+(?:"
                  + "|".join(re.escape(m) for m in _MARKS) + r")\b\s*", re.IGNORECASE)
# words that name who moves: a later clause that starts with one keeps its own subject, unless it is a pronoun ("...,
# then she waves": the first clause's subject is said instead, as a prompt of its own would say it)
_SUBJECT_WORDS = frozenset("a an the someone somebody person man woman".split())
_PRONOUNS = frozenset("he she they i we".split())
_PEOPLE = frozenset(("person", "man", "woman"))  # what a word for who moves means (engine.wordforms.MEANING)
_WHO_NOUNS = _SUBJECT_WORDS - {"a", "an", "the"} | frozenset("zombie robot chicken gorilla monkey ape soldier".split())


def _actions(text: str) -> tuple[str, ...]:
    return tuple(s.action for s in parse_intent(text).segments)


def _names_who(word: str) -> bool:
    """A word for who moves: the corpus's ("man", "someone", "zombie") or one read as one by meaning ("boxer",
    "grandpa"); not a determiner ("a zombie": the subject ends at "zombie", not at "a")."""
    return word.lower() in _WHO_NOUNS | _PRONOUNS or any(
        set(wordforms.MEANING.get(base, ())) & _PEOPLE for base in wordforms.base_forms(word.lower()))


def _subject(words: list[str]) -> list[str]:
    """The words of a clause before its first action word, up to the last that names who moves ("a tired old man" of
    "a tired old man walks ...", "a boxer" of "a boxer throws two punches")."""
    for k in range(len(words)):
        if _actions(" ".join(words[: k + 1])):
            who = [j for j in range(k) if _names_who(words[j])]
            return words[:who[-1] + 1] if who else words[:k]
    return []


@lru_cache(maxsize=256)
def clause_prompts(text: str) -> tuple[str, ...]:
    """The prompt's actions in time order, one prompt each; ``(text,)`` when it asks for one action or its order
    cannot be cut from the words (see the module docstring)."""
    text = " ".join(str(text).split())
    segments = parse_intent(text).segments
    whole = tuple(s.action for s in segments)
    if len(whole) < 2:
        return (text,)
    pieces: list[str] = []
    for piece in _CUT.split(text):
        piece = piece.strip(" ,;.")
        if not piece:
            continue
        if pieces and not _actions(piece):  # a piece with no action of its own: a modifier of the one before it
            pieces[-1] = f"{pieces[-1]}, {piece}"
        else:
            pieces.append(piece)
    if len(pieces) == len(whole):  # "turns around, then walks back": said alone, the return is a walk forward
        pieces = [as_return(p) if k and turned_around(segments[k - 1]) and says_return(p) else p
                  for k, p in enumerate(pieces)]
    if len(pieces) != len(whole) or any(_actions(p) != (a,) for p, a in zip(pieces, whole)):
        return (text,)
    subject = _subject(pieces[0].split()) or ["a", "person"]
    out = [pieces[0]]
    for piece in pieces[1:]:
        words = piece.split()
        own = _subject(words)
        if any(w.lower() in _SUBJECT_WORDS for w in own):
            out.append(piece)
        else:
            out.append(" ".join(subject + [w for w in own if w.lower() not in _PRONOUNS] + words[len(own):]))
    return tuple(out)
