"""Training data: one interface over the procedural corpus and HumanML3D-layout folders, plus batching."""
from __future__ import annotations

import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
import torch

from engine.model.denoiser import MAX_FRAMES, Condition
from engine.attention.context import BatchRoles, WordIndex
from engine.text import PromptError, TokenizedPrompt, Tokenizer, split_words


@dataclass(frozen=True)
class MotionText:
    features: np.ndarray  # (T, 263) float32, not normalised
    captions: tuple[str, ...]


class MotionSource(Protocol):
    """Where training motions come from: ``get(i)`` for any i >= 0 (sources may be infinite)."""

    def get(self, index: int) -> MotionText: ...

    def words(self) -> Sequence[str]: ...


class CorpusSource:
    """The procedural corpus, generated on the fly."""

    def __init__(self, *, split: str = "train", seed: int = 0):
        from engine.synth import Corpus

        self.corpus = Corpus(split=split, seed=seed)

    def get(self, index: int) -> MotionText:
        s = self.corpus.sample(index)
        return MotionText(features=s.features, captions=tuple(s.captions))

    def words(self) -> Sequence[str]:
        from engine.synth import vocabulary

        return vocabulary()


class FolderSource:
    """A HumanML3D-layout folder (new_joint_vecs/, texts/, split lists); cycles over its samples.

    Whole-clip captions stay with their clip; a caption with a time interval becomes its own
    item cropped to that interval, as HumanML3D's loaders do.
    """

    def __init__(self, folder: str | Path, *, split: str = "train", min_frames: int = 20):
        from engine.io.humanml3d import HumanML3DFolder

        self.items: list[tuple[np.ndarray, tuple[str, ...]]] = []
        for _, features, captions in HumanML3DFolder(folder).iter_samples(split, skip_missing=True):
            features = np.asarray(features, dtype=np.float32)
            whole = tuple(c.text for c in captions if c.whole_clip)
            if whole and len(features) >= min_frames:
                self.items.append((features, whole))
            for c in captions:
                span = c.frames()
                if span is not None and span[1] - span[0] >= min_frames:
                    self.items.append((features[span[0] : span[1]], (c.text,)))
        if not self.items:
            raise ValueError(f"no usable samples in split {split!r} of {folder}")

    def get(self, index: int) -> MotionText:
        features, captions = self.items[index % len(self.items)]
        return MotionText(features=features, captions=captions)

    def words(self) -> Sequence[str]:
        return sorted({w for _, caps in self.items for c in caps for w in split_words(c)})


@dataclass
class Batch:
    x0: torch.Tensor  # (B, T, 263) normalised
    cond: Condition
    captions: list[str]


def collate(
    items: Sequence[MotionText],
    *,
    tokenizer: Tokenizer,
    normalize,
    rng: np.random.Generator,
    max_frames: int = MAX_FRAMES,
    text_dropout: float = 0.1,
) -> Batch:
    """Random caption per item, random crop to ``max_frames``, zero-padding with a frame mask."""
    feats, tokenized = [], []
    for item in items:
        f = item.features
        if len(f) > max_frames:
            start = int(rng.integers(0, len(f) - max_frames + 1))
            f = f[start : start + max_frames]
        feats.append(normalize(f))
        tokenized.append(_pick_caption(item.captions, tokenizer, rng))
    length = max(len(f) for f in feats)
    x0 = torch.zeros(len(feats), length, feats[0].shape[-1])
    frame_mask = torch.zeros(len(feats), length, dtype=torch.bool)
    for i, f in enumerate(feats):
        x0[i, : len(f)] = torch.from_numpy(np.asarray(f, dtype=np.float32))
        frame_mask[i, : len(f)] = True
    ids, mask = tokenizer.batch(tokenized)
    use_text = torch.from_numpy(rng.random(len(items)) >= text_dropout)
    cond = Condition(
        text_ids=ids, text_mask=mask, frame_mask=frame_mask, use_text=use_text,
        roles=BatchRoles.single("out", size=len(items)), words=WordIndex(words=tuple(t.words for t in tokenized)),
    )
    return Batch(x0=x0, cond=cond, captions=[t.prompt for t in tokenized])


def _pick_caption(captions: Sequence[str], tokenizer: Tokenizer, rng: np.random.Generator) -> TokenizedPrompt:
    """A random caption the tokenizer can read (over-long ones are passed over)."""
    for i in rng.permutation(len(captions)):
        try:
            return tokenizer.encode(captions[i])
        except PromptError:
            continue
    raise ValueError(f"none of the captions can be tokenised: {list(captions)[:2]}")


def batches(
    source: MotionSource,
    *,
    tokenizer: Tokenizer,
    normalize,
    batch_size: int,
    seed: int,
    start_index: int = 0,
    stride: int = 1,
    **collate_kwargs,
) -> Iterator[Batch]:
    """An endless stream of batches; item indices start_index, start_index + stride, ... (DDP ranks interleave)."""
    rng = np.random.default_rng(seed)
    index = start_index
    while True:
        items = []
        while len(items) < batch_size:
            item = source.get(index)
            index += stride
            if np.isfinite(item.features).all():
                items.append(item)
            else:  # a broken sample must never reach the model
                warnings.warn(f"training sample {index - stride} has non-finite features; skipped", RuntimeWarning)
        yield collate(items, tokenizer=tokenizer, normalize=normalize, rng=rng, **collate_kwargs)
