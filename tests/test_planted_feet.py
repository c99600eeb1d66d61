"""The planted-feet denoiser wrapper (engine.diffusion.feet): feet on the floor stop sliding, the legs keep their
bones, the root and everything but the legs are left alone, and turned off it is the inner denoiser bit for bit."""
import numpy as np
import pytest
import torch

from engine.diffusion.feet import BONES, FEET, MOVED, PlantedFeet
from engine.evaluation.metrics import foot_skate
from engine.representation import FEATURE_DIM, SLICES, Normalizer, features_to_joints
from engine.synth import Corpus


def _walk() -> np.ndarray:
    """A corpus walk's features (T, 263)."""
    corpus = Corpus("test")
    for k in range(200):
        s = corpus.sample(k)
        if [seg.action for seg in s.program.segments] == ["walk"]:
            return s.features.astype(np.float32)
    raise AssertionError("no plain walk in the first 200 test motions")


def _sliding(features: np.ndarray, *, metres_per_frame: float) -> np.ndarray:
    """The walk with its feet and knees dragged forward in the body frame a little more every frame: the body
    moonwalks, each planted foot slides."""
    out = features.copy()
    ric = out[:, SLICES["ric"]].reshape(len(out), -1, 3)
    drift = metres_per_frame * (np.arange(len(out)) % 20)[:, None]  # a sawtooth: a slide within every 1 s
    for j in MOVED:
        ric[:, j - 1, 2] += drift[:, 0]
    out[:, SLICES["ric"]] = ric.reshape(len(out), -1)
    return out


class _Fixed:
    """A denoiser that predicts the same x0 whatever it is given."""

    def __init__(self, x0: torch.Tensor):
        self.x0 = x0

    def __call__(self, x, t, cond, *, step=0, controller=None):
        return self.x0.clone()


@pytest.fixture(scope="module")
def case():
    feats = _sliding(_walk(), metres_per_frame=0.03)
    mean = feats.mean(0)
    std = feats.std(0) + 0.1
    norm = Normalizer(mean=mean, std=std)
    x0 = torch.from_numpy((feats - mean) / std)[None]  # (1, T, 263) normalised
    return feats, norm, x0


def _joints(x0: torch.Tensor, norm: Normalizer) -> np.ndarray:
    return features_to_joints(x0[0].numpy() * norm.std + norm.mean)


def _bones(joints: np.ndarray) -> np.ndarray:
    a, b = zip(*BONES)
    return np.linalg.norm(joints[:, list(b)] - joints[:, list(a)], axis=-1)


def test_feet_on_the_floor_stop_sliding_and_the_legs_keep_their_bones(case):
    feats, norm, x0 = case
    before = _joints(x0, norm)
    wrapped = PlantedFeet(_Fixed(x0), norm)
    out = wrapped(x0, torch.tensor([100]), None)
    after = _joints(out, norm)
    assert foot_skate(before) > 0.3  # the dragged walk slides
    assert foot_skate(after) < 0.5 * foot_skate(before)
    assert np.abs(_bones(after) - _bones(before)).max() < 0.02  # metres
    # the root and every joint the correction does not move are where they were; feet keep their height
    kept = [j for j in range(22) if j not in MOVED]
    np.testing.assert_allclose(after[:, kept], before[:, kept], atol=1e-4)
    low = before[:, list(FEET), 1] < 0.05
    assert np.abs(after[:, list(FEET), 1] - before[:, list(FEET), 1])[low].mean() < 0.01
    # only the moved joints' ric features change
    changed = np.flatnonzero(np.abs(out[0].numpy() - x0[0].numpy()).max(0) > 0)
    moved = {SLICES["ric"].start + 3 * (j - 1) + c for j in MOVED for c in range(3)}
    assert len(changed) > 0 and set(changed.tolist()) <= moved


def test_off_or_at_the_noisy_steps_it_is_the_inner_denoiser(case):
    _, norm, x0 = case
    inner = _Fixed(x0)
    assert torch.equal(PlantedFeet(inner, norm, strength=0.0)(x0, torch.tensor([100]), None), x0)
    assert torch.equal(PlantedFeet(inner, norm, below=400)(x0, torch.tensor([400]), None), x0)


def test_a_motion_in_the_air_is_left_alone():
    feats = _walk()
    ric = feats[:, SLICES["ric"]].reshape(len(feats), -1, 3)
    ric[:, :, 1] += 1.0  # every joint a metre up (ric heights are above the floor): no foot on the floor
    feats[:, SLICES["ric"]] = ric.reshape(len(feats), -1)
    norm = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    x0 = torch.from_numpy(feats)[None]
    assert torch.equal(PlantedFeet(_Fixed(x0), norm)(x0, torch.tensor([0]), None), x0)


def test_a_walk_hovering_above_the_floor_is_brought_onto_it():
    """The walk 3 cm up (every joint): its feet on the floor come down to it; the pelvis stays where it was."""
    feats = _walk()
    ric = feats[:, SLICES["ric"]].reshape(len(feats), -1, 3)
    ric[:, :, 1] += 0.03
    feats[:, SLICES["ric"]] = ric.reshape(len(feats), -1)
    feats[:, SLICES["root_height"]] += 0.03
    norm = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    x0 = torch.from_numpy(feats)[None]
    before = _joints(x0, norm)
    lowest = before[:, list(FEET), 1].min(1)
    assert np.median(lowest) > 0.025
    after = _joints(PlantedFeet(_Fixed(x0), norm)(x0, torch.tensor([0]), None), norm)
    assert np.median(after[:, list(FEET), 1].min(1)) < 0.01
    np.testing.assert_allclose(after[:, 0], before[:, 0], atol=1e-5)
    assert np.abs(_bones(after) - _bones(before)).max() < 0.02
    # turned off, the hover stays (and only the sliding is corrected)
    kept = _joints(PlantedFeet(_Fixed(x0), norm, ground=False)(x0, torch.tensor([0]), None), norm)
    assert np.median(kept[:, list(FEET), 1].min(1)) > 0.02


def test_the_second_take_keeps_planted_feet_still_in_its_sandwich():
    """DoubleTake's second take (engine.methods.doubletake) wraps its prediction in PlantedFeet by default:
    on a first take whose walk slides, the re-made sandwich slides less than the paper's second take makes it, and
    the frames outside the sandwich are the first take's in both."""
    from tests.conftest import random_corpus_model
    from engine.generate import SampleConfig
    from engine.methods.doubletake import SecondTake, second_take

    loaded = random_corpus_model(layers=2)
    feats = _sliding(_walk(), metres_per_frame=0.03)
    first = torch.from_numpy(loaded.normalizer.normalize(feats)).float()  # (T, 263)
    n = len(first)
    a, b = n // 2 - 10, n // 2 + 10
    sample = SampleConfig(steps=10, seed=3)
    made = {on: second_take(loaded, first, [(a, b)], SecondTake(context=30, planted_feet=on), sample=sample)
            for on in (True, False)}
    joints = {on: features_to_joints(loaded.normalizer.denormalize(x.numpy())) for on, x in made.items()}
    inside = slice(a - 30, b + 30)
    assert foot_skate(joints[True][inside]) < 0.7 * foot_skate(joints[False][inside]), \
        (foot_skate(joints[True][inside]), foot_skate(joints[False][inside]))
    for on in (True, False):
        torch.testing.assert_close(made[on][: a - 31], first[: a - 31])
        torch.testing.assert_close(made[on][b + 31 :], first[b + 31 :])


def test_the_correction_does_not_jitter_from_frame_to_frame():
    """On a corpus walk that barely slides the feet stop sliding, and the correction changes smoothly over frames:
    its third difference (what the jerk figure sums) stays under 10 mm per frame. With Adam's default eps the joints
    that needed no change moved a step's size a different way each frame: 15 mm here, +20 % jerk on generated walks."""
    feats = _walk()
    norm = Normalizer(mean=feats.mean(0), std=feats.std(0) + 0.1)
    x0 = torch.from_numpy((feats - norm.mean) / norm.std)[None].float()
    before = _joints(x0, norm)
    after = _joints(PlantedFeet(_Fixed(x0), norm)(x0, torch.tensor([0]), None), norm)
    assert foot_skate(before) > 0.02 and foot_skate(after) < 0.5 * foot_skate(before)
    correction = (after - before)[:, list(MOVED)]  # (T, 6, 3) metres
    third = np.linalg.norm(np.diff(correction, 3, axis=0), axis=-1).mean()
    assert third < 0.010, third
