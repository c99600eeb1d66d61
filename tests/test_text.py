"""Word tokeniser: token i is word i; unknown words are named with suggestions."""
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


def test_unknown_words_are_reported_by_name_with_suggestions():
    with pytest.raises(PromptError) as info:
        tok().encode("a persn jumps thrice")
    err = info.value
    assert err.unknown == ["persn", "thrice"]
    assert "person" in err.suggestions["persn"]
    assert "persn" in str(err) and "thrice" in str(err)


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
