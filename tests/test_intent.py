"""The prompt -> intent parser: synonyms, inflections, counts, sides, order, unknown words, and every
caption of a corpus slice parsed back to its own program."""
from __future__ import annotations

import pytest

from engine.intent import IntentSegment, lemma, parse_intent
from engine.synth import Corpus


def seg(text: str, k: int = 0) -> IntentSegment:
    return parse_intent(text).segments[k]


def test_synonyms_parse_to_the_same_intent():
    a = parse_intent("waves the left hand")
    b = parse_intent("waving hello with the left arm")
    assert a.segments == b.segments == (IntentSegment(action="wave", side="left"),)
    assert a.complete and b.complete


def test_inflections_and_base_forms():
    assert lemma("waving") == "wave" and lemma("hopped") == "hop" and lemma("punches") == "punch"
    assert lemma("ran") == "run" and lemma("jumps") == "jump"
    for text in ("walk", "walked", "walking", "walks"):
        assert seg(f"a person {text}").action == "walk"
    assert seg("someone sprinted").action == "run"


def test_unstated_attributes_stay_open():
    s = seg("a person waves")
    assert (s.action, s.count, s.side, s.direction) == ("wave", None, None, None)


@pytest.mark.parametrize("text,count", [("jumps once", 1), ("jumps twice", 2), ("jumps 3 times", 3),
                                        ("jumps four times", 4), ("does five jumping jacks", 5),
                                        ("jumps thrice", 3)])
def test_counts(text, count):
    assert seg(f"a person {text}").count == count


def test_sides_directions_and_disambiguation():
    assert seg("a man hops on the right leg three times") == IntentSegment(action="hop", count=3, side="right")
    assert seg("someone kicks out with the left foot two times") == IntentSegment(action="kick", count=2, side="left")
    assert seg("a person punches with both hands").side == "both"
    assert seg("a person walks to the left").direction == "left"
    assert seg("a man runs in a circle").direction == "circle"
    assert seg("a person turns around").direction == "around"
    assert seg("a person walks backwards").action == "walk_backward"
    assert seg("someone steps sideways to the left") == IntentSegment(action="side_step", direction="left")
    assert seg("a person jumps forward twice").action == "jump_forward"
    assert seg("a person jumps on one leg").action == "hop"


def test_sequences_keep_time_order():
    assert [s.action for s in parse_intent("a person walks forward then jumps twice").segments] == ["walk", "jump"]
    assert [s.action for s in parse_intent("a man jumps once, then claps twice, then bows").segments] == \
        ["jump", "clap", "bow"]
    assert [s.action for s in parse_intent("a person claps after jumping").segments] == ["jump", "clap"]
    assert [s.action for s in parse_intent("after jumping, a man claps").segments] == ["jump", "clap"]
    over = seg("someone walks while waving the right hand")
    assert over.action == "walk" and over.overlay == IntentSegment(action="wave", side="right")


def test_styles_and_unknown_words():
    assert parse_intent("a zombie walks slowly").style == "zombie"
    assert parse_intent("a man jumps like a monkey").style == "gorilla"
    unknown = parse_intent("a person flurbs")
    assert unknown.segments == () and unknown.unplaced == ("flurbs",) and not unknown.complete
    partly = parse_intent("a person walks mysteriously")
    assert partly.segments[0].action == "walk" and partly.unplaced == ("mysteriously",)
    assert "not understood: mysteriously" in partly.describe()


def test_words_outside_the_lexicon_are_read_by_meaning():
    staggers = parse_intent("a person staggers forward stiffly")  # a gait verb read as a walk with its manner
    assert [s.action for s in staggers.segments] == ["walk"] and staggers.segments[0].direction == "forward"
    assert staggers.style == "drunk" and staggers.complete
    assert [s.action for s in parse_intent("a kid skips twice").segments] == ["hop"]
    assert parse_intent("a person walks gracefully").segments[0].speed == "slowly"  # gracefully -> gently
    assert parse_intent("she's waving").segments[0].action == "wave"


def test_the_intent_of_what_the_model_reads():
    """With the tokenizer's reading: words it left out are ignored, words it read by meaning or as a typo's
    word are read the same way."""
    from engine.text import Tokenizer

    tok = Tokenizer(["a", "person", "man", "jumps", "walks", "hops", "drunkenly", "forward", "then", "both", "hands",
                     "lifts", "the", "twice"])
    typed = "a man jumsp twice then lifts both hands above the head"
    read = tok.encode(typed)
    assert read.read_as["jumsp"] == "jumps" and set(read.left_out) == {"above", "head"}
    intent = parse_intent(typed, read)
    assert [s.action for s in intent.segments] == ["jump", "raise_arms"] and intent.segments[0].count == 2
    assert intent.unplaced == ()  # 'above', 'head' were left out: not asked for
    assert "jumsp" in parse_intent(typed).unplaced  # on its own the parser knows no typos
    for prompt in ("a person staggers forward stiffly", "a guy stiffly walks over and waves at someone",
                   "the woman staggers forward like she is drunk", "someone tiptoes sneakily across the room"):
        parse_intent(prompt)  # never raises
        try:
            parse_intent(prompt, tok.encode(prompt))
        except Exception as exc:  # noqa: BLE001 - only the tokenizer's PromptError (nothing readable) is allowed
            assert type(exc).__name__ == "PromptError", exc


def test_corpus_captions_parse_back_to_their_programs():
    corpus = Corpus("test")
    wrong = []
    for i in range(60):
        s = corpus.sample(i, with_features=False)
        want = [(g.action, g.count if g.action in ("jump", "jump_forward", "hop", "jumping_jacks", "squat", "kick",
                                                  "punch", "wave", "clap", "raise_arms", "bow") else None)
                for g in s.program.segments]
        for cap in s.captions:
            intent = parse_intent(cap)
            if [(g.action, g.count) for g in intent.segments] != want or intent.unplaced:
                wrong.append(cap)
    assert not wrong, wrong[:3]


def test_a_clause_without_an_action_modifies_the_one_before():
    assert seg("a person walks forward, slowly") == IntentSegment(action="walk", direction="forward", speed="slowly")
    assert seg("a man runs, to the left").direction == "left"
    assert len(parse_intent("a person walks forward, slowly").segments) == 1
