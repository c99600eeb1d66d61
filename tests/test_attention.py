"""The attention extension point on a tiny seeded model."""
from __future__ import annotations

import threading

import pytest
import torch

from engine.attention import AttentionStore, BatchRoles, Controller, StoreConfig, attach, stack
from engine.attention.context import WordIndex
from engine.diffusion import ClassifierFreeGuidance, CosineSchedule, ddim, final
from engine.model import Condition, Denoiser, ModelConfig


def tiny_model(seed: int = 0) -> Denoiser:
    torch.manual_seed(seed)
    return Denoiser(ModelConfig(width=32, layers=3, heads=2, text_layers=1, vocab_size=16, dropout=0.0)).eval()


def condition(batch: int = 2, frames: int = 24, words: int = 4, roles=("ref", "edit")) -> Condition:
    g = torch.Generator().manual_seed(1)
    return Condition(
        text_ids=torch.randint(1, 16, (batch, words), generator=g),
        text_mask=torch.ones(batch, words, dtype=torch.bool),
        frame_mask=torch.ones(batch, frames, dtype=torch.bool),
        use_text=torch.ones(batch, dtype=torch.bool),
        roles=BatchRoles.of(*roles),
        words=WordIndex(words=tuple(tuple(f"w{i}" for i in range(words)) for _ in range(batch))),
    )


def inputs(batch=2, frames=24):
    g = torch.Generator().manual_seed(2)
    return torch.randn(batch, frames, 263, generator=g), torch.full((batch,), 400)


class Recorder(Controller):
    def __init__(self):
        self.calls = []

    def on_qkv(self, q, k, v, ctx):
        self.calls.append(ctx)
        return None


def test_do_nothing_controller_is_bit_identical():
    model, cond = tiny_model(), condition()
    x, t = inputs()
    plain = model(x, t, cond)
    assert torch.equal(plain, model(x, t, cond, controller=Controller()))
    assert torch.equal(plain, model(x, t, cond, controller=stack(Controller(), Controller())))
    # the same holds through a whole guided sampling run
    sched = CosineSchedule()
    guided = ClassifierFreeGuidance(model, scale=2.5)
    a = final(ddim(guided, x, cond, schedule=sched, num_steps=5)).x_prev
    b = final(ddim(guided, x, cond, schedule=sched, num_steps=5, controller=Controller())).x_prev
    assert torch.equal(a, b)


def test_every_call_gets_an_explicit_context():
    model, cond = tiny_model(), condition()
    x, t = inputs()
    rec = Recorder()
    model(x, t, cond, controller=rec, step=7)
    kinds = [(c.layer, c.kind) for c in rec.calls]
    assert kinds == [(l, k) for l in range(3) for k in ("self", "cross")]
    assert all(c.step == 7 and c.t == 400 and c.roles.names == ("ref", "edit") for c in rec.calls)
    assert rec.calls[1].words.index(1, "w2") == 2


def test_explicit_softmax_path_matches_fast_path():
    model, cond = tiny_model(), condition()
    x, t = inputs()
    store = AttentionStore()
    assert store.needs_maps
    out = model(x, t, cond, controller=store)
    assert torch.allclose(out, model(x, t, cond), atol=1e-5)
    m = store.map(step=0, layer=1, kind="cross", slot=1)
    assert m.shape == (24, 4)
    assert torch.allclose(m.sum(-1), torch.ones(24), atol=1e-2)


def test_the_training_path_computes_the_same_attention():
    """Training's own explicit path (one baddbmm with the mask as a bias; the softmax kept in bf16 under autocast)
    gives the sampling path's output: to float precision in fp32, to bf16's in bf16, padded keys and text-less slots
    included."""
    from engine.model.attention import training_probs

    model, cond = tiny_model(), condition()
    cond.text_mask[1, 2:] = False  # padded words
    cond.frame_mask[0, 20:] = False  # padded frames
    x, t = inputs()
    with torch.no_grad():
        sampled = model(x, t, cond)
    model.train()
    trained = model(x, t, cond)
    assert torch.allclose(trained, sampled, atol=1e-5)
    trained.sum().backward()  # and it has a gradient
    assert all(p.grad is not None for p in model.blocks[0].self_attn.parameters())
    g = torch.Generator().manual_seed(4)
    q, k = torch.randn(2, 2, 5, 8, generator=g), torch.randn(2, 2, 7, 8, generator=g)
    mask = torch.ones(2, 7, dtype=torch.bool)
    mask[0, 4:] = False
    expected = (q @ k.transpose(-1, -2) / 8**0.5).masked_fill(~mask[:, None, None, :], float("-inf")).softmax(-1)
    assert torch.allclose(training_probs(q, k, mask), expected, atol=1e-6)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        low = training_probs(q.bfloat16(), k.bfloat16(), mask)
    assert low.dtype == torch.bfloat16 and float(low[0, :, :, 4:].abs().max()) == 0.0
    assert torch.allclose(low.float(), expected, atol=2e-2)


def test_probs_edit_changes_only_what_it_should():
    model, cond = tiny_model(), condition()
    x, t = inputs()

    class ZeroWord(Controller):
        needs_maps = True

        def on_probs(self, probs, ctx):
            if ctx.kind != "cross":
                return None
            probs = probs.clone()
            probs[ctx.roles.slot("edit"), :, :, 0] = 0.0
            return probs

    base = model(x, t, cond)
    edited = model(x, t, cond, controller=ZeroWord())
    ref_slot, edit_slot = 0, 1
    assert torch.allclose(edited[ref_slot], base[ref_slot], atol=1e-5)
    assert (edited[edit_slot] - base[edit_slot]).abs().max() > 1e-4


def test_store_respects_selection_and_budget():
    model, cond = tiny_model(), condition()
    x, t = inputs()
    store = AttentionStore(StoreConfig(kinds=("self",), layers=frozenset({2}), record_qkv=True))
    model(x, t, cond, controller=store, step=3)
    assert store.sites() == [(3, 2, "self")]
    rec = store.get(step=3, layer=2, kind="self")
    assert rec.q.shape == (2, 2, 24, 16) and rec.probs.shape == (2, 2, 24, 24)
    tiny = AttentionStore(StoreConfig(budget_bytes=100))
    model(x, t, cond, controller=tiny)
    assert not tiny.records and tiny.skipped_sites
    with pytest.raises(KeyError, match="nothing recorded"):
        store.get(step=0, layer=0, kind="cross")


def test_store_skips_unconditional_half_of_cfg():
    model, cond = tiny_model(), condition()
    x, _ = inputs()
    store = AttentionStore()
    final(ddim(ClassifierFreeGuidance(model, scale=2.0), x, cond, schedule=CosineSchedule(), num_steps=3, controller=store))
    rec = store.get(step=2, layer=0, kind="cross")
    assert rec.probs.shape[0] == 2 and rec.roles == ("ref", "edit")
    assert store.steps == [0, 1, 2]


def test_attach_restores_and_isolates_threads():
    model, cond = tiny_model(), condition()
    x, t = inputs()
    rec = Recorder()
    with attach(model, rec):
        model(x, t, cond)
        seen_in_thread = []

        def other():
            before = len(rec.calls)
            model(x, t, cond)
            seen_in_thread.append(len(rec.calls) - before)

        th = threading.Thread(target=other)
        th.start()
        th.join()
    assert len(rec.calls) == 6 and seen_in_thread == [0]
    with pytest.raises(RuntimeError):
        with attach(model, rec):
            raise RuntimeError("boom")
    model(x, t, cond)
    assert len(rec.calls) == 6  # detached after the error too


def test_unconditional_rows_ignore_text():
    model = tiny_model()
    cond = condition()
    x, t = inputs()
    cond.use_text = torch.tensor([False, False])
    other = condition()
    other.use_text = torch.tensor([False, False])
    other.text_ids = (other.text_ids % 15) + 1
    assert torch.allclose(model(x, t, cond), model(x, t, other))


def test_windows():
    from engine.attention.context import AttnCtx
    from engine.methods.windows import Window

    bound = Window(0.0, 0.5, layers=(1, 2)).bind(10)
    assert sorted(bound.steps) == [0, 1, 2, 3, 4]
    ctx = AttnCtx(layer=1, kind="self", step=4, t=0, roles=BatchRoles.of("out"))
    assert bound.covers(ctx) and not bound.covers(AttnCtx(layer=0, kind="self", step=4, t=0, roles=ctx.roles))
    assert not bound.covers(AttnCtx(layer=1, kind="self", step=5, t=0, roles=ctx.roles))
    with pytest.raises(ValueError):
        Window(0.6, 0.5)
    with pytest.raises(ValueError):
        Window().bind(0)


def test_guidance_in_a_limited_interval_is_the_conditional_prediction_outside_it():
    model, cond = tiny_model(), condition()
    x, t = inputs()  # t = 400 in every slot
    plain = model(x, t, cond)
    full = ClassifierFreeGuidance(model, scale=2.5)(x, t, cond)
    assert not torch.allclose(plain, full)
    assert torch.equal(ClassifierFreeGuidance(model, scale=2.5, from_t=500)(x, t, cond), plain)
    assert torch.equal(ClassifierFreeGuidance(model, scale=2.5, from_t=401)(x, t, cond), plain)
    assert torch.equal(ClassifierFreeGuidance(model, scale=2.5, from_t=400)(x, t, cond), full)
    assert torch.equal(ClassifierFreeGuidance(model, scale=2.5, from_t=0)(x, t, cond), full)
