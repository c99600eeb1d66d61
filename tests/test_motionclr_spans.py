"""MotionCLR, issue #33: grounding a word to several frame spans, counting exactly as published, the example-based
chunk size as an option, and replacement between prompts of different word counts aligned as prompt-to-prompt
aligns them (on tiny seeded models)."""
from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.ndimage import gaussian_filter
from scipy.signal import find_peaks

from engine.analysis.counting import COUNTING_METHODS, CountingConfig, count_from_attention
from engine.attention import AttentionStore, BatchRoles, stack
from engine.attention.context import WordIndex
from engine.methods.edit_options import EditOptions, build_config, option_spec
from engine.methods.motionclr import (ExampleBased, ExampleConfig, Ground, GroundingConfig, Replace, ReplaceConfig)
from engine.methods.spans import check_spans, mask_spans, parse_spans, spans_mask, spans_text
from engine.methods.word_alignment import ALIGNED, WORD_BY_WORD, align_words, global_align
from engine.model import Condition, Denoiser, ModelConfig
from tests.conftest import cyclic_attention_map, random_corpus_model

FRAMES = 40


def tiny():
    torch.manual_seed(0)
    return Denoiser(ModelConfig(width=32, layers=2, heads=2, text_layers=1, vocab_size=16, dropout=0.0)).eval()


def cond(roles, words_per_slot):
    """A batch whose slots may have prompts of different lengths (padded, the padding masked)."""
    b, width = len(roles), max(len(w) for w in words_per_slot)
    g = torch.Generator().manual_seed(1)
    ids = torch.randint(1, 16, (b, width), generator=g)
    mask = torch.zeros(b, width, dtype=torch.bool)
    for i, w in enumerate(words_per_slot):
        mask[i, : len(w)] = True
    return Condition(text_ids=ids, text_mask=mask, frame_mask=torch.ones(b, FRAMES, dtype=torch.bool),
                     use_text=torch.ones(b, dtype=torch.bool), roles=BatchRoles.of(*roles),
                     words=WordIndex(words=tuple(tuple(w) for w in words_per_slot)))


def x_for(b):
    return torch.randn(b, FRAMES, 263, generator=torch.Generator().manual_seed(2))


# ---------------------------------------------------------------------------------------------- spans
def test_spans_parse_sort_and_refuse_bad_input():
    assert parse_spans("10:20") == ((10, 20),)
    assert parse_spans(" 40:50, 10:20 ,60:61") == ((10, 20), (40, 50), (60, 61))
    assert spans_text(parse_spans("40:50,10:20")) == "10:20,40:50"
    assert parse_spans("10:20,20:30") == ((10, 20), (20, 30))  # touching is not overlapping
    for text, message in [("10:30,20:40", "10:30 and 20:40 overlap"), ("20:10", "0 <= start < end"),
                          ("10", "'10' is not a frame span START:END"), ("a:b", "is not a frame span"),
                          ("10:20,,30:40", "an empty frame span"), ("", "no frame span given"),
                          ("-5:10", "0 <= start < end"), ("1:2:3", "is not a frame span")]:
        with pytest.raises(ValueError, match=message):
            parse_spans(text)
    with pytest.raises(ValueError, match="runs past the motion's end: it has 80 frames"):
        check_spans([(10, 20), (70, 90)], frames=80)
    mask = spans_mask([(40, 50), (2, 5)], 60)
    assert len(mask) == 60 and sum(mask) == 13 and mask[2] and not mask[5] and mask[49] and not mask[50]
    assert mask_spans(mask) == ((2, 5), (40, 50))
    assert mask_spans([True] * 4) == ((0, 4),)


def test_edit_options_take_several_spans_for_grounding_only():
    one = EditOptions(kind="emphasize", word="jumps", frames=(10, 30))
    assert one.frames == (10, 30) and one.spans == ((10, 30),)
    several = EditOptions(kind="ground", word="jumps", frames=((130, 150), (10, 30), (50, 70), (90, 110)))
    assert several.frames == ((10, 30), (50, 70), (90, 110), (130, 150))  # kept sorted
    with pytest.raises(ValueError, match="10:30 and 20:40 overlap"):
        EditOptions(kind="ground", word="jumps", frames=((10, 30), (20, 40)))
    cfg = build_config(several, frames=160)
    assert cfg.spans == ((10, 30), (50, 70), (90, 110), (130, 150)) and len(cfg.mask) == 160
    assert sum(cfg.mask) == 80 and cfg.mask[10] and not cfg.mask[30] and cfg.mask[149] and not cfg.mask[150]
    # one span, and none (the whole motion) still work
    assert build_config(EditOptions(kind="ground", word="jumps", frames=(5, 9)), frames=40).spans == ((5, 9),)
    assert build_config(EditOptions(kind="ground", word="jumps"), frames=40).spans == ((0, 40),)
    with pytest.raises(ValueError, match="runs past the motion's end"):
        build_config(EditOptions(kind="ground", word="jumps", frames=((10, 30), (150, 170))), frames=160)
    with pytest.raises(ValueError, match="emphasize takes one frame span, got 2"):
        build_config(EditOptions(kind="emphasize", word="jumps", frames=((1, 3), (5, 9))), frames=40)
    with pytest.raises(ValueError, match="erase takes one frame span"):
        build_config(EditOptions(kind="erase", word="jumps", frames=((1, 3), (5, 9))), frames=40)


def test_grounding_to_two_spans_raises_inside_both_and_lowers_between():
    model = tiny()
    c = cond(("out",), [("a", "man", "jumps", "high")])
    cfg = GroundingConfig.from_spans("jumps", [(4, 10), (24, 30)], frames=FRAMES, weight=0.3)
    plain, grounded = AttentionStore(), AttentionStore()
    model(x_for(1), torch.full((1,), 300), c, controller=plain)
    model(x_for(1), torch.full((1,), 300), c, controller=stack(Ground(cfg, num_steps=10), grounded))
    diff = (grounded.map(step=0, layer=0, kind="cross") - plain.map(step=0, layer=0, kind="cross"))[:, 2].numpy()
    inside = np.zeros(FRAMES, bool)
    inside[4:10] = inside[24:30] = True
    assert (diff[inside] > 0.25).all() and (diff[~inside] <= 0).all()
    other = (grounded.map(step=0, layer=0, kind="cross") - plain.map(step=0, layer=0, kind="cross"))[:, [0, 1, 3]]
    assert other.abs().max() < 1e-6  # only the grounded word's column changes


# ---------------------------------------------------------------------------------------------- the CLI
def _parse(*argv):
    from engine.cli.edit import add_parser, options_from_args
    from engine.cli.common import Parser

    parser = Parser(prog="moattn")  # the CLI's own: no abbreviated flags
    add_parser(parser.add_subparsers())
    return options_from_args(parser.parse_args(["edit", *argv]))


def test_cli_frames_flag_takes_one_or_several_spans(capsys):
    o = _parse("ground", "a person jumps four times", "--word", "jumps", "--frames", "130:150,10:30,50:70,90:110")
    assert o.frames == ((10, 30), (50, 70), (90, 110), (130, 150))
    assert _parse("emphasize", "a person jumps", "--word", "jumps", "--frames", "10:20").frames == (10, 20)
    # the older flags still give one span; --from-frame alone runs to the motion's end
    assert _parse("emphasize", "a person jumps", "--word", "jumps", "--from-frame", "10", "--to-frame", "20").frames \
        == (10, 20)
    assert _parse("erase", "a person jumps", "--word", "jumps", "--from-frame", "10", "--seconds", "3").frames \
        == (10, 60)
    with pytest.raises(ValueError, match="not both"):
        _parse("ground", "a person jumps", "--word", "jumps", "--frames", "1:5", "--from-frame", "2")
    with pytest.raises(SystemExit):
        _parse("ground", "a person jumps", "--word", "jumps", "--frames", "10:30,20:40")
    assert "argument --frames: the frame spans 10:30 and 20:40 overlap" in capsys.readouterr().err


def test_cli_declares_the_chunk_size_and_counting_methods_from_one_place(capsys):
    from engine.cli import build_parser

    spec = option_spec("chunk_frames")
    assert (spec.default, spec.bounds, spec.flag) == (20, (4, 100), "--chunk-frames")
    assert _parse("example", "a person jumps").chunk_frames == spec.default
    assert _parse("example", "a person jumps", "--chunk-frames", "10").chunk_frames == 10
    with pytest.raises(ValueError, match="chunk size \\(frames\\) must be between 4 and 100, got 2"):
        _parse("example", "a person jumps", "--chunk-frames", "2")
    with pytest.raises(SystemExit):
        build_parser().parse_args(["edit", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert " ".join(spec.help.split()) in help_text and "(4 to 100; default 20; read by example)" in help_text
    for method in COUNTING_METHODS:
        assert build_parser().parse_args(["edit", "count", "a person jumps", "--count-method", method]).count_method \
            == method
    assert build_parser().parse_args(["edit", "count", "a person jumps"]).count_method == "lag"


# ---------------------------------------------------------------------------------------------- example chunks
def test_the_chunk_size_reaches_the_controller_and_is_bounded():
    cfg = build_config(EditOptions(kind="example", prompt="a person jumps", chunk_frames=8), frames=FRAMES)
    assert cfg.chunk_frames == 8
    assert build_config(EditOptions(kind="example", prompt="a person jumps"), frames=FRAMES).chunk_frames == 20
    ctrl = ExampleBased(cfg, num_steps=10, frames=FRAMES)
    for slot in range(3):
        order = ctrl.order(slot)
        assert sorted(order.tolist()) == list(range(FRAMES))
        starts = order[::8]
        assert all(s % 8 == 0 for s in starts)  # whole chunks of 8 frames moved
        assert all((order[i:i + 8] == np.arange(starts[k], starts[k] + 8)).all() for k, i in enumerate(range(0, 40, 8)))
    assert not np.array_equal(ctrl.order(0), np.arange(FRAMES))
    whole = ExampleBased(ExampleConfig(chunk_frames=FRAMES), num_steps=10, frames=FRAMES)
    assert np.array_equal(whole.order(0), np.arange(FRAMES))  # one chunk: the example's own order
    with pytest.raises(ValueError, match="between 4 and 100, got 101"):
        ExampleConfig(chunk_frames=101)
    with pytest.raises(ValueError, match="between 4 and 100, got 3"):
        EditOptions(kind="example", chunk_frames=3)


# ---------------------------------------------------------------------------------------------- counting
def code6(matrix: np.ndarray) -> tuple[float, list[list[int]]]:
    """MotionCLR's Code 6, written out from the paper: smoothing, ×4 pooling, 0-1 normalisation, peaks in every row
    above 3 × the normalised matrix's mean, count = total peaks / rows with a peak."""
    smoothed = gaussian_filter(matrix, sigma=0.8)
    n = len(smoothed) // 4 * 4
    pooled = smoothed[:n, :n].reshape(n // 4, 4, n // 4, 4).mean(axis=(1, 3))
    normalized = (pooled - pooled.min()) / (pooled.max() - pooled.min())
    height = normalized.mean() * 3
    per_row = [list(find_peaks(row, height=height, distance=1)[0]) for row in normalized]
    total = sum(len(p) for p in per_row)
    rows = sum(1 for p in per_row if len(p))
    return (total / rows if rows else 0.0), per_row


def test_published_counting_thresholds_by_the_whole_maps_mean():
    t = np.arange(120)
    diagonal = np.exp(-0.5 * ((t[:, None] - t[None]) / 3.0) ** 2)
    stripes = [diagonal + amp * np.exp(-0.5 * ((np.abs(t[:, None] - t[None]) - 40) / 3.0) ** 2) for amp in (0.3, 0.5)]
    bumps = []
    for reps in (2, 3, 4):
        bump = np.exp(-0.5 * ((t[:, None] - (np.arange(reps) + 0.5)[None] * 120 / reps) / 3.0) ** 2).max(1)
        bumps.append(0.05 + np.outer(bump, bump))
    maps = [cyclic_attention_map(r, rest=rest) for r in (2, 3, 4) for rest in (0, 10)] + stripes + bumps
    maps += [m / m.sum(1, keepdims=True) for m in stripes + bumps]  # row-stochastic, as softmax maps are
    for attn in maps:
        published = count_from_attention(attn, CountingConfig(method="published"))
        expected, per_row = code6(attn)
        assert published.count == pytest.approx(expected)
        assert sorted(published.peaks) == sorted((r * 4 + 2, int(c) * 4 + 2) for r, p in enumerate(per_row) for c in p)
        assert published.period is None and published.span is None
    # where the rows' means differ, the per-row threshold is another method: on the stripes map without row
    # normalisation the published recipe counts 1 (28 peaks), the per-row one 1.53 (46 peaks)
    rows = count_from_attention(stripes[0], CountingConfig(method="rows"))
    published = count_from_attention(stripes[0], CountingConfig(method="published"))
    assert len(published.peaks) == 28 and published.count == pytest.approx(1.0)
    assert len(rows.peaks) == 46 and rows.count == pytest.approx(46 / 30)
    assert set(COUNTING_METHODS) == {"lag", "published", "rows"} and CountingConfig().method == "lag"


# ---------------------------------------------------------------------------------------------- alignment
def test_words_align_as_prompt_to_prompt_aligns_them():
    same = align_words("a person jumps twice".split(), "a person kicks twice".split())
    assert same.mode == WORD_BY_WORD and same.changes() == ["'jumps' → 'kicks'"]
    assert same.links == tuple(((j, 1.0),) for j in range(4))
    # prompt-to-prompt's aligner: gap 0, match +1, mismatch -1 (shared words matched in order)
    assert global_align("a b c".split(), "a x b c".split()) == [(0, 0), (None, 1), (1, 2), (2, 3)]
    inserted = align_words("a person jumps".split(), "a person slowly jumps".split())
    assert inserted.mode == ALIGNED and inserted.links == (((0, 1.0),), ((1, 1.0),), (), ((2, 1.0),))
    assert inserted.inserted == (2,) and inserted.changes() == ["+'slowly'"]
    assert "+ 'slowly' (new: its own attention)" in inserted.describe()
    dropped = align_words("a person jumps and waves".split(), "a person jumps".split())
    assert dropped.dropped == (3, 4) and dropped.links == (((0, 1.0),), ((1, 1.0),), ((2, 1.0),))
    assert "− 'and waves' (dropped)" in dropped.describe()
    # a word swapped for two: each takes half its attention (prompt-to-prompt's word -> several tokens)
    split = align_words("a person jumps".split(), "a person kicks high".split())
    assert split.links[2:] == (((2, 0.5),), ((2, 0.5),)) and split.changes() == ["'jumps' → 'kicks high'"]
    merged = align_words("a person jumps twice".split(), "a person kicks".split())
    assert merged.links[2] == ((2, 1.0), (3, 1.0))
    both = align_words("a person walks then jumps twice".split(), "a person slowly walks forward then kicks".split())
    assert both.changes() == ["+'slowly'", "+'forward'", "'jumps twice' → 'kicks'"]
    assert both.swaps == {6} and both.inserted == (2, 4)  # 'kicks' takes others' place; 'slowly', 'forward' are new
    assert both.describe().startswith("aligned as prompt-to-prompt refines (6 → 7 words): 'a' = 'a', ")
    # as many words on both sides: word by word, even where a shared word moved
    moved = align_words("a person jumps then walks".split(), "a person walks then jumps".split())
    assert moved.mode == WORD_BY_WORD and moved.changes() == ["'jumps' → 'walks'", "'walks' → 'jumps'"]
    assert moved.swaps == {2, 4}
    with pytest.raises(ValueError, match="at least one word"):
        align_words((), ("a",))


def test_replace_between_prompts_of_different_lengths_maps_aligned_words():
    model = tiny()
    ref, edit = ("a", "man", "jumps", "high"), ("a", "slowly", "man", "kicks", "high")
    c = cond(("ref", "edit"), [ref, edit])
    x = x_for(2)
    plain = AttentionStore()
    model(x, torch.full((2,), 300), c, controller=plain)
    replaced = AttentionStore()
    ctrl = Replace(ReplaceConfig(self_attention=False, swapped="reference"), num_steps=10)
    model(x, torch.full((2,), 300), c, controller=stack(ctrl, replaced))
    src = plain.map(step=0, layer=0, kind="cross", slot=0)
    own = plain.map(step=0, layer=0, kind="cross", slot=1)
    got = replaced.map(step=0, layer=0, kind="cross", slot=1)
    # a <- a, slowly: its own, man <- man, kicks <- jumps, high <- high
    for j, i in ((0, 0), (2, 1), (3, 2), (4, 3)):
        assert torch.allclose(got[:, j], src[:, i], atol=1e-3), (j, i)
    assert torch.allclose(got[:, 1], own[:, 1], atol=1e-3)
    assert not torch.allclose(own[:, 1], src[:, 1], atol=1e-3)  # (the reference's column there differs)
    assert torch.equal(replaced.map(step=0, layer=0, kind="cross", slot=0), src)  # the reference is untouched
    assert ctrl.alignment(ref, edit).changes() == ["+'slowly'", "'jumps' → 'kicks'"]
    # the same-length case copies the reference's whole map, as before
    c2 = cond(("ref", "edit"), [ref, ("a", "man", "kicks", "high")])
    same = AttentionStore()
    model(x, torch.full((2,), 300), c2, controller=stack(
        Replace(ReplaceConfig(self_attention=True, swapped="reference"), num_steps=10), same))
    for kind in ("cross", "self"):
        assert torch.equal(same.map(step=0, layer=1, kind=kind, slot=0), same.map(step=0, layer=1, kind=kind, slot=1))


@pytest.mark.parametrize("edit", [("a", "man", "kicks", "high"), ("a", "slowly", "man", "kicks", "high")])
def test_replace_lets_a_swapped_word_keep_its_own_attention_by_default(edit):
    """swapped="own" (the default): 'kicks' attends with its own column; 'a', 'man', 'high' take the reference's;
    each frame's weights sum to 1 as a softmax row does."""
    model = tiny()
    ref = ("a", "man", "jumps", "high")
    c = cond(("ref", "edit"), [ref, edit])
    x = x_for(2)
    plain = AttentionStore()
    model(x, torch.full((2,), 300), c, controller=plain)
    replaced = AttentionStore()
    assert ReplaceConfig().swapped == "own"
    model(x, torch.full((2,), 300), c, controller=stack(Replace(ReplaceConfig(), num_steps=10), replaced))
    kicks = edit.index("kicks")
    kept = [(edit.index(w), ref.index(w)) for w in ("a", "man", "high")]
    for head in range(2):  # per head: each head's rows are scaled by their own factor
        src = plain.map(step=0, layer=0, kind="cross", slot=0, head=head)
        own = plain.map(step=0, layer=0, kind="cross", slot=1, head=head)
        got = replaced.map(step=0, layer=0, kind="cross", slot=1, head=head)
        assert torch.allclose(got.sum(-1), torch.ones(got.shape[0]), atol=1e-3)
        scale = got[:, kept[0][0]] / src[:, kept[0][1]]  # (F,) the one factor each frame's row was scaled by
        for j, i in kept:
            assert torch.allclose(got[:, j], src[:, i] * scale, atol=1e-3), (j, i)
        assert torch.allclose(got[:, kicks], own[:, kicks] * scale, atol=1e-3)
        assert not torch.allclose(own[:, kicks], src[:, 2], atol=1e-3)  # (the replaced word's column differs)
        assert not torch.allclose(scale, torch.ones_like(scale), atol=1e-3)
    with pytest.raises(ValueError, match="swapped must be one of own, reference"):
        ReplaceConfig(swapped="theirs")


def test_engine_replace_runs_prompts_of_different_lengths_and_reports_the_alignment():
    from engine.generate import SampleConfig
    from engine.methods import edits

    loaded = random_corpus_model(layers=2)
    out = edits.replace(loaded, "a person jumps", "a person slowly kicks", frames=20,
                        sample=SampleConfig(steps=2, seed=0))
    alignment = out.extra["alignment"]
    assert alignment.source == ("a", "person", "jumps") and alignment.target == ("a", "person", "slowly", "kicks")
    assert alignment.changes() == ["'jumps' → 'slowly kicks'"]
    assert out.after.shape == (20, 22, 3) and np.isfinite(out.after).all()
    assert np.abs(out.after - out.before).max() > 1e-4
