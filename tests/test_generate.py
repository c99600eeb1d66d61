"""generate(): shapes, trimming, determinism, clear errors; inversion utilities run end to end."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from engine.attention import AttentionStore
from engine.checkpoint import LoadedModel
from engine.generate import Request, SampleConfig, frames_for, generate
from engine.methods.inversion import InversionConfig, roundtrip_error
from engine.model import Denoiser, ModelConfig
from engine.representation import FEATURE_DIM, Normalizer
from engine.skeleton import Skeleton
from engine.text import PromptError, Tokenizer


@pytest.fixture(scope="module")
def loaded() -> LoadedModel:
    torch.manual_seed(0)
    model = Denoiser(ModelConfig(width=32, layers=2, heads=2, text_layers=1, vocab_size=16)).eval()
    rng = np.random.default_rng(0)
    normalizer = Normalizer(mean=rng.normal(0, 0.01, FEATURE_DIM), std=np.full(FEATURE_DIM, 0.05))
    return LoadedModel(model=model, tokenizer=Tokenizer(["a", "person", "jumps", "walks"]), normalizer=normalizer,
                       config={}, folder=Path("."))


def test_generate_shapes_and_trimming(loaded):
    store = AttentionStore()
    gen = generate(loaded, Request(prompts=["a person jumps", "a person walks"], frames=[30, 20]),
                   SampleConfig(steps=4, guidance=2.0), controller=store)
    assert gen.features.shape == (2, 30, FEATURE_DIM)
    assert [j.shape for j in gen.joints] == [(30, 22, 3), (20, 22, 3)]
    assert gen.tokens[0].words == ("a", "person", "jumps")
    assert store.steps == [0, 1, 2, 3]
    assert store.map(step=3, layer=1, kind="cross", slot=0).shape == (30, 3)


def test_same_seed_same_motion(loaded):
    req = Request(prompts=["a person walks"], frames=[16])
    a = generate(loaded, req, SampleConfig(steps=3, seed=5)).features
    b = generate(loaded, req, SampleConfig(steps=3, seed=5)).features
    c = generate(loaded, req, SampleConfig(steps=3, seed=6)).features
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_bad_requests_are_explained(loaded):
    with pytest.raises(ValueError, match="between"):
        frames_for(12.0)
    with pytest.raises(ValueError, match="between"):
        frames_for(0.2)
    with pytest.raises(ValueError, match="number"):
        frames_for(float("nan"))
    assert frames_for(6.0) == 120
    # a typo is read as the one word it is a slip of, and said so; a prompt with nothing readable that says a
    # motion is still refused, naming the word
    typo = generate(loaded, Request(prompts=["a person jumpz"], frames=[10]), SampleConfig(steps=2))
    assert typo.tokens[0].words == ("a", "person", "jumpz") and typo.tokens[0].read_as == {"jumpz": "jumps"}
    assert typo.tokens[0].notes() == ["read 'jumpz' as 'jumps'"]
    with pytest.raises(PromptError, match="flurbs"):
        generate(loaded, Request(prompts=["a person flurbs"], frames=[10]), SampleConfig(steps=2))
    with pytest.raises(PromptError, match="jumpz"):  # strict (training captions) refuses any unknown word
        loaded.tokenizer.encode("a person jumpz", strict=True)
    with pytest.raises(ValueError, match="steps"):
        SampleConfig(steps=0)
    with pytest.raises(ValueError, match="sampler"):
        SampleConfig(sampler="euler")
    with pytest.raises(ValueError, match="exceed"):
        generate(loaded, Request(prompts=["a person walks"], frames=[300]), SampleConfig(steps=2))


def test_inversion_round_trip_runs_and_reports_metres(loaded):
    rng = np.random.default_rng(1)
    from engine.rotations import axis_angle_to_matrix

    sk = Skeleton.default()
    joints = sk.forward(axis_angle_to_matrix(np.cumsum(rng.normal(0, 0.02, (25, 22, 3)), 0)),
                        np.array([0.0, 0.95, 0.0]) + np.cumsum(rng.normal(0, 0.01, (25, 3)), 0))
    report = roundtrip_error(loaded, joints, InversionConfig(prompt="a person walks", steps=10, refine=2))
    assert report["frames"] == 24 and np.isfinite(report["mean_m"]) and report["max_m"] >= report["mean_m"]
    assert np.isfinite(report["noise_std"]) and report["noise_std"] > 0
    with pytest.raises(ValueError, match="longer than the model's 9.8 s: pick a window with --start/--seconds"):
        roundtrip_error(loaded, np.zeros((300, 22, 3)) + joints[:1], InversionConfig(steps=2))


def test_sample_config_guides_only_from_its_timestep():
    """The guidance applies at t >= guidance_from (the units' default); 0 = every step; 1.0 = no wrapper."""
    import pytest

    from engine.diffusion import ClassifierFreeGuidance
    from engine.generate import SampleConfig
    from engine.units import DEFAULT_GUIDANCE_FROM

    inner = object()
    guided = SampleConfig().guided(inner)
    assert isinstance(guided, ClassifierFreeGuidance) and guided.denoiser is inner
    assert guided.from_t == DEFAULT_GUIDANCE_FROM == SampleConfig().guidance_from
    assert SampleConfig(guidance_from=0).guided(inner).from_t == 0
    assert SampleConfig(guidance=1.0).guided(inner) is inner
    with pytest.raises(ValueError, match="guidance_from must be a timestep"):
        SampleConfig(guidance_from=1000)


def test_stochastic_sampling_keeps_a_seed_one_motion(loaded):
    """The default eta adds noise at every step, drawn from each slot's own start: the same seed gives the same
    motion, and a slot that starts from a motion's noise in a bigger, longer batch (an edit's ref and out, a leader
    beside its followers) retraces that motion; eta 0 is deterministic DDIM and differs."""
    from engine.units import DEFAULT_ETA

    assert SampleConfig().eta == DEFAULT_ETA > 0
    config = SampleConfig(steps=6, seed=4)
    alone = generate(loaded, Request(prompts=["a person jumps"], frames=[20]), config)
    again = generate(loaded, Request(prompts=["a person jumps"], frames=[20]), config)
    np.testing.assert_array_equal(alone.features, again.features)
    start = torch.cat([alone.noise, torch.randn(1, 20, FEATURE_DIM)], 1)  # padded to 40 frames
    batch = generate(loaded, Request(prompts=["a person walks", "a person jumps", "a person jumps"], frames=[40, 20, 20],
                                     noise=torch.cat([torch.randn(1, 40, FEATURE_DIM), start, start])), config)
    np.testing.assert_allclose(batch.features[1, :20], alone.features[0], atol=1e-4)
    np.testing.assert_allclose(batch.features[1], batch.features[2], atol=1e-5)  # up to the batch's rounding
    ddim = generate(loaded, Request(prompts=["a person jumps"], frames=[20]), SampleConfig(steps=6, seed=4, eta=0.0))
    assert np.abs(ddim.features - alone.features).max() > 1e-3
    with pytest.raises(ValueError, match="eta must be between 0 and 1"):
        SampleConfig(eta=1.5)


def test_a_real_source_slot_is_that_motion_at_eta_one(loaded, real_joints):
    """Example-based generation from a real motion at the default eta (stochastic steps): the example's slot follows
    its inversion path, so it is the real motion itself (what the outputs' queries read), not a random variation."""
    from engine.methods.edits import example_based
    from engine.representation import features_to_joints, joints_to_features

    joints = np.ascontiguousarray(real_joints[:41], dtype=np.float32)
    out = example_based(loaded, joints, count=2, frames=40, sample=SampleConfig(steps=4, seed=2))
    example = out.generation.joints[0]
    truth = features_to_joints(joints_to_features(joints))
    assert SampleConfig().eta > 0 and example.shape == truth.shape
    np.testing.assert_allclose(example, truth, atol=2e-3)
