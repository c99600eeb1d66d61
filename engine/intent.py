"""What a prompt asks for: a parser from free text to the motion program it intends.

``parse_intent("a woman waves the left hand twice, then walks forward")`` gives two segments,
``wave (left, x2)`` and ``walk (forward)``, and the words it could not place. Its lexicon is the caption
grammar's own phrase tables (``engine.synth.grammar``: verbs, counts, speeds, styles, directions, joins,
overlays), so every corpus caption parses back to its program, plus the words people type for the same motions
("waving hello", "3 times", "jumps on one leg"), in any inflection ("walk", "walked", "walking"). Attributes a
prompt does not state stay ``None``: "a person waves" asks for a wave with either hand, and the adherence
benchmark scores it that way; so do vague counts ("repeatedly", "several times").

The Generate tab shows :meth:`Intent.describe`; ``moattn bench --adherence`` scores motions
against :class:`Intent` (``engine.evaluation.adherence``).
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING

from engine import wordforms
from engine.synth import grammar as G
from engine.synth.program import ACTIONS

if TYPE_CHECKING:
    from engine.text import TokenizedPrompt

COUNTED_ACTIONS = ("jump", "jump_forward", "hop", "jumping_jacks", "squat", "kick", "punch", "wave", "clap",
                   "raise_arms", "bow")
SIDES_OF = {"kick": ("left", "right"), "wave": ("left", "right", "both"), "hop": ("left", "right"),
            "punch": ("left", "right", "both"), "raise_arms": ("left", "right", "both")}  # sides a prompt may name

# ------------------------------------------------------------------------------------------------ lexicon
# Words people type beyond the grammar's tables (which are read from engine.synth.grammar below). Phrases in base
# form (lemmas, see :func:`lemma`); the longest phrase at a place wins.
ACTION_PHRASES: dict[str, tuple[str, ...]] = {
    "walk_backward": ("walk backward", "walk backwards", "walk back", "step backward", "step backwards",
                      "step back", "move backward", "move backwards", "back up", "backpedal", "walk in reverse",
                      "step in reverse", "move in reverse", "back away"),
    "side_step": ("side step", "sidestep", "step sideways", "step to the side", "shuffle sideways",
                  "move sideways", "walk sideways", "shuffle to the side", "side shuffle", "strafe"),
    "jump_forward": ("jump forward", "jump forwards", "jump ahead", "leap forward", "leap forwards", "leap ahead",
                     "broad jump", "long jump"),
    "jumping_jacks": ("jump jack", "star jump", "do jump jack", "perform jump jack", "do star jump",
                      "perform star jump"),
    "hop": ("hop", "jump on one leg", "jump on one foot", "jump on the left leg", "jump on the right leg",
            "jump on the left foot", "jump on the right foot"),
    "walk": ("walk", "stroll", "pace", "stride", "march", "wander", "amble", "step", "move", "saunter", "trudge",
             "take a walk", "go for a walk", "tread", "proceed", "travel on foot"),
    "run": ("run", "sprint", "dash", "race", "rush", "hurry"),
    "jog": ("jog", "trot"),
    "turn": ("turn", "rotate", "spin", "pivot", "swivel"),
    "jump": ("jump", "leap", "bounce", "spring", "jump up", "jump up and down", "jump in place"),
    "squat": ("squat", "squat down", "do a squat", "crouch down", "knee bend", "bend the knee", "do a knee bend"),
    "kick": ("kick", "kick out", "do a kick"),
    "punch": ("punch", "throw a punch", "punch forward", "box", "jab", "strike", "hit the air"),
    "wave": ("wave", "wave hello", "wave goodbye", "wave hi", "greet"),
    "clap": ("clap", "clap the hand", "clap hand", "applaud", "clap his hand", "clap her hand",
             "bring the hand together"),
    "raise_arms": ("raise", "lift", "put up", "raise up", "lift up", "hold up", "throw up", "stretch up", "reach up",
                   "bring up", "stretch the arm", "stretch the arm up", "stretch the hand up", "reach the arm up"),
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
# the level a phrase says where the grammar's own table (per action, engine.synth.grammar.INTENSITY_WORDS) has none
# for the action: "low" is a little for a jump or a kick but a deep bow, so the action's table is read first
_INTENSITY_LEVEL = {"very high": "high", "high": "high", "deeply": "high", "all the way down": "high",
                    "energetically": "high", "vigorously": "high", "hard": "high", "deep": "high",
                    "a little": "a little", "slightly": "a little", "a tiny bit": "a little", "a bit": "a little"}
_INTENSITY_KEY = {"jump_forward": "jump", "hop": "jump"}  # the actions that share another's words in the grammar
# style phrases: the corpus's own (lemmatised at import) plus single words people use
STYLE_WORDS: dict[str, str] = {
    "zombie": "zombie", "chicken": "chicken", "robot": "robot", "robotically": "robot", "mechanically": "robot",
    "drunk": "drunk", "drunkenly": "drunk", "unsteadily": "drunk", "tipsy": "drunk", "gorilla": "gorilla",
    "monkey": "gorilla", "ape": "gorilla", "sad": "sad", "sadly": "sad", "gloomily": "sad", "dejectedly": "sad",
    "happy": "happy", "happily": "happy", "cheerfully": "happy", "joyfully": "happy", "proud": "proud",
    "proudly": "proud", "soldier": "proud", "old": "old", "elderly": "old", "tiredly": "old", "wearily": "old",
    "tired": "old", "sneakily": "crouched", "stealthily": "crouched", "sneak": "crouched", "crouch": "crouched",
    "crouching": "crouched", "with hand up": "hands_up", "with arm up": "hands_up", "hand up": "hands_up",
    "arm up": "hands_up",
}
DIRECTION_PHRASES: dict[str, str] = {
    "forward": "forward", "forwards": "forward", "ahead": "forward", "straight ahead": "forward",
    "straight": "forward", "backward": "backward", "backwards": "backward", "to the left": "left",
    "toward the left": "left", "towards the left": "left", "curve left": "left",
    "left": "left", "to the right": "right", "toward the right": "right", "towards the right": "right",
    "curve right": "right", "right": "right", "in a circle": "circle",
    "around in a circle": "circle", "in a circle to the left": "circle_left",
    "in a counterclockwise circle": "circle_left", "counterclockwise": "circle_left",
    "anticlockwise": "circle_left", "in a circle to the right": "circle_right",
    "in a clockwise circle": "circle_right", "clockwise": "circle_right", "around": "around",
    "all the way around": "around", "to face the other way": "around", "in a circle around": "circle",
    "in circles": "circle", "around in circles": "circle", "in a loop": "circle",
}
LIMBS = {"hand": "arm", "arm": "arm", "fist": "arm", "leg": "leg", "foot": "leg"}
SEQUENCE_MARKS = ("and then", "then", "after that", "afterwards", "afterward", "followed by", "next", "finally",
                  "before", "later", "subsequently", "and finally", "and after that", "and afterwards", "and later",
                  "and next", "right after that")
OVERLAY_MARKS = ("while", "whilst", "while also", "all the while", "and at the same time", "at the same time",
                 "and simultaneously", "simultaneously")
# words that place nothing: subjects, the templates' frames ("we see", "a video of"), function words
FILLER = frozenset(
    "a an the person someone somebody man woman human he she they it his her its their this that is are be do "
    "and with using use in on to up out of at by from we see clip motion show shows can seen here keep first "
    "while place spot one hello perform time also just again some people guy girl boy lady figure character "
    "whole body arm hand leg foot both over all way around down side air into there them him "
    "video animation start begin make take give throw deliver".split()) | frozenset(
    w for subject in G.SUBJECTS + tuple(G._OBJECT_CASE.values()) for w in subject.split())

_IRREGULAR = {"ran": "run", "spun": "spin", "leapt": "leap", "did": "do", "done": "do", "stood": "stand",
              "threw": "throw", "took": "take", "feet": "foot", "went": "go", "does": "do", "is": "be", "are": "be",
              "was": "be", "sprang": "spring", "sprung": "spring", "knees": "knee"}
_DETERMINERS = ("the", "a", "an", "his", "her", "its", "their", "my", "your", "with")
_NOUN_AFTER_DETERMINER = ("head",)  # "heads forward" walks, "above the head" does not
_IMPLIED_WALK = "+walk"  # a gait verb read as its manner ("staggers"): a walk unless the clause names an action


def _grammar_bases() -> set[str]:
    """Base forms of every word a corpus caption can contain (the grammar's own lemmas: "treads" -> tread)."""
    out = set()
    for w in G.vocabulary():
        base, _ = G._lemma_pos(w)
        out.add(_IRREGULAR.get(w, base))
    return out


def _phrase_lemmas() -> set[str]:
    out: set[str] = set()
    tables = [p for ps in ACTION_PHRASES.values() for p in ps] + list(COUNT_PHRASES) + list(SPEED_PHRASES) + \
        list(INTENSITY_PHRASES) + list(STYLE_WORDS) + list(DIRECTION_PHRASES) + list(LIMBS) + \
        list(SEQUENCE_MARKS) + list(OVERLAY_MARKS)
    for phrase in tables:
        out.update(phrase.split())
    return out | set(FILLER) | _grammar_bases()


_KNOWN = _phrase_lemmas()
_VOCABULARY = frozenset(G.vocabulary())  # every word a corpus caption can contain
_SPELLED = frozenset(_KNOWN | _VOCABULARY)  # what a typo may be a slip of


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


def _words(phrase: str) -> tuple[str, ...]:
    return tuple(lemma(w) for w in re.findall(r"[a-z]+", phrase.lower()))


def _lexicon() -> dict[tuple[str, ...], tuple[str, object]]:
    """Every phrase -> (kind, value). Kinds: action, hop (a hop's leg: side or None), side, count (an int, or None
    for a vague count: "repeatedly"), speed, style, direction, intensity, mark (a sequence join), overlay ("while"),
    ignore (placed, says nothing the intent keeps: "in place", "and lowers them again", "normally").
    A phrase two kinds claim keeps the first kind below; a grammar verb two actions share ("walks", "jumps") keeps
    the plain action (a direction or "on one leg" makes it walk_backward or hop)."""
    out: dict[tuple[str, ...], tuple[str, object]] = {}

    def put(phrase: str, kind: str, value) -> None:
        key = _words(phrase)
        if key:
            out.setdefault(key, (kind, value))

    for action, phrases in ACTION_PHRASES.items():
        for p in phrases:
            put(p, "action", action)
    plain_first = sorted(G.VERBS, key=lambda a: a in ("walk_backward", "hop"))
    for action in plain_first:
        for third, gerund in G.VERBS[action]:
            put(third, "action", action)
            put(gerund, "action", action)
    for action, (one, many, verbs) in G.COUNT_NOUNS.items():
        put(one, "action", action)
        put(many, "action", action)
        for third, gerund in verbs:  # "does a jump", "does three jumps" (the count is read on its own)
            put(f"{third} a {one}", "action", action)
    for side in ("left", "right"):
        for p in G.HOP_SIDE:
            put(p.format(side=side), "hop", side)
    for p in G.HOP_UNSAID:
        put(p, "hop", None)
    for side in ("left", "right", "both"):
        for limb in ("hand", "arm", "fist", "leg", "foot", "hands", "arms", "fists", "legs", "feet"):
            put(f"{side} {limb}", "side", side)
    for limb in ("arms", "hands"):
        put(f"both of the {limb}", "side", "both")
    for m in SEQUENCE_MARKS + tuple(j.strip(" ,") for j in G.SEQ_JOIN + G.ING_JOIN):
        if m != "and":
            put(m, "mark", True)
    for m in OVERLAY_MARKS + tuple(j.strip(" ,") for j, _ in G.OVERLAY_JOINS):
        put(m, "overlay", True)
    by_phrase: dict[str, set[int]] = {}
    for n, phrases in G.COUNT_WORDS.items():
        for p in phrases:
            by_phrase.setdefault(p, set()).add(n)
    for p, ns in by_phrase.items():
        put(p, "count", next(iter(ns)) if len(ns) == 1 else None)  # VAGUE_COUNTS: no number stated
    for p in G.SINGLE:
        put(p, "count", 1)
    for p, n in COUNT_PHRASES.items():
        put(p, "count", n)
    for p, v in SPEED_PHRASES.items():
        put(p, "speed", v)
    for v, phrases in G.SPEED_WORDS.items():
        for p in phrases:
            put(p, "speed", v)
    for p, v in DIRECTION_PHRASES.items():
        put(p, "direction", v)
    directions: dict[str, set[str]] = {}
    for v, phrases in (*G.DIRECTION_WORDS.items(), *G.TURN_WORDS.items()):
        for p in phrases:
            directions.setdefault(p, set()).add(v)
    for p, vs in directions.items():
        if p.startswith("and turn"):  # "walks and turns left": see _split_sequence
            continue
        put(p, "direction", next(iter(vs)) if len(vs) == 1 else "circle" if vs <= {"circle_left", "circle_right"} else None)
    for p, vs in directions.items():  # "runs along a straight path": the verb took "along"
        if p.startswith("along ") and len(vs) == 1:
            put(p[len("along "):], "direction", next(iter(vs)))
    for side in ("left", "right"):
        for p in G.SIDE_STEP_WORDS:
            put(p.format(d=side), "direction", side)
    for name, phrases in G.STYLE_PHRASES.items():
        for p in phrases:
            put(p, "style", name)
    for p, v in STYLE_WORDS.items():
        put(p, "style", v)
    for p in INTENSITY_PHRASES:
        put(p, "intensity", p)
    for levels in G.INTENSITY_WORDS.values():
        for phrases in levels.values():
            for p in phrases:
                put(p, "intensity", p)
    ignored = (*G.NEUTRAL_PHRASES, *G.IN_PLACE, *G.JUMP_PLACE, *G.RAISE_WHERE, *G._strings(G.RAISE_LOWER),
               *G._strings(G.RAISE_LOWER_ING), *(p for pair in G.BOW_BACK for p in pair))
    for third, gerund in G.VERBS["jumping_jacks"]:  # "works out with two jumping jacks": the count is read apart
        for verb in (third, gerund):
            head = re.split(r"\b(?:some|jumping|star|side)\b", verb)[0].strip()
            ignored += (head,) if head and _words(head) not in out else ()
    for p in ignored:
        put(p, "ignore", True)
    return out


_LEXICON = _lexicon()
# count phrases the grammar says for more than one count ("repeatedly": 3 to 5 times): placed, no number stated
VAGUE_COUNTS = tuple(dict.fromkeys(p for n, ps in G.COUNT_WORDS.items() for p in ps
                                   if any(p in other for m, other in G.COUNT_WORDS.items() if m != n)))
_LONGEST = max(len(k) for k in _LEXICON)


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
    intensity: str | None = None  # "high" | "a little" (the corpus's intensity levels: "jumps high", "waves gently")

    def describe(self) -> str:
        label = self.action.replace("_", " ")
        bits = [b for b in (self.side and f"{self.side} side" if self.side in ("left", "right") else self.side,
                            self.direction, self.speed, self.intensity,
                            f"\u00d7{self.count}" if self.count else None) if b]
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


@dataclass(frozen=True)
class _Span:
    """A run of the prompt's words: a lexicon phrase (kind, value) or one word the lexicon lacks (kind "word")."""

    kind: str
    value: object
    words: tuple[str, ...]

    @property
    def word(self) -> str:
        return self.words[0]


def _read(word: str, tokens: "TokenizedPrompt | None") -> list[str]:
    """The lexicon words a typed word stands for: none for a word the model left out (``tokens``), a gait verb read
    as its manner as a walk with that manner ("staggers" -> walk drunkenly), the word the model read it as by meaning
    or spelling ("skips" -> "hops"), and a word the lexicon lacks read by meaning against the lexicon, or as the word
    a typo is a slip of ("jumsp" -> "jumps")."""
    if tokens is not None and word in tokens.left_out:
        return []
    base = lemma(word)
    if word in _VOCABULARY or base in _KNOWN:  # a gait verb the lexicon knows: see _spans
        return [base]
    if wordforms.is_manner_verb(word):
        manner = wordforms.meaning_word(word, _KNOWN)
        return [_IMPLIED_WALK, manner] if manner and manner != "walk" else [_IMPLIED_WALK]
    if tokens is not None and tokens.read_by.get(word) in ("meaning", "spelling"):
        return [lemma(tokens.read_as[word])]
    hit = wordforms.meaning_word(word, _KNOWN) or wordforms.typo_reading(word, _SPELLED)
    return [lemma(hit) if hit else base]


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


_POSSESSIVES = frozenset(("his", "her", "their", "its", "my", "your"))
_BODY = frozenset(("head", "hand", "arm", "leg", "foot", "knees", "toe", "shoulder", "fist", "chest", "hip"))


def _the_body(words: list[str]) -> list[str]:
    """"above his head", "claps her hands", "with his right leg": a possessive before a body part is the grammar's
    "the" ("above the head", "claps the hand")."""
    return ["the" if w in _POSSESSIVES and (words[k + 1:k + 2] and words[k + 1] in _BODY or
                                           words[k + 1:k + 2] in (["left"], ["right"], ["both"]) and
                                           words[k + 2:k + 3] and words[k + 2] in _BODY) else w
            for k, w in enumerate(words)]


def _tokens(text: str, tokens: "TokenizedPrompt | None" = None) -> list[str]:
    text = text.lower().replace("\u2019", "'")
    text = re.sub(r"\b([1-9])\b", lambda m: f" {NUMBER_WORDS[m.group(1)]} ", text)
    text = re.sub(r"[,;.!?]", " , ", text)
    return _the_body([t for w in re.findall(r"[a-z]+(?:'[a-z]+)?|,", text)
                      for t in ([w] if w == "," else _read(w, tokens) if "'" not in w else _read_clitic(w, tokens))])


def _spans(words: list[str]) -> list[_Span]:
    """The words as lexicon phrases, longest first from the left ("at a relaxed pace" is a speed, not a walk)."""
    out: list[_Span] = []
    i = 0
    while i < len(words):
        w = words[i]
        if w == ",":
            out.append(_Span("comma", None, (",",)))
            i += 1
            continue
        if w == _IMPLIED_WALK:
            out.append(_Span("action", "implied", (w,)))
            i += 1
            continue
        hit = None
        for n in range(min(_LONGEST, len(words) - i), 0, -1):
            key = tuple(words[i:i + n])
            if key in _LEXICON:
                hit = (n, _LEXICON[key])
                break
        if hit is not None and hit[0] == 1 and hit[1][0] == "action" and w in _NOUN_AFTER_DETERMINER and \
                i > 0 and words[i - 1] in _DETERMINERS:
            hit = None
        if hit is None:
            hit = (1, ("word", w))
        n, (kind, value) = hit
        if kind in ("style", "word") and _LEXICON.get((w,), ("",))[0] != "action" and wordforms.is_manner_verb(w):
            out.append(_Span("action", "implied", ()))  # "staggers forward": a walk, unless an action is named
        out.append(_Span(kind, value, tuple(words[i:i + n])))
        i += n
    return out


def _has_action(clause: list[_Span]) -> bool:
    return any(s.kind == "action" for s in clause)


def _is_direction_turn(items: list[_Span], i: int, clause: list[_Span]) -> bool:
    """"walks forward and turns left": in the corpus lexicon a walk's direction, not a second action."""
    return items[i].kind == "word" and items[i].word == "and" and i + 2 < len(items) and \
        items[i + 1].kind == "action" and items[i + 1].words == ("turn",) and \
        items[i + 2].kind == "direction" and items[i + 2].value in ("left", "right") and \
        any(s.kind == "action" and s.value in ("walk", "run", "jog") for s in clause)


def _split_sequence(items: list[_Span]) -> list[tuple[list[_Span], bool]]:
    """Clauses in time order, each with whether it holds an action. "A before B" keeps the order;
    "A after B" reverses it ("after B, A" is already in time order)."""
    clauses: list[list[_Span]] = [[]]
    earlier: set[int] = set()  # clauses that happen before the clause ahead of them
    i = 0
    while i < len(items):
        s = items[i]
        if s.kind == "word" and s.word == "after":
            if _has_action(clauses[-1]):  # "A after B"
                clauses.append([])
                earlier.add(len(clauses) - 1)
            i += 1
            continue
        if s.kind == "mark":
            if clauses[-1]:
                clauses.append([])
            i += 1
            continue
        if _is_direction_turn(items, i, clauses[-1]):
            clauses[-1].append(_Span("direction", items[i + 2].value, ("and", "turn", *items[i + 2].words)))
            i += 3
            continue
        if (s.kind == "comma" or (s.kind == "word" and s.word == "and")) and _has_action(clauses[-1]) and \
                _has_action(items[i + 1:i + 4]) and not (i + 1 < len(items) and items[i + 1].kind == "overlay"):
            clauses.append([])
            i += 1
            continue
        clauses[-1].append(s)
        i += 1
    order = list(range(len(clauses)))
    for k in sorted(earlier):
        order[k - 1], order[k] = order[k], order[k - 1]
    return [(clauses[k], _has_action(clauses[k])) for k in order if clauses[k]]


_MOVING = ("walk", "run", "jog", "walk_backward", "side_step", "turn", "jump_forward")


def _parse_clause(items: list[_Span], used: list[bool], style: list[str], *,
                  action: str | None = None) -> IntentSegment | None:
    """The segment a clause asks for, marking the spans it places in ``used`` and any style in ``style``.
    ``action`` given: the clause names none of its own, its modifiers are read for that action."""
    if action is None:
        named = [k for k, s in enumerate(items) if s.kind == "action" and s.value != "implied"]
        implied = [k for k, s in enumerate(items) if s.kind == "action" and s.value == "implied"]
        for k in implied:  # a gait verb's walk: only where the clause names no action ("staggers forward")
            used[k] = True
        if named:
            action = items[named[0]].value
            used[named[0]] = True
        elif implied:
            action = "walk"
    if action is None:
        return None
    kinds = {s.kind: s.value for s, u in zip(items, used) if not u}
    words = {w for s, u in zip(items, used) if not u and s.kind == "word" for w in s.words}
    if action == "walk" and kinds.get("direction") == "backward" or action == "walk" and "back" in words:
        action = "walk_backward"
    if action == "walk" and "sideways" in words:
        action = "side_step"
    if action == "jump" and kinds.get("direction") == "forward" or action == "jump" and \
            words & {"forward", "forwards", "ahead"}:
        action = "jump_forward"
    side = None
    if action in ("jump", "hop") and "hop" in kinds:
        action, side = "hop", kinds["hop"]
    found: dict = {}
    for k, s in enumerate(items):
        if used[k]:
            continue
        prev = items[k - 1].words[-1] if k > 0 and items[k - 1].words else ""
        nxt = items[k + 1] if k + 1 < len(items) else None
        if s.kind == "side":
            side = s.value
        elif s.kind == "hop":
            side = side or s.value
        elif s.kind == "direction":
            if s.value in ("left", "right") and action in ("kick", "punch", "wave", "raise_arms", "hop") and \
                    prev in ("the", "with", "his", "her", "their"):
                side = s.value
            elif action in _MOVING or s.value in ("forward", "backward"):
                found["direction"] = s.value
            else:
                continue
        elif s.kind == "count":
            if nxt is not None and nxt.kind == "word" and nxt.word in LIMBS and len(s.words) == 1:
                continue  # "two hands"
            found["count"] = s.value
        elif s.kind == "speed":
            level = intensity_level(" ".join(s.words), action, table_only=True)  # "waves gently": the grammar's size
            found["intensity" if level else "speed"] = level or s.value
        elif s.kind == "style":
            style.append(s.value)
        elif s.kind == "intensity":
            found["intensity"] = intensity_level(str(s.value), action) or found.get("intensity")
        elif s.kind == "ignore":
            pass
        elif s.kind == "word" and s.word in ("back", "backward", "backwards", "sideways") and \
                action in ("walk_backward", "side_step"):
            pass
        else:
            continue
        used[k] = True
    count, direction, speed = found.get("count"), found.get("direction"), found.get("speed")
    if action == "walk_backward":
        direction = "backward"
    if action == "side_step" and direction not in ("left", "right"):
        direction = None
    if action == "turn" and direction in ("forward", "backward"):
        direction = None
    if action in ("walk", "run", "jog") and direction == "backward":
        action, direction = ("walk_backward", "backward") if action == "walk" else (action, direction)
    if action not in COUNTED_ACTIONS:
        count = None
    if side not in SIDES_OF.get(action, ()):
        side = None
    return IntentSegment(action=action, count=count, side=side, direction=direction, speed=speed,
                         intensity=found.get("intensity"))


def action_of_word(word: str) -> str | None:
    """The corpus action a single word names as a verb or noun ("jumps", "hopping", "waves", "kick"), or None."""
    kind, value = _LEXICON.get(_words(word), (None, None))
    return value if kind == "action" and value != "implied" else None


def intensity_table(action: str) -> dict[str, tuple[str, ...]] | None:
    """The corpus grammar's intensity words of ``action`` ({"high": (...), "a little": (...)}), or None where the corpus
    does not scale it."""
    return G.INTENSITY_WORDS.get(_INTENSITY_KEY.get(action, action))


def _levels_in_every_table() -> dict[tuple[str, ...], str]:
    """Phrases the grammar's intensity tables give one level wherever they appear ("really high": high), so another
    scaled action may say them ("kicks really high"); "low" (a small jump, a deep bow) is not among them."""
    seen: dict[tuple[str, ...], set[str]] = {}
    for levels in G.INTENSITY_WORDS.values():
        for level, phrases in levels.items():
            for p in phrases:
                seen.setdefault(_words(p), set()).add(level)
    return {k: next(iter(v)) for k, v in seen.items() if len(v) == 1}


_ANY_TABLE_LEVEL = _levels_in_every_table()


def intensity_level(phrase: str, action: str, *, table_only: bool = False) -> str | None:
    """The corpus intensity level ("high" | "a little") an intensity phrase says for ``action``: the grammar's own
    words for that action first ("low" is a little for a jump, a deep bow for a bow; "gently" is a small wave), else
    (unless ``table_only``) the phrase's usual sense; None where the action has no size to scale (a walk "hard")."""
    table = intensity_table(action)
    if table is None:
        return None
    key = _words(phrase)
    for level, phrases in table.items():
        if any(_words(p) == key for p in phrases):
            return level
    if table_only:
        return None
    return _INTENSITY_LEVEL.get(" ".join(key)) or _INTENSITY_LEVEL.get(phrase) or _ANY_TABLE_LEVEL.get(key)


# "turns around, then walks back": after a turn on the spot, "back" is the way the body came, ahead of it now (a
# return, not a walk backwards); "walks backwards", "steps back" and "backs away" keep their meaning
_RETURN_VERBS = frozenset(("walk", "go", "come", "head", "run", "jog", "stroll", "wander", "march"))


def _says_return(items: list[_Span]) -> bool:
    """The clause's only backward word is a bare "back" after a gait verb ("walks back", "goes back", "runs back"; not
    "walks back and forth")."""
    words = [w for s in items for w in s.words]
    if {"backward", "backwards", "reverse"} & set(words):
        return False
    return any(w == "back" and k > 0 and words[k - 1] in _RETURN_VERBS and words[k + 1:k + 2] != ["and"]
               for k, w in enumerate(words))


def turned_around(segment: IntentSegment) -> bool:
    """A turn on the spot: a later "walks back" is a return (see :func:`says_return`)."""
    return segment.action == "turn" and segment.direction == "around"


def says_return(text: str) -> bool:
    """``text`` (one clause) goes back the way it came with a bare "back" ("then walks back"); after a turn on the
    spot (:func:`turned_around`) that is ahead of the body: :func:`parse_intent` reads it as a walk forward."""
    return _says_return(_spans(_tokens(text)))


def as_return(text: str) -> str:
    """A returning clause said as a prompt of its own says it: "walks back" -> "walks forward"."""
    return re.sub(r"\bback\b", "forward", text, flags=re.IGNORECASE)


def _returning(segment: IntentSegment) -> IntentSegment:
    if segment.action == "walk_backward":
        return replace(segment, action="walk", direction="forward")
    if segment.direction == "backward":
        return replace(segment, direction="forward")
    return segment


def _unplaced(items: list[_Span], used: list[bool]) -> list[str]:
    return [w for s, u in zip(items, used) if not u and s.kind != "comma"
            for w in s.words if w not in FILLER and w != _IMPLIED_WALK]


def parse_intent(text: str, tokens: "TokenizedPrompt | None" = None) -> Intent:
    """The intended program of a prompt (see the module docstring). ``tokens``: the prompt as a model read it
    (``Tokenizer.encode``): the words it left out are ignored, and those it read by meaning or as a typo's word are
    read the same way, so the intent is that of what the model is asked. Without it, words the lexicon lacks are
    read by meaning (engine.wordforms) where the meaning table knows them, or as the word a typo is a slip of."""
    items = _spans(_tokens(text, tokens))
    segments: list[IntentSegment] = []
    styles: list[str] = []
    unplaced: list[str] = []
    for clause, has_action in _split_sequence(items):
        # "walks while waving": the phrase after "while" is an overlay on the clause's action
        w = next((k for k, s in enumerate(clause) if s.kind == "overlay"), None)
        if w is not None and has_action and _has_action(clause[w + 1:]):
            main_items, over_items = clause[:w], clause[w + 1:]
        else:
            main_items, over_items = clause, []
        used = [s.kind in ("comma", "overlay") for s in main_items]
        if not has_action:
            # a clause with no action: its modifiers belong to the previous segment ("..., slowly")
            if segments:
                prev = segments[-1]
                extra = _parse_clause(main_items, used, styles, action=prev.action)
                segments[-1] = replace(prev, direction=prev.direction or extra.direction,
                                       speed=prev.speed or extra.speed, count=prev.count or extra.count,
                                       intensity=prev.intensity or extra.intensity)
            unplaced += _unplaced(main_items, used)
            continue
        seg = _parse_clause(main_items, used, styles)
        if seg is not None and segments and turned_around(segments[-1]) and _says_return(main_items):
            seg = _returning(seg)
        unplaced += _unplaced(main_items, used)
        if over_items:
            over_used = [s.kind in ("comma", "overlay") for s in over_items]
            over = _parse_clause(over_items, over_used, styles)
            unplaced += _unplaced(over_items, over_used)
            if over is not None and seg is None:  # "goes in a curve while punching": only the gesture is known
                seg = over
            elif over is not None:
                if seg.action in ("walk", "stand", "side_step", "turn", "run", "jog", "walk_backward") and \
                        over.action in ("wave", "clap", "raise_arms", "punch"):
                    seg = replace(seg, overlay=over)
                else:
                    segments.append(seg)
                    seg = over
        if seg is not None:
            segments.append(seg)
    style = styles[0] if styles else None
    return Intent(text=text, segments=tuple(segments), style=style, unplaced=tuple(dict.fromkeys(unplaced)))
