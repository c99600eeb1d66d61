"""batch_loader: batch k is a pure function of (seed, start_index, stride, k), whatever the number of workers."""
from __future__ import annotations

import collections
import itertools
import pickle
import warnings

import numpy as np
import pytest
import torch

from engine.data import Batch, CorpusSource, MotionText, batch_loader
from engine.model.denoiser import Condition
from engine.attention.context import BatchRoles, WordIndex
from engine.text import Tokenizer


class ToySource:
    """Deterministic by index; index i's first feature is i, so a batch's indices can be read back."""

    def __init__(self, broken: frozenset[int] = frozenset(), unreadable: frozenset[int] = frozenset()):
        self.broken = broken
        self.unreadable = unreadable

    def get(self, index: int) -> MotionText:
        rng = np.random.default_rng(index)
        frames = int(rng.integers(20, 40))
        features = rng.normal(size=(frames, 263)).astype(np.float32)
        features[:, 0] = index
        if index in self.broken:
            features[3, 5] = np.nan
        if index in self.unreadable:  # no caption the tokenizer reads exactly (a word outside the vocabulary)
            return MotionText(features=features, captions=("a person levitates", "a person rises " * 200))
        return MotionText(features=features, captions=("a person rises", "a person falls"))

    def words(self):
        return ["a", "person", "rises", "falls"]


def _identity(f):
    return f


def _take(source, n, *, workers, batch_size=4, seed=3, **kw):
    tokenizer = Tokenizer(sorted(source.words()))
    stream = batch_loader(source, tokenizer=tokenizer, normalize=_identity, batch_size=batch_size, seed=seed,
                          workers=workers, max_frames=30, **kw)
    try:
        return list(itertools.islice(stream, n))
    finally:
        stream.close()


def _indices(batch: Batch) -> list[int]:
    return [int(v) for v in batch.x0[:, 0, 0]]


def _same(a: list[Batch], b: list[Batch]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert torch.equal(x.x0, y.x0)
        assert x.captions == y.captions
        for name in ("text_ids", "text_mask", "frame_mask", "use_text"):
            assert torch.equal(getattr(x.cond, name), getattr(y.cond, name)), name
        assert x.cond.roles == y.cond.roles and x.cond.words == y.cond.words


def test_toy_batches_are_identical_for_0_1_and_2_workers():
    base = _take(ToySource(), 5, workers=0)
    assert [_indices(b) for b in base] == [[4 * k + j for j in range(4)] for k in range(5)]
    assert isinstance(base[0].cond, Condition)
    _same(base, _take(ToySource(), 5, workers=1))
    two = _take(ToySource(), 5, workers=2)
    _same(base, two)
    # the condition's non-tensor parts cross the DataLoader untouched
    assert isinstance(two[0].cond.roles, BatchRoles) and isinstance(two[0].cond.words, WordIndex)
    assert two[0].cond.roles == BatchRoles.single("out", size=4)


def test_batch_k_depends_only_on_seed_and_k():
    a = _take(ToySource(), 3, workers=0, seed=1)
    b = _take(ToySource(), 3, workers=0, seed=2)
    assert [_indices(x) for x in a] == [_indices(x) for x in b]  # same items, other crops / captions / dropout
    assert any(not torch.equal(x.x0, y.x0) or x.captions != y.captions for x, y in zip(a, b))


def test_corpus_batches_are_identical_for_0_and_2_workers():
    source = CorpusSource(split="train")
    assert pickle.loads(pickle.dumps(source)).get(5).features.shape == source.get(5).features.shape
    tokenizer = Tokenizer(sorted(source.words()))

    def take(workers):
        stream = batch_loader(source, tokenizer=tokenizer, normalize=_identity, batch_size=4, seed=0,
                              workers=workers, max_frames=196)
        try:
            return list(itertools.islice(stream, 2))
        finally:
            stream.close()

    first = take(0)
    assert [b.x0.shape[0] for b in first] == [4, 4]
    _same(first, take(2))


def test_ranks_interleave_on_disjoint_indices():
    rank0 = _take(ToySource(), 3, workers=0, start_index=0, stride=2)
    rank1 = _take(ToySource(), 3, workers=2, start_index=1, stride=2)
    seen0 = [i for b in rank0 for i in _indices(b)]
    seen1 = [i for b in rank1 for i in _indices(b)]
    assert seen0 == list(range(0, 24, 2)) and seen1 == list(range(1, 24, 2))
    # a resumed rank (start_index advanced by k * batch_size * stride) continues where it stopped
    resumed = _take(ToySource(), 1, workers=0, start_index=1 + 2 * 4 * 2, stride=2)
    assert _indices(resumed[0]) == _indices(rank1[2])


def test_a_non_finite_item_is_dropped_with_a_warning():
    with pytest.warns(RuntimeWarning, match="training sample 6 has non-finite features"):
        got = _take(ToySource(broken=frozenset({6})), 3, workers=0)
    assert [_indices(b) for b in got] == [[0, 1, 2, 3], [4, 5, 7], [8, 9, 10, 11]]
    assert all(torch.isfinite(b.x0).all() for b in got)
    # a batch with nothing usable is skipped, the others keep their content
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        got = _take(ToySource(broken=frozenset({4, 5, 6, 7})), 2, workers=0)
    assert [_indices(b) for b in got] == [[0, 1, 2, 3], [8, 9, 10, 11]]


def test_an_item_without_a_readable_caption_is_dropped_with_a_warning():
    """A training run must not die on one corpus item whose captions are all over-long (session 24: two runs
    stopped at step ~900 on one)."""
    with pytest.warns(RuntimeWarning, match="training sample 5: none of its captions can be tokenised"):
        got = _take(ToySource(unreadable=frozenset({5})), 2, workers=0)
    assert [_indices(b) for b in got] == [[0, 1, 2, 3], [4, 6, 7]]


def test_bad_arguments_fail_at_once():
    tokenizer = Tokenizer(["a"])
    for kw in ({"batch_size": 0}, {"batch_size": 2, "stride": 0}, {"batch_size": 2, "workers": -1}):
        with pytest.raises(ValueError):
            batch_loader(ToySource(), tokenizer=tokenizer, normalize=_identity, seed=0, **kw)


def test_length_groups_cover_each_item_once_with_less_padding():
    """Batches of similar length: the items of G batches are the same as random batching's, each once, sorted into
    batches of similar length (less padding), in an order that is the same on every call."""
    groups = 4
    random = _take(ToySource(), groups, workers=0, batch_size=4)
    grouped = _take(ToySource(), groups, workers=0, batch_size=4, length_groups=groups)
    assert sorted(i for b in grouped for i in _indices(b)) == sorted(i for b in random for i in _indices(b))

    def padded_share(batches):
        return sum(int(b.cond.frame_mask.sum()) for b in batches) / sum(b.cond.frame_mask.numel() for b in batches)

    assert padded_share(grouped) > padded_share(random)
    for b in grouped:  # within a batch, lengths come from one slice of the sorted group
        lengths = b.cond.frame_mask.sum(1)
        assert int(lengths.max() - lengths.min()) <= 19
    _same(grouped, _take(ToySource(), groups, workers=0, batch_size=4, length_groups=groups))
    with pytest.raises(ValueError, match="length_groups"):
        _take(ToySource(), 1, workers=0, length_groups=0)


def test_length_groups_with_workers_see_the_same_items():
    one = _take(ToySource(), 8, workers=0, batch_size=4, length_groups=4)
    two = _take(ToySource(), 8, workers=2, batch_size=4, length_groups=4)
    assert sorted(i for b in one for i in _indices(b)) == sorted(i for b in two for i in _indices(b))


class CountingSource(ToySource):
    """ToySource that counts how often each item is built."""

    def __init__(self):
        super().__init__()
        self.built: collections.Counter = collections.Counter()

    def get(self, index: int) -> MotionText:
        self.built[index] += 1
        return super().get(index)


@pytest.mark.parametrize("groups", [1, 4])
def test_reuse_puts_each_item_in_two_consecutive_groups_and_builds_it_once(groups):
    """--reuse 2: group g reads the window of G x B items starting at g x G x B / 2: every item in two groups, never
    twice in one batch, with its own crop and caption draws each time, and built once."""
    source = CountingSource()
    n = 4 * groups  # batches taken: 4 groups (or 4 batches)
    batches = _take(source, n, workers=0, batch_size=4, length_groups=groups, reuse=2)
    per_group = [sorted(i for b in batches[g * groups:(g + 1) * groups] for i in _indices(b)) for g in range(4)]
    half = 2 * groups
    assert per_group == [list(range(g * half, g * half + 2 * half)) for g in range(4)]
    assert all(len(set(_indices(b))) == len(_indices(b)) for b in batches)
    assert max(source.built.values()) == 1 and len(source.built) == 5 * half  # the last window's tail: built once
    _same(batches, _take(ToySource(), n, workers=0, batch_size=4, length_groups=groups, reuse=2))
    # workers build their groups apart (nothing kept across workers): the same batches (with length groups, the
    # same items: the order of a group's batches then depends on the workers, as without reuse)
    two = _take(ToySource(), n, workers=2, batch_size=4, length_groups=groups, reuse=2)
    if groups == 1:
        _same(batches, two)
    assert sorted(i for b in two for i in _indices(b)) == sorted(i for b in batches for i in _indices(b))
    with pytest.raises(ValueError, match="reuse"):
        _take(ToySource(), 1, workers=0, batch_size=4, reuse=3)


def test_action_focus_oversamples_its_actions_deterministically():
    from engine.data import ActionFocus
    from engine.train import TrainConfig, focus_from, make_source

    focus = ActionFocus(actions=("punch", "hop"), share=0.5)
    plain, focused = CorpusSource(split="train"), CorpusSource(split="train", focus=focus)

    def share(source):
        return np.mean([focus.holds(source.corpus.program(source.corpus_index(i))[0]) for i in range(300)])

    assert share(focused) > share(plain) + 0.25  # half the items redrawn until they hold a punch or a hop
    moved = [i for i in range(300) if focused.corpus_index(i) != i]
    assert moved and all(focused.corpus_index(i) >= 1 << 40 for i in moved)  # no plain item is read twice
    assert [focused.corpus_index(i) for i in range(50)] == [focused.corpus_index(i) for i in range(50)]
    i = moved[0]
    assert np.array_equal(focused.get(i).features, plain.corpus.sample(focused.corpus_index(i)).features)
    # the config's flags reach the training source; the test split stays plain
    config = TrainConfig(focus_actions="punch, hop", focus_share=0.5)
    assert focus_from(config) == focus and make_source(config).focus == focus
    assert make_source(config, split="test").focus is None and focus_from(TrainConfig()) is None
    with pytest.raises(ValueError, match="unknown corpus action.*punches"):
        ActionFocus(actions=("punches",), share=0.5)
    with pytest.raises(ValueError, match="share"):
        ActionFocus(actions=("punch",), share=1.5)


def test_counted_focus_redraws_repeated_actions_only():
    from engine.data import ActionFocus
    from engine.train import TrainConfig, focus_from

    focus = ActionFocus(actions=("clap", "wave"), share=1.0, counted=True)
    source = CorpusSource(split="train", focus=focus)
    repeated = 0
    for i in range(60):
        program = source.corpus.program(source.corpus_index(i))[0]
        parts = [p for seg in program.segments for p in (seg, seg.overlay) if p is not None]
        repeated += any(p.action in ("clap", "wave") and p.count >= 2 for p in parts)
    assert repeated >= 55  # every item redrawn until it holds a repeated clap or wave (64 tries each)
    plain = ActionFocus(actions=("clap", "wave"), share=1.0)
    once = [p for p in (source.corpus.program(j)[0] for j in range(400))
            if plain.holds(p) and not focus.holds(p)]
    assert once  # the corpus has single claps and waves, which the counted focus does not take
    assert focus_from(TrainConfig(focus_actions="clap,wave", focus_share=1.0, focus_counted=True)) == focus


def test_intense_focus_redraws_actions_said_with_an_intensity_word():
    from engine.data import ActionFocus
    from engine.train import TrainConfig, focus_from

    focus = ActionFocus(actions=("jump", "wave"), share=1.0, intense=True)
    source = CorpusSource(split="train", focus=focus)
    words, held = [], 0
    for i in range(60):
        program = source.corpus.program(source.corpus_index(i))[0]
        parts = [p for seg in program.segments for p in (seg, seg.overlay) if p is not None]
        words += [p.intensity_word for p in parts if p.action in ("jump", "wave") and p.intensity_word != "normal"]
        held += focus.holds(program)
    assert held >= 55  # every item redrawn until a jump or a wave is said "high" or "a little" (64 tries each)
    assert {"high", "a little"} <= set(words)
    normal = [p for p in (source.corpus.program(j)[0] for j in range(400))
              if ActionFocus(actions=("jump", "wave"), share=1.0).holds(p) and not focus.holds(p)]
    assert normal  # plain jumps and waves are in the corpus, and the intense focus does not take them
    assert focus_from(TrainConfig(focus_actions="jump,wave", focus_share=1.0, focus_intense=True)) == focus
