"""Words a person types, read against a model's vocabulary: inflections and suggestions by meaning.

* **Inflections.** A word the vocabulary lacks is read as another form of the same word that it has:
  "jump" and "jumped" as "jumps", "running" and "ran" as "runs", "waved" as "waves". The typed word stays the
  prompt's word (chips, attention and edits name it); only its id is the known form's.
* **Suggestions by meaning.** For a word with no known form, a table of motion verbs, adjectives and adverbs maps
  common words onto what the model knows ("skips" -> "hops", "staggers" -> "walks unsteadily", "tired" ->
  "wearily"), conjugated like the typed word. Spelling neighbours come after, and never a mere derivation
  ("tired" -> "tiredly" made "a tiredly old man").

* **Reading by meaning.** :func:`meaning_word` reads a word the vocabulary lacks as ONE known word of the same
  meaning ("skips" -> "hops", "stiffly" -> "robotically", "staggers" -> "drunkenly", "guy" -> "man"), so that
  token i stays word i of the prompt. A gait verb whose point is its manner reads as the manner ("staggers" ->
  "drunkenly", "tiptoes" -> "sneakily"): a moving prompt walks anyway, the manner is what the word adds.
* **Typos, not words.** :func:`is_english` tells a real English word (lemminflect's offline lexicon of ~70k
  word forms, plus the function words it lacks) from a typo. Only a typo gets spelling suggestions, and
  :func:`typo_reading` reads it as the one known word it is a slip of ("jumsp" -> "jumps"), when there is one.

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
    """What to offer for an unknown word: by meaning; close spellings only for a typo (a word that is not English:
    'head', 'them', 'away' get none) and only where no meaning is known."""
    by_meaning = meaning_suggestions(word, known)
    if by_meaning or is_english(word):
        return by_meaning[:n]
    return spelling_suggestions(word, known, n=n)


# ------------------------------------------------------------------------------------------ English or typo
# Closed-class words (pronouns, determiners, prepositions, conjunctions, auxiliaries...) that lemminflect's lexicon
# of nouns, verbs, adjectives and adverbs lacks, and a few informal words people type.
FUNCTION_WORDS = frozenset("""
a an the this that these those some any each every either neither no none all both half such what which whose
i me my mine myself you your yours yourself yourselves he him his himself she her hers herself it its itself we us
our ours ourselves they them their theirs themselves who whom whoever whatever whichever someone somebody something
anyone anybody anything everyone everybody everything nobody nothing one ones
and or but nor so yet if then than because as while whilst until till unless although though whereas whether once
when whenever where wherever why how after before since
about above across after against along amid among amongst around as at before behind below beneath beside besides
between beyond by despite down during except for from in inside into like near of off on onto out outside over
past per round since than through throughout to toward towards under underneath unlike until up upon via with
within without
am is are was were be been being do does did doing done have has had having will would shall should can could may
might must ought 'll 're 've 'd 's 'm n't not
there here just very too also again still even only maybe perhaps please okay ok yeah yes hey hi
away back home apart together along aside ahead forth around about somewhere anywhere everywhere nowhere
""".split())

# words that say who or how many, not what to do: a prompt of only these (after leaving words out) is refused
NOT_A_MOTION = FUNCTION_WORDS | frozenset("""
person persons people man men woman women human humans guy someone somebody figure character individual subject
kid child boy girl lady two three four five six one once twice thrice times time
""".split())

_LEMMAS = None  # lemminflect.getAllLemmas once imported; False when it cannot be


def _in_lexicon(word: str) -> bool:
    """Whether lemminflect's offline English lexicon (SPECIALIST, ~70k word forms, loaded once in ~0.2 s) has
    ``word`` as a noun, verb, adjective or adverb form. Without lemminflect: only the hand lists decide."""
    global _LEMMAS
    if _LEMMAS is None:
        try:
            from lemminflect import getAllLemmas

            _LEMMAS = getAllLemmas
        except Exception:  # noqa: BLE001 - not installed or unreadable
            _LEMMAS = False
    return bool(_LEMMAS and _LEMMAS(word))


def is_english(word: str) -> bool:
    """Whether ``word`` is an English word (any inflection), not a typo: 'head', 'them', 'away', 'stiffly' are;
    'jumsp', 'persn' are not."""
    word = word.lower().replace("\u2019", "'")
    if word in FUNCTION_WORDS or word in IRREGULAR or word in MEANING or word in SYNONYMS:
        return True
    head, _, tail = word.partition("'")
    if tail:  # "she's", "don't", "o'clock"
        return bool(head) and (is_english(head[:-1] if tail == "t" and head.endswith("n") else head)
                               if tail in ("s", "t", "ll", "re", "ve", "d", "m") else _in_lexicon(word))
    return any(b in MEANING or _in_lexicon(b) for b in base_forms(word))


def edit_distance(a: str, b: str) -> int:
    """Damerau-Levenshtein distance (optimal string alignment): a swap of two neighbours is one edit."""
    prev2: list[int] | None = None
    prev = list(range(len(b) + 1))
    for i in range(1, len(a) + 1):
        cur = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            cost = a[i - 1] != b[j - 1]
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost)
            if prev2 is not None and i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                cur[j] = min(cur[j], prev2[j - 2] + 1)
        prev2, prev = prev, cur
    return prev[-1]


def typo_reading(word: str, known: Collection[str]) -> str | None:
    """The known word a typo is a slip of ("jumsp" -> "jumps", "persn" -> "person"): only for a word of 4+ letters
    that is not English, one edit away (a letter added, dropped, changed, or two neighbours swapped) from exactly
    one known word, with the same first letter (or the first two swapped)."""
    word = word.lower()
    if len(word) < 4 or word in known or is_english(word):
        return None
    hits = [k for k in known if abs(len(k) - len(word)) <= 1 and (k[0] == word[0] or k[:2] == word[1::-1])
            and edit_distance(word, k) == 1]
    if len(hits) > 1:  # "jumsp": "jumps" (two letters swapped) over "jump" (one dropped)
        hits = [k for k in hits if sorted(k) == sorted(word)] or hits
    return hits[0] if len(hits) == 1 else None


# ------------------------------------------------------------------------------------------ reading by meaning
# base form -> known words of the same meaning, best first, ONE word each (token i stays word i). A verb is
# conjugated like the typed word ("skipped" -> "hopped" or another known form of "hop"); other words are read as
# they are. The first candidate the vocabulary has wins; none: the word is left out.
_GAIT_UNSTEADY = ("drunkenly", "unsteadily", "walk")
_GAIT_SNEAKY = ("sneakily", "stealthily", "walk")
_GAIT_WEARY = ("wearily", "tiredly", "walk")
_GAIT_EASY = ("stroll", "leisurely", "walk")
_RUN = ("run", "sprint", "dash")
MEANING: dict[str, tuple[str, ...]] = {
    # gait: a verb whose point is its manner reads as the manner
    **dict.fromkeys(("stagger", "stumble", "lurch", "totter", "wobble", "teeter", "reel", "sway"), _GAIT_UNSTEADY),
    "limp": ("unsteadily", "slowly", "walk"), "hobble": ("unsteadily", "slowly", "walk"),
    **dict.fromkeys(("tiptoe", "sneak", "creep", "prowl", "slink", "skulk"), _GAIT_SNEAKY),
    **dict.fromkeys(("trudge", "plod", "drag", "slog"), _GAIT_WEARY),
    **dict.fromkeys(("amble", "saunter", "wander", "meander", "mosey", "promenade"), _GAIT_EASY),
    "stroll": ("walk", "leisurely"), "shuffle": ("walk", "slowly"), "stride": ("walk", "march"),
    "march": ("walk", "marching"), "parade": ("march", "walk"), "pace": ("walk",), "step": ("walk",),
    "go": ("walk", "move"), "come": ("walk", "move"), "cross": ("walk",),
    "strut": ("proudly", "walk"), "swagger": ("proudly", "walk"),
    # running
    **dict.fromkeys(("hurry", "rush", "race", "scurry", "scamper", "bolt", "flee", "gallop", "scramble"), _RUN),
    "sprint": ("run", "dash"), "dash": ("run", "sprint"), "run": ("sprint", "jog"), "jog": ("trot", "run"),
    "trot": ("jog", "run"), "walk": ("stroll", "pace"),
    # jumps and hops
    "skip": ("hop", "jump"), "bounce": ("jump", "hop"), "spring": ("jump", "leap"), "leap": ("jump", "hop"),
    "bound": ("jump", "leap"), "vault": ("jump", "leap"), "hop": ("jump",), "jump": ("leap", "hop"),
    "pounce": ("jump", "leap"),
    # low and bent
    "kneel": ("crouch", "squat"), "crouch": ("squat",), "duck": ("crouch", "squat"), "squat": ("crouch",),
    "stoop": ("bend", "bow", "crouch"), "hunch": ("bend", "crouch"), "bend": ("bow",), "lean": ("bend", "bow"),
    "bow": ("bend",), "sit": ("squat", "crouch"), "curtsy": ("bow",), "nod": ("bow",),
    # arms
    **dict.fromkeys(("greet", "salute", "beckon", "signal", "gesture", "motion"), ("wave",)),
    **dict.fromkeys(("box", "strike", "jab", "hit", "fight", "spar", "smack", "slap", "swing"), ("punch",)),
    "applaud": ("clap",), "cheer": ("clap", "happily"), "toss": ("throw",), "pitch": ("throw",),
    "hurl": ("throw",), "fling": ("throw",), "lob": ("throw",),
    **dict.fromkeys(("reach", "stretch", "lift", "hold", "hoist", "elevate", "extend"), ("raise", "lift")),
    "raise": ("lift",), "lower": ("lower", "down"), "drop": ("lower", "down"),
    "boot": ("kick",), "punt": ("kick",), "stomp": ("kick", "walk"), "stamp": ("kick",),
    "flap": ("flapping",), "flail": ("flapping",),
    # turning and dancing
    **dict.fromkeys(("twirl", "pirouette", "whirl", "swirl"), ("spin", "turn")),
    "rotate": ("turn", "spin"), "pivot": ("turn", "rotate"), "spin": ("turn", "rotate"), "turn": ("rotate", "spin"),
    "circle": ("circle",),
    **dict.fromkeys(("wiggle", "boogie", "groove", "shimmy", "jive", "twist", "rock", "tango", "waltz", "disco"),
                    ("dance",)),
    # staying
    **dict.fromkeys(("wait", "pause", "idle", "rest", "stop", "freeze", "halt", "linger", "stand"), ("stand", "stay")),
    "remain": ("stay", "stand"), "stay": ("stand",),
    # manner: adjectives and adverbs
    **dict.fromkeys(("tired", "exhausted", "weary", "sleepy", "fatigued", "worn", "wearily", "exhaustedly"),
                    ("wearily", "tiredly", "slowly")),
    **dict.fromkeys(("angry", "furious", "mad", "angrily", "furiously", "fiercely", "aggressively", "forcefully",
                     "powerfully", "strongly", "violently"), ("vigorously", "energetically")),
    **dict.fromkeys(("excited", "energetic", "lively", "excitedly", "enthusiastically", "eagerly", "wildly",
                     "vigorous", "dynamic", "dynamically", "actively"), ("energetically", "vigorously")),
    **dict.fromkeys(("cheerful", "joyful", "glad", "joyous", "merry", "merrily", "gleefully", "gleeful", "cheerily",
                     "joyously", "playful", "playfully", "gladly", "delightedly", "happy"),
                    ("happily", "cheerfully", "joyfully", "happy")),
    **dict.fromkeys(("unhappy", "depressed", "miserable", "gloomy", "sorrowful", "upset", "sorrowfully",
                     "unhappily", "miserably", "mournfully", "glumly", "dejected", "sadly"),
                    ("sadly", "gloomily", "dejectedly", "sad")),
    **dict.fromkeys(("drunken", "tipsy", "intoxicated", "drunkly", "wobbly", "shaky", "shakily", "clumsy",
                     "clumsily", "unsteady", "dizzy", "dizzily", "groggy", "groggily"),
                    ("drunkenly", "unsteadily", "drunk")),
    **dict.fromkeys(("aged", "senior", "elder", "older", "frail", "feeble", "feebly"), ("elderly", "old")),
    **dict.fromkeys(("quick", "rapid", "speedy", "swift", "hasty", "briskly", "swiftly", "hastily", "hurriedly",
                     "speedily", "rapidly", "fast", "brisk"), ("quickly", "fast", "rapidly")),
    **dict.fromkeys(("sluggish", "lazy", "lazily", "sluggishly", "leisurely", "unhurried", "unhurriedly",
                     "casually", "casual", "relaxed", "calmly", "calm"), ("leisurely", "slowly", "slow")),
    **dict.fromkeys(("careful", "carefully", "cautious", "cautiously", "gradually", "steadily"), ("slowly", "gently")),
    **dict.fromkeys(("soft", "softly", "graceful", "gracefully", "elegant", "elegantly", "smoothly", "smooth",
                     "delicately", "lightly", "tenderly"), ("gently", "slowly")),
    **dict.fromkeys(("sneaky", "stealthy", "quiet", "quietly", "silently", "secretly", "furtively", "covertly"),
                    ("sneakily", "stealthily")),
    **dict.fromkeys(("robotic", "mechanical", "stiff", "stiffly", "rigid", "rigidly", "jerky", "jerkily",
                     "awkward", "awkwardly", "mechanically", "robotically"), ("robotically", "mechanically")),
    **dict.fromkeys(("proud", "confident", "confidently", "boldly", "bold", "majestically", "regally", "proudly"),
                    ("proudly",)),
    **dict.fromkeys(("low", "lowly", "deep"), ("low", "deeply")),
    **dict.fromkeys(("tall", "high", "highly", "upward", "upwards", "skyward"), ("high", "up")),
    "downward": ("down",), "downwards": ("down",), "slightly": ("little",), "somewhat": ("slightly", "little"),
    "repeatedly": ("twice",), "twice": ("two",), "thrice": ("three",), "again": ("twice",),
    # directions
    "towards": ("toward",), "toward": ("towards",), "onward": ("forward",), "onwards": ("forward",),
    "ahead": ("forward",), "forth": ("forward",),  # not "back": "steps back", but "stands back up", "his back"
    "backward": ("backwards",), "backwards": ("backward",), "round": ("around",), "about": ("around",),
    "sideway": ("sideways",), "sidewards": ("sideways",), "aside": ("sideways",),
    "anticlockwise": ("counterclockwise",), "clockwise": ("clockwise",),
    # people
    **dict.fromkeys(("guy", "boy", "gentleman", "dude", "fellow", "lad", "he", "him", "himself", "male", "sir"),
                    ("man", "person")),
    **dict.fromkeys(("girl", "lady", "gal", "she", "herself", "female", "madam"), ("woman", "person")),
    **dict.fromkeys(("kid", "child", "toddler", "teen", "teenager", "youngster", "figure", "character",
                     "individual", "people", "adult", "dancer", "athlete", "player", "actor", "performer",
                     "human", "they", "subject", "avatar", "model", "mannequin", "user", "somebody", "anyone",
                     "i", "student", "worker", "boxer", "fighter", "runner", "jogger", "walker", "ninja", "warrior",
                     "gymnast", "acrobat", "skater", "man", "woman"), ("person", "someone", "human")),
    "someone": ("person",), "person": ("someone", "human"),
    "grandpa": ("elderly", "old", "man"), "grandma": ("elderly", "old", "woman"),
    # body
    "fist": ("hand",), "palm": ("hand",), "finger": ("hand",), "wrist": ("hand",), "elbow": ("arm",),
    "shoulder": ("arm",), "toe": ("foot",), "heel": ("foot",), "ankle": ("foot",), "knee": ("knees",),
    "limb": ("arm", "leg"), "hand": ("arm",), "arm": ("hand",), "foot": ("leg",), "leg": ("foot",),
}


def is_manner_verb(word: str) -> bool:
    """A gait verb read as its manner ("staggers" -> "drunkenly"), whose last meaning is the plain verb ("walks")."""
    return any((c := MEANING.get(b)) and c[0].endswith("ly") and c[-1] == "walk" for b in base_forms(word))


def meaning_words(word: str, known: Collection[str]) -> list[str]:
    """Every known word an unknown ``word`` may be read as by meaning, best first: each candidate in the typed
    word's inflection where the vocabulary has it ("kneels" -> "squats" before "crouch"), then in any known form.
    Empty when the table has no meaning for it that the vocabulary knows."""
    word = word.lower()
    for base in base_forms(word):
        candidates = MEANING.get(base)
        if not candidates:
            continue
        inflected = base != word or word in IRREGULAR
        exact: list[str] = []
        for cand in candidates:
            forms = inflections(cand)
            if inflected and forms[form_of(word)] in known:
                exact.append(forms[form_of(word)])
            elif cand in known and (not inflected or not any(f in known for f in forms.values() if f != cand)):
                exact.append(cand)  # a word with no other known form (an adverb, "down"): as it is
        loose = [hit for cand in candidates if (hit := read_as(cand, known)) is not None]
        return [w for w in dict.fromkeys(exact + loose) if w != word]
    return []  # (the first base form with a meaning decides: "kids" never falls through to "kid" + s)


def meaning_word(word: str, known: Collection[str]) -> str | None:
    """The ONE known word an unknown ``word`` is read as by meaning ("skips" -> "hops", "stiffly" ->
    "robotically", "he" -> "man"); None when the table has none the vocabulary knows."""
    hits = meaning_words(word, known)
    return hits[0] if hits else None


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
