"""Words a person types, read against a model's vocabulary: inflections and suggestions by meaning.

* **Inflections.** A word the vocabulary lacks is read as another form of the same word that it has:
  "jump" and "jumped" as "jumps", "running" and "ran" as "runs", "waved" as "waves". The typed word stays the
  prompt's word (chips, attention and edits name it); only its id is the known form's.
* **Suggestions by meaning.** For a word with no known form, a table of motion verbs, adjectives and adverbs maps
  common words onto what the model knows ("skips" -> "hops", "staggers" -> "walks unsteadily", "tired" ->
  "wearily"), conjugated like the typed word. Spelling neighbours come after, and never a mere derivation
  ("tired" -> "tiredly" made "a tiredly old man").

Every table here is in base forms; what a model knows is decided by its own vocabulary alone.
"""
from __future__ import annotations

import difflib
from collections.abc import Collection, Iterable

# irregular forms -> base form
IRREGULAR = {
    "ran": "run", "stood": "stand", "sat": "sit", "threw": "throw", "thrown": "throw", "spun": "spin",
    "swung": "swing", "knelt": "kneel", "leapt": "leap", "fell": "fall", "fallen": "fall", "went": "go",
    "gone": "go", "took": "take", "taken": "take", "did": "do", "done": "do", "got": "get", "strode": "stride",
    "struck": "strike", "rose": "rise", "risen": "rise", "held": "hold", "bent": "bend", "shook": "shake",
    "saw": "see", "crept": "creep", "put": "put", "hit": "hit", "is": "be", "are": "be", "was": "be", "were": "be",
}
_DOUBLED = set("bdgklmnprt")  # consonants doubled before -ing/-ed (hop -> hopping, jog -> jogged)

# base form -> replacement phrases in base form (a verb first is conjugated like the typed word).
# A phrase that starts with "~" is a manner adverb for an adjective: the rewrite moves it after the verb.
SYNONYMS: dict[str, tuple[str, ...]] = {
    # gait
    "stagger": ("walk unsteadily", "walk drunkenly"), "stumble": ("walk unsteadily",), "totter": ("walk unsteadily",),
    "wobble": ("walk unsteadily",), "limp": ("walk unsteadily", "walk slowly"), "lurch": ("walk drunkenly",),
    "stroll": ("walk leisurely",), "amble": ("stroll", "walk leisurely"), "saunter": ("stroll",),
    "wander": ("stroll", "walk slowly"), "meander": ("stroll",), "stride": ("walk", "march"), "trudge": ("walk wearily",),
    "plod": ("walk wearily", "walk slowly"), "shuffle": ("walk slowly",), "tiptoe": ("walk sneakily", "walk stealthily"),
    "sneak": ("walk sneakily", "walk stealthily"), "creep": ("walk stealthily", "walk sneakily"),
    "prowl": ("walk stealthily",), "march": ("walk",), "parade": ("march",), "pace": ("walk",), "step": ("walk",),
    "hurry": ("walk quickly", "run"), "rush": ("run", "dash"), "race": ("run", "sprint"), "sprint": ("run",),
    "dash": ("run",), "jog": ("run", "trot"), "trot": ("jog",), "gallop": ("run",), "scurry": ("run",),
    # jumps and hops
    "skip": ("hop",), "bounce": ("jump", "hop"), "spring": ("jump",), "leap": ("jump",), "bound": ("jump", "leap"),
    "vault": ("jump",), "hop": ("jump",), "jump": ("hop",),
    # low and bent
    "kneel": ("squat", "crouch"), "crouch": ("squat",), "duck": ("crouch", "squat"), "stoop": ("bow", "crouch"),
    "squat": ("crouch",), "bend": ("bow",), "lean": ("bow",), "bow": ("bend",), "sit": ("squat",),
    # arms
    "greet": ("wave",), "salute": ("wave",), "beckon": ("wave",), "signal": ("wave",), "wave": ("raise",),
    "box": ("punch",), "strike": ("punch",), "jab": ("punch",), "hit": ("punch",), "fight": ("punch",),
    "spar": ("punch",), "applaud": ("clap",), "cheer": ("clap",), "toss": ("throw",), "pitch": ("throw",),
    "hurl": ("throw",), "fling": ("throw",), "reach": ("raise",), "stretch": ("raise",), "lift": ("raise",),
    "hold": ("raise",), "boot": ("kick",), "punt": ("kick",),
    # turning and dancing
    "twirl": ("spin",), "pirouette": ("spin",), "whirl": ("spin",), "rotate": ("turn", "spin"), "pivot": ("turn",),
    "spin": ("turn",), "turn": ("rotate",), "wiggle": ("dance",), "boogie": ("dance",), "groove": ("dance",),
    "sway": ("dance",), "shimmy": ("dance",),
    # staying
    "wait": ("stand still",), "pause": ("stand still",), "idle": ("stand still",), "rest": ("stand still",),
    "stop": ("stand still",), "remain": ("stay",), "stay": ("stand",),
    # manner: adjectives (moved after the verb as adverbs) and adverbs
    "tired": ("~wearily", "~tiredly"), "exhausted": ("~wearily",), "weary": ("~wearily",), "sleepy": ("~wearily",),
    "fatigued": ("~wearily",), "angry": ("~vigorously",), "furious": ("~vigorously",), "excited": ("~energetically",),
    "energetic": ("~energetically",), "cheerful": ("~cheerfully",), "joyful": ("~joyfully",), "glad": ("happy",),
    "joyous": ("~joyfully",), "unhappy": ("sad",), "depressed": ("sad",), "miserable": ("sad",), "gloomy": ("sad",),
    "drunken": ("drunk",), "tipsy": ("drunk",), "aged": ("elderly", "old"), "senior": ("elderly",), "quick": ("fast",),
    "rapid": ("fast",), "speedy": ("fast",), "swift": ("fast",), "sluggish": ("slow",), "lazy": ("slow",),
    "sneaky": ("~sneakily",), "stealthy": ("~stealthily",), "careful": ("~slowly",), "robotic": ("~robotically",),
    "angrily": ("vigorously",), "furiously": ("vigorously",), "excitedly": ("energetically",),
    "enthusiastically": ("energetically",), "briskly": ("quickly",), "swiftly": ("quickly",), "hastily": ("quickly",),
    "hurriedly": ("quickly",), "speedily": ("quickly",), "lazily": ("leisurely", "slowly"), "casually": ("leisurely",),
    "carefully": ("slowly", "gently"), "cautiously": ("stealthily", "slowly"), "quietly": ("sneakily", "stealthily"),
    "softly": ("gently",), "gracefully": ("gently",), "elegantly": ("gently",), "wearily": ("tiredly",),
    "exhaustedly": ("wearily",), "merrily": ("happily", "cheerfully"), "gleefully": ("joyfully",),
    "sorrowfully": ("sadly",), "unhappily": ("sadly",), "miserably": ("sadly",), "drunkly": ("drunkenly",),
    "clumsily": ("unsteadily",), "shakily": ("unsteadily",), "mechanically": ("robotically",),
    # people
    "guy": ("man",), "boy": ("man", "person"), "girl": ("woman", "person"), "lady": ("woman",),
    "gentleman": ("man",), "figure": ("person",), "character": ("person",), "individual": ("person",),
    "somebody": ("someone",), "people": ("person",), "adult": ("person",), "dancer": ("person",),
    "athlete": ("person",), "player": ("person",),
}


def base_forms(word: str) -> list[str]:
    """Candidate base forms of ``word`` (itself first): 'hopping' -> hopp, hop, hoppe...; not all are words."""
    word = word.lower()
    out = [word]
    if word in IRREGULAR:
        out.append(IRREGULAR[word])
    if word.endswith("ing") and len(word) > 4:
        stem = word[:-3]
        out += [stem, stem + "e"] + ([stem[:-1]] if len(stem) > 2 and stem[-1] == stem[-2] else [])
    if word.endswith("ied") and len(word) > 4:
        out.append(word[:-3] + "y")
    if word.endswith("ed") and len(word) > 3:
        stem = word[:-2]
        out += [stem, word[:-1]] + ([stem[:-1]] if len(stem) > 2 and stem[-1] == stem[-2] else [])
    if word.endswith("ies") and len(word) > 4:
        out.append(word[:-3] + "y")
    if word.endswith("es") and len(word) > 3:
        out.append(word[:-2])
    if word.endswith("s") and not word.endswith("ss") and len(word) > 2:
        out.append(word[:-1])
    return list(dict.fromkeys(out))


def inflections(base: str) -> dict[str, str]:
    """The regular forms of a base verb or noun: {'base', 's', 'ing', 'ed'} -> form."""
    if base.endswith("e") and not base.endswith("ee"):
        ing, ed = base[:-1] + "ing", base + "d"
    elif (len(base) >= 3 and base[-1] in _DOUBLED and base[-2] in "aeiou" and base[-3] not in "aeiou"
          and len(base) <= 4):
        ing, ed = base + base[-1] + "ing", base + base[-1] + "ed"
    elif base.endswith("y") and len(base) > 2 and base[-2] not in "aeiou":
        ing, ed = base + "ing", base[:-1] + "ied"
    else:
        ing, ed = base + "ing", base + "ed"
    if base.endswith(("s", "x", "z", "ch", "sh")):
        s = base + "es"
    elif base.endswith("y") and len(base) > 2 and base[-2] not in "aeiou":
        s = base[:-1] + "ies"
    else:
        s = base + "s"
    return {"base": base, "s": s, "ing": ing, "ed": ed}


def form_of(word: str) -> str:
    """Which inflection a typed word is: 'ing', 'ed', 's' or 'base'."""
    word = word.lower()
    if word.endswith("ing") and len(word) > 4:
        return "ing"
    if word.endswith("ed") and len(word) > 3 or word in IRREGULAR and IRREGULAR[word] != word:
        return "ed"
    if word.endswith("s") and not word.endswith("ss") and len(word) > 2:
        return "s"
    return "base"


# what a typed form reads as when the vocabulary lacks it: captions say "a person walks", so the -s form first
_PREFERENCE = {"base": ("s", "base", "ing", "ed"), "s": ("s", "base", "ing", "ed"),
               "ed": ("ed", "s", "base", "ing"), "ing": ("ing", "s", "base", "ed")}


def read_as(word: str, known: Collection[str]) -> str | None:
    """The vocabulary word a typed word is read as: itself when known, else a known form of the same word
    (same inflection first, then the -s form), else None."""
    word = word.lower()
    if word in known:
        return word
    bases = base_forms(word)[1:] + [word]
    for kind in _PREFERENCE[form_of(word)]:
        for base in bases:
            form = inflections(base)[kind]
            if form in known:
                return form
    return None


def conjugate(phrase: str, like: str, known: Collection[str]) -> str | None:
    """``phrase`` (base forms) with its first word in ``like``'s inflection, every word read against ``known``;
    None when a word has no known form."""
    words = phrase.split()
    if not words:
        return None
    first = inflections(words[0])[form_of(like)]
    out = [read_as(first, known)] + [read_as(w, known) for w in words[1:]]
    return None if None in out else " ".join(out)


def meaning_suggestions(word: str, known: Collection[str]) -> list[str]:
    """Replacements by meaning for an unknown ``word`` (phrases of known words; '~adverb' = move after the verb)."""
    word = word.lower()
    out: list[str] = []
    for base in base_forms(word):
        for phrase in SYNONYMS.get(base, ()):
            if phrase.startswith("~"):
                adverb = read_as(phrase[1:], known)
                hit = None if adverb is None else "~" + adverb
            elif base == word and form_of(word) != "base" and word not in IRREGULAR:
                hit = conjugate(phrase, "x", known)  # an adjective or adverb that only looks inflected
            else:
                hit = conjugate(phrase, word, known)
            if hit and hit not in out and hit != word:
                out.append(hit)
        if out:
            break
    return out


def spelling_suggestions(word: str, known: Iterable[str], *, n: int = 3) -> list[str]:
    """Close spellings (typos), leaving out mere derivations of the typed word ('tired' -> 'tiredly')."""
    word = word.lower()
    close = difflib.get_close_matches(word, list(known), n=n + 3, cutoff=0.75)
    derived = ("ly", "ily", "ness", "er", "est")
    keep = [c for c in close if not any(c == word + d or word == c + d for d in derived)]
    return keep[:n]


def suggestions(word: str, known: Collection[str], *, n: int = 3) -> list[str]:
    """What to offer for an unknown word: by meaning; close spellings (typos) only where no meaning is known."""
    return (meaning_suggestions(word, known) or spelling_suggestions(word, known, n=n))[:n]


def rewrite(prompt: str, word: str, replacement: str) -> str:
    """``prompt`` with ``word`` (whole word, case-insensitive) replaced. A '~adverb' replacement removes the word and
    puts the adverb at the end of its clause ("a tired man walks, then sits" -> "a man walks wearily, then sits")."""
    import re

    pattern = re.compile(rf"(?i)\b{re.escape(word)}\b")
    if not replacement.startswith("~"):
        return pattern.sub(replacement, prompt)
    match = pattern.search(prompt)
    if match is None:
        return prompt
    before, after = prompt[: match.start()].rstrip(), prompt[match.end():].lstrip()
    end = re.search(r"[,.;!?]|\s(?:then|and|while|before|after)\s", after)
    cut = end.start() if end else len(after.rstrip())
    after = after[:cut].rstrip() + " " + replacement[1:] + after[cut:]
    if re.search(r"(?i)\ba$", before) and re.match(r"(?i)[aeiou]", after):
        before += "n"  # "a tired old man" -> "an old man ..."
    return (before + " " + after).strip() if before else after.strip()


def shown(replacement: str) -> str:
    """A suggestion as a person reads it: 'hops', or 'wearily' (after the verb) for a moved adverb."""
    return f"'{replacement[1:]}' (after the verb)" if replacement.startswith("~") else repr(replacement)
