"""Word-level tokeniser over the corpus vocabulary and a small transformer text encoder.

Token i is word i of the prompt (no start token), so the UI and the attention edits can point
at words directly. Unknown words are reported by name with suggestions, never dropped.
"""
from __future__ import annotations

import math
import re
import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import torch
from torch import nn

from engine import wordforms

PAD = "<pad>"
# a word: a letter, then letters and combining marks, optionally one apostrophe and more of them ("don't"); matched
# in text where every other character has been made a space (see split_words)
_WORD = re.compile(r"[^\W\d_][^\s']*(?:'[^\s']+)?")
MAX_WORDS = 64


class _Separators(dict):
    """str.translate table: letters, combining marks (not variation selectors) and the apostrophe (also typed as
    U+2019) are kept, every other character (digits, punctuation, symbols and emoji, spaces, controls) becomes a
    space; filled as characters are met (at most 4096 remembered)."""

    def __missing__(self, code: int) -> int:
        ch = chr(code)
        category = unicodedata.category(ch)
        if ch in "'\u2019\u02bc":
            out = 0x27
        elif category[0] == "L" or (category in ("Mn", "Mc") and not 0xFE00 <= code <= 0xFE0F
                                      and not 0xE0100 <= code <= 0xE01EF):
            out = code
        else:
            out = 0x20
        if len(self) < 4096:
            self[code] = out
        return out


_SEPARATORS = _Separators()


def split_words(prompt: str) -> list[str]:
    """Lowercase words of a prompt (NFKC-normalised), in any alphabet ("naïve", "café" are one word each);
    digits, punctuation, symbols and emoji are separators (never part of a word, never splitting one)."""
    return _WORD.findall(unicodedata.normalize("NFKC", prompt).lower().translate(_SEPARATORS))


class PromptError(ValueError):
    """A prompt the model cannot read: empty, too long, or with unknown words."""

    def __init__(self, message: str, *, unknown: Sequence[str] = (), suggestions: dict[str, list[str]] | None = None):
        super().__init__(message)
        self.unknown = list(unknown)
        self.suggestions = dict(suggestions or {})


@dataclass(frozen=True)
class TokenizedPrompt:
    prompt: str
    words: tuple[str, ...]
    ids: tuple[int, ...]

    def word_index(self, word: str, occurrence: int = 0) -> int:
        """Token index of ``word`` (its ``occurrence``-th appearance) in this prompt."""
        word = word.lower()
        hits = [i for i, w in enumerate(self.words) if w == word]
        if len(hits) <= occurrence:
            raise PromptError(f"the word {word!r} is not in the prompt {self.prompt!r} (words: {', '.join(self.words)})")
        return hits[occurrence]


class Tokenizer:
    """Maps words to ids; id 0 is padding."""

    def __init__(self, vocabulary: Iterable[str]):
        # order is kept (a checkpoint's word list must map to the same ids); duplicates dropped
        words = list(dict.fromkeys(w.strip().lower() for w in vocabulary if w.strip() and w != PAD))
        bad = [w for w in words if split_words(w) != [w]]  # a plain word: a prompt of just itself
        if bad:
            raise ValueError(f"vocabulary entries are not plain words: {bad[:5]}")
        self.words: tuple[str, ...] = (PAD, *words)
        self._ids = {w: i for i, w in enumerate(self.words)}
        self._known = frozenset(words)
        self._read_as: dict[str, str | None] = {}

    def extended(self, vocabulary: Iterable[str]) -> "Tokenizer":
        """This tokenizer plus new words appended at the end (existing ids unchanged)."""
        return Tokenizer([*self.words[1:], *vocabulary])

    def __len__(self) -> int:
        return len(self.words)

    def __contains__(self, word: str) -> bool:
        return word.lower() in self._ids and word != PAD

    def read_as(self, word: str) -> str | None:
        """The vocabulary word a typed word is read as: itself, another form of it ("jump" -> "jumps",
        "ran" -> "runs"), or None (unknown). See engine.wordforms."""
        word = word.lower()
        if word in self._ids and word != PAD:
            return word
        if word not in self._read_as:
            self._read_as[word] = wordforms.read_as(word, self._known)
        return self._read_as[word]

    def inflected(self, prompt: str) -> dict[str, str]:
        """Typed words read as another form of a known word: {"jump": "jumps"}."""
        return {w: k for w in dict.fromkeys(split_words(prompt)) if (k := self.read_as(w)) not in (None, w)}

    def suggest(self, word: str, n: int = 3) -> list[str]:
        """Replacements for an unknown word, by meaning first ("skips" -> "hops", "tired" -> "~wearily": an adverb
        moved after the verb by :func:`engine.wordforms.rewrite`), close spellings only where no meaning is known."""
        return wordforms.suggestions(word, self._known, n=n)

    def unknown_words(self, prompt: str) -> list[str]:
        return [w for w in split_words(prompt) if self.read_as(w) is None]

    def encode(self, prompt: str, *, max_words: int = MAX_WORDS) -> TokenizedPrompt:
        words = split_words(prompt)
        if not words:
            raise PromptError("the prompt is empty: type a few words, e.g. 'a person jumps twice'")
        if len(words) > max_words:
            raise PromptError(f"the prompt has {len(words)} words; at most {max_words} are supported")
        unknown = [w for w in dict.fromkeys(words) if self.read_as(w) is None]
        if unknown:
            suggestions = {w: self.suggest(w) for w in unknown}
            hints = "; ".join(
                f"{w!r} (did you mean {', '.join(wordforms.shown(s) for s in sug)}?)" if sug else repr(w)
                for w, sug in suggestions.items()
            )
            raise PromptError(f"unknown word{'s' if len(unknown) > 1 else ''}: {hints}", unknown=unknown, suggestions=suggestions)
        return TokenizedPrompt(prompt=prompt, words=tuple(words), ids=tuple(self._ids[self.read_as(w)] for w in words))

    def batch(self, prompts: Sequence[str | TokenizedPrompt]) -> tuple[torch.Tensor, torch.Tensor]:
        """Pad a batch: ids (B, L) long and mask (B, L) bool (True = a real word)."""
        tokenized = [p if isinstance(p, TokenizedPrompt) else self.encode(p) for p in prompts]
        length = max(1, max(len(t.ids) for t in tokenized))  # at least one (padding) column
        ids = torch.zeros(len(tokenized), length, dtype=torch.long)
        mask = torch.zeros(len(tokenized), length, dtype=torch.bool)
        for row, t in enumerate(tokenized):
            ids[row, : len(t.ids)] = torch.tensor(t.ids)
            mask[row, : len(t.ids)] = True
        return ids, mask


def sinusoidal(positions: torch.Tensor, dim: int) -> torch.Tensor:
    """Sinusoidal embedding of (...,) positions/timesteps -> (..., dim)."""
    half = dim // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, dtype=torch.float32, device=positions.device) / half)
    args = positions.float()[..., None] * freqs
    return torch.cat([torch.sin(args), torch.cos(args)], dim=-1)


class TextEncoder(nn.Module):
    """Word embeddings + positions -> a small transformer -> one feature per word (B, L, width)."""

    def __init__(self, *, vocab_size: int, width: int, layers: int = 2, heads: int = 4, dropout: float = 0.1):
        super().__init__()
        self.width = width
        self.embed = nn.Embedding(vocab_size, width, padding_idx=0)
        layer = nn.TransformerEncoderLayer(
            d_model=width, nhead=heads, dim_feedforward=2 * width, dropout=dropout, batch_first=True, norm_first=True
        )
        self.encoder = nn.TransformerEncoder(layer, num_layers=layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(width)

    def forward(self, ids: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        # ids, mask: (B, L) -> (B, L, width)
        positions = torch.arange(ids.shape[1], device=ids.device)
        h = self.embed(ids) + sinusoidal(positions, self.width)[None]
        h = self.encoder(h, src_key_padding_mask=~mask)
        return self.norm(h)

    def resize_vocabulary(self, new_size: int) -> None:
        """Grow the embedding table (new words start near zero); used when resuming on a larger vocabulary."""
        old = self.embed
        if new_size < old.num_embeddings:
            raise ValueError("the vocabulary can only grow")
        grown = nn.Embedding(new_size, self.width, padding_idx=0)
        with torch.no_grad():
            grown.weight.normal_(0, 0.02)
            grown.weight[: old.num_embeddings] = old.weight
        self.embed = grown
