"""What a prompt asks for: a parser from free text to the motion program it intends.

``parse_intent("a woman waves the left hand twice, then walks forward")`` gives two segments,
``wave (left, x2)`` and ``walk (forward)``, and the words it could not place. It reads the corpus
lexicon (``engine.synth.grammar``) plus the words people type for the same motions ("waving
hello", "strides", "3 times", "jumps on one leg"), in any inflection ("walk", "walked",
"walking"). Attributes a prompt does not state stay ``None``: "a person waves" asks for a wave
with either hand, and the adherence benchmark scores it that way.

The Generate tab shows :meth:`Intent.describe`; ``moattn bench --adherence`` scores motions
against :class:`Intent` (``engine.evaluation.adherence``).
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass, field, replace

from typing import TYPE_CHECKING

from engine import wordforms
from engine.synth.grammar import STYLE_PHRASES
from engine.synth.program import ACTIONS

if TYPE_CHECKING:
    from engine.text import TokenizedPrompt

COUNTED_ACTIONS = ("jump", "jump_forward", "hop", "jumping_jacks", "squat", "kick", "punch", "wave", "clap",
                   "raise_arms", "bow")
SIDES_OF = {"kick": ("left", "right"), "wave": ("left", "right", "both"), "hop": ("left", "right"),
            "punch": ("left", "right", "both"), "raise_arms": ("left", "right", "both")}  # sides a prompt may name

# ------------------------------------------------------------------------------------------------ lexicon
# Phrases in base form (lemmas, see :func:`lemma`), longest match wins. Each maps to an action.
ACTION_PHRASES: dict[str, tuple[str, ...]] = {
    "walk_backward": ("walk backward", "walk backwards", "walk back", "step backward", "step backwards",
                      "step back", "move backward", "move backwards", "back up", "backpedal"),
    "side_step": ("side step", "sidestep", "step sideways", "step to the side", "shuffle sideways",
                  "move sideways", "walk sideways", "shuffle to the side", "side shuffle", "strafe"),
    "jump_forward": ("jump forward", "jump forwards", "jump ahead", "leap forward", "leap forwards", "leap ahead",
                     "broad jump", "long jump"),
    "jumping_jacks": ("jump jack", "star jump", "do jump jack", "perform jump jack", "do star jump",
                      "perform star jump"),
    "hop": ("hop", "jump on one leg", "jump on one foot", "jump on the left leg", "jump on the right leg",
            "jump on the left foot", "jump on the right foot"),
    "walk": ("walk", "stroll", "pace", "stride", "march", "wander", "amble", "step", "move", "saunter", "trudge",
             "take a walk", "go for a walk"),
    "run": ("run", "sprint", "dash", "race", "rush", "hurry"),
    "jog": ("jog", "trot"),
    "turn": ("turn", "rotate", "spin", "pivot"),
    "jump": ("jump", "leap", "bounce", "spring", "jump up", "jump up and down", "jump in place"),
    "squat": ("squat", "squat down", "do a squat", "crouch down", "knee bend"),
    "kick": ("kick", "kick out", "do a kick"),
    "punch": ("punch", "throw a punch", "punch forward", "box", "jab", "strike"),
    "wave": ("wave", "wave hello", "wave goodbye", "wave hi", "greet"),
    "clap": ("clap", "clap the hand", "clap hand", "applaud", "clap his hand", "clap her hand"),
    "raise_arms": ("raise", "lift", "put up", "raise up", "lift up", "hold up", "throw up"),
    "bow": ("bow", "take a bow", "bend forward to bow", "bend forward", "bend over", "bend down"),
    "dance": ("dance", "dance from side to side", "do a little dance", "groove", "boogie", "sway"),
    "stand": ("stand still", "stand in place", "stay still", "stand", "stay", "idle", "wait", "remain still",
              "do nothing", "stand there"),
}
assert set(ACTION_PHRASES) == set(ACTIONS)

COUNT_PHRASES: dict[str, int] = {
    "once": 1, "one time": 1, "one": 1, "a single time": 1, "twice": 2, "two time": 2, "a couple of time": 2, "thrice": 3,
    "three time": 3, "four time": 4, "five time": 5, "1 time": 1, "2 time": 2, "3 time": 3, "4 time": 4,
    "5 time": 5, "two": 2, "three": 3, "four": 4, "five": 5, "a pair of": 2, "double": 2,
}
NUMBER_WORDS = {"1": "one", "2": "two", "3": "three", "4": "four", "5": "five", "6": "six", "7": "seven",
                "8": "eight", "9": "nine"}
SPEED_PHRASES: dict[str, str] = {
    "slowly": "slowly", "slow": "slowly", "at a slow pace": "slowly", "leisurely": "slowly", "gently": "slowly",
    "quickly": "quickly", "fast": "quickly", "rapidly": "quickly", "at a fast pace": "quickly", "quick": "quickly",
    "swiftly": "quickly", "briskly": "quickly", "hurriedly": "quickly",
}
INTENSITY_PHRASES = ("very high", "high", "a little", "slightly", "a tiny bit", "low", "deeply", "all the way down",
                     "energetically", "vigorously", "hard", "a bit", "deep")
# style phrases: the corpus's own (lemmatised at import) plus single words people use
STYLE_WORDS: dict[str, str] = {
    "zombie": "zombie", "chicken": "chicken", "robot": "robot", "robotically": "robot", "mechanically": "robot",
    "drunk": "drunk", "drunkenly": "drunk", "unsteadily": "drunk", "tipsy": "drunk", "gorilla": "gorilla",
    "monkey": "gorilla", "ape": "gorilla", "sad": "sad", "sadly": "sad", "gloomily": "sad", "dejectedly": "sad",
    "happy": "happy", "happily": "happy", "cheerfully": "happy", "joyfully": "happy", "proud": "proud",
    "proudly": "proud", "soldier": "proud", "old": "old", "elderly": "old", "tiredly": "old", "wearily": "old",
    "tired": "old", "sneakily": "crouched", "stealthily": "crouched", "sneak": "crouched", "crouch": "crouched",
    "crouching": "crouched",
}
DIRECTION_PHRASES: dict[str, str] = {
    "forward": "forward", "forwards": "forward", "ahead": "forward", "straight ahead": "forward",
    "straight": "forward", "backward": "backward", "backwards": "backward", "to the left": "left",
    "toward the left": "left", "towards the left": "left", "and turn left": "left", "curve left": "left",
    "left": "left", "to the right": "right", "toward the right": "right", "towards the right": "right",
    "and turn right": "right", "curve right": "right", "right": "right", "in a circle": "circle",
    "around in a circle": "circle", "in a circle to the left": "circle_left",
    "in a counterclockwise circle": "circle_left", "counterclockwise": "circle_left",
    "anticlockwise": "circle_left", "in a circle to the right": "circle_right",
    "in a clockwise circle": "circle_right", "clockwise": "circle_right", "around": "around",
    "all the way around": "around", "to face the other way": "around", "in a circle around": "circle",
}
LIMBS = {"hand": "arm", "arm": "arm", "fist": "arm", "leg": "leg", "foot": "leg"}
SEQUENCE_MARKS = ("and then", "then", "after that", "afterwards", "afterward", "followed by", "next", "finally",
                  "before", "later", "subsequently")
FILLER = frozenset(
    "a an the person someone somebody man woman human he she they it his her its their this that is are be do "
    "and with using use in on to up out of at by from we see clip motion show shows can seen here keep first "
    "while place spot one hello perform time also just again some people guy girl boy lady figure character "
    "whole body arm hand leg foot both over all way around down side air into there".split())

_SEPARATOR = "|"  # sequence boundary mark inside the token list
_IRREGULAR = {"ran": "run", "spun": "spin", "leapt": "leap", "did": "do", "done": "do", "stood": "stand",
              "threw": "throw", "took": "take", "feet": "foot", "went": "go", "does": "do", "is": "be", "are": "be",
              "was": "be", "sprang": "spring", "sprung": "spring", "knees": "knee"}


def _phrase_lemmas() -> set[str]:
    out: set[str] = set()
    tables = [p for ps in ACTION_PHRASES.values() for p in ps] + list(COUNT_PHRASES) + list(SPEED_PHRASES) + \
        list(INTENSITY_PHRASES) + list(STYLE_WORDS) + list(DIRECTION_PHRASES) + list(LIMBS) + list(SEQUENCE_MARKS)
    for phrase in tables:
        out.update(phrase.split())
    return out | set(FILLER)


_KNOWN = _phrase_lemmas()


def lemma(word: str) -> str:
    """The base form of an inflected word when that base is in the lexicon ("waving" -> "wave",
    "hopped" -> "hop", "punches" -> "punch"); otherwise the word itself."""
    if word in _KNOWN:
        return word
    if word in _IRREGULAR:
        return _IRREGULAR[word]
    candidates = []
    if word.endswith("ing") and len(word) > 4:
        stem = word[:-3]
        candidates += [stem, stem + "e"] + ([stem[:-1]] if len(stem) > 2 and stem[-1] == stem[-2] else [])
    if word.endswith("ed") and len(word) > 3:
        stem = word[:-2]
        candidates += [stem, word[:-1]] + ([stem[:-1]] if len(stem) > 2 and stem[-1] == stem[-2] else [])
    if word.endswith("ies"):
        candidates.append(word[:-3] + "y")
    if word.endswith("es"):
        candidates.append(word[:-2])
    if word.endswith("s"):
        candidates.append(word[:-1])
    for c in candidates:
        if c in _KNOWN:
            return c
    return word


def _style_phrases() -> dict[tuple[str, ...], str]:
    out = {tuple(lemma(w) for w in re.findall(r"[a-z]+", p)): name
           for name, phrases in STYLE_PHRASES.items() for p in phrases}
    out.update({(w,): s for w, s in STYLE_WORDS.items()})
    out[("with", "hand", "up")] = "hands_up"
    out[("with", "arm", "up")] = "hands_up"
    out[("hand", "up")] = "hands_up"
    out[("arm", "up")] = "hands_up"
    return out


# ------------------------------------------------------------------------------------------------ intent
@dataclass(frozen=True)
class IntentSegment:
    """One intended action. ``None`` = the prompt does not say (any value matches)."""

    action: str
    count: int | None = None
    side: str | None = None  # "left" | "right" | "both"
    direction: str | None = None  # forward, backward, left, right, circle(_left|_right), around
    speed: str | None = None  # "slowly" | "quickly"
    overlay: "IntentSegment | None" = None  # a gesture made while doing the action ("walks while waving")

    def describe(self) -> str:
        label = self.action.replace("_", " ")
        bits = [b for b in (self.side and f"{self.side} side" if self.side in ("left", "right") else self.side,
                            self.direction, self.speed, f"\u00d7{self.count}" if self.count else None) if b]
        out = label + (f" ({', '.join(bits)})" if bits else "")
        if self.overlay is not None:
            out += " while " + self.overlay.describe()
        return out


@dataclass(frozen=True)
class Intent:
    """The program a prompt asks for: segments in order, a style, and the words it did not place."""

    text: str
    segments: tuple[IntentSegment, ...]
    style: str | None = None
    unplaced: tuple[str, ...] = field(default=())

    @property
    def complete(self) -> bool:
        """Every word was placed and at least one action was found."""
        return bool(self.segments) and not self.unplaced

    def describe(self) -> str:
        if not self.segments:
            text = "no action recognised"
        else:
            text = " \u2192 ".join(s.describe() for s in self.segments)
        if self.style:
            text += f"; style: {self.style.replace('_', ' ')}"
        if self.unplaced:
            text += f"; not understood: {', '.join(self.unplaced)}"
        return text

    def to_json(self) -> dict:
        return {"text": self.text, "segments": [asdict(s) for s in self.segments], "style": self.style,
                "unplaced": list(self.unplaced)}


def _read(word: str, tokens: "TokenizedPrompt | None") -> list[str]:
    """The lexicon words a typed word stands for: none for a word the model left out (``tokens``), the word the
    model read it as by meaning or spelling ("skips" -> "hops"), a gait verb read as its manner as a walk with that
    manner ("staggers" -> walk drunkenly), and a word the lexicon lacks read by meaning against the lexicon."""
    if tokens is not None and word in tokens.left_out:
        return []
    base = lemma(word)
    if base in _KNOWN:
        return [base]
    if wordforms.is_manner_verb(word):
        manner = wordforms.meaning_word(word, _KNOWN)
        return ["walk", manner] if manner and manner != "walk" else ["walk"]
    if tokens is not None and tokens.read_by.get(word) in ("meaning", "spelling"):
        return [lemma(tokens.read_as[word])]
    hit = wordforms.meaning_word(word, _KNOWN)
    return [lemma(hit) if hit else base]


def _tokens(text: str, tokens: "TokenizedPrompt | None" = None) -> list[str]:
    text = text.lower().replace("\u2019", "'")
    text = re.sub(r"\b([1-9])\b", lambda m: f" {NUMBER_WORDS[m.group(1)]} ", text)
    text = re.sub(r"[,;.!?]", " , ", text)
    return [t for w in re.findall(r"[a-z]+(?:'[a-z]+)?|,", text)
            for t in ([w] if w == "," else _read(w, tokens) if "'" not in w else _read_clitic(w, tokens))]


def _read_clitic(word: str, tokens: "TokenizedPrompt | None") -> list[str]:
    """"she's" -> she, "doesn't" -> do, not; "o'clock" as typed."""
    if tokens is not None and word in tokens.left_out:
        return []
    head, _, tail = word.partition("'")
    if tail == "t" and head.endswith("n"):
        return _read(head[:-1], tokens) + ["not"]
    if tail in ("s", "ll", "re", "ve", "d", "m"):
        return _read(head, tokens)
    return [word]


def _match(tokens: list[str], used: list[bool], start: int, table) -> tuple[int, object] | None:
    """The longest phrase of ``table`` (tuple of words -> value) starting at ``start`` on unused tokens."""
    best = None
    for phrase, value in table.items():
        n = len(phrase)
        if tuple(tokens[start:start + n]) == phrase and not any(used[start:start + n]):
            if best is None or n > best[0]:
                best = (n, value)
    return best


def _table(mapping: dict[str, object]) -> dict[tuple[str, ...], object]:
    return {tuple(lemma(w) for w in k.split()): v for k, v in mapping.items()}


_ACTIONS = {tuple(lemma(w) for w in p.split()): a for a, ps in ACTION_PHRASES.items() for p in ps}
_COUNTS = _table(COUNT_PHRASES)
_SPEEDS = _table(SPEED_PHRASES)
_DIRECTIONS = _table(DIRECTION_PHRASES)
_INTENSITIES = _table({p: True for p in INTENSITY_PHRASES})
_STYLES = _style_phrases()
_MARKS = _table({m: True for m in SEQUENCE_MARKS})


def _split_sequence(tokens: list[str]) -> list[tuple[list[str], bool]]:
    """Clauses in time order, each with whether it holds an action. "A before B" keeps the order;
    "A after B" reverses it ("after B, A" is already in time order)."""
    clauses: list[list[str]] = [[]]
    earlier: set[int] = set()  # clauses that happen before the clause ahead of them
    i = 0
    while i < len(tokens):
        if tokens[i] == "after" and tuple(tokens[i:i + 2]) != ("after", "that"):
            if _has_action(clauses[-1]):  # "A after B"
                clauses.append([])
                earlier.add(len(clauses) - 1)
            i += 1
            continue
        m = _match(tokens, [False] * len(tokens), i, _MARKS)
        if m is not None:
            if clauses[-1]:
                clauses.append([])
            i += m[0]
            continue
        if tokens[i] in (",", "and") and _has_action(clauses[-1]) and _has_action(tokens[i + 1:i + 4]) \
                and not _is_direction_turn(tokens, i):
            clauses.append([])
            i += 1
            continue
        clauses[-1].append(tokens[i])
        i += 1
    order = list(range(len(clauses)))
    for k in sorted(earlier):
        order[k - 1], order[k] = order[k], order[k - 1]
    return [(clauses[k], _has_action(clauses[k])) for k in order if clauses[k]]


def _has_action(clause: list[str]) -> bool:
    return any(_match(clause, [False] * len(clause), k, _ACTIONS) is not None for k in range(len(clause)))


def _is_direction_turn(tokens: list[str], i: int) -> bool:
    """"walks forward and turns left": in the corpus lexicon a walk's direction, not a second action."""
    return tokens[i] == "and" and tuple(tokens[i + 1:i + 3]) in (("turn", "left"), ("turn", "right")) and \
        any(_ACTIONS.get((t,)) in ("walk", "run", "jog") for t in tokens[:i])


def _parse_clause(tokens: list[str], used: list[bool], style: list[str], *,
                  action: str | None = None) -> IntentSegment | None:
    """The segment a clause asks for, marking the tokens it places in ``used`` and any style in ``style``.
    ``action`` given: the clause names none of its own, its modifiers are read for that action."""
    # the action: first action phrase (longest match), with the corpus's disambiguations
    for k in range(len(tokens) if action is None else 0):
        m = _match(tokens, used, k, _ACTIONS)
        if m is not None:
            n, action = m
            for j in range(k, k + n):
                used[j] = True
            break
    if action is None:
        return None
    rest = [t for t, u in zip(tokens, used) if not u]
    if action == "walk" and any(t in ("backward", "backwards", "back") for t in rest):
        action = "walk_backward"
    if action == "walk" and "sideways" in rest:
        action = "side_step"
    if action == "jump" and any(t in ("forward", "forwards", "ahead") for t in rest):
        action = "jump_forward"
    if action == "jump" and ("one" in rest and any(t in ("leg", "foot") for t in rest)):
        action = "hop"
    if action == "jump" and any(tokens[j:j + 4] in (["on", "the", "left", "leg"], ["on", "the", "right", "leg"],
                                                    ["on", "the", "left", "foot"], ["on", "the", "right", "foot"])
                                for j in range(len(tokens))):
        action = "hop"
    side = None
    found: dict = {}  # modifier -> value
    moving = ("walk", "run", "jog", "walk_backward", "side_step", "turn", "jump_forward")
    modifiers = (  # (name, phrase table, whether a match at token k with this value belongs to this action)
        ("direction", _DIRECTIONS, lambda k, v: action in moving or v in ("forward", "backward")),
        ("count", _COUNTS, lambda k, v: not (tokens[k] in ("one", "two", "three", "four", "five") and
                                             k + 1 < len(tokens) and tokens[k + 1] in LIMBS)),  # "two hands"
        ("speed", _SPEEDS, lambda k, v: True),
        ("style", _STYLES, lambda k, v: True),
        ("intensity", _INTENSITIES, lambda k, v: True),
    )
    k = 0
    while k < len(tokens):
        if used[k]:
            k += 1
            continue
        t = tokens[k]
        # "the left hand", "with both arms", "on the right leg": a side
        if t in ("left", "right") and k + 1 < len(tokens) and tokens[k + 1] in LIMBS:
            side = t
            used[k] = used[k + 1] = True
            k += 2
            continue
        if t == "both" and k + 1 < len(tokens) and tokens[k + 1] in LIMBS:
            side = "both"
            used[k] = used[k + 1] = True
            k += 2
            continue
        if t in ("left", "right") and action in ("kick", "punch", "wave", "raise_arms", "hop") and \
                tokens[max(0, k - 1)] in ("the", "with", "his", "her", "their"):
            side = t
            used[k] = True
            k += 1
            continue
        placed = False
        for name, table, accept in modifiers:
            m = _match(tokens, used, k, table)
            if m is not None and accept(k, m[1]):
                n, found[name] = m
                if name == "style":
                    style.append(m[1])
                for j in range(k, k + n):
                    used[j] = True
                k += n
                placed = True
                break
        if placed:
            continue
        k += 1
    count, direction, speed = found.get("count"), found.get("direction"), found.get("speed")
    if action == "walk_backward":
        direction = "backward"
        for j, t in enumerate(tokens):
            if t in ("backward", "backwards", "back") and not used[j]:
                used[j] = True
    if action == "side_step":
        for j, t in enumerate(tokens):
            if t == "sideways":
                used[j] = True
        if direction not in ("left", "right"):
            direction = None
    if action == "turn" and direction in ("forward", "backward"):
        direction = None
    if action == "hop" and side is None:
        for j, t in enumerate(tokens):
            if t in ("left", "right") and not used[j]:
                side = t
                used[j] = True
    if action in ("walk", "run", "jog") and direction == "backward":
        action, direction = ("walk_backward", "backward") if action == "walk" else (action, direction)
    if action not in COUNTED_ACTIONS:
        count = None
    if side not in SIDES_OF.get(action, ()):
        side = None
    return IntentSegment(action=action, count=count, side=side, direction=direction, speed=speed)


def _unplaced(tokens: list[str], used: list[bool]) -> list[str]:
    return [t for t, u in zip(tokens, used) if not u and t != "," and t not in FILLER]


def parse_intent(text: str, tokens: "TokenizedPrompt | None" = None) -> Intent:
    """The intended program of a prompt (see the module docstring). ``tokens``: the prompt as a model read it
    (``Tokenizer.encode``): the words it left out are ignored, and those it read by meaning or as a typo's word are
    read the same way, so the intent is that of what the model is asked. Without it, words the lexicon lacks are
    read by meaning (engine.wordforms) where the meaning table knows them."""
    tokens = _tokens(text, tokens)
    segments: list[IntentSegment] = []
    styles: list[str] = []
    unplaced: list[str] = []
    for clause, has_action in _split_sequence(tokens):
        # "walks while waving": the gerund after "while" is an overlay on the clause's action
        if "while" in clause and has_action and _has_action(clause[clause.index("while") + 1:]):
            w = clause.index("while")
            main_tokens, over_tokens = clause[:w], clause[w + 1:]
        else:
            main_tokens, over_tokens = clause, []
        used = [t == "," for t in main_tokens]
        if not has_action:
            # a clause with no action: its modifiers belong to the previous segment ("..., slowly")
            if segments:
                prev = segments[-1]
                extra = _parse_clause(main_tokens, used, styles, action=prev.action)
                segments[-1] = replace(prev, direction=prev.direction or extra.direction,
                                       speed=prev.speed or extra.speed)
            unplaced += _unplaced(main_tokens, used)
            continue
        seg = _parse_clause(main_tokens, used, styles)
        unplaced += _unplaced(main_tokens, used)
        if over_tokens:
            over_used = [t == "," for t in over_tokens]
            over = _parse_clause(over_tokens, over_used, styles)
            unplaced += _unplaced(over_tokens, over_used)
            if over is not None and seg is None:  # "goes in a curve while punching": only the gesture is known
                seg = over
            elif over is not None:
                if seg.action in ("walk", "stand", "side_step", "turn", "run", "jog") and \
                        over.action in ("wave", "clap", "raise_arms", "punch"):
                    seg = replace(seg, overlay=over)
                else:
                    segments.append(seg)
                    seg = over
        if seg is not None:
            segments.append(seg)
    style = styles[0] if styles else None
    return Intent(text=text, segments=tuple(segments), style=style, unplaced=tuple(dict.fromkeys(unplaced)))
