"""Word-level tokeniser over the corpus vocabulary and a small transformer text encoder.

Token i is word i of the prompt's kept words (no start token), so the UI and the attention edits can point
at words directly. A word the model does not know never refuses a prompt: it is read by meaning or as the
word a typo is a slip of, or left out, and :meth:`TokenizedPrompt.notes` says which ("read 'skips' as 'hops'",
"left out: stiffly"). ``encode(prompt, strict=True)`` refuses unknown words instead (training captions).
"""
from __future__ import annotations

import math
import re
import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import torch
from torch import nn
from torch.nn.attention import SDPBackend, sdpa_kernel

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
    """A prompt the model cannot read: empty, too long, or with no word it knows (or, with ``strict``, any word it
    does not know)."""

    def __init__(self, message: str, *, unknown: Sequence[str] = (), suggestions: dict[str, list[str]] | None = None):
        super().__init__(message)
        self.unknown = list(unknown)
        self.suggestions = dict(suggestions or {})


# how a typed word was read (TokenizedPrompt.read_by)
FORM, MEANING, SPELLING = "form", "meaning", "spelling"


@dataclass(frozen=True)
class TokenizedPrompt:
    """A prompt as the model reads it. Token i is ``words[i]``: the typed words KEPT, in order (a word the model
    cannot read is left out, never given a token).

    ``read_as``: each kept typed word that is not itself a vocabulary word -> the vocabulary word whose id it got,
    with ``read_by`` saying how: "form" (another form of it, "jump" -> "jumps"), "meaning" ("skips" -> "hops") or
    "spelling" (a typo, "jumsp" -> "jumps"). ``left_out``: typed words given no token, in prompt order (once each);
    ``suggestions``: replacements a person may pick for them (meaning phrases, or close spellings of a typo)."""

    prompt: str
    words: tuple[str, ...]
    ids: tuple[int, ...]
    read_as: dict[str, str] = field(default_factory=dict, hash=False)
    read_by: dict[str, str] = field(default_factory=dict, hash=False)
    left_out: tuple[str, ...] = ()
    suggestions: dict[str, tuple[str, ...]] = field(default_factory=dict, hash=False)

    def word_index(self, word: str, occurrence: int = 0) -> int:
        """Token index of ``word`` (its ``occurrence``-th appearance) among the kept words; a word read as another
        is also found by the vocabulary word it was read as ("hops" for a typed "skips")."""
        word = word.lower()
        hits = [i for i, w in enumerate(self.words) if w == word]
        if not hits:
            hits = [i for i, w in enumerate(self.words) if self.read_as.get(w) == word]
        if len(hits) <= occurrence:
            if word in self.left_out:
                raise PromptError(f"the word {word!r} was left out of the prompt {self.prompt!r} (the model does not "
                                  f"know it), so it cannot be pointed at; words read: {', '.join(self.words)}",
                                  unknown=[word], suggestions={word: list(self.suggestions.get(word, ()))})
            raise PromptError(f"the word {word!r} is not in the prompt {self.prompt!r} (words: {', '.join(self.words)})")
        return hits[occurrence]

    @property
    def exact(self) -> bool:
        """Every typed word was read as itself or another form of itself (nothing left out or read by meaning)."""
        return not self.left_out and all(how == FORM for how in self.read_by.values())

    def notes(self) -> list[str]:
        """What the model did with the words it does not know, to show beside the prompt:
        ["read 'skips' as 'hops'", "read 'jumsp' as 'jumps'", "left out: head, stiffly"]. Other forms of known
        words ("jump" -> "jumps") are not noted: they are the same word."""
        out = [f"read {w!r} as {self.read_as[w]!r}" for w in self.read_as if self.read_by.get(w) != FORM]
        if self.left_out:
            out.append("left out: " + ", ".join(
                w + (f" (did you mean {' or '.join(wordforms.shown(s) for s in self.suggestions[w])}?)"
                     if self.suggestions.get(w) else "")
                for w in self.left_out))
        return out


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
        self._reading: dict[str, tuple[str | None, str | None]] = {}
        self._meanings: dict[str, tuple[str, ...]] = {}

    def extended(self, vocabulary: Iterable[str]) -> "Tokenizer":
        """This tokenizer plus new words appended at the end (existing ids unchanged)."""
        return Tokenizer([*self.words[1:], *vocabulary])

    def __len__(self) -> int:
        return len(self.words)

    def __contains__(self, word: str) -> bool:
        return word.lower() in self._ids and word != PAD

    def read_as(self, word: str) -> str | None:
        """The vocabulary word a typed word is read as by its form: itself, another form of it ("jump" -> "jumps",
        "ran" -> "runs"), or None (unknown). See engine.wordforms; :meth:`reading` also reads by meaning."""
        word = word.lower()
        if word in self._ids and word != PAD:
            return word
        if word not in self._read_as:
            if len(self._read_as) > 20000:
                self._read_as.clear()
            self._read_as[word] = wordforms.read_as(word, self._known)
        return self._read_as[word]

    def reading(self, word: str) -> tuple[str | None, str | None]:
        """(vocabulary word, how) a typed word is read as in :meth:`encode`: (itself or another form, "form"),
        (a word of the same meaning, "meaning": "skips" -> "hops"), (the word a typo is a slip of, "spelling":
        "jumsp" -> "jumps"; only a non-English word, one edit from exactly one known word), or (None, None): left
        out."""
        word = word.lower()
        form = self.read_as(word)
        if form is not None:
            return form, FORM
        if word not in self._reading:
            if len(self._reading) > 20000:
                self._reading.clear()
            if meanings := self.meanings(word):
                self._reading[word] = (meanings[0], MEANING)
            elif (hit := wordforms.typo_reading(word, self._known)) is not None:
                self._reading[word] = (hit, SPELLING)
            else:
                self._reading[word] = (None, None)
        return self._reading[word]

    def meanings(self, word: str) -> tuple[str, ...]:
        """Vocabulary words of the same meaning as an unknown word, best first (engine.wordforms.MEANING)."""
        word = word.lower()
        if word not in self._meanings:
            if len(self._meanings) > 20000:
                self._meanings.clear()
            self._meanings[word] = tuple(wordforms.meaning_words(word, self._known))
        return self._meanings[word]

    def inflected(self, prompt: str) -> dict[str, str]:
        """Typed words read as another form of a known word: {"jump": "jumps"}."""
        return {w: k for w in dict.fromkeys(split_words(prompt)) if (k := self.read_as(w)) not in (None, w)}

    def suggest(self, word: str, n: int = 3) -> list[str]:
        """Replacements for an unknown word, by meaning first ("skips" -> "hops", "tired" -> "~wearily": an adverb
        moved after the verb by :func:`engine.wordforms.rewrite`); close spellings only for a typo (not for an
        English word: 'head' gets none) and only where no meaning is known."""
        return wordforms.suggestions(word, self._known, n=n)

    def unknown_words(self, prompt: str) -> list[str]:
        """Words of the prompt the vocabulary lacks in every form (encode reads them by meaning or leaves them out)."""
        return [w for w in split_words(prompt) if self.read_as(w) is None]

    def left_out_words(self, prompt: str) -> list[str]:
        """Words :meth:`encode` leaves out (once each, in prompt order)."""
        return [w for w in dict.fromkeys(split_words(prompt)) if self.reading(w)[0] is None]

    def encode(self, prompt: str, *, max_words: int = MAX_WORDS, strict: bool = False) -> TokenizedPrompt:
        """The prompt as the model reads it (see :class:`TokenizedPrompt`). A word the vocabulary lacks is read as
        another form of a known word, or by meaning, or (a typo) as the one known word it is a slip of, or else
        left out; a PromptError only for an empty or too long prompt, or one where a word was left out and what is
        left says no motion (only words like 'a', 'the', 'person', 'two': "a person flurbs").

        ``strict``: every word must be a vocabulary word or another form of one (training captions: nothing read
        by meaning, nothing dropped); else a PromptError naming the unknown words with suggestions."""
        words = split_words(prompt)
        if not words:
            raise PromptError("the prompt is empty: type a few words, e.g. 'a person jumps twice'")
        if len(words) > max_words:
            raise PromptError(f"the prompt has {len(words)} words; at most {max_words} are supported")
        if strict:
            unknown = [w for w in dict.fromkeys(words) if self.read_as(w) is None]
            if unknown:
                suggestions = {w: self.suggest(w) for w in unknown}
                hints = "; ".join(
                    f"{w!r} (did you mean {', '.join(wordforms.shown(s) for s in sug)}?)" if sug else repr(w)
                    for w, sug in suggestions.items()
                )
                raise PromptError(f"unknown word{'s' if len(unknown) > 1 else ''}: {hints}", unknown=unknown,
                                  suggestions=suggestions)
        kept: list[str] = []
        ids: list[int] = []
        read_as: dict[str, str] = {}
        read_by: dict[str, str] = {}
        left_out: list[str] = []
        readings = [self.reading(w) for w in words]
        taken = {hit for hit, how in readings if hit is not None and how != MEANING}
        for w, (hit, how) in zip(words, readings):
            if how == MEANING and hit in taken and wordforms.is_manner_verb(w):
                # a manner the prompt already says ("tiptoes sneakily": not "sneakily sneakily"): the plain verb
                hit = next((m for m in self.meanings(w) if not m.endswith("ly") and m not in taken), hit)
            if how == MEANING:
                taken.add(hit)
            if hit is None:
                if w not in left_out:
                    left_out.append(w)
                continue
            kept.append(w)
            ids.append(self._ids[hit])
            if hit != w:
                read_as[w], read_by[w] = hit, how
        suggestions = {w: tuple(self.suggest(w)) for w in left_out}
        if left_out and all((read_as.get(w) or w) in wordforms.NOT_A_MOTION for w in kept):
            # nothing left says what to do ("a person flurbs"): refuse, naming the words
            raise PromptError(
                f"unknown word{'s' if len(left_out) > 1 else ''} {', '.join(repr(w) for w in left_out)}: nothing "
                "else in the prompt says what to do; describe a motion, e.g. 'a person jumps twice'",
                unknown=left_out, suggestions={w: list(s) for w, s in suggestions.items()})
        return TokenizedPrompt(prompt=prompt, words=tuple(kept), ids=tuple(ids), read_as=read_as, read_by=read_by,
                               left_out=tuple(left_out), suggestions=suggestions)

    def batch(self, prompts: Sequence[str | TokenizedPrompt], *, strict: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """Pad a batch: ids (B, L) long and mask (B, L) bool (True = a real word). Prompts given as text are encoded
        here (``strict`` as in :meth:`encode`)."""
        tokenized = [p if isinstance(p, TokenizedPrompt) else self.encode(p, strict=strict) for p in prompts]
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
        if self.training and torch.is_grad_enabled():
            # on the CPU, the math attention's backward is about twice as fast as the fused kernel's (bench --train);
            # inference keeps the fused kernel, so generation is unchanged
            with sdpa_kernel([SDPBackend.MATH]):
                h = self.encoder(h, src_key_padding_mask=~mask)
        else:
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
