"""Words a person types: inflections of known words are understood, and unknown words get suggestions by
meaning (one-click rewrites), not by spelling."""
from __future__ import annotations

from pathlib import Path

import pytest

from engine.text import PromptError, Tokenizer
from engine.wordforms import edit_distance, is_english, read_as, rewrite, suggestions, typo_reading


@pytest.fixture(scope="module")
def shipped() -> Tokenizer:
    # the 214-word vocabulary of the step-16000 model (shipped until session 23): it lacks the base forms ("walk")
    # and many words people type, which is what these tests are about
    words = (Path(__file__).parent / "data" / "vocabulary_step16000.txt").read_text(encoding="utf-8").split()
    return Tokenizer(words)


@pytest.mark.parametrize("typed, known", [
    ("walk", "walks"), ("jump", "jumps"), ("kick", "kicks"), ("run", "runs"), ("wave", "waves"),
    ("jumped", "jumps"), ("waved", "waves"), ("hopped", "hops"), ("squatted", "squats"), ("clapped", "claps"),
    ("ran", "runs"), ("spun", "spins"), ("stood", "stands"), ("threw", "throws"), ("punched", "punches"),
    ("strolls", "strolls"), ("walking", "walking"), ("dance", "dance"),
])
def test_inflections_of_known_words_are_read_as_a_known_form(shipped, typed, known):
    assert shipped.read_as(typed) == known


def test_a_prompt_with_base_forms_encodes_as_its_known_forms(shipped):
    plain = shipped.encode("a person jumps twice then kicks")
    typed = shipped.encode("a person jump twice then kick")
    assert typed.ids == plain.ids
    assert typed.words == ("a", "person", "jump", "twice", "then", "kick")  # the words stay the user's
    assert typed.word_index("jump") == 2
    assert shipped.inflected("a person jump twice then kick") == {"jump": "jumps", "kick": "kicks"}
    assert shipped.unknown_words("someone walked and waved") == []


@pytest.mark.parametrize("typed, expected", [
    ("skips", "hops"), ("staggers", "walks unsteadily"), ("greets", "waves"), ("twirls", "spins"),
    ("bounced", "jumps"), ("tiptoes", "walks sneakily"), ("guy", "man"), ("angrily", "vigorously"),
])
def test_unknown_words_get_suggestions_by_meaning(shipped, typed, expected):
    assert shipped.read_as(typed) is None
    assert shipped.suggest(typed)[0] == expected


def test_an_adjective_becomes_an_adverb_after_the_verb_never_a_derivation(shipped):
    offered = shipped.suggest("tired")
    assert offered[0] == "~wearily" and "tiredly" not in offered  # 'tiredly' made "a tiredly old man"
    assert rewrite("a tired old man walks to the left, then stops", "tired", offered[0]) == \
        "an old man walks to the left wearily, then stops"
    assert shipped.unknown_words(rewrite("A tired man walks", "tired", "~wearily")) == []
    assert rewrite("a man staggers forward", "staggers", "walks unsteadily") == "a man walks unsteadily forward"


def test_spelling_only_for_typos_and_only_without_a_meaning(shipped):
    assert shipped.suggest("jumsp") == ["jumps"]
    assert shipped.suggest("staggers") and "star" not in shipped.suggest("staggers")
    assert shipped.suggest("qwxyz") == []
    # English words are not typos: no spelling neighbours (the head -> ahead, them -> the, away -> way)
    for word in ("head", "them", "away", "stiffly", "above"):
        assert is_english(word) and not any(s in ("ahead", "the", "way") for s in shipped.suggest(word)), word
    for typo in ("jumsp", "persn", "walsk", "qwxyz"):
        assert not is_english(typo)
    assert is_english("she's") and is_english("don't") and is_english("staggered") and is_english("tiptoeing")


def test_typos_are_read_only_when_one_known_word_is_that_close():
    known = {"jumps", "jump", "person", "walks", "waves", "wave", "hops", "the"}
    assert typo_reading("jumsp", known) == "jumps"  # two letters swapped, over 'jump' (one dropped)
    assert typo_reading("persn", known) == "person"
    assert typo_reading("wavs", known) is None  # 'waves' and 'wave' equally close: not guessed
    assert typo_reading("head", known) is None and typo_reading("them", known) is None  # English: never a typo
    assert typo_reading("flurbs", known) is None and typo_reading("teh", known) is None  # too short to guess
    assert edit_distance("jumsp", "jumps") == 1 and edit_distance("flurbs", "four") > 2


@pytest.mark.parametrize("typed, read", [
    ("skips", "hops"), ("stiffly", "robotically"), ("staggers", "drunkenly"), ("guy", "man"), ("kid", "person"),
    ("twirls", "spins"), ("kneels", "squats"), ("excitedly", "energetically"), ("fist", "hand"),
])
def test_unknown_words_are_read_by_meaning_as_one_known_word(shipped, typed, read):
    assert shipped.read_as(typed) is None
    assert shipped.reading(typed) == (read, "meaning")


def test_encode_reads_by_meaning_and_leaves_out_the_rest_with_notes(shipped):
    t = shipped.encode("a guy stiffly walks over to the head")
    assert t.words == ("a", "guy", "stiffly", "walks", "to", "the")  # 'over', 'head' have no token
    assert [shipped.words[i] for i in t.ids] == ["a", "man", "robotically", "walks", "to", "the"]
    assert t.left_out == ("over", "head")
    assert t.notes() == ["read 'guy' as 'man'", "read 'stiffly' as 'robotically'", "left out: over, head"]
    assert t.read_by == {"guy": "meaning", "stiffly": "meaning"}
    # a manner the prompt already says is not said twice: the gait verb is read as the plain verb
    sneaky = shipped.encode("someone tiptoes sneakily")
    assert [shipped.words[i] for i in sneaky.ids] == ["someone", "walks", "sneakily"]
    # inflections are the same word: read, but no note
    jump = shipped.encode("a person jump twice")
    assert jump.read_as == {"jump": "jumps"} and jump.read_by == {"jump": "form"} and jump.notes() == []
    assert jump.exact


NATURAL_PROMPTS = (
    "a guy stiffly walks over and waves at someone", "someone hops on their left foot three times",
    "a person lifts both hands above the head then lowers them", "the woman staggers forward like she is drunk",
    "a kid skips happily in a circle", "he shuffles slowly to the right", "a dancer spins around twice",
    "a man jumsp up and down", "a tired old man trudges to the left and sits down",
    "someone tiptoes sneakily across the room", "a boxer throws a few punches with his right fist",
    "a girl waves hello with her left hand then runs away", "the person kneels down and then stands back up",
    "a soldier marches proudly forward", "she twirls around happily and claps her hands",
    "a person walks backwards slowly while waving", "someone kicks with the right leg, then punches twice",
    "a zombie limps forward awkwardly", "a child bounces up and down excitedly",
    "an elderly woman strolls leisurely in a circle", "a man sprints forward then stops suddenly",
)


@pytest.mark.parametrize("vocabulary", ["shipped", "synth"])
def test_natural_prompts_are_never_refused(shipped, vocabulary):
    from engine.intent import parse_intent
    from engine.paths import PROJECT_ROOT as ROOT

    tok = shipped if vocabulary == "shipped" else Tokenizer((ROOT / "engine/synth/vocabulary.txt").read_text().split())
    for prompt in NATURAL_PROMPTS:
        t = tok.encode(prompt)
        assert len(t.words) == len(t.ids) and all(t.ids)
        assert not set(t.words) & set(t.left_out)
        for note in t.notes():
            assert note.startswith(("read '", "left out: ")), note
        parse_intent(prompt, t)
    # the nonsense corrections are gone: these words are known, left out or read by meaning, never
    # read as a spelling neighbour (head -> ahead, them -> the, away -> way)
    t = tok.encode("a person lifts both hands above the head then lowers them and walks away")
    for word in ("head", "them", "away"):
        assert word in tok or word in t.left_out or t.read_by.get(word) == "meaning", word
        assert t.read_by.get(word) != "spelling" and not set(tok.suggest(word)) & {"ahead", "the", "way"}


def test_the_strict_error_message_offers_the_rewrites(shipped):
    with pytest.raises(PromptError) as info:
        shipped.encode("a tired person skips", strict=True)
    text = str(info.value)
    assert "'tired' (did you mean 'wearily' (after the verb)" in text and "'skips' (did you mean 'hops'" in text
    assert info.value.unknown == ["tired", "skips"]


def test_a_vocabulary_without_the_target_offers_nothing_it_cannot_read():
    tok = Tokenizer(["a", "person", "walks"])
    assert tok.suggest("skips") == []  # 'hops' is not there: no suggestion the model would refuse
    assert tok.suggest("staggers") == []  # 'unsteadily' missing: the phrase is left out, not half-offered
    assert read_as("strolled", {"strolling"}) == "strolling"
    assert suggestions("strolls", {"walks", "leisurely"}) == ["walks leisurely"]
