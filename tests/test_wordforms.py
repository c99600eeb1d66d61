"""Words a person types: inflections of known words are understood, and unknown words get suggestions by
meaning (one-click rewrites), not by spelling."""
from __future__ import annotations

import pytest

from engine.checkpoint import read_config
from engine.paths import MODEL_DIR
from engine.text import PromptError, Tokenizer
from engine.wordforms import read_as, rewrite, suggestions


@pytest.fixture(scope="module")
def shipped() -> Tokenizer:
    return Tokenizer(read_config(MODEL_DIR)["vocabulary"])


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


def test_the_error_message_offers_the_rewrites(shipped):
    with pytest.raises(PromptError) as info:
        shipped.encode("a tired person skips")
    text = str(info.value)
    assert "'tired' (did you mean 'wearily' (after the verb)" in text and "'skips' (did you mean 'hops'" in text
    assert info.value.unknown == ["tired", "skips"]


def test_a_vocabulary_without_the_target_offers_nothing_it_cannot_read():
    tok = Tokenizer(["a", "person", "walks"])
    assert tok.suggest("skips") == []  # 'hops' is not there: no suggestion the model would refuse
    assert tok.suggest("staggers") == []  # 'unsteadily' missing: the phrase is left out, not half-offered
    assert read_as("strolled", {"strolling"}) == "strolling"
    assert suggestions("strolls", {"walks", "leisurely"}) == ["walks leisurely"]
