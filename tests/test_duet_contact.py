"""Contact guidance for duets (engine/methods/duet_contact.py): plans learned from the few-shot
examples, prompts read through the training captions, and the x̂0 guidance itself."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from engine.methods.duet_contact import (ContactConfig, ContactGuidance, ContactPlan, combined_place, contact_error,
                                         learn_plans, planned_distances, plans_for)
from engine.methods.duet_data import few_shot, pair_item, stack_pairs
from engine.representation import FEATURE_DIM, SLICES, Normalizer
from engine.skeleton import JOINT_INDEX

IDENTITY = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))


@pytest.fixture(scope="module")
def train_samples():
    return few_shot("train", per_interaction=2)


def test_plans_are_the_examples_contacts_as_fractions_of_the_clip(train_samples):
    table = learn_plans(train_samples)
    hand = [s for s in train_samples if s.interaction == "handshake"]
    (plan,) = table["plans"]["handshake"]
    assert plan["kind"] == "right_hands"
    starts = [s.labels["contacts"][0]["start"] / s.labels["frames"] for s in hand]
    ends = [s.labels["contacts"][0]["end"] / s.labels["frames"] for s in hand]
    assert plan["start"] == pytest.approx(np.mean(starts), abs=1e-4)
    assert plan["end"] == pytest.approx(np.mean(ends), abs=1e-4)
    assert table["plans"]["sparring"] == [] and table["plans"]["following"] == []
    assert table["plans"]["hug"][0]["kind"] == "bodies"
    assert table["plans"]["push"][0]["kind"] == "hands_on_chest"
    for s in train_samples:
        assert all(table["captions"][c] == s.interaction for c in s.captions)


def test_a_prompt_reads_as_the_interaction_of_the_caption_it_shares_most_words_with(train_samples):
    table = learn_plans(train_samples)
    name, plans = plans_for(table, "Two people shake hands")
    assert name == "handshake" and [p.kind for p in plans] == ["right_hands"]
    assert plans_for(table, "two people hug each other")[0] == "hug"
    assert plans_for(table, "two people walk side by side") == ("side_by_side", [])  # no contact to guide
    assert plans_for(table, "a person juggles") == (None, [])  # too few words in common
    assert plans_for({}, "two people hug") == (None, [])


def test_plan_and_config_checks():
    with pytest.raises(ValueError, match="unknown contact kind"):
        ContactPlan("elbows", 0.1, 0.2)
    with pytest.raises(ValueError, match="start < end"):
        ContactPlan("right_hands", 0.5, 0.5)
    with pytest.raises(ValueError, match="iters"):
        ContactConfig(iters=-1)
    assert ContactPlan("right_hands", 0.25, 0.5).frames(80) == slice(20, 40)
    assert not ContactConfig(iters=0).active


def _true_states(samples, normalizer=IDENTITY):
    x0, _ = stack_pairs([pair_item(s, normalizer) for s in samples])
    return x0


def test_the_truth_meets_its_own_plan_and_a_pair_moved_apart_does_not():
    hug = [s for s in few_shot("test", per_interaction=1) if s.interaction == "hug"]
    x0 = _true_states(hug)
    c = hug[0].labels["contacts"][0]
    n = hug[0].labels["frames"] - 1
    # the labelled frames, kept inside the features (one frame fewer than the joints)
    plan = [ContactPlan("bodies", (c["start"] + 2) / n, (min(c["end"], n) - 2) / n)]
    d = planned_distances(x0, IDENTITY)
    span = plan[0].frames(d.shape[1])
    assert d[0, span, 1:3].max() < 0.22  # a's hands on b's back: under the benchmark's 0.22 m
    apart = x0.clone()
    apart[0, -1, 1] += 0.8  # a sees b 0.8 m further away: the drawn pair, 0.4 m
    assert contact_error(apart, plan, IDENTITY) > contact_error(x0, plan, IDENTITY) + 0.1


def test_the_guided_placement_is_the_one_a_duet_is_drawn_with():
    from engine.methods.duet import combined_placement

    rng = np.random.default_rng(0)
    for _ in range(5):
        yaws = rng.uniform(-np.pi, np.pi, 2)
        rows = np.stack([[*rng.normal(size=2), np.cos(y), np.sin(y)] for y in yaws]).astype(np.float32)
        mine = combined_place(torch.from_numpy(rows))[0].numpy()
        theirs = combined_placement(rows).vector()
        np.testing.assert_allclose(mine, theirs, atol=1e-5)


class _Fixed:
    """A denoiser that always predicts the same x̂0."""

    def __init__(self, x0):
        self.x0 = x0

    def __call__(self, x, t, cond, *, step=0, controller=None):
        return self.x0.clone()


def test_guidance_closes_the_planned_contact_moving_only_arms_and_placement():
    hands = [s for s in few_shot("test", per_interaction=1) if s.interaction == "handshake"]
    x0 = _true_states(hands)
    x0[0, -1, 1] += 0.35  # b stands 35 cm further away than the truth (seen from a)
    x0[1, -1, 1] += 0.35  # and a from b
    plan = [ContactPlan("right_hands", 0.45, 0.6)]
    n = x0.shape[1] - 1
    before = contact_error(x0, plan, IDENTITY).item()
    assert before > 0.1
    config = ContactConfig(ramp=5)
    guided = ContactGuidance(_Fixed(x0), plan, IDENTITY, config)(x0, None, None)
    assert contact_error(guided, plan, IDENTITY).item() < 1e-3 * before
    d = planned_distances(guided, IDENTITY)
    assert d[0, plan[0].frames(n), 0].max() < 0.1  # the benchmark's handshake threshold
    changed = (guided - x0).abs() > 1e-7  # (2, T + 1, D)
    dims = set(np.flatnonzero(changed[:, :-1].any(0).any(0).numpy()).tolist())
    arm = set()
    for name in ("left_wrist", "right_wrist", "left_elbow", "right_elbow"):
        r = SLICES["ric"].start + 3 * (JOINT_INDEX[name] - 1)
        v = SLICES["local_vel"].start + 3 * JOINT_INDEX[name]
        arm |= {r, r + 1, r + 2, v, v + 1, v + 2}
    assert dims and dims <= arm
    assert set(np.flatnonzero(changed[:, -1].any(0).numpy()).tolist()) <= {0, 1}  # placement x, z only
    span = plan[0].frames(n)
    frames = np.flatnonzero(changed[:, :-1].any(0).any(-1).numpy())
    assert frames.min() >= span.start - config.ramp - 1 and frames.max() <= span.stop + config.ramp


def test_no_plan_or_no_iterations_is_bit_identical():
    x0 = torch.randn(2, 21, FEATURE_DIM)
    assert torch.equal(ContactGuidance(_Fixed(x0), [], IDENTITY)(x0, None, None), x0)
    plan = [ContactPlan("right_hands", 0.2, 0.6)]
    assert torch.equal(ContactGuidance(_Fixed(x0), plan, IDENTITY, ContactConfig(iters=0))(x0, None, None), x0)


def test_text_to_duet_guides_the_contact_the_prompt_reads_as(tiny_model_dir, tiny_duet_dir):
    from engine.evaluation.bench_duet import HANDS_TOUCH
    from engine.generate import FPS, SampleConfig
    from engine.methods.duet import text_to_duet
    from engine.train_commdm import load_trained

    model = load_trained(tiny_duet_dir, tiny_model_dir)
    (plan,) = plans_for(model.contact_table, "two people shake hands")[1]
    sample = SampleConfig(steps=6, seed=1)
    # the guidance alone (the spacing rule would move the untrained tiny model's people apart: test_duet_spacing.py)
    free = text_to_duet(model, "two people shake hands", seconds=3.0, sample=sample, contact=None, spacing=False)
    guided = text_to_duet(model, "two people shake hands", seconds=3.0, sample=sample, spacing=False)
    assert free.interaction is None and free.contacts == ()
    assert guided.interaction == "handshake" and guided.contacts == (plan,)
    span = plan.frames(3 * FPS)
    rw = JOINT_INDEX["right_wrist"]

    def hands(d):
        return np.linalg.norm(d.joints[0, span, rw] - d.joints[1, span, rw], axis=-1)

    assert hands(guided).max() < HANDS_TOUCH < hands(free).mean()
    # a prompt with no trained contact samples exactly as without guidance
    walk = text_to_duet(model, "two people walk side by side", seconds=2.0, sample=sample)
    walk_free = text_to_duet(model, "two people walk side by side", seconds=2.0, sample=sample, contact=None)
    assert walk.interaction == "side_by_side" and walk.contacts == ()
    np.testing.assert_array_equal(walk.joints, walk_free.joints)
