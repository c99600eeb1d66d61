"""The prediction's skip (``ModelConfig.skip_sigma``): x0_hat = c x_t / sqrt(alpha_bar) + (1 - c) network, so the last
sampling steps keep what the network cannot draw (a motion unlike the corpus), the noisy ones are the network's."""
from __future__ import annotations

import json

import torch

from engine.diffusion import CosineSchedule
from engine.model.denoiser import Denoiser, ModelConfig
from tests.test_attention import condition

TINY = dict(width=32, layers=2, heads=2, text_layers=1, vocab_size=16, max_frames=40)


def _model(skip: float) -> Denoiser:
    torch.manual_seed(0)
    return Denoiser(ModelConfig(**TINY, skip_sigma=skip)).eval()


def test_without_the_skip_the_prediction_is_the_networks_output():
    model = _model(0.0)
    x = torch.randn(2, 12, model.config.feature_dim)
    t = torch.tensor([999, 19])
    cond = condition(batch=2, frames=12, roles=("ref", "edit"))
    with torch.no_grad():
        run = model.begin(t, cond)
        out = model.head(model.layers(model.embed_frames(x), run, range(model.num_layers)))
        assert torch.equal(model(x, t, cond), out)
    assert "skip_sigma" in json.loads(model.config_json())


def test_the_skip_keeps_the_input_at_the_last_steps_and_leaves_the_noisy_ones_to_the_network():
    model = _model(0.1)
    with torch.no_grad():  # a network that draws nothing: every prediction is 0 but for the skip
        model.out_proj.weight.zero_()
        model.out_proj.bias.zero_()
    x = torch.randn(3, 12, model.config.feature_dim)
    t = torch.tensor([19, 199, 999])
    cond = condition(batch=3, frames=12, roles=("ref", "edit", "out"))
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
