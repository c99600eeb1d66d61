"""The prediction's skip (``ModelConfig.skip_sigma``): x0_hat = c x_t / sqrt(alpha_bar) + (1 - c) network on the slots
whose condition keeps its input (``KEEP_INPUT``: training, DDIM inversion and the rebuild from inverted noise), so the
last steps keep what the network cannot draw (a motion unlike the corpus), the noisy ones are the network's; generation
without it is the network's own."""
from __future__ import annotations

import json

from dataclasses import replace

import torch

from engine.diffusion import CosineSchedule
from engine.model.denoiser import KEEP_INPUT, Denoiser, ModelConfig
from tests.test_attention import condition

TINY = dict(width=32, layers=2, heads=2, text_layers=1, vocab_size=16, max_frames=40)


def _model(skip: float) -> Denoiser:
    torch.manual_seed(0)
    return Denoiser(ModelConfig(**TINY, skip_sigma=skip)).eval()


def _network_output(model: Denoiser, x: torch.Tensor, t: torch.Tensor, cond) -> torch.Tensor:
    """The network's own output (B, T, 263), before the prediction's skip."""
    run = model.begin(t, cond)
    return model.head(model.layers(model.embed_frames(x), run, range(model.num_layers)))


def test_without_the_skip_the_prediction_is_the_networks_output():
    model = _model(0.0)
    x = torch.randn(2, 12, model.config.feature_dim)
    t = torch.tensor([999, 19])
    cond = condition(batch=2, frames=12, roles=("ref", "edit"))
    with torch.no_grad():
        assert torch.equal(model(x, t, cond), _network_output(model, x, t, cond))
    assert "skip_sigma" in json.loads(model.config_json())


def test_the_skip_keeps_the_input_at_the_last_steps_and_leaves_the_noisy_ones_to_the_network():
    model = _model(0.1)
    with torch.no_grad():  # a network that draws nothing: every prediction is 0 but for the skip
        model.out_proj.weight.zero_()
        model.out_proj.bias.zero_()
    x = torch.randn(3, 12, model.config.feature_dim)
    t = torch.tensor([19, 199, 999])
    cond = condition(batch=3, frames=12, roles=("ref", "edit", "out")).keeping_input()
    with torch.no_grad():
        x0_hat = model(x, t, cond)
    ab = CosineSchedule().alpha_bar(t).reshape(-1, 1, 1)
    c = 0.01 / ((1 - ab) / ab + 0.01)
    assert torch.allclose(x0_hat, c * x / ab.sqrt(), atol=1e-5)
    assert c[0] > 0.8 and c[1] < 0.1 and c[2] < 1e-6  # t = 19: mostly the input; t = 999: the network alone
    kept = (x0_hat[0] - x[0]).norm() / x[0].norm()
    assert kept < 0.2  # at the last step a motion the network cannot draw is kept (plain x0 prediction: lost)


def test_a_negative_skip_is_refused():
    try:
        _model(-0.1)
    except ValueError as exc:
        assert "skip_sigma" in str(exc)
    else:
        raise AssertionError("a negative skip_sigma was accepted")


def test_the_skip_path_starts_as_the_plain_skip_and_then_corrects_every_feature():
    """``skip_path``: a full-width convolution on the skip's input, its output starting at zero, so a fine-tune that
    switches it on starts from the plain skip; once its weights move it changes every feature dimension."""
    plain = _model(0.1)
    torch.manual_seed(0)
    path = Denoiser(ModelConfig(**TINY, skip_sigma=0.1, skip_path=24)).eval()
    missing, unexpected = path.load_state_dict(plain.state_dict(), strict=False)
    assert not unexpected and missing and all(k.startswith("skip_path.") for k in missing)
    x = torch.randn(2, 12, path.config.feature_dim)
    t = torch.tensor([19, 99])
    cond = condition(batch=2, frames=12, roles=("ref", "edit")).keeping_input()
    with torch.no_grad():
        assert torch.equal(path(x, t, cond), plain(x, t, cond))
        torch.nn.init.normal_(path.skip_path.conv_out.weight, std=0.1)
        moved = (path(x, t, cond) - plain(x, t, cond)).abs().amax(dim=(0, 1))  # (263,)
    assert bool((moved > 0).all())


def test_a_skip_path_without_the_skip_is_refused():
    try:
        Denoiser(ModelConfig(**TINY, skip_path=16))
    except ValueError as exc:
        assert "skip_path" in str(exc)
    else:
        raise AssertionError("a skip path without a skip was accepted")


def test_the_skip_acts_only_on_the_slots_that_keep_their_input():
    """Generation leaves ``KEEP_INPUT`` out: its prediction is the network's output bit for bit, whatever the skip; a
    condition keeping one slot changes that slot only."""
    model = _model(0.1)
    x = torch.randn(2, 12, model.config.feature_dim)
    t = torch.tensor([19, 19])
    cond = condition(batch=2, frames=12, roles=("ref", "edit"))
    with torch.no_grad():
        network = _network_output(model, x, t, cond)
        assert torch.equal(model(x, t, cond), network)
        one = replace(cond, extras={KEEP_INPUT: torch.tensor([False, True])})
        mixed, both = model(x, t, one), model(x, t, cond.keeping_input())
    assert torch.equal(mixed[0], network[0])
    assert not torch.allclose(mixed[1], network[1], atol=1e-3)
    assert torch.allclose(mixed[1], both[1], atol=1e-5)


def test_the_inversion_round_trip_keeps_a_motion_the_network_cannot_draw(real_joints):
    """DDIM inversion and the rebuild from its noise keep their input (``motion_condition``): with a network that
    draws nothing but the mean pose, a real motion comes back through the skip (but for the share the network should
    draw), and is lost without it."""
    from engine.checkpoint import LoadedModel
    from engine.methods.inversion import InversionConfig, motion_condition, roundtrip_error
    from tests.conftest import random_corpus_model

    assert bool(motion_condition(random_corpus_model(layers=1), "", 8).extras[KEEP_INPUT].all())
    errors = {}
    for skip, landing in ((0.0, 0), (0.1, 0), (0.1, 4)):
        base = random_corpus_model(layers=1)
        torch.manual_seed(0)
        model = Denoiser(ModelConfig(**{**base.model.config.to_json(), "skip_sigma": skip})).eval()
        with torch.no_grad():
            model.out_proj.weight.zero_()
            model.out_proj.bias.zero_()
        loaded = LoadedModel(model=model, tokenizer=base.tokenizer, normalizer=base.normalizer, config={},
                             folder=base.folder)
        errors[skip, landing] = roundtrip_error(loaded, real_joints[:40], InversionConfig(steps=50, landing=landing))[
            "mean_m"]
    # at the last step (t = 19) the skip keeps 85 % of the input and the network draws the rest: here nothing
    assert errors[0.1, 0] < 0.3 * errors[0.0, 0], errors
    # the landing solves that last step (the latent at t = 19 whose prediction is the motion): the round trip closes
    assert errors[0.1, 4] < 0.1 * errors[0.1, 0], errors


def test_keeping_input_marks_the_slots_on_the_conditions_own_device():
    """Training the skip path on a GPU moves the condition there first, then asks it to keep its input (session 44:
    the mark was made on the CPU and the prediction's blend failed on cuda:0). The meta device stands in for one."""
    cond = condition(batch=2, frames=12, roles=("ref", "edit")).to_device(torch.device("meta"))
    keep = cond.keeping_input().extras[KEEP_INPUT]
    assert keep.device.type == "meta" and keep.dtype == torch.bool and keep.shape == (2,)
