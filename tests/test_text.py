"""Word tokeniser: token i is kept word i; unknown words are read by meaning or as a typo's word, or left out with
a note; strict encoding names them with suggestions."""
from __future__ import annotations

import pytest
import torch

from engine.text import PromptError, TextEncoder, Tokenizer, split_words


def tok() -> Tokenizer:
    return Tokenizer(["a", "person", "jumps", "twice", "walks", "forward", "then"])


def test_words_map_to_tokens_in_order():
    t = tok().encode("A person jumps, then walks forward.")
    assert t.words == ("a", "person", "jumps", "then", "walks", "forward")
    assert t.word_index("walks") == 4
    assert split_words("it's 3 o'clock!") == ["it's", "o'clock"]


def test_unknown_words_never_refuse_a_prompt_they_are_read_or_left_out():
    t = tok().encode("a persn jumps thrice happily")
    assert t.words == ("a", "persn", "jumps")  # token i is kept word i; 'persn' a typo read as 'person'
    assert t.ids == tuple(tok().words.index(w) for w in ("a", "person", "jumps"))
    assert t.read_as == {"persn": "person"} and t.read_by == {"persn": "spelling"}
    assert t.left_out == ("thrice", "happily") and not t.exact
    assert t.notes() == ["read 'persn' as 'person'", "left out: thrice, happily"]
    assert t.word_index("jumps") == 2 and t.word_index("persn") == 1 and t.word_index("person") == 1
    with pytest.raises(PromptError, match="'happily' was left out"):
        t.word_index("happily")


def test_strict_encoding_refuses_unknown_words_with_suggestions():
    with pytest.raises(PromptError) as info:
        tok().encode("a persn jumps thrice", strict=True)
    err = info.value
    assert err.unknown == ["persn", "thrice"]
    assert "person" in err.suggestions["persn"]
    assert "persn" in str(err) and "thrice" in str(err)
    assert tok().encode("a person jumps twice", strict=True).exact
    with pytest.raises(PromptError, match="unknown word"):
        tok().batch(["a person jumps", "a person skips"], strict=True)


def test_a_prompt_with_nothing_readable_is_refused_in_one_line():
    for prompt in ("flurbs zzzq", "the flurbs", "qwxyz", "a person flurbs", "two people zzzq"):
        with pytest.raises(PromptError) as info:
            tok().encode(prompt)
        msg = str(info.value)
        assert "\n" not in msg and msg.startswith("unknown word") and info.value.unknown
        assert all(repr(w) in msg for w in info.value.unknown) and ("flurbs" in msg or "zzzq" in msg or "qwxyz" in msg)
    assert tok().encode("a person").words == ("a", "person")  # every word known: read as typed


def test_empty_and_too_long_prompts():
    with pytest.raises(PromptError, match="empty"):
        tok().encode("  ...  ")
    with pytest.raises(PromptError, match="at most"):
        tok().encode("a " * 70)


def test_batch_padding_and_extension_keeps_ids():
    t = tok()
    ids, mask = t.batch(["a person jumps", "a person walks forward then jumps"])
    assert ids.shape == (2, 6) and mask[0].sum() == 3 and not mask[0, 3:].any()
    grown = t.extended(["kicks", "a"])
    assert grown.words[: len(t)] == t.words and "kicks" in grown and len(grown) == len(t) + 1


def test_text_encoder_shapes_and_padding_invariance():
    torch.manual_seed(0)
    enc = TextEncoder(vocab_size=16, width=32, layers=1, heads=2, dropout=0.0).eval()
    ids = torch.tensor([[1, 2, 3, 0, 0]])
    mask = torch.tensor([[True, True, True, False, False]])
    out = enc(ids, mask)
    short = enc(ids[:, :3], mask[:, :3])
    assert out.shape == (1, 5, 32)
    assert torch.allclose(out[:, :3], short, atol=1e-5)  # padding never changes the real words
