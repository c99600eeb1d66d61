"""MoMo on a tiny seeded model: mixing only inside its windows, key masks, pinned inversion, analysis, CLI."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from engine.analysis.qk import (
    ClusterConfig, Site, attention_map, cluster_site, fit, fit_clusters, nearest_keys, paper_site, qk_at, qk_record,
)
from engine.attention import AttentionStore, BatchRoles, stack
from engine.attention.context import AttnCtx
from engine.checkpoint import LoadedModel
from tests.conftest import random_corpus_model
from engine.generate import Request, SampleConfig, generate
from engine.methods.mixing import MixConfig, MixedAttention
from engine.methods.momo import (
    FOLLOWER, LEADER, OUT, Source, TransferConfig, analyze, canonical, prepare, transfer, transfer_streams,
)
from engine.methods.momo_baselines import inpaint_upper_body, lower_body_dims, motion_space_nn
from engine.methods.windows import Window
from engine.representation import SLICES
from engine.skeleton import FOOT_JOINTS, JOINT_INDEX
from engine.synth import Corpus
from engine.text import PromptError

STEPS = 6


@pytest.fixture(scope="module")
def loaded() -> LoadedModel:
    return random_corpus_model(layers=3)


@pytest.fixture(scope="module")
def corpus_motion() -> np.ndarray:
    return Corpus(split="test").sample(3).joints[:61]


def _ctx(names, *, layer=1, step=2, uncond=()):
    return AttnCtx(layer=layer, kind="self", step=step, t=500, roles=BatchRoles(names=tuple(names), uncond=tuple(uncond)))


def test_mixed_attention_takes_q_from_leader_and_kv_from_follower_only_inside_the_window():
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER, target=OUT, window=Window(0.2, 0.6, layers=(1, 2))),
                         num_steps=10)
    g = torch.Generator().manual_seed(0)
    q, k, v = (torch.randn(3, 2, 7, 4, generator=g) for _ in range(3))
    names = (LEADER, FOLLOWER, OUT)
    q2, k2, v2 = mix.on_qkv(q, k, v, _ctx(names, layer=1, step=3))
    assert torch.equal(q2[2], q[0]) and torch.equal(k2[2], k[1]) and torch.equal(v2[2], v[1])
    assert torch.equal(q2[:2], q[:2]) and torch.equal(k2[:2], k[:2])  # leader and follower untouched
    for layer, step in ((0, 3), (1, 1), (1, 6), (2, 9)):  # outside the layers or the steps
        assert mix.on_qkv(q, k, v, _ctx(names, layer=layer, step=step)) is None
    cross = AttnCtx(layer=1, kind="cross", step=3, t=500, roles=BatchRoles(names=names))
    assert mix.on_qkv(q, k, v, cross) is None


def test_mixing_reaches_both_cfg_halves_and_pairs_several_followers():
    names = (LEADER, FOLLOWER, OUT, FOLLOWER, OUT)
    roles = BatchRoles(names=names).with_uncond()
    ctx = AttnCtx(layer=1, kind="self", step=0, t=900, roles=roles)
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER), num_steps=4)
    q = torch.arange(10.0).view(10, 1, 1, 1).expand(10, 1, 3, 2).clone()
    q2, k2, _ = mix.on_qkv(q, q.clone(), q.clone(), ctx)
    assert q2[:, 0, 0, 0].tolist() == [0, 1, 0, 3, 0, 5, 6, 5, 8, 5]
    assert k2[:, 0, 0, 0].tolist() == [0, 1, 1, 3, 3, 5, 6, 6, 8, 8]
    mask = torch.tensor([[True] * 3 + [False]] * 10)
    mask[1, :] = True  # follower 1 is longer than the others
    borrowed = mix.on_key_mask(mask, ctx)
    assert borrowed[2].all() and not borrowed[4].all() and borrowed[0].tolist() == mask[0].tolist()


def test_mixing_without_its_roles_is_a_clear_error():
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER), num_steps=4)
    q = torch.zeros(2, 1, 3, 2)
    with pytest.raises(KeyError, match="leader"):
        mix.on_qkv(q, q, q, _ctx((FOLLOWER, OUT), step=0, layer=0))


def test_an_empty_window_gives_the_plain_generation(loaded):
    """No mixing step: `out` is the follower prompt sampled from the leader's noise (up to batched float sums)."""
    config = TransferConfig(start=0.5, end=0.5, root="none", flights=False)  # nothing taken from the leader
    sample = SampleConfig(steps=STEPS, guidance=2.0, seed=3)
    result = transfer(loaded, Source(prompt="a person walks forward", seconds=2), [Source(prompt="a person jumps", seconds=2)],
                      config, sample=sample)
    noise = result.leader.noise
    plain = generate(loaded, Request(prompts=["a person jumps"], frames=[40], noise=noise), sample)
    np.testing.assert_allclose(result.out(0), plain.joints[0], atol=1e-5)


def test_transfer_changes_the_output_and_keeps_lengths_and_root(loaded):
    sample = SampleConfig(steps=STEPS, guidance=2.0)
    leader = Source(prompt="a person walks forward", seconds=2.5)
    followers = [Source(prompt="a person jumps", seconds=1.5), Source(prompt="a person runs forward", seconds=3)]
    result = transfer(loaded, leader, followers, TransferConfig(root="trajectory"), sample=sample)
    assert result.leader_joints().shape == (50, 22, 3)
    assert [result.follower(i).shape[0] for i in range(2)] == [30, 60]
    assert [result.out(i).shape[0] for i in range(2)] == [50, 50]
    plain = transfer(loaded, leader, followers[:1], TransferConfig(start=0.0, end=0.0), sample=sample)
    assert np.abs(result.out(0) - plain.out(0)).max() > 1e-4  # mixing changed the output
    feats = result.output.generation.features
    root = slice(0, SLICES["root_lin_vel"].stop)
    for i in range(2):  # "trajectory": the leader's root, exactly
        np.testing.assert_array_equal(feats[result.slot(OUT, i), :50, root], feats[0, :50, root])


def test_keep_feet_option_copies_the_leaders_footwork(loaded):
    from engine.methods.momo import kept_dims

    sample = SampleConfig(steps=STEPS, guidance=2.0)
    leader, follower = Source(prompt="a person walks forward", seconds=2), Source(prompt="a person jumps", seconds=2)
    feet = kept_dims(TransferConfig(feet=True))
    assert set(kept_dims(TransferConfig()).tolist()) < set(feet.tolist())
    assert set(range(SLICES["contacts"].start, SLICES["contacts"].stop)) <= set(feet.tolist())
    kept = transfer(loaded, leader, [follower], TransferConfig(feet=True), sample=sample).output.generation.features
    plain = transfer(loaded, leader, [follower], sample=sample).output.generation.features
    out = 2  # [leader, follower, out]
    np.testing.assert_array_equal(kept[out, :40][:, feet], kept[0, :40][:, feet])
    assert np.abs(plain[out, :40][:, feet] - plain[0, :40][:, feet]).max() > 1e-4  # not so without the option
    hands = [SLICES["ric"].start + (JOINT_INDEX["right_wrist"] - 1) * 3 + k for k in range(3)]
    assert np.abs(kept[out, :40][:, hands] - kept[0, :40][:, hands]).max() > 1e-4  # the rest stays the out's own


def test_paper_root_option_copies_only_the_rotation(loaded):
    sample = SampleConfig(steps=STEPS, guidance=1.0)
    result = transfer(loaded, Source(prompt="a person walks forward", seconds=2), [Source(prompt="a person jumps", seconds=2)],
                      TransferConfig(root="rotation"), sample=sample)
    f = result.output.generation.features
    out = result.slot(OUT)
    np.testing.assert_array_equal(f[out, :40, 0], f[0, :40, 0])
    assert np.abs(f[out, :40, 1:3] - f[0, :40, 1:3]).max() > 1e-6


def test_inverted_leader_is_rebuilt_exactly_and_reports_its_inversion_error(loaded, corpus_motion):
    sample = SampleConfig(steps=STEPS, guidance=2.5)
    result = transfer(loaded, Source(joints=corpus_motion, prompt="a person walks"), [Source(prompt="a person jumps", seconds=2)],
                      sample=sample)
    assert result.leader.inverted and result.leader.frames == len(corpus_motion) - 1
    np.testing.assert_allclose(result.leader_joints(), canonical(corpus_motion), atol=1e-4)
    err = result.leader.inversion
    assert err is not None and np.isfinite(err["mean_m"]) and err["max_m"] >= err["mean_m"] >= 0
    assert result.followers[0].inversion is None
    assert result.out(0).shape[0] == len(corpus_motion) - 1


def test_inversion_steps_must_match_the_sampler(loaded, corpus_motion):
    stream = prepare(loaded, Source(joints=corpus_motion), seed=0, steps=4, measure_inversion=False)
    other = prepare(loaded, Source(prompt="a person jumps", seconds=2), seed=0, steps=4)
    with pytest.raises(ValueError, match="same number"):
        transfer_streams(loaded, stream, [other], sample=SampleConfig(steps=5))


def test_bad_sources_and_configs_fail_clearly(loaded):
    with pytest.raises(ValueError, match="prompt or a motion"):
        Source(prompt="  ")
    with pytest.raises(PromptError, match="flurbs"):
        transfer(loaded, Source(prompt="a person flurbs"), [Source(prompt="a person jumps")], sample=SampleConfig(steps=2))
    with pytest.raises(ValueError, match="do not exist"):
        TransferConfig(layers=(0, 7)).window(3)
    with pytest.raises(ValueError, match="root"):
        TransferConfig(root="sideways")
    with pytest.raises(ValueError, match="start <= end"):
        TransferConfig(start=0.8, end=0.2)
    with pytest.raises(ValueError, match="between 1 and"):
        transfer(loaded, Source(prompt="a person jumps"), [], sample=SampleConfig(steps=2))


def test_baselines_run_on_prepared_streams(loaded, corpus_motion):
    follower = Corpus(split="test").sample(5).joints[:41]
    nn = motion_space_nn(corpus_motion, follower)
    assert nn.shape == (len(corpus_motion) - 1, 22, 3)
    np.testing.assert_allclose(nn[:, 0], canonical(corpus_motion)[:, 0], atol=1e-5)  # the leader's root
    dims = lower_body_dims()
    assert 0 in dims and 262 in dims and SLICES["ric"].start + 3 * 19 not in dims  # no left-wrist ric
    sample = SampleConfig(steps=STEPS, guidance=1.0)
    lead = prepare(loaded, Source(joints=corpus_motion), seed=0, steps=STEPS, measure_inversion=False)
    foll = prepare(loaded, Source(prompt="a person waves", seconds=2), seed=1, steps=STEPS)
    out = inpaint_upper_body(loaded, lead, foll, sample=sample)
    assert out.shape == (len(corpus_motion) - 1, 22, 3)
    legs = [7, 8, 10, 11]
    np.testing.assert_allclose(out[:, legs], canonical(corpus_motion)[:, legs], atol=1e-3)


# ----------------------------------------------------------------------------- analysis
def test_paper_sites_map_onto_the_model():
    assert paper_site(layer=12, t=0, n_layers=12, n_steps=100) == Site(layer=11, step=99)
    assert paper_site(layer=11, t=30, n_layers=6, n_steps=50) == Site(layer=5, step=35)
    assert cluster_site(2, 10) == Site(layer=1, step=7)


def test_nearest_keys_and_maps():
    q = np.eye(4)[[0, 1, 2, 3, 0]] * 5
    k = np.eye(4)[[3, 2, 1, 0]]
    assert nearest_keys(q, k).tolist() == [3, 2, 1, 0, 3]
    m = attention_map(q, k, heads=2)
    assert m.shape == (5, 4) and np.allclose(m.sum(1), 1.0)
    assert m[0].argmax() == 3


def test_clusters_separate_distinct_groups():
    rng = np.random.default_rng(0)
    centres = rng.normal(0, 10, (3, 16))
    x = np.concatenate([c + rng.normal(0, 0.1, (30, 16)) for c in centres])
    cl = fit(x, x[::-1].copy(), site=Site(0, 0), config=ClusterConfig(components=4, clusters=3))
    q_lab, k_lab = cl.labels(x, x)
    assert len(set(q_lab[:30])) == 1 and len(set(q_lab)) == 3
    with pytest.raises(ValueError, match="at least"):
        fit(x[:2], x[:2], site=Site(0, 0))


def test_analysis_of_a_recorded_transfer(loaded):
    sample = SampleConfig(steps=STEPS, guidance=2.0)
    result = transfer(loaded, Source(prompt="a person walks forward", seconds=2), [Source(prompt="a person jumps", seconds=1.5)],
                      sample=sample, record=qk_record())
    site = cluster_site(3, STEPS)
    q, k = qk_at(result.output.store, site, slot=0, frames=40)
    assert q.shape == (40, 32) and k.shape == (40, 32)
    clusters = fit_clusters(loaded, ["a person walks forward", "a person jumps"], site=site, sample=sample, seconds=2,
                            per_prompt=1, config=ClusterConfig(components=4, clusters=4))
    a = analyze(loaded, result, clusters=clusters, sample=sample)
    assert {r: len(v) for r, v in a.q_labels.items()} == {LEADER: 40, FOLLOWER: 30, OUT: 40}
    assert a.nearest.shape == (40,) and a.nearest.max() < 30
    assert a.maps["mixed"].shape == (40, 30) and a.maps["follower"].shape == (30, 30)
    assert set(a.per_query(5)) == {"leader", "mixed"}
    with pytest.raises(IndexError):
        a.per_query(40)
    json.dumps(a.to_json())
    plain = transfer(loaded, Source(prompt="a person walks"), [Source(prompt="a person jumps")], sample=SampleConfig(steps=2))
    with pytest.raises(ValueError, match="record"):
        analyze(loaded, plain, clusters=clusters)


def test_store_and_mixing_stack_without_changing_the_leader(loaded):
    """Recording is passive: the leader stream is the same as sampling its prompt alone."""
    sample = SampleConfig(steps=STEPS, guidance=2.0, seed=1)
    result = transfer(loaded, Source(prompt="a person walks forward", seconds=2), [Source(prompt="a person jumps", seconds=2)],
                      sample=sample, record=qk_record())
    alone = generate(loaded, Request(prompts=["a person walks forward"], frames=[40], noise=result.leader.noise), sample)
    np.testing.assert_allclose(result.leader_joints(), alone.joints[0], atol=1e-5)
    assert isinstance(result.output.store, AttentionStore) and stack(None) is None


def test_a_text_less_slot_beside_prompted_ones_stays_finite(loaded, corpus_motion):
    """An imported motion without a description shares the batch with prompt slots (no NaN leaks)."""
    result = transfer(loaded, Source(joints=corpus_motion), [Source(prompt="a person jumps", seconds=2)],
                      sample=SampleConfig(steps=STEPS, guidance=2.5))
    assert result.leader.prompt is None
    assert np.isfinite(result.out(0)).all() and np.isfinite(result.follower(0)).all()


# ----------------------------------------------------------------------------- the direction trick and the root
def test_several_keys_slots_per_target_are_concatenated_in_time():
    """keys_per_target=2: each out attends over its two followers' K, V (and masks) side by side; the other slots
    keep their own keys, padded with masked frames."""
    names = (LEADER, FOLLOWER, FOLLOWER, OUT, FOLLOWER, FOLLOWER, OUT)
    roles = BatchRoles(names=names).with_uncond()
    ctx = AttnCtx(layer=1, kind="self", step=0, t=900, roles=roles)
    mix = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER, keys_per_target=2, window=Window(0.0, 1.0, layers=(1,))),
                         num_steps=4)
    b, m = len(roles.names), 3
    q = torch.arange(float(b)).view(b, 1, 1, 1).expand(b, 1, m, 2).clone()
    k, v = q.clone() + 100, q.clone() + 200
    q2, k2, v2 = mix.on_qkv(q, k, v, ctx)
    assert q2.shape == q.shape and k2.shape == (b, 1, 2 * m, 2) and v2.shape == (b, 1, 2 * m, 2)
    for out, group, leader in ((3, (1, 2), 0), (6, (4, 5), 0), (10, (8, 9), 7), (13, (11, 12), 7)):
        assert q2[out, 0, 0, 0] == leader
        assert k2[out, 0, :, 0].tolist() == [100 + group[0]] * m + [100 + group[1]] * m
        assert v2[out, 0, :, 0].tolist() == [200 + group[0]] * m + [200 + group[1]] * m
    assert k2[1, 0, :m, 0].tolist() == [101] * m and not k2[1, 0, m:].any()  # a follower: its own keys, padded
    mask = torch.ones(b, m, dtype=torch.bool)
    mask[2, -1] = False  # the second copy of follower 1 is a frame shorter
    wide = mix.on_key_mask(mask, ctx)
    assert wide.shape == (b, 2 * m)
    assert wide[3].tolist() == [True] * m + [True, True, False]
    assert wide[1].tolist() == [True] * m + [False] * m  # padding never attended
    outside = AttnCtx(layer=0, kind="self", step=0, t=900, roles=roles)
    assert mix.on_qkv(q, k, v, outside) is None and mix.on_key_mask(mask, outside) is None
    with pytest.raises(KeyError, match="2 per target"):  # one follower slot for two outs of two copies each
        mix.on_qkv(q[:4], k[:4], v[:4], _ctx((LEADER, FOLLOWER, OUT, OUT), step=0))
    with pytest.raises(ValueError, match="keys_per_target"):
        MixConfig(queries=LEADER, keys=FOLLOWER, keys_per_target=0)


def test_two_identical_copies_give_the_same_attention_as_one():
    """Concatenating a follower with itself leaves softmax attention unchanged: why the paper's constant rotation
    (which changes no feature, see the next test) would be a no-op and the copies are turned instead."""
    g = torch.Generator().manual_seed(1)
    q, k, v = (torch.randn(3, 2, 5, 4, generator=g) for _ in range(3))
    names = (LEADER, FOLLOWER, OUT)
    one = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER), num_steps=4)
    q1, k1, v1 = one.on_qkv(q, k, v, _ctx(names, step=0))
    dup = torch.cat([k[:2], k[1:2]]), torch.cat([v[:2], v[1:2]])
    two = MixedAttention(MixConfig(queries=LEADER, keys=FOLLOWER, keys_per_target=2), num_steps=4)
    q2, k2, v2 = two.on_qkv(torch.cat([q[:2], q[1:2], q[2:]]), torch.cat([dup[0], k[2:]]), torch.cat([dup[1], v[2:]]),
                            _ctx((LEADER, FOLLOWER, FOLLOWER, OUT), step=0))
    a = torch.nn.functional.scaled_dot_product_attention(q1[2], k1[2], v1[2])
    b = torch.nn.functional.scaled_dot_product_attention(q2[3], k2[3], v2[3])
    torch.testing.assert_close(a, b)


def test_turned_copies_bend_the_path_and_keep_the_pose(corpus_motion):
    from engine.methods.momo import direction_copies, turned
    from engine.representation import facing_direction, features_to_joints, joints_to_features

    base = joints_to_features(corpus_motion)
    # a constant rotation about the vertical axis changes no feature at all (the paper's rotation, literally)
    a = np.radians(70)
    rot = corpus_motion.copy()
    rot[..., 0], rot[..., 2] = (corpus_motion[..., 0] * np.cos(a) + corpus_motion[..., 2] * np.sin(a),
                                -corpus_motion[..., 0] * np.sin(a) + corpus_motion[..., 2] * np.cos(a))
    np.testing.assert_allclose(joints_to_features(rot), base, atol=2e-4)

    def heading(joints):  # facing angle per frame, degrees, unwrapped
        f = facing_direction(joints)
        return np.degrees(np.unwrap(np.arctan2(f[:, 0], f[:, 2])))

    # turned by +-90 degrees over the clip: as the model reads it (decoded from its features), the copy faces
    # 90 degrees further round by the end, with the same root-relative pose and the same speed
    for angle in (np.pi / 2, -np.pi / 2):
        bent = joints_to_features(turned(corpus_motion, angle))
        turn = heading(features_to_joints(bent)) - heading(features_to_joints(base))
        assert abs(turn[-1] - np.degrees(angle)) < 12 and abs(turn[0]) < 1e-3
        assert np.abs(bent[:, SLICES["ric"]] - base[:, SLICES["ric"]]).max() < 0.08  # the pose: within a few cm
        speed = lambda f: np.linalg.norm(f[:, 1:3], axis=1)  # noqa: E731 (root speed per frame)
        assert np.abs(speed(bent) - speed(base)).max() < 0.01
        np.testing.assert_allclose(bent[:, SLICES["root_height"]], base[:, SLICES["root_height"]], atol=1e-6)
    np.testing.assert_allclose(turned(corpus_motion, 0.0), corpus_motion, atol=1e-5)
    copies = direction_copies(Source(joints=corpus_motion, prompt="a person walks", name="walk.npy"), 4)
    assert [c.name for c in copies] == ["walk.npy (turned +90°)", "walk.npy (turned +180°)", "walk.npy (turned -90°)"]
    assert all(c.prompt == "a person walks" for c in copies)


def test_directions_trick_reads_several_followers(loaded, corpus_motion):
    sample = SampleConfig(steps=STEPS, guidance=2.0)
    leader, follower = Source(prompt="a person walks forward", seconds=2), Source(prompt="a person jumps", seconds=2)
    one = transfer(loaded, leader, [follower], TransferConfig(root="none"), sample=sample)
    three = transfer(loaded, leader, [follower], TransferConfig(root="none", directions=3), sample=sample)
    assert three.output.generation.roles.names == (LEADER, FOLLOWER, FOLLOWER, FOLLOWER, OUT)
    assert three.per_follower == 3 and len(three.copies[0]) == 2
    np.testing.assert_allclose(three.follower(0), one.follower(0), atol=1e-5)  # the follower as given, same seed
    assert np.abs(three.copy(0, 1) - three.follower(0)).max() > 1e-3  # another seed
    assert [c.source.label for c in three.copies[0]] == ["a person jumps (seed 9)", "a person jumps (seed 17)"]
    assert np.abs(three.out(0) - one.out(0)).max() > 1e-4  # the out read the copies too
    np.testing.assert_allclose(three.leader_joints(), one.leader_joints(), atol=1e-5)
    assert three.slot(FOLLOWER) == 1 and three.slot(OUT) == 4
    with pytest.raises(IndexError, match="2 direction copies"):
        three.copy(0, 3)
    # an imported follower: turned copies, each inverted (pinned, so each rebuilds its turned motion)
    real = transfer(loaded, leader, [Source(joints=corpus_motion, prompt="a person walks")],
                    TransferConfig(directions=2), sample=sample)
    assert all(c.inverted for c in real.copies[0]) and "turned +180°" in real.copies[0][0].source.label
    from engine.methods.momo import turned

    np.testing.assert_allclose(real.copy(0, 1), canonical(turned(corpus_motion, np.pi)), atol=1e-3)
    assert np.isfinite(real.out(0)).all() and real.out(0).shape == (40, 22, 3)
    # two followers with two directions each: each out reads its own follower's copies
    both = transfer(loaded, leader, [follower, Source(prompt="a person runs forward", seconds=2)],
                    TransferConfig(directions=2), sample=sample)
    assert both.output.generation.roles.names == (LEADER, FOLLOWER, FOLLOWER, OUT, FOLLOWER, FOLLOWER, OUT)
    assert both.slot(FOLLOWER, 1) == 4 and both.slot(OUT, 1) == 6


def test_root_and_direction_options_fail_clearly(loaded):
    from engine.methods.transfer_config import ROOT_DEFAULT, option_info

    assert TransferConfig().root == ROOT_DEFAULT == option_info("root").default
    for bad, message in ((0, "between 1 and 8"), (9, "between 1 and 8"), (1.5, "whole number"),
                         (True, "whole number")):
        with pytest.raises(ValueError, match=message):
            TransferConfig(directions=bad)
    with pytest.raises(ValueError, match="follower streams"):
        transfer(loaded, Source(prompt="a person walks"), [Source(prompt="a person jumps")] * 3,
                 TransferConfig(directions=6), sample=SampleConfig(steps=2))
    with pytest.raises(ValueError, match="direction copies per follower"):
        stream = prepare(loaded, Source(prompt="a person jumps", seconds=2), seed=0, steps=2)
        transfer_streams(loaded, stream, [stream], TransferConfig(directions=2), sample=SampleConfig(steps=2))
    with pytest.raises(ValueError, match="start must be between 0 and 1"):
        TransferConfig(start=-0.1)


def _standing(frames: int = 40) -> np.ndarray:
    """A still body: feet on the floor (y 0.05 for the ankles, 0 for the toes), the pelvis at 0.9 m."""
    joints = np.zeros((frames, 22, 3))
    joints[:, :, 1] = np.linspace(0.9, 1.6, 22)[None]
    for ankle, toe in FOOT_JOINTS.values():
        joints[:, ankle, 1], joints[:, toe, 1] = 0.05, 0.0
    return joints


def test_flight_lift_follows_the_leader_off_the_floor_and_never_pushes_down():
    from engine.methods.momo import flight_lift

    leader, out = _standing(), _standing()
    leader[15:25, :, 1] += 0.3  # a jump: the whole body 0.3 m up for 10 frames
    lift = flight_lift(leader, out)
    assert lift.shape == (40,)
    assert lift[17:23].min() == pytest.approx(0.3, abs=0.02) and lift[:10].max() == 0 and lift[29:].max() == 0
    # an out already in the air is lifted only by what it lacks; a leader on the floor lifts nothing
    out[15:25, :, 1] += 0.1
    assert flight_lift(leader, out)[17:23].max() == pytest.approx(0.2, abs=0.02)
    assert not flight_lift(_standing(), out).any()
    crouch = _standing()
    crouch[10:20, 0, 1] -= 0.3  # the pelvis lower, the feet on the floor: no lift, and never a push down
    assert not flight_lift(crouch, _standing()).any()


def test_flights_option_lifts_the_out_where_the_leader_leaves_the_floor(loaded, monkeypatch):
    import engine.methods.momo as momo

    sample = SampleConfig(steps=STEPS, guidance=2.0)
    leader, follower = Source(prompt="a person jumps", seconds=2), Source(prompt="a person walks forward", seconds=2)
    # a known lift (the tiny model's leader need not jump): 0.25 m over frames 10-19
    monkeypatch.setattr(momo, "flight_lift", lambda lead, out: np.where((np.arange(len(out)) >= 10) &
                                                                         (np.arange(len(out)) < 20), 0.25, 0.0))
    lifted = transfer(loaded, leader, [follower], TransferConfig(flights=True), sample=sample)
    plain = transfer(loaded, leader, [follower], TransferConfig(flights=False), sample=sample)
    a, b = lifted.out(0), plain.out(0)
    np.testing.assert_allclose(a[10:20, :, 1] - b[10:20, :, 1], 0.25, atol=1e-4)  # every joint, root included
    np.testing.assert_allclose(a[:, :, [0, 2]], b[:, :, [0, 2]], atol=1e-5)  # the path and the pose stay
    np.testing.assert_allclose(a[:10], b[:10], atol=1e-5)
    np.testing.assert_array_equal(lifted.leader_joints(), plain.leader_joints())
    assert TransferConfig().flights  # on by default: chosen by `moattn bench --transfer` (session 39)
