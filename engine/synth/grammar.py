"""Captions: a small grammar with synonyms and varied word order, and the finite vocabulary.

Every caption is built from the phrase tables below, so :func:`vocabulary` (all words any
caption of any split can contain, lowercase, punctuation stripped) is exact by construction;
``tests/test_synth_grammar.py`` checks it against generated captions and the file
``vocabulary.txt``. Templates marked held out appear only in the ``ood`` split.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from engine.synth.program import Program, Segment

SUBJECTS = ("a person", "someone", "a man", "a woman", "the person", "a human", "the man", "the woman")
COUNT_WORDS = {1: ("once", "one time"), 2: ("twice", "two times"), 3: ("three times", "thrice"),
               4: ("four times",), 5: ("five times",)}
COUNT_NUMBERS = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}
SPEED_WORDS = {"slowly": ("slowly", "at a slow pace", "leisurely"),
               "quickly": ("quickly", "fast", "rapidly", "at a fast pace")}
STYLE_PHRASES = {
    "zombie": ("like a zombie", "as a zombie", "in a zombie way"),
    "chicken": ("like a chicken", "as a chicken", "flapping the arms like a chicken"),
    "hands_up": ("with hands up", "with both hands raised", "with the arms up in the air", "holding the hands up"),
    "crouched": ("sneakily", "in a crouch", "stealthily", "while crouching low"),
    "old": ("like an old man", "like an elderly person", "tiredly", "wearily"),
    "happy": ("happily", "cheerfully", "joyfully", "in a happy way"),
    "sad": ("sadly", "gloomily", "in a sad way", "dejectedly"),
    "robot": ("like a robot", "robotically", "mechanically"),
    "drunk": ("like a drunk person", "drunkenly", "unsteadily"),
    "gorilla": ("like a gorilla", "like a monkey", "like an ape"),
    "proud": ("proudly", "like a marching soldier", "in a marching style", "with high knees"),
}
# verbs: (third person, gerund)
VERBS = {
    "walk": (("walks", "walking"), ("strolls", "strolling"), ("paces", "pacing")),
    "run": (("runs", "running"), ("sprints", "sprinting"), ("dashes", "dashing")),
    "jog": (("jogs", "jogging"), ("trots", "trotting")),
    "walk_backward": (("walks", "walking"), ("steps", "stepping"), ("moves", "moving")),
    "side_step": (("side steps", "side stepping"), ("steps sideways", "stepping sideways"),
                  ("shuffles sideways", "shuffling sideways")),
    "turn": (("turns", "turning"), ("rotates", "rotating"), ("spins", "spinning")),
    "jump": (("jumps", "jumping"), ("leaps", "leaping")),
    "jump_forward": (("jumps forward", "jumping forward"), ("leaps forward", "leaping forward"),
                     ("jumps ahead", "jumping ahead")),
    "hop": (("hops", "hopping"), ("jumps", "jumping")),
    "jumping_jacks": (("does jumping jacks", "doing jumping jacks"), ("performs jumping jacks", "performing jumping jacks"),
                      ("does star jumps", "doing star jumps")),
    "squat": (("squats", "squatting"), ("squats down", "squatting down"), ("does a squat", "doing a squat")),
    "kick": (("kicks", "kicking"), ("kicks out", "kicking out")),
    "punch": (("punches", "punching"), ("throws a punch", "throwing a punch"), ("punches forward", "punching forward")),
    "wave": (("waves", "waving"), ("waves hello", "waving hello")),
    "clap": (("claps", "clapping"), ("claps the hands", "clapping the hands"), ("claps hands", "clapping hands")),
    "raise_arms": (("raises", "raising"), ("lifts", "lifting"), ("puts up", "putting up")),
    "bow": (("bows", "bowing"), ("takes a bow", "taking a bow"), ("bends forward to bow", "bending forward to bow")),
    "dance": (("dances", "dancing"), ("dances from side to side", "dancing from side to side"),
              ("does a little dance", "doing a little dance")),
    "stand": (("stands still", "standing still"), ("stands in place", "standing in place"), ("stays still", "staying still")),
}
DIRECTION_WORDS = {
    "forward": ("forward", "ahead", "straight ahead", "forwards"),
    "backward": ("backward", "backwards"),
    "left": ("to the left", "toward the left", "and turns left", "curving left"),
    "right": ("to the right", "toward the right", "and turns right", "curving right"),
    "circle_left": ("in a circle", "in a circle to the left", "around in a circle", "in a counterclockwise circle"),
    "circle_right": ("in a circle", "in a circle to the right", "around in a circle", "in a clockwise circle"),
}
TURN_WORDS = {"around": ("around", "all the way around", "to face the other way"),
              "left": ("to the left", "left", "toward the left"), "right": ("to the right", "right", "toward the right")}
INTENSITY_WORDS = {
    "jump": {"high": ("high", "very high"), "a little": ("a little", "slightly", "a tiny bit")},
    "kick": {"high": ("high", "very high"), "a little": ("low", "a little")},
    "squat": {"high": ("deeply", "all the way down"), "a little": ("a little", "slightly")},
    "bow": {"high": ("deeply",), "a little": ("slightly", "a little")},
    "wave": {"high": ("energetically", "vigorously"), "a little": ("a little", "gently")},
}
LIMB = {"hand": ("hand", "arm"), "leg": ("leg", "foot")}
SEQ_JOIN = (", then ", " and then ", ", after that ", ", and afterwards ", " before ")
# templates: {s} subject, {vp} verb phrase (3rd person), {ing} gerund phrase
TEMPLATES = {
    "simple": "{s} {vp}",
    "progressive": "{s} is {ing}",
    "sees": "we see {s} {ing}",
    "shows": "this motion shows {s} {ing}",
    "first": "{s} first {vp}",
}
HELD_OUT_TEMPLATES = {
    "video": "in this clip {s} can be seen {ing}",
    "here": "here {s} keeps {ing}",
}
_FILLER = ("and", "with", "the", "both", "while", "then", "after", "that", "afterwards", "before", "arms",
           "hands", "his", "her", "its", "in", "place", "one", "on", "to", "is", "a", "times")


def _pick(rng: np.random.Generator, options):
    return options[int(rng.integers(len(options)))]


def _side_phrase(seg: Segment, rng, limb: str, *, bare: bool) -> str:
    """"with the left hand"; ``bare`` also allows "the left hand" right after a one-word verb."""
    side = seg.side
    word = _pick(rng, LIMB[limb])
    if side == "both":
        return _pick(rng, (f"with both {word}s", f"using both {word}s"))
    if side in ("left", "right"):
        options = [f"with the {side} {word}", f"using the {side} {word}"]
        if bare:
            options.append(f"the {side} {word}")
        return _pick(rng, tuple(options))
    return ""


def _count_phrase(seg: Segment, rng) -> str:
    c = max(1, min(seg.count, 5))
    return _pick(rng, COUNT_WORDS[c])


def action_phrase(seg: Segment, form: int, rng: np.random.Generator, *, with_count: bool = True,
                  with_side: bool = True) -> str:
    """Verb phrase for a segment; form 0 = third person ("walks"), 1 = gerund ("walking"). ``with_count`` and
    ``with_side`` False leave the count and the side unsaid."""
    a = seg.action
    verb = _pick(rng, VERBS[a])[form]
    parts = [verb]
    extra = []
    if a in ("walk", "run", "jog") and seg.direction in DIRECTION_WORDS:
        extra.append(_pick(rng, DIRECTION_WORDS[seg.direction]))
    elif a == "walk_backward":
        extra.append(_pick(rng, DIRECTION_WORDS["backward"]))
    elif a == "side_step":
        d = "left" if seg.direction != "right" else "right"
        extra.append(_pick(rng, (f"to the {d}", f"toward the {d}")))
    elif a == "turn":
        key = "around" if abs(seg.turn) > 2.5 else ("left" if seg.turn > 0 else "right")
        extra.append(_pick(rng, TURN_WORDS[key]))
        if rng.random() < 0.5:
            extra.append("in place")
    elif a == "jump" and rng.random() < 0.3:
        extra.append(_pick(rng, ("in place", "up and down", "on the spot")))
    elif a == "hop":
        if with_side and seg.side in ("left", "right"):
            extra.append(_pick(rng, (f"on the {seg.side} leg", f"on the {seg.side} foot", f"on one leg")))
        elif rng.random() < 0.5:  # a side left unsaid
            extra.append("on one leg")
    elif a == "kick":
        parts.append(_side_phrase(seg, rng, "leg", bare=" " not in verb) if with_side else "")
    elif a in ("punch", "wave"):
        parts.append(_side_phrase(seg, rng, "hand", bare=" " not in verb) if with_side else "")
    elif a == "raise_arms":
        side = seg.side if seg.side != "none" else "both"
        if not with_side:
            parts.append(_pick(rng, ("an arm", "a hand", "the arms", "the hands")))
        elif side == "both":
            parts.append(_pick(rng, ("both arms", "both hands", "the arms", "the hands")))
        else:
            parts.append(_pick(rng, (f"the {side} arm", f"the {side} hand")))
        if verb.startswith("lift") or verb.startswith("rais"):
            if rng.random() < 0.4:
                parts.append("up")
    if with_count and a in ("jump", "jump_forward", "hop", "squat", "kick", "punch", "wave", "clap", "bow",
                            "raise_arms", "jumping_jacks"):
        if a == "jumping_jacks":
            c = max(1, min(seg.count, 5))
            if rng.random() < 0.5:
                parts = [verb.replace("jumping jacks", f"{COUNT_NUMBERS[c]} jumping jacks").replace(
                    "star jumps", f"{COUNT_NUMBERS[c]} star jumps")]
            else:
                extra.append(_count_phrase(seg, rng))
        else:
            extra.append(_count_phrase(seg, rng))
    key = {"jump_forward": "jump", "hop": "jump"}.get(a, a)
    if seg.intensity_word in ("high", "a little") and key in INTENSITY_WORDS:
        extra.append(_pick(rng, INTENSITY_WORDS[key][seg.intensity_word]))
    if seg.speed_word in SPEED_WORDS and a != "stand":
        sp = _pick(rng, SPEED_WORDS[seg.speed_word])
        if form == 0 and sp.endswith("ly") and rng.random() < 0.35:
            parts.insert(0, sp)  # "slowly walks"
        else:
            extra.append(sp)
    extra = [e for e in extra if e]
    order = rng.permutation(len(extra)) if rng.random() < 0.3 else np.arange(len(extra))
    return " ".join(parts + [extra[i] for i in order])


def _vp(program: Program, rng, style: bool) -> str:
    """Third-person phrase; "before" joins switch the following phrase to a gerund."""
    return _joined(program, rng, style, joins=SEQ_JOIN, gerund_after_before=True)


def _ing(program: Program, rng, style: bool) -> str:
    """Gerund phrase ("walking, then jumping")."""
    return _joined(program, rng, style, joins=(", then ", " and then ", " before "), gerund_after_before=False)


def _joined(program: Program, rng, style: bool, *, joins, gerund_after_before: bool) -> str:
    """The segments' phrases joined in order, an overlay as "while ...", the style phrase on one of them."""
    parts = []
    sty_at = int(rng.integers(len(program.segments))) if program.style != "none" and style else -1
    for i, seg in enumerate(program.segments):
        join = "" if i == 0 else _pick(rng, joins)
        form = 1 if not gerund_after_before or join == " before " else 0
        p = action_phrase(seg, form, rng)
        if seg.overlay is not None:
            p += " while " + action_phrase(seg.overlay, 1, rng)
        if i == sty_at:
            p += " " + _pick(rng, STYLE_PHRASES[program.style])
        parts.append(join + p)
    return "".join(parts)


def captions(program: Program, rng: np.random.Generator, *, n: int = 4, held_out: bool = False) -> list[str]:
    """``n`` (>= 3) distinct paraphrases. ``held_out`` draws only from the held-out templates."""
    pool = HELD_OUT_TEMPLATES if held_out else TEMPLATES
    names = list(pool)
    out: list[str] = []
    tries = 0
    while len(out) < n and tries < 40:
        tries += 1
        name = names[(len(out) + int(rng.integers(len(names)))) % len(names)] if tries > 1 else _pick(rng, names)
        tpl = pool[name]
        subj = _pick(rng, SUBJECTS)
        text = tpl.format(s=subj, vp=_vp(program, rng, True) if "{vp}" in tpl else "",
                          ing=_ing(program, rng, True) if "{ing}" in tpl else "")
        # a style phrase may also open the sentence ("happily, a person walks")
        text = re.sub(r"\s+", " ", text).strip()
        if text not in out:
            out.append(text)
    return out


def underspecified_captions(program: Program, rng: np.random.Generator, *, n: int = 2) -> list[str]:
    """Captions that leave attributes out, the way people type ("a person waves" for a left-hand wave, twice).

    Side, count, speed, intensity and style are each dropped at random, keeping the meaning: an unstated side
    covers either hand, an unstated count any count. About a third are bare subject-and-verb captions of two to
    four words ("someone kicks"). Only words of the phrase tables are used, so :func:`vocabulary` is unchanged.
    """
    from dataclasses import replace as _replace

    out: list[str] = []
    for _ in range(6 * n):
        if len(out) >= n:
            break
        bare = rng.random() < 0.35
        segments = []
        for seg in program.segments:
            fields = {}
            say_side = not (bare or rng.random() < 0.6)
            if bare or rng.random() < 0.6:
                fields["speed_word"] = "normal"
            if bare or rng.random() < 0.6:
                fields["intensity_word"] = "normal"
            if bare and seg.action in ("walk", "run", "jog") and rng.random() < 0.7:
                fields["direction"] = "none"
            keep_count = not bare and rng.random() < 0.5
            overlay = None if bare else seg.overlay
            segments.append((_replace(seg, overlay=overlay, **fields), keep_count, say_side))
        parts = []
        for i, (seg, keep_count, say_side) in enumerate(segments):
            join = "" if i == 0 else _pick(rng, (", then ", " and then ", ", after that "))
            phrase = action_phrase(seg, 0, rng, with_count=keep_count, with_side=say_side)
            if seg.overlay is not None:
                phrase += " while " + action_phrase(seg.overlay, 1, rng, with_count=False, with_side=False)
            parts.append(join + phrase)
        text = re.sub(r"\s+", " ", f"{_pick(rng, SUBJECTS)} {''.join(parts)}").strip()
        if text not in out:
            out.append(text)
    return out


def words(text: str) -> list[str]:
    """Lowercase words with punctuation stripped (the tokeniser's view)."""
    return re.findall(r"[a-z]+", text.lower())


def vocabulary() -> tuple[str, ...]:
    """Every word any caption of any split can contain (sorted)."""
    found: set[str] = set()

    def add(text: str) -> None:
        found.update(words(text))

    for table in (SUBJECTS, tuple(SEQ_JOIN), _FILLER):
        for t in table:
            add(t)
    for d in (COUNT_WORDS, SPEED_WORDS, STYLE_PHRASES, DIRECTION_WORDS, TURN_WORDS, LIMB):
        for v in d.values():
            for t in v:
                add(t)
    for v in COUNT_NUMBERS.values():
        add(v)
    for forms in VERBS.values():
        for pair in forms:
            for t in pair:
                add(t)
    for d in INTENSITY_WORDS.values():
        for v in d.values():
            for t in v:
                add(t)
    for tpl in list(TEMPLATES.values()) + list(HELD_OUT_TEMPLATES.values()):
        add(re.sub(r"\{\w+\}", " ", tpl))
    for t in ("in place", "up and down", "on the spot", "on one leg", "using", "up", "jumping jacks", "star jumps",
              "leg", "foot", "left", "right", "arm", "hand", "legs", "feet"):
        add(t)
    return tuple(sorted(found))


VOCABULARY_FILE = Path(__file__).with_name("vocabulary.txt")


def write_vocabulary(path: Path = VOCABULARY_FILE) -> Path:
    path.write_text("\n".join(vocabulary()) + "\n")
    return path


# ------------------------------------------------------------------------ HumanML3D tokens
_POS = {
    "a": "DET", "the": "DET", "both": "DET", "this": "DET", "his": "DET", "her": "DET", "its": "DET",
    "someone": "PRON", "we": "PRON", "he": "PRON", "she": "PRON", "and": "CCONJ", "then": "ADV",
    "while": "SCONJ", "before": "ADP", "after": "ADP", "that": "PRON", "afterwards": "ADV", "to": "ADP",
    "in": "ADP", "on": "ADP", "with": "ADP", "like": "ADP", "as": "ADP", "at": "ADP", "toward": "ADP",
    "around": "ADV", "from": "ADP", "up": "ADP", "down": "ADV", "out": "ADP", "is": "AUX", "can": "AUX",
    "be": "AUX", "seen": "VERB", "keeps": "VERB", "once": "ADV", "twice": "ADV", "thrice": "ADV",
    "one": "NUM", "two": "NUM", "three": "NUM", "four": "NUM", "five": "NUM", "left": "ADJ", "right": "ADJ",
    "forward": "ADV", "forwards": "ADV", "ahead": "ADV", "straight": "ADV", "backward": "ADV",
    "backwards": "ADV", "sideways": "ADV", "high": "ADV", "very": "ADV", "little": "ADJ", "tiny": "ADJ",
    "slow": "ADJ", "fast": "ADV", "all": "DET", "way": "NOUN", "here": "ADV", "first": "ADV", "side": "NOUN",
    "other": "ADJ", "low": "ADV", "deeply": "ADV", "elderly": "ADJ", "old": "ADJ", "sad": "ADJ", "happy": "ADJ",
    "drunk": "ADJ", "clockwise": "ADJ", "counterclockwise": "ADJ", "marching": "VERB", "spot": "NOUN",
    "hello": "INTJ", "using": "VERB", "raised": "VERB", "holding": "VERB", "crouching": "VERB",
    "flapping": "VERB", "curving": "VERB", "shows": "VERB", "see": "VERB", "air": "NOUN", "place": "NOUN",
}
_LEMMA = {"feet": "foot", "jacks": "jack", "jumps": "jump", "knees": "knee", "arms": "arm", "hands": "hand",
          "legs": "leg", "times": "time", "keeps": "keep", "shows": "show", "seen": "see", "is": "be"}


def _verb_lemmas() -> dict[str, str]:
    out: dict[str, str] = {}
    for forms in VERBS.values():
        for third, gerund in forms:
            w3, wg = third.split()[0], gerund.split()[0]
            if w3 == "does":
                lemma = "do"
            elif w3.endswith(("ches", "shes", "sses")):
                lemma = w3[:-2]
            else:
                lemma = w3[:-1]
            out[w3] = lemma
            out[wg] = lemma
    return out


_VERB_LEMMA = _verb_lemmas()


def _lemma_pos(word: str) -> tuple[str, str]:
    if word in _VERB_LEMMA:
        return _VERB_LEMMA[word], "VERB"
    if word in _POS:
        pos = _POS[word]
    elif word.endswith("ly"):
        pos = "ADV"
    else:
        pos = "NOUN"
    return _LEMMA.get(word, word), pos


def tokens(text: str) -> str:
    """HumanML3D token string: ``word/POS`` (lemmatised) separated by spaces."""
    return " ".join("/".join(_lemma_pos(w)) for w in words(text))
