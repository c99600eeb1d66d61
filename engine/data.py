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


@dataclass(frozen=True)
class ActionFocus:
    """Oversampling of some corpus actions: a ``share`` of the items is redrawn (deterministically, from corpus
    indices no plain item uses) until its program holds one of ``actions``, as a segment or an overlay (``counted``:
    one repeated, count >= 2; ``intense``: one said with an intensity word, "jumps high", "waves gently")."""

    actions: tuple[str, ...]
    share: float
    tries: int = 64
    counted: bool = False  # the focus action repeated (count >= 2), not just present
    intense: bool = False  # the focus action with an intensity word ("high", "a little"), not a normal one

    def __post_init__(self) -> None:
        from engine.synth.program import ACTIONS

        unknown = [a for a in self.actions if a not in ACTIONS]
        if unknown:
            raise ValueError(f"unknown corpus action(s) {', '.join(unknown)}; known: {', '.join(ACTIONS)}")
        if not self.actions:
            raise ValueError("focus needs at least one action")
        if not 0.0 < self.share <= 1.0:
            raise ValueError(f"focus share must be in (0, 1], got {self.share}")

    def holds(self, program) -> bool:
        parts = [p for seg in program.segments for p in (seg, seg.overlay) if p is not None]
        return any(p.action in self.actions and (not self.counted or p.count >= 2)
                   and (not self.intense or p.intensity_word != "normal") for p in parts)


# redrawn items come from corpus indices at and above this one, which no plain training item reaches
_FOCUS_BASE = 1 << 40


class CorpusSource:
    """The procedural corpus, generated on the fly. ``underspecified``: that many extra captions per motion which
    leave attributes out the way people type ("a person waves"; engine.synth.grammar.underspecified_captions),
    drawn from their own stream so the corpus's captions stay as they are; ``plain_verbs`` is the chance that such a
    caption says the action's plain verb ("walks", not "treads"), ``styled`` the chance that it keeps a styled
    motion's style ("a person walks like a robot"). ``focus``: oversample some actions (:class:`ActionFocus`)."""

    def __init__(self, *, split: str = "train", seed: int = 0, underspecified: int = 0, plain_verbs: float = 0.0,
                 styled: float = 0.0, focus: ActionFocus | None = None, keep_intensity: bool = False):
        from engine.synth import Corpus

        self.corpus = Corpus(split=split, seed=seed)
        self.underspecified = underspecified
        self.plain_verbs = plain_verbs
        self.styled = styled
        self.focus = focus
        self.keep_intensity = keep_intensity

    def corpus_index(self, index: int) -> int:
        """The corpus item that training item ``index`` reads: itself, or (for the focus share) the first of its
        own stream of redraws whose program holds a focus action."""
        focus = self.focus
        if focus is None or np.random.default_rng([self.corpus.seed, index, 104729]).random() >= focus.share:
            return index
        first = _FOCUS_BASE + index * focus.tries
        for j in range(first, first + focus.tries):
            if focus.holds(self.corpus.program(j)[0]):
                return j
        return index

    def get(self, index: int) -> MotionText:
        s = self.corpus.sample(self.corpus_index(index))
        captions = tuple(s.captions)
        if self.underspecified:
            from engine.synth.grammar import underspecified_captions

            rng = np.random.default_rng([s.program.seed, index, 7919])
            captions += tuple(underspecified_captions(s.program, rng, n=self.underspecified,
                                                            plain=self.plain_verbs, styled=self.styled,
                                                            keep_intensity=self.keep_intensity))
        return MotionText(features=s.features, captions=captions)

    def words(self) -> Sequence[str]:
        from engine.synth import vocabulary

        return vocabulary()


class FolderSource:
    """A HumanML3D-layout folder (new_joint_vecs/, texts/, split lists); cycles over its samples.

    Whole-clip captions stay with their clip; a caption with a time interval becomes its own
    item cropped to that interval (at 20 fps), as HumanML3D's loaders do. Listed samples whose
    feature or caption file is missing are skipped with one warning; a broken file (wrong shape,
    NaN, bad caption line, bad Mean/Std) raises a ``MotionIOError`` naming it.
    """

    def __init__(self, folder: str | Path, *, split: str = "train", min_frames: int = 20):
        from engine.io.humanml3d import TEXTS_DIR, HumanML3DFolder

        data = HumanML3DFolder(folder)
        if data.has_normalizer():
            data.normalizer()  # a broken Mean.npy/Std.npy fails now, naming the file, not mid-training
        self.folder = data.root
        self.split = split
        self._texts = data.root / TEXTS_DIR
        self.items: list[tuple[np.ndarray, tuple[str, ...]]] = []
        self.names: list[str] = []  # the sample each item comes from (for messages)
        read = 0
        for name, features, captions in data.iter_samples(split, skip_missing=True):
            read += 1
            features = np.asarray(features, dtype=np.float32)
            whole = tuple(c.text for c in captions if c.whole_clip)
            if whole and len(features) >= min_frames:
                self.items.append((features, whole))
                self.names.append(name)
            for c in captions:
                span = c.frames()
                if span is None:
                    continue
                clip = features[span[0] : span[1]]
                if len(clip) >= min_frames:
                    self.items.append((clip, (c.text,)))
                    self.names.append(name)
        if not self.items:
            raise ValueError(f"no usable samples in split {split!r} of {folder}: {read} read, none with a caption "
                             f"covering at least {min_frames} frames")

    def __len__(self) -> int:
        return len(self.items)

    def caption_file(self, index: int) -> Path:
        """The texts/<name>.txt file item ``index`` takes its captions from."""
        return self._texts / f"{self.names[index % len(self.items)]}.txt"

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


def _readable(caption: str, tokenizer: Tokenizer) -> bool:
    try:
        tokenizer.encode(caption, strict=True)
    except PromptError:
        return False
    return True


def _pick_caption(captions: Sequence[str], tokenizer: Tokenizer, rng: np.random.Generator) -> TokenizedPrompt:
    """A random caption the tokenizer can read exactly (over-long ones, or ones with words outside the vocabulary,
    are passed over: training never reads a word by meaning or leaves one out)."""
    for i in rng.permutation(len(captions)):
        try:
            return tokenizer.encode(captions[i], strict=True)
        except PromptError:
            continue
    raise ValueError(f"none of the captions can be tokenised: {list(captions)[:2]}")


def batch_loader(
    source: MotionSource,
    *,
    tokenizer: Tokenizer,
    normalize,
    batch_size: int,
    seed: int,
    start_index: int = 0,
    stride: int = 1,
    workers: int = 0,
    pin_memory: bool = False,
    prefetch_factor: int = 2,
    length_groups: int = 1,
    reuse: int = 1,
    **collate_kwargs,
) -> Iterator[Batch]:
    """An endless stream of batches, built in this process (``workers=0``) or by DataLoader worker processes.

    ``length_groups`` G > 1: batches of similar length. The items of G consecutive batches (a group) are sorted
    by their cropped length and cut into G batches, sent in an order drawn per group, so padding goes to the
    longest of similar items instead of the longest of a random batch (the corpus's random batches are 56 %
    real frames). Every item is still seen once, in the same groups of G x batch_size; the order of batches then
    depends on ``workers`` too (worker w builds whole groups g = w mod W).

    Batch k is a pure function of (seed, start_index, stride, k): its items are source indices
    ``start_index + stride * (k * batch_size + j)`` for j < batch_size (DDP ranks interleave with stride = world
    size), and its collate rng is ``np.random.default_rng([seed, k])``. Items with non-finite features are dropped
    with a warning (that batch is smaller; a batch left empty is skipped). Worker w of W builds the batches
    k = w (mod W) and the DataLoader hands them back in order, so the stream is the same for any ``workers``.
    ``pin_memory``: page-locked batches for fast, asynchronous copies to a CUDA device (ignored without CUDA).
    Close the iterator (``.close()``) to stop worker processes early; they also stop when it is garbage-collected.

    ``reuse`` R > 1: every item goes into R consecutive groups (batches, without length groups), each time with its
    own crop, caption and text dropout (and the trainer's own timestep and noise). Group g reads the window of
    G x batch_size items that starts at item g x G x batch_size / R, so each group holds distinct items and builds
    only 1/R of them anew (kept from the group before in this process). Batch k is then no longer about items
    ``k * batch_size + j``: the stream has consumed ``k * batch_size / R`` new items after k batches. Worker
    processes send the same stream, but each builds its groups apart (consecutive groups go to different workers),
    so the saving is the in-process trainer's.
    """
    if batch_size < 1:
        raise ValueError(f"batch_size must be at least 1, got {batch_size}")
    if stride < 1 or start_index < 0:
        raise ValueError(f"start_index must be >= 0 and stride >= 1, got {start_index} and {stride}")
    if workers < 0:
        raise ValueError(f"workers must be 0 or more, got {workers}")
    if length_groups < 1:
        raise ValueError(f"length_groups must be 1 or more, got {length_groups}")
    if reuse < 1 or batch_size % reuse:
        raise ValueError(f"reuse must be 1 or more and divide the batch size ({batch_size}), got {reuse}")
    dataset = _BatchStream(source, tokenizer=tokenizer, normalize=normalize, batch_size=batch_size, seed=seed,
                           start_index=start_index, stride=stride, collate_kwargs=collate_kwargs,
                           length_groups=length_groups, reuse=reuse)
    pin = pin_memory and torch.cuda.is_available()
    if workers == 0:
        return _in_process(dataset, pin)
    import multiprocessing

    from torch.utils.data import DataLoader

    context = "fork" if "fork" in multiprocessing.get_all_start_methods() else None
    loader = DataLoader(dataset, batch_size=None, num_workers=workers, persistent_workers=True,
                        prefetch_factor=max(2, min(4, prefetch_factor)), multiprocessing_context=context,
                        pin_memory=pin, collate_fn=_as_is)
    return _from_loader(loader)


class _Packed:
    """A batch as it crosses from a worker: DataLoader's pin-memory thread calls ``pin_memory()`` on it."""

    __slots__ = ("batch",)

    def __init__(self, batch: Batch | None):
        self.batch = batch

    def pin_memory(self, device=None) -> "_Packed":
        return _Packed(None if self.batch is None else _pinned(self.batch))


def _pinned(batch: Batch) -> Batch:
    from dataclasses import replace

    return replace(batch, x0=batch.x0.pin_memory(), cond=batch.cond.map_tensors(lambda t: t.pin_memory()))


def _as_is(item):
    return item


class _BatchStream(torch.utils.data.IterableDataset):
    """Batch k for every k this process builds (all of them, or worker w's share k = w mod W); with length
    groups, group g's batches for every group this process builds (all, or g = w mod W)."""

    def __init__(self, source: MotionSource, *, tokenizer: Tokenizer, normalize, batch_size: int, seed: int,
                 start_index: int, stride: int, collate_kwargs: dict, length_groups: int = 1, reuse: int = 1):
        super().__init__()
        self.source, self.tokenizer, self.normalize = source, tokenizer, normalize
        self.batch_size, self.seed, self.start_index, self.stride = batch_size, seed, start_index, stride
        self.collate_kwargs = collate_kwargs
        self.length_groups = length_groups
        self.reuse = reuse
        self._kept: dict[int, MotionText | None] = {}  # with reuse: the window's items, by slot (None: skipped)

    def _items(self, first: int, count: int) -> list[MotionText]:
        """Finite items of the slots first .. first + count - 1 (with reuse, the ones the window before read are
        taken from it)."""
        kept = {j: self._kept[j] for j in range(first, first + count) if j in self._kept}
        items = []
        for j in range(first, first + count):
            item = kept[j] if j in kept else self._item(self.start_index + self.stride * j)
            if self.reuse > 1:
                kept[j] = item
            if item is not None:
                items.append(item)
        if self.reuse > 1:
            self._kept = kept
        return items

    def _item(self, index: int) -> MotionText | None:
        """Source item ``index``, or None (with a warning) where it must not reach the model."""
        item = self.source.get(index)
        if not np.isfinite(item.features).all():  # a broken sample must never reach the model
            warnings.warn(f"training sample {index} has non-finite features; skipped", RuntimeWarning)
        elif not any(_readable(c, self.tokenizer) for c in item.captions):  # e.g. every caption over-long
            warnings.warn(f"training sample {index}: none of its captions can be tokenised; skipped",
                          RuntimeWarning)
        else:
            return item
        return None

    def _collate(self, items: list[MotionText], rng: np.random.Generator) -> Batch | None:
        if not items:
            return None
        return collate(items, tokenizer=self.tokenizer, normalize=self.normalize, rng=rng, **self.collate_kwargs)

    def batch(self, k: int) -> Batch | None:
        items = self._items(k * self.batch_size // self.reuse, self.batch_size)
        return self._collate(items, np.random.default_rng([self.seed, k]))

    def group(self, g: int) -> list[Batch | None]:
        """Group g's batches: its G x batch_size items sorted by cropped length, cut into G, in a drawn order."""
        size = self.length_groups * self.batch_size
        items = self._items(g * size // self.reuse, size)
        cap = self.collate_kwargs.get("max_frames", MAX_FRAMES)
        items.sort(key=lambda item: min(len(item.features), cap))
        chunks = [items[i * self.batch_size:(i + 1) * self.batch_size] for i in range(self.length_groups)]
        order = np.random.default_rng([self.seed, g, 1]).permutation(self.length_groups)
        return [self._collate(chunks[c], np.random.default_rng([self.seed, g, 2, int(c)])) for c in order]

    def __iter__(self) -> Iterator[_Packed]:
        info = torch.utils.data.get_worker_info()
        k, step = (0, 1) if info is None else (info.id, info.num_workers)
        while True:
            # an empty batch is sent too, so the workers' round-robin order holds
            if self.length_groups == 1:
                yield _Packed(self.batch(k))
            else:
                yield from (_Packed(b) for b in self.group(k))
            k += step


def _in_process(dataset: _BatchStream, pin: bool) -> Iterator[Batch]:
    for packed in dataset:
        if packed.batch is not None:
            yield _pinned(packed.batch) if pin else packed.batch


def _from_loader(loader) -> Iterator[Batch]:
    for packed in loader:
        if packed.batch is not None:
            yield packed.batch
