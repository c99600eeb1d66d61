"""MotionCLR controllers on a tiny seeded model: each map changes where it should and nowhere else."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from engine.analysis.counting import CountingConfig, count_from_attention, count_from_root_height
from engine.attention import AttentionStore, BatchRoles, stack
from engine.attention.context import WordIndex
from engine.methods.motionclr import (
    ExampleBased, ExampleConfig, Ground, GroundingConfig, Replace, ReplaceConfig, Reweight, ReweightConfig,
    Shift, ShiftConfig, StyleTransfer, StyleTransferConfig, erase_config,
)
from engine.methods.windows import Window
from engine.model import Condition, Denoiser, ModelConfig
from tests.conftest import cyclic_attention_map

FRAMES = 24


def tiny():
    torch.manual_seed(0)
    return Denoiser(ModelConfig(width=32, layers=3, heads=2, text_layers=1, vocab_size=16, dropout=0.0)).eval()


def cond(roles, words=("a", "man", "jumps", "high")):
    b = len(roles)
    g = torch.Generator().manual_seed(1)
    return Condition(text_ids=torch.randint(1, 16, (b, len(words)), generator=g),
                     text_mask=torch.ones(b, len(words), dtype=torch.bool),
                     frame_mask=torch.ones(b, FRAMES, dtype=torch.bool), use_text=torch.ones(b, dtype=torch.bool),
                     roles=BatchRoles.of(*roles), words=WordIndex(words=tuple(words for _ in roles)))


def run(model, c, controller, step=0):
    x = torch.randn(len(c), FRAMES, 263, generator=torch.Generator().manual_seed(2))
    store = AttentionStore(record_qkv=True)
    out = model(x, torch.full((len(c),), 300), c, controller=stack(controller, store), step=step)
    return out, store


def test_reweight_adds_to_the_word_column_only_in_its_window():
    model, c = tiny(), cond(("ref", "out"))
    _, base = run(model, c, None)
    cfg = ReweightConfig(word="jumps", weight=0.5, frames=(5, 15), window=Window(0.0, 0.5, layers=(1,)))
    _, edited = run(model, c, Reweight(cfg, num_steps=10), step=2)
    # layer 0 is outside the layer window: identical maps
    assert torch.equal(edited.map(step=2, layer=0, kind="cross", slot=1), base.map(step=0, layer=0, kind="cross", slot=1))
    # the store sees maps after the edit only for later controllers; check the model output path instead
    out_base, _ = run(model, c, None)
    out_edit, _ = run(model, c, Reweight(cfg, num_steps=10), step=2)
    assert torch.allclose(out_edit[0], out_base[0], atol=1e-6)  # the ref slot is untouched
    assert (out_edit[1] - out_base[1]).abs().max() > 1e-4
    out_late, _ = run(model, c, Reweight(cfg, num_steps=10), step=7)  # outside the step window
    assert torch.equal(out_late, out_base)


def test_reweight_map_values():
    model, c = tiny(), cond(("out",))
    cfg = ReweightConfig(word="jumps", weight=0.5, frames=(5, 15))
    # a store stacked after the edit records the edited maps
    _, before = run(model, c, None)
    x = torch.randn(1, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    after = AttentionStore()
    model(x, torch.full((1,), 300), c, controller=stack(Reweight(cfg, num_steps=10), after))
    a, b = after.map(step=0, layer=0, kind="cross"), before.map(step=0, layer=0, kind="cross")
    diff = (a - b).numpy()
    assert np.allclose(diff[5:15, 2], 0.5, atol=2e-3)
    assert np.abs(np.delete(diff, 2, axis=1)).max() < 2e-3
    assert np.abs(diff[:5, 2]).max() < 2e-3 and np.abs(diff[15:, 2]).max() < 2e-3


def test_erase_multiplies_by_a_tenth():
    model, c = tiny(), cond(("out",))
    x = torch.randn(1, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    plain, erased = AttentionStore(), AttentionStore()
    model(x, torch.full((1,), 300), c, controller=plain)
    model(x, torch.full((1,), 300), c, controller=stack(Reweight(erase_config("jumps", frames=(12, 24)), num_steps=10), erased))
    a, b = erased.map(step=0, layer=1, kind="cross"), plain.map(step=0, layer=1, kind="cross")
    assert torch.allclose(a[12:, 2], 0.1 * b[12:, 2], atol=1e-3)
    assert torch.allclose(a[:12], b[:12], atol=1e-3)


def test_word_must_exist():
    model, c = tiny(), cond(("out",))
    with pytest.raises(KeyError, match="walks"):
        run(model, c, Reweight(ReweightConfig(word="walks"), num_steps=10))


def test_replace_copies_reference_maps_into_the_edit_slot():
    model = tiny()
    c = cond(("ref", "edit"))
    c.text_ids[1, 2] = (c.text_ids[0, 2] % 15) + 1  # a different verb in the edit prompt
    x = torch.randn(2, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    store = AttentionStore()
    model(x, torch.full((2,), 300), c, controller=stack(Replace(ReplaceConfig(), num_steps=10), store), step=1)
    # the paper's replacement: the cross-attention maps only; the edited prompt keeps its own self-attention
    assert torch.equal(store.map(step=1, layer=2, kind="cross", slot=0), store.map(step=1, layer=2, kind="cross", slot=1))
    assert not torch.equal(store.map(step=1, layer=2, kind="self", slot=0),
                           store.map(step=1, layer=2, kind="self", slot=1))
    both = AttentionStore()  # the authors' code: the self-attention maps too
    model(x, torch.full((2,), 300), c, controller=stack(Replace(ReplaceConfig(self_attention=True), num_steps=10),
                                                        both), step=1)
    for kind in ("cross", "self"):
        assert torch.equal(both.map(step=1, layer=2, kind=kind, slot=0), both.map(step=1, layer=2, kind=kind, slot=1))
    late = AttentionStore()
    model(x, torch.full((2,), 300), c, controller=stack(Replace(ReplaceConfig(), num_steps=10), late), step=8)
    assert not torch.equal(late.map(step=8, layer=2, kind="cross", slot=0), late.map(step=8, layer=2, kind="cross", slot=1))


def test_shift_rolls_q_k_v():
    model, c = tiny(), cond(("ref", "edit"))
    cfg = ShiftConfig(fraction=0.25)
    x = torch.randn(2, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    store = AttentionStore(record_qkv=True)
    # the store before the shift sees the originals, one after sees the shifted tensors
    after = AttentionStore(record_qkv=True, kinds=("self",))
    model(x, torch.full((2,), 300), c, controller=stack(store, Shift(cfg, num_steps=10, frames=FRAMES), after))
    q_ref = store.get(step=0, layer=0, kind="self").q[0].float()
    q_edit = after.get(step=0, layer=0, kind="self").q[1].float()
    assert torch.equal(q_edit, torch.roll(q_ref, shifts=-6, dims=1))


def test_example_based_shuffles_whole_chunks():
    model, c = tiny(), cond(("ref", "out", "out"))
    ctrl = ExampleBased(ExampleConfig(chunk_frames=6, seed=3), num_steps=10, frames=FRAMES)
    x = torch.randn(3, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    before, after = AttentionStore(record_qkv=True, kinds=("self",)), AttentionStore(record_qkv=True, kinds=("self",))
    model(x, torch.full((3,), 300), c, controller=stack(before, ctrl, after))
    q_ref = before.get(step=0, layer=1, kind="self").q[0]
    for k_th, slot in enumerate((1, 2)):
        order = ctrl.order(k_th)
        assert sorted(order.tolist()) == list(range(FRAMES))
        assert all(order[i + 1] == order[i] + 1 for i in range(0, FRAMES, 6) for _ in [0] if i + 1 < FRAMES)
        assert torch.equal(after.get(step=0, layer=1, kind="self").q[slot], q_ref[:, torch.as_tensor(order)])
    assert not np.array_equal(ctrl.order(0), ctrl.order(1))


def test_style_transfer_mixes_q_and_kv():
    model, c = tiny(), cond(("style", "content", "out"))
    x = torch.randn(3, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    before, after = AttentionStore(record_qkv=True, kinds=("self",)), AttentionStore(record_qkv=True, kinds=("self",))
    model(x, torch.full((3,), 300), c, controller=stack(before, StyleTransfer(StyleTransferConfig(), num_steps=10), after))
    b, a = before.get(step=0, layer=0, kind="self"), after.get(step=0, layer=0, kind="self")
    assert torch.equal(a.q[2], b.q[0]) and torch.equal(a.k[2], b.k[1]) and torch.equal(a.v[2], b.v[1])
    assert torch.equal(a.q[0], b.q[0]) and torch.equal(a.k[1], b.k[1])


def test_grounding_raises_inside_and_lowers_outside():
    model, c = tiny(), cond(("out",))
    mask = tuple(8 <= i < 16 for i in range(FRAMES))
    x = torch.randn(1, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    plain, grounded = AttentionStore(), AttentionStore()
    model(x, torch.full((1,), 300), c, controller=plain)
    model(x, torch.full((1,), 300), c, controller=stack(Ground(GroundingConfig(word="jumps", mask=mask), num_steps=10), grounded))
    diff = (grounded.map(step=0, layer=0, kind="cross") - plain.map(step=0, layer=0, kind="cross"))[:, 2]
    assert (diff[8:16] > 0.25).all() and (diff[:8] <= 0).all() and (diff[16:] <= 0).all()


def test_counting_on_a_synthetic_action_map():
    """The lag method finds the period and counts the repetitions inside the active span only (the still
    frames around them are not repetitions); MotionCLR's row recipe and the root-height baseline count
    isolated action bumps."""
    for reps in (2, 3, 4):
        for rest in (0, 12, 30):
            res = count_from_attention(cyclic_attention_map(reps, rest=rest))
            assert res.rounded == reps and abs(res.period - 16) <= 1, (reps, rest, res.count, res.period)
            first, last = res.span
            assert abs(first - rest) <= 4 and abs(last - (rest + reps * 16 - 1)) <= 4, (rest, res.span)
            assert {c - r for r, c in res.peaks if c > r} == {k * res.period for k in range(1, reps)}
            assert all(first <= r <= last and first <= c <= last for r, c in res.peaks)
    t = np.arange(120)
    for reps in (2, 3, 4):  # (with 5 narrow bumps in 6 s the row mean x3 threshold hides the peaks)
        centres = (np.arange(reps) + 0.5) * 120 / reps
        bump = np.exp(-0.5 * ((t[:, None] - centres[None]) / 3.0) ** 2).max(1)  # (T,) action strength
        attn = 0.05 + np.outer(bump, bump)
        attn /= attn.sum(1, keepdims=True)
        res = count_from_attention(attn, CountingConfig(method="rows"))
        assert res.rounded == reps, (reps, res.count)
        assert all(0 <= r < 120 and 0 <= c < 120 for r, c in res.peaks)
        assert count_from_root_height(0.9 + 0.2 * bump) == reps
    # one action, nothing repeated: no period, count 1
    one = np.exp(-0.5 * ((t[:, None] - t[None]) / 3.0) ** 2)
    res = count_from_attention(one / one.sum(1, keepdims=True))
    assert res.rounded == 1 and res.period is None and res.peaks == []
    # the diagonal dominates a real map: a weak repetition stripe is found by the lag profile, not by row peaks
    weak = one + 0.1 * np.exp(-0.5 * ((np.abs(t[:, None] - t[None]) - 40) / 3.0) ** 2)
    assert count_from_attention(weak).rounded == 3
    assert count_from_attention(weak, CountingConfig(method="rows")).rounded == 1
    with pytest.raises(ValueError, match="NaN"):
        count_from_attention(np.full((40, 40), np.nan))
    with pytest.raises(ValueError, match="one of 'lag', 'published', 'rows', got 'fft'"):
        CountingConfig(method="fft")
    with pytest.raises(ValueError):
        count_from_attention(np.zeros((5, 6)))


def test_counting_skips_a_weak_sub_period_stripe():
    """A jumping jack hops twice per repetition: besides the repetition's stripes (period 32) its map carries
    faint ones at half the period. The first peak of the lag profile is the hop; the period is the first
    peak at least ``relative_prominence`` as prominent as the strongest."""
    reps, period = 3, 32
    attn = cyclic_attention_map(reps, rest=10, period=period)
    t = np.arange(len(attn))
    active = (t >= 10) & (t < 10 + reps * period)
    hop = np.exp(2 * (np.cos(4 * np.pi * (t[:, None] - t[None]) / period) - 1)) * np.outer(active, active)
    attn = attn + 0.004 * hop  # the hop stripe: a tenth as prominent as the repetition's in the lag profile
    attn /= attn.sum(1, keepdims=True)
    res = count_from_attention(attn)
    assert res.rounded == reps and abs(res.period - period) <= 1, (res.count, res.period)
    naive = count_from_attention(attn, CountingConfig(relative_prominence=0.0))
    assert abs(naive.period - period // 2) <= 1 and naive.rounded == 2 * reps, (naive.count, naive.period)
    with pytest.raises(ValueError, match="relative_prominence"):
        CountingConfig(relative_prominence=1.5)


def test_counting_run_chooses_layers_and_steps():
    from engine.methods.edits import CountingRun

    assert CountingRun().chosen_layers([0, 1, 2, 3, 4, 5]) == [2, 3, 4, 5]
    assert CountingRun().chosen_layers([0, 1]) == [1]  # two layers: the first is skipped, one is kept
    assert CountingRun().chosen_layers([0]) == [0]
    assert CountingRun(skip_layers=0).chosen_layers([0, 1, 2]) == [0, 1, 2]
    assert CountingRun(layers=(1, 3)).chosen_layers([0, 1, 2, 3]) == [1, 3]
    with pytest.raises(ValueError, match="not recorded"):
        CountingRun(layers=(7,)).chosen_layers([0, 1])
    assert CountingRun().chosen_steps([0, 4, 9, 14, 19], 20) == [14, 19]
    assert CountingRun(steps=(0.0, 0.1)).chosen_steps([5, 10], 20) == [5, 10]  # none inside: all recorded
    with pytest.raises(ValueError, match="skip_layers"):
        CountingRun(skip_layers=1.0)
    with pytest.raises(ValueError, match="steps"):
        CountingRun(steps=(0.8, 0.2))


def test_guide_mode_moves_the_out_slot_away_from_the_word_erased_and_nothing_else():
    from engine.methods.motionclr import erased
    from engine.methods.word_guidance import WordGuidance

    model, c = tiny(), cond(("ref", "out"))
    x = torch.randn(2, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    t = torch.full((2,), 300)
    cfg = ReweightConfig(word="jumps", weight=0.5, mode="guide", window=Window(0.0, 0.5))
    plain = model(x, t, c, step=1)
    # guide mode changes no attention map by itself: the controller is a no-op and the output bit-identical
    assert torch.equal(model(x, t, c, step=1, controller=Reweight(cfg, num_steps=10)), plain)
    erase = Reweight(erased(cfg), num_steps=10)
    out_only = c.take([1])  # the erased pass runs on the out slot alone: its tensors, role and words
    assert out_only.roles.names == ("out",) and out_only.words.words == (c.words.words[1],)
    assert torch.equal(out_only.text_ids, c.text_ids[1:]) and torch.equal(out_only.frame_mask, c.frame_mask[1:])
    without = model(x, t, c, step=1, controller=erase)
    assert (without[1] - plain[1]).abs().max() > 1e-4  # erasing the word changes the prediction

    def guided(weight, step=1):
        return WordGuidance(model, erase=erase, weight=weight, role="out", steps=erase.window.steps)(x, t, c, step=step)

    assert torch.equal(guided(0.5)[0], plain[0])  # the ref slot keeps the plain prediction
    assert torch.allclose(guided(0.5)[1], plain[1] + 0.5 * (plain[1] - without[1]), atol=1e-6)
    assert torch.allclose(guided(-1.0)[1], without[1], atol=1e-6)  # -1: the word erased
    assert torch.equal(guided(0.0), plain)
    assert torch.equal(guided(0.5, step=7), plain)  # outside the step window: no guidance
    with pytest.raises(ValueError, match=r"between -1 and 1 \(-1 is the word erased"):
        ReweightConfig(word="jumps", weight=1.5, mode="guide")
    with pytest.raises(ValueError, match="add, mul, guide, intensity"):
        ReweightConfig(word="jumps", mode="scale")


def test_intensity_mode_moves_the_out_slot_towards_the_other_prompt_in_its_window_and_frames():
    from engine.methods.word_guidance import PromptGuidance

    model, c = tiny(), cond(("ref", "out"))
    x = torch.randn(2, FRAMES, 263, generator=torch.Generator().manual_seed(2))
    t = torch.full((2,), 300)
    plain = model(x, t, c, step=1)
    other_cond = cond(("out",), words=("a", "man", "jumps", "low"))
    other_cond = Condition(**{**other_cond.__dict__, "text_ids": torch.tensor([[3, 5, 7, 9]])})
    other = model(x[1:], t[1:], other_cond, step=1)
    assert (other[0] - plain[1]).abs().max() > 1e-4  # the other prompt predicts another motion

    def guided(weight, step=1, frames=None):
        return PromptGuidance(model, toward=other_cond, weight=weight, role="out", steps=frozenset({0, 1, 2}),
                              frames=frames)(x, t, c, step=step)

    assert torch.equal(guided(0.5)[0], plain[0])  # the ref slot keeps the plain prediction
    assert torch.allclose(guided(0.5)[1], plain[1] + 0.5 * (other[0] - plain[1]), atol=1e-6)
    assert torch.allclose(guided(1.0)[1], other[0], atol=1e-6)  # 1: the other prompt's prediction
    assert torch.equal(guided(0.0), plain)
    assert torch.equal(guided(0.5, step=7), plain)  # outside the step window: no guidance
    part = guided(1.0, frames=(4, 10))[1]  # only the frame span moves
    assert torch.equal(part[:4], plain[1, :4]) and torch.equal(part[10:], plain[1, 10:])
    assert torch.allclose(part[4:10], other[0, 4:10], atol=1e-6)
    # intensity mode edits no attention map by itself: its controller is a no-op and the output bit-identical
    cfg = ReweightConfig(word="jumps", weight=-0.5, mode="intensity")
    assert torch.equal(model(x, t, c, step=1, controller=Reweight(cfg, num_steps=10)), plain)
    with pytest.raises(ValueError, match=r"between -1 and 1 \(\+1 is the prompt said with the action's high word"):
        ReweightConfig(word="jumps", weight=1.5, mode="intensity")


def test_a_prompt_said_with_the_corpus_intensity_word_for_its_action():
    from engine.methods.intensity import intensity_word, with_intensity
    from engine.synth.grammar import INTENSITY_WORDS

    assert with_intensity("a person jumps", "jumps", level="high") == "a person jumps high"
    assert intensity_word("waves", "high") == INTENSITY_WORDS["wave"]["high"][0]
    assert intensity_word("hops", "a little") == INTENSITY_WORDS["jump"]["a little"][0]  # a hop says a jump's words
    # the word goes at the end of the action's own clause, as the corpus's captions put it
    assert with_intensity("a person walks forward then jumps twice", "jumps", level="a little") == \
        "a person walks forward then jumps twice a little"
    assert with_intensity("a person jumps and waves", "jumps", level="high") == "a person jumps high and waves"
    assert with_intensity("a person waves the right hand, then kicks", "waves", level="high") == \
        "a person waves the right hand energetically, then kicks"
    assert with_intensity("a person jumps then jumps again", "jumps", level="high", occurrence=1) == \
        "a person jumps then jumps again high"
    # an intensity the clause already says is replaced, not added to
    assert with_intensity("a person jumps a little then punches", "jumps", level="high") == \
        "a person jumps high then punches"
    assert with_intensity("a person waves the right hand gently", "waves", level="high") == \
        "a person waves the right hand energetically"
    with pytest.raises(ValueError, match="'walks' has no intensity word"):
        with_intensity("a person walks", "walks", level="high")
    with pytest.raises(ValueError, match="intensity level"):
        intensity_word("jumps", "medium")
