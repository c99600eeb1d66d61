"""ComMDM (PriorMDM): placement geometry on the corpus's duets, the duet state and pairing, the block (zero at
initialisation, the prior frozen, the other person's motion reaching this one), training on a tiny prior,
text-to-duet and prefix completion (the prefix kept exactly), the duet bench's measures on ground truth, and
`moattn duet` / `moattn train --commdm` with their errors."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from engine.attention.context import BatchRoles
from engine.methods.commdm import (ComConfig, DuetDenoiser, Pose, PriorTwice, duet_roles, pack, partners, placements,
                                   unpack)
from engine.synth.duet import DuetCorpus, make_duet
from tests.conftest import PROJECT_ROOT, random_corpus_model

pytestmark = pytest.mark.timeout(600)


# ----------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("interaction", ["handshake", "side_by_side", "following", "push"])
def test_placements_match_the_corpus_labels(interaction):
    from engine.representation import canonicalize

    s = make_duet(interaction, np.random.default_rng(3))
    b_from_a, a_from_b = placements(s.joints_a, s.joints_b)
    off, facing = s.labels["placement"]["offset_xz"], s.labels["placement"]["facing"]
    assert b_from_a.x == pytest.approx(off[0], abs=2e-3) and b_from_a.z == pytest.approx(off[1], abs=2e-3)
    assert np.cos(b_from_a.yaw - facing) == pytest.approx(1.0, abs=1e-5)
    # each person's canonical joints placed by its pose land where they were
    for joints in s.joints:
        pose = Pose.of_joints(joints)
        back = pose.place(canonicalize(joints))
        np.testing.assert_allclose(back[..., [0, 2]], joints[..., [0, 2]], atol=1e-4)
    # a seen from b is the inverse of b seen from a
    inv = b_from_a.inverse()
    assert (inv.x, inv.z) == pytest.approx((a_from_b.x, a_from_b.z), abs=1e-6)
    assert np.cos(inv.yaw - a_from_b.yaw) == pytest.approx(1.0, abs=1e-9)


def test_canonical_transform_turns_a_person_facing_minus_z():
    from engine.representation import facing_direction
    from engine.synth.corpus import to_canonical

    s = make_duet("hug", np.random.default_rng(0))
    assert facing_direction(s.joints_b[0])[2] < -0.99  # person b faces -Z exactly
    canon, rot, _ = to_canonical(s.joints_b)
    assert facing_direction(canon[0])[2] > 0.99
    assert Pose.of_joints(s.joints_b).yaw == pytest.approx(np.pi, abs=1e-3) or \
        Pose.of_joints(s.joints_b).yaw == pytest.approx(-np.pi, abs=1e-3)


def test_pose_vector_round_trip_and_bad_values():
    p = Pose(0.3, -1.2, 2.5)
    q = Pose.of_vector(p.vector())
    assert (q.x, q.z, q.yaw) == pytest.approx((p.x, p.z, p.yaw), abs=1e-6)
    with pytest.raises(ValueError, match="4 finite numbers"):
        Pose.of_vector([0.0, np.nan, 1.0, 0.0])


# ----------------------------------------------------------------------------- the duet state
def test_pack_unpack_and_partners():
    motion, place = torch.randn(4, 7, 263), torch.randn(4, 4)
    x = pack(motion, place)
    assert x.shape == (4, 8, 263) and torch.equal(x[:, -1, 4:], torch.zeros(4, 259))
    m, p = unpack(x)
    assert torch.equal(m, motion) and torch.equal(p, place)
    roles = duet_roles(2)
    assert partners(roles).tolist() == [2, 3, 0, 1]
    # classifier-free guidance doubles the batch: unconditional slots pair among themselves
    assert partners(roles.with_uncond()).tolist() == [2, 3, 0, 1, 6, 7, 4, 5]
    with pytest.raises(ValueError, match="pairs person_a and person_b"):
        partners(BatchRoles.of("person_a", "person_a", "person_b"))
    with pytest.raises(ValueError, match="must be person_a or person_b"):
        partners(BatchRoles.of("person_a", "person_b", "out"))


def _duet_batch(loaded, frames=12, pairs=2, prompt="a person walks"):
    from engine.model.denoiser import Condition
    from engine.attention.context import WordIndex

    tok = loaded.tokenizer.encode(prompt)
    ids, mask = loaded.tokenizer.batch([tok] * (2 * pairs))
    frame_mask = torch.zeros(2 * pairs, frames + 1, dtype=torch.bool)
    frame_mask[:, :frames] = True
    cond = Condition(text_ids=ids, text_mask=mask, frame_mask=frame_mask, use_text=torch.ones(2 * pairs, dtype=torch.bool),
                     roles=duet_roles(pairs), words=WordIndex(words=(tok.words,) * (2 * pairs)))
    g = torch.Generator().manual_seed(1)
    return torch.randn(2 * pairs, frames + 1, 263, generator=g), cond


def test_untrained_block_leaves_the_prior_unchanged_and_the_prior_stays_frozen():
    loaded = random_corpus_model(layers=3)
    prior = loaded.model
    before = {k: v.clone() for k, v in prior.state_dict().items()}
    duet = DuetDenoiser(prior, known_words=len(loaded.tokenizer) - 1, new_words=3, config=ComConfig(after=2))
    x, cond = _duet_batch(loaded)
    t = torch.full((4,), 300)
    with torch.no_grad():
        out = duet(x, t, cond)
        motion, _ = unpack(x)
        from dataclasses import replace

        alone = prior(motion, t, replace(cond, frame_mask=cond.frame_mask[:, :-1]))
    # ΔO starts at zero: the motion is the prior's own prediction
    torch.testing.assert_close(unpack(out)[0], alone, atol=1e-5, rtol=1e-5)
    assert all(not p.requires_grad for p in prior.parameters())
    trainable = {n for n, p in duet.named_parameters() if p.requires_grad}
    assert trainable and all(n.startswith("com.") or n == "text_encoder.embed.new" for n in trainable)
    # a training step moves the block and the new word rows only
    opt = torch.optim.SGD([p for p in duet.parameters() if p.requires_grad], lr=0.1)
    loss = duet(x, t, cond).pow(2).mean()
    loss.backward()
    opt.step()
    for k, v in prior.state_dict().items():
        assert torch.equal(v, before[k]), k


def test_the_other_person_reaches_this_one_through_the_block_only():
    loaded = random_corpus_model(layers=2)
    duet = DuetDenoiser(loaded.model, known_words=len(loaded.tokenizer) - 1, new_words=0, config=ComConfig())
    torch.nn.init.normal_(duet.com.delta.weight, std=0.5)  # a block that has learned something
    x, cond = _duet_batch(loaded, pairs=1)
    t = torch.full((2,), 500)
    changed = x.clone()
    changed[1, :-1] += 1.0  # person b moves differently
    with torch.no_grad():
        a_with = duet(x, t, cond)[0]
        a_other = duet(changed, t, cond)[0]
        solo = PriorTwice(duet, torch.tensor([0.0, 1.0, -1.0, 0.0]))
        s_with, s_other = solo(x, t, cond), solo(changed, t, cond)
    assert (a_with - a_other)[:-1].abs().max() > 1e-3  # person a answers person b
    torch.testing.assert_close(s_with[0], s_other[0])  # the baseline does not
    np.testing.assert_allclose(unpack(s_with)[1].numpy(), [[0.0, 1.0, -1.0, 0.0]] * 2)


# ----------------------------------------------------------------------------- training and sampling (tiny prior)
@pytest.fixture(scope="module")
def duet_model(tiny_model_dir, tiny_duet_dir):
    from engine.train_commdm import load_trained

    return load_trained(tiny_duet_dir, tiny_model_dir)


def test_trained_folder_holds_the_block_only(tiny_duet_dir, tiny_model_dir):
    from engine.checkpoint import load_model
    from engine.methods.commdm import fingerprint

    config = json.loads((tiny_duet_dir / "config.json").read_text())
    assert config["kind"] == "commdm" and config["step"] == 6 and config["samples"] == 8
    assert config["prior"] == fingerprint(load_model(tiny_model_dir))
    assert {"hug", "shake", "people"} <= set(config["words"])
    weights = torch.load(tiny_duet_dir / "weights.pt", weights_only=True)
    assert weights and all(k.startswith("com.") or k == "text_encoder.embed.new" for k in weights)
    assert all(v.dtype == torch.float16 for v in weights.values())
    log = [json.loads(line) for line in (tiny_duet_dir / "log.jsonl").read_text().splitlines()]
    assert log and all(np.isfinite(r["mse"]) and np.isfinite(r["place"]) for r in log)


def test_a_duet_model_refuses_another_prior(tiny_duet_dir):
    from engine.methods.duet import load_duet

    other = random_corpus_model(layers=2)
    with pytest.raises(ValueError, match="trained on another base model"):
        load_duet(tiny_duet_dir, other)


def test_a_duet_folder_runs_on_the_prior_it_ships(tiny_duet_dir, tiny_model_dir, tmp_path):
    """Given a newer base model, a duet folder with its own prior/ runs on that copy; a wrong copy is refused."""
    import shutil

    from engine.methods.commdm import fingerprint
    from engine.methods.duet import PRIOR_FOLDER, load_duet

    folder = tmp_path / "duet"
    shutil.copytree(tiny_duet_dir, folder)
    shutil.copytree(tiny_model_dir, folder / PRIOR_FOLDER)
    other = random_corpus_model(layers=2)
    model = load_duet(folder, other)
    assert model.prior is not other
    assert fingerprint(model.prior) == json.loads((folder / "config.json").read_text())["prior"]

    weights = torch.load(folder / PRIOR_FOLDER / "weights.pt", weights_only=True)
    name = next(k for k, v in weights.items() if v.is_floating_point())
    weights[name] = weights[name] + 1
    torch.save(weights, folder / PRIOR_FOLDER / "weights.pt")
    with pytest.raises(ValueError, match="is not the base model the duet block"):
        load_duet(folder, other)


def test_text_to_duet(duet_model):
    from engine.generate import SampleConfig
    from engine.methods.duet import text_to_duet
    from engine.text import PromptError

    d = text_to_duet(duet_model, "two people shake hands", seconds=2.0, sample=SampleConfig(steps=4))
    assert d.joints.shape == (2, 40, 22, 3) and np.isfinite(d.joints).all()
    # person a stands in its own canonical frame; person b where the placement says
    np.testing.assert_allclose(d.joints[0, 0, 0, [0, 2]], 0.0, atol=1e-5)
    np.testing.assert_allclose(d.joints[1, 0, 0, [0, 2]], [d.placement.x, d.placement.z], atol=1e-4)
    base = text_to_duet(duet_model, "two people shake hands", seconds=2.0, sample=SampleConfig(steps=4),
                        communicate=False, contact=None, spacing=False)  # (guidance and spacing may move b)
    mean = duet_model.mean_place
    assert (base.placement.x, base.placement.z) == pytest.approx((mean.x, mean.z), abs=1e-4)
    assert base.spacing is None
    with pytest.raises(PromptError, match="zzzz"):
        text_to_duet(duet_model, "two people zzzz", seconds=2.0)
    with pytest.raises(ValueError, match="between"):
        text_to_duet(duet_model, "two people hug", seconds=30.0)


def test_a_duet_from_a_prompt_keeps_its_people_apart(duet_model):
    from engine.analysis.duet_pose import torso_distance
    from engine.generate import SampleConfig
    from engine.methods.duet import text_to_duet
    from engine.methods.duet_spacing import TRUTH

    kw = dict(seconds=2.0, sample=SampleConfig(steps=4), communicate=False, contact=None)
    raw = text_to_duet(duet_model, "two people shake hands", spacing=False, **kw)
    d = text_to_duet(duet_model, "two people shake hands", **kw)
    assert d.spacing.rule.interaction == "handshake"
    assert torso_distance(d.joints)[:20].min() >= TRUTH["handshake"][0] - 1e-4
    np.testing.assert_array_equal(d.joints[0], raw.joints[0])  # person a never moves
    np.testing.assert_allclose(d.joints[1] - raw.joints[1], np.broadcast_to(
        d.spacing.offset[:, None], raw.joints[1].shape), atol=1e-5)
    # the readout's placement is where b now stands
    np.testing.assert_allclose(d.joints[1, 0, 0, [0, 2]], [d.placement.x, d.placement.z], atol=1e-4)


def test_prefix_completion_keeps_the_prefix(duet_model):
    from engine.generate import SampleConfig
    from engine.methods.duet import complete

    s = DuetCorpus("test").sample(2)
    turn = Pose(0.7, -0.4, 0.9)  # the caller's frame need not be person a's
    ja, jb = turn.place(s.joints_a), turn.place(s.joints_b)
    d = complete(duet_model, ja, jb, sample=SampleConfig(steps=4, guidance=1.0))
    assert d.joints.shape == (2, 80, 22, 3)
    for person, truth in enumerate((ja, jb)):
        np.testing.assert_allclose(d.joints[person, :20], truth[:20], atol=2e-3)
    with pytest.raises(ValueError, match="needs 21 frames"):
        complete(duet_model, ja[:10], jb[:10])
    bad = ja.copy()
    bad[3, 4, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        complete(duet_model, bad, jb)
    with pytest.raises(ValueError, match=r"joints \(T, 22, 3\)"):
        complete(duet_model, ja[:, :20], jb)
    with pytest.raises(ValueError, match="longer than"):
        complete(duet_model, ja, jb, seconds=9.8, prefix_seconds=2.0)


def test_completion_samples_the_prefix_as_the_block_was_trained(duet_model):
    """A block trained for completion (prefix_noise_free) sees the prefix as sqrt(alpha_bar)·x0 at every step
    (PriorMDM Algorithm 2); the prior alone gets plain inpainting with fresh noise."""
    from engine.diffusion import CosineSchedule
    from engine.generate import SampleConfig
    from engine.methods.duet import complete

    assert duet_model.config["prefix_noise_free"] is True
    s = DuetCorpus("test").sample(1)
    schedule = CosineSchedule()
    for communicate, noise_free in ((True, True), (False, False)):
        states = []
        complete(duet_model, s.joints_a, s.joints_b, sample=SampleConfig(steps=5, guidance=1.0),
                 communicate=communicate, on_step=states.append)
        scaled = [st.x_prev[:, :20] / schedule.alpha_bar(torch.tensor(st.t_next)).sqrt() for st in states[:-1]]
        same = all(torch.allclose(x, states[-1].x_prev[:, :20], atol=1e-5) for x in scaled)
        assert same == noise_free
        # the frames after the prefix are never pinned
        assert not torch.allclose(states[0].x_prev[:, 30:], states[-1].x_prev[:, 30:], atol=1e-2)


def test_contact_loss_measures_the_people_put_together():
    """The training's contact distances, from packed duet states through the placement, equal the distances
    between the corpus's two people in their shared frame; the loss is 0 on the truth, grows when the
    predicted placement moves person b away, and its gradient reaches the placement."""
    from engine.methods.duet_data import few_shot, pair_item, stack_pairs
    from engine.methods.duet_losses import CHEST, RW, _together, contact_loss
    from engine.representation import FEATURE_DIM, Normalizer

    identity = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    samples = few_shot("test", per_interaction=1)
    x0, mask = stack_pairs([pair_item(s, identity) for s in samples])
    d = _together(x0, identity).numpy()
    for k, s in enumerate(samples):
        n = len(s.joints_a) - 1  # features hold one frame fewer than the joints
        hands = np.linalg.norm(s.joints_a[:n, RW] - s.joints_b[:n, RW], axis=-1)
        chest = np.linalg.norm(s.joints_b[:n, RW] - s.joints_a[:n, CHEST], axis=-1)
        np.testing.assert_allclose(d[k, :n, 0], hands, atol=1e-3)
        np.testing.assert_allclose(d[k, :n, 4], chest, atol=1e-3)
    assert contact_loss(x0, x0, mask, normalizer=identity).item() == pytest.approx(0.0, abs=1e-5)
    moved = x0.clone().requires_grad_(True)
    shift = torch.zeros_like(x0)
    shift[: len(samples), -1, 1] = 0.3  # b stands 0.3 m further along a's z
    loss = contact_loss(moved + shift, x0, mask, normalizer=identity)
    assert loss.item() > 0.05
    loss.backward()
    assert moved.grad[: len(samples), -1, :2].abs().sum() > 0


def test_training_gives_completion_pairs_their_prefix_noise_free():
    from engine.methods.duet_losses import prefix_cells

    x0 = torch.randn(6, 31, 263)  # 3 pairs
    cells = prefix_cells(x0, torch.tensor([True, False, True]), 20)
    for row, given in enumerate([True, False, True] * 2):
        assert bool(cells[row, :20].all()) == given and bool(cells[row, -1, :4].all()) == given
        assert not cells[row, 20:-1].any() and not cells[row, -1, 4:].any()


# ----------------------------------------------------------------------------- the bench's measures
def test_contact_and_placement_measures_on_ground_truth():
    from engine.analysis.duet_pose import face_each_other
    from engine.evaluation.bench_duet import FACE_TO_FACE, contact_timing, placement_error
    from engine.methods.duet_data import few_shot

    for s in few_shot("test", per_interaction=2):
        both = np.stack([s.joints_a, s.joints_b])
        assert placement_error(both, s.joints_a, s.joints_b) == pytest.approx((0.0, 0.0), abs=1e-6)
        swapped = np.stack([s.joints_b, s.joints_a])  # the better person order is taken
        assert placement_error(swapped, s.joints_a, s.joints_b)[0] == pytest.approx(0.0, abs=1e-6)
        for c in s.labels["contacts"]:
            err, hit = contact_timing(c["kind"], c["start"], c["end"], s.joints_a, s.joints_b)
            assert hit and err <= 0.2, (s.interaction, err)
            # people 3 m apart never touch
            far = s.joints_b + np.array([3.0, 0.0, 0.0])
            err, hit = contact_timing(c["kind"], c["start"], c["end"], s.joints_a, far)
            assert not hit and err == pytest.approx(len(s.joints_a) / 20)
        if s.interaction in FACE_TO_FACE:
            assert face_each_other(both)
            assert not face_each_other(np.stack([s.joints_a, s.joints_b[:, :, ::1] * [-1, 1, 1]]))


def test_bench_duet_runs_on_the_tiny_model(duet_model):
    from engine.evaluation.bench_duet import DuetBenchConfig, bench_duet, format_table

    result = bench_duet(duet_model, DuetBenchConfig(per_interaction=1, steps=2), log=lambda _: None)
    assert result["samples"] == 8
    for method in ("commdm", "prior_twice"):
        p, t = result["prefix"][method], result["text"][method]
        assert p["n"] >= 1 and all(np.isfinite(p[k]) and p[k] >= 0 for k in p)
        assert t["n"] == 8 and 0 <= t["contact_rate"] <= 1 and 0 <= t["face_each_other"] <= 1
        assert p["root_1s"] <= p["root_3s"] + 1.0
    assert set(result["beats_baseline"]) >= {"prefix.root_1s", "text.placement_m", "text.contact_timing_s"}
    table = format_table(result)
    assert "prefix completion" in table and "prior_twice" in table
    layers = duet_model.denoiser.prior.num_layers  # the tiny block: after the last layer, trained with mirroring
    assert (result["block_after_layer"], result["base_layers"], result["mirrored"]) == (layers, layers, True)
    assert f"the block after base layer {layers} of {layers}, trained with mirrored duets" in table
    from engine.evaluation.bench_duet import METHODS

    spacing = result["spacing"]
    assert list(spacing) == ["truth", *[m for method in METHODS for m in (f"{method} raw", method)]]
    assert spacing["truth"]["inside_start"] == 0.0 and spacing["truth"]["moved"] == 0.0
    for method in METHODS:  # as shown, no duet starts with its people inside each other
        assert spacing[method]["inside_start"] == 0.0 and 0.0 <= spacing[method]["moved"] <= 1.0
        assert spacing[method]["start_min_m"] >= spacing[f"{method} raw"]["start_min_m"] - 1e-6
    assert set(result["spacing_start_by_interaction"]["hug"]) == {"truth", "raw", "spaced"}
    assert "spacing: torso distance" in table and "commdm raw" in table


# ----------------------------------------------------------------------------- CLI
def _moattn(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "engine.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=PROJECT_ROOT, timeout=timeout)


def test_moattn_duet_writes_both_people(tmp_path, tiny_model_dir, tiny_duet_dir, workspace):
    out = tmp_path / "duet.npy"
    done = _moattn("duet", "two people hug", "--out", out, "--seconds", "2", "--steps", "3",
                   "--model", tiny_model_dir, "--duet-model", tiny_duet_dir)
    assert done.returncode == 0, done.stderr
    joints = np.load(out)
    assert joints.shape == (2, 40, 22, 3) and json.loads(done.stdout)["frames"] == 40
    # both people are kept in the library, person b as made from person a, each with the duet's recipe
    from engine.library import MotionLibrary

    lib = MotionLibrary(workspace=workspace)
    kept = {e.title: e for e in lib.entries()}
    a, b = kept["two people hug · person a"], kept["two people hug · person b"]
    np.testing.assert_array_equal(lib.joints(a.id), joints[0])
    np.testing.assert_array_equal(lib.joints(b.id), joints[1])
    recipe = lib.recipe(b.id)
    assert recipe["parents"] == [a.id] and recipe["operation"]["duet"] == {"person": "b"}
    assert (recipe["prompt"], recipe["steps"], recipe["seconds"]) == ("two people hug", 3, 2.0)
    done = _moattn("duet", "--prefix", out, "--prefix-seconds", "0.5", "--seconds", "1", "--out",
                   tmp_path / "more.npy", "--steps", "3", "--model", tiny_model_dir, "--duet-model", tiny_duet_dir)
    assert done.returncode == 0, done.stderr
    more = np.load(tmp_path / "more.npy")
    assert more.shape == (2, 30, 22, 3)
    np.testing.assert_allclose(more[:, :10], joints[:, :10], atol=2e-3)  # the given half second, both people
    from engine.cli.duet import write_duet
    from engine.io import load_motion

    a_path, b_path = write_duet(joints, tmp_path / "pair.bvh")
    assert (a_path.name, b_path.name) == ("pair_a.bvh", "pair_b.bvh")
    assert len(load_motion(a_path)) == len(load_motion(b_path)) == 40


@pytest.mark.parametrize("args, message", [
    (["two people zzzq", "--out", "x.npy"], "unknown word"),
    (["   ", "--out", "x.npy"], "prompt is empty"),
    (["two people hug", "--out", "x.txt"], "must end in .npy or .bvh"),
    (["--out", "x.npy"], "give a prompt"),
])
def test_moattn_duet_errors(tmp_path, tiny_model_dir, tiny_duet_dir, args, message):
    args = [str(tmp_path / a) if a.startswith("x.") else a for a in args]
    done = _moattn("duet", *args, "--model", tiny_model_dir, "--duet-model", tiny_duet_dir)
    assert done.returncode == 2 and message in done.stderr, done.stderr


def test_duet_prefix_file_is_checked(tmp_path, tiny_model_dir, tiny_duet_dir):
    bad = tmp_path / "bad.npy"
    np.save(bad, np.zeros((3, 30, 22, 3), dtype=np.float32))
    done = _moattn("duet", "--prefix", bad, "--out", tmp_path / "o.npy", "--model", tiny_model_dir,
                   "--duet-model", tiny_duet_dir)
    assert done.returncode == 2 and "expected joints of shape (2, T, 22, 3)" in done.stderr
    pickled = tmp_path / "p.npy"
    np.save(pickled, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    done = _moattn("duet", "--prefix", pickled, "--out", tmp_path / "o.npy", "--model", tiny_model_dir,
                   "--duet-model", tiny_duet_dir)
    assert done.returncode == 2 and "pickle" in done.stderr


def test_train_flags_belong_to_their_kind():
    """Each trainer takes only its own flags (`moattn train base|control|duet`); the old spelling still maps."""
    done = _moattn("train", "--shots", "3", "--steps", "1")  # no --commdm: the base trainer, which has no --shots
    assert done.returncode == 2 and "moattn train base" in done.stderr and "--shots" in done.stderr
    done = _moattn("train", "--commdm", "--data", "somewhere")  # the duet trainer reads no folder
    assert done.returncode == 2 and "moattn train duet" in done.stderr and "--data" in done.stderr
    done = _moattn("train", "control", "--control", "root", "--init-from", "x", "--underspecified", "2")
    assert done.returncode == 2 and "--underspecified" in done.stderr  # a control fine-tune keeps its base's data
    assert len(done.stderr.strip().splitlines()) == 1


def test_bench_seeds_flag_goes_with_duet(capsys):
    from engine.cli import main

    assert main(["bench", "--edits", "--seeds", "2"]) == 2
    assert "--seeds goes with --duet" in capsys.readouterr().err
    assert main(["bench", "--duet", "--seeds", "0"]) == 2
    assert "--seeds must be at least 1" in capsys.readouterr().err


# ----------------------------------------------------------------------------- the block's layer (issue #33)
def test_the_block_follows_the_last_layer_by_default():
    from engine.methods.duet import new_duet

    assert ComConfig().after == 0 and ComConfig().layer(6) == 6 and ComConfig(after=5).layer(6) == 5
    loaded = random_corpus_model(layers=3)
    assert DuetDenoiser(loaded.model, known_words=len(loaded.tokenizer) - 1, new_words=0).after == 3
    # a new model records the layer as a number: it loads with that layer whatever "the last" becomes
    assert new_duet(loaded, []).config["com"] == {"after": 3, "heads": 4, "ff": 512}
    assert new_duet(loaded, [], config=ComConfig(after=1)).config["com"]["after"] == 1
    with pytest.raises(ValueError, match="between 1 and 3 \\(0 = the last\\), got 4"):
        DuetDenoiser(loaded.model, known_words=len(loaded.tokenizer) - 1, new_words=0, config=ComConfig(after=4))
    for bad in ({"after": -1}, {"heads": 0}, {"after": 1.5}, {"ff": True}):
        with pytest.raises(ValueError, match="must be a whole number"):
            ComConfig(**bad)
    with pytest.raises(TypeError):
        ComConfig(2)  # keyword-only


def test_where_the_block_sits_changes_the_prediction():
    """The same trained block after layer 1 and after the last layer: the layer is used, not just recorded."""
    loaded = random_corpus_model(layers=3)
    known = len(loaded.tokenizer) - 1
    last = DuetDenoiser(loaded.model, known_words=known, new_words=0)
    first = DuetDenoiser(loaded.model, known_words=known, new_words=0, config=ComConfig(after=1))
    torch.nn.init.normal_(last.com.delta.weight, std=0.5)  # a block that has learned something
    first.load_state_dict(last.state_dict())
    x, cond = _duet_batch(loaded, pairs=1)
    t = torch.full((2,), 400)
    with torch.no_grad():
        a, b = last(x, t, cond), first(x, t, cond)
    assert (last.after, first.after) == (3, 1) and (a - b)[:, :-1].abs().max() > 1e-3


def test_the_shipped_block_runs_on_the_shipped_base_after_its_last_layer():
    """assets/duet is trained on assets/model itself (no copy of another prior ships), after the last layer, with
    mirrored duets, as the paper places and augments it; a block saved before those options resumes as it was."""
    from engine.checkpoint import load_model
    from engine.methods.duet import PRIOR_FOLDER, fingerprint
    from engine.paths import DUET_DIR, MODEL_DIR
    from engine.train_commdm import ComTrainConfig, load_trained

    config = json.loads((DUET_DIR / "config.json").read_text())
    assert config["prior"] == fingerprint(load_model(MODEL_DIR)) and not (DUET_DIR / PRIOR_FOLDER).exists()
    model = load_trained(DUET_DIR)
    assert model.denoiser.after == model.denoiser.prior.num_layers == 6
    assert config["train"]["mirror"] is True and config["mirrored"] is True
    # a training config saved before the options existed resumes with what it trained with: layer 5, no mirroring
    old = ComTrainConfig.from_json({k: v for k, v in config["train"].items() if k not in ("mirror",)} |
                                   {"com": {**config["train"]["com"], "after": 5}})
    assert old.com.after == 5 and old.mirror is False
    assert ComTrainConfig().mirror is True and ComTrainConfig().com.after == 0


def test_the_tiny_duet_trained_after_the_last_layer_with_mirroring(tiny_duet_dir):
    config = json.loads((tiny_duet_dir / "config.json").read_text())
    layers = json.loads((Path(config["train"]["prior"]) / "config.json").read_text())["model"]["layers"]
    assert config["train"]["com"]["after"] == 0 and config["com"]["after"] == layers
    assert config["train"]["mirror"] is True and config["mirrored"] is True and config["items"] % 2 == 0


def test_train_duet_flags_come_from_the_configs():
    done = _moattn("train", "duet", "--help")
    assert done.returncode == 0, done.stderr
    text = " ".join(done.stdout.split())
    assert "--mirror, --no-mirror" in text and "mirrored left <-> right" in text and "(default: True)" in text
    assert "--commdm-after COMMDM_AFTER the base layer the block follows" in text and "(the paper's place)" in text


# ----------------------------------------------------------------------------- mirroring the few-shot duets
def test_mirror_joints_swaps_sides_and_reflects():
    from engine.skeleton import JOINT_INDEX, measure_bone_lengths, mirror_joints

    s = make_duet("handshake", np.random.default_rng(1))
    m = mirror_joints(s.joints_a)
    lw, rw = JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]
    np.testing.assert_allclose(m[:, lw], s.joints_a[:, rw] * [-1, 1, 1])
    np.testing.assert_allclose(mirror_joints(m), s.joints_a)
    np.testing.assert_allclose(measure_bone_lengths(m), measure_bone_lengths(s.joints_a), atol=1e-6)
    with pytest.raises(ValueError, match="expected joints"):
        mirror_joints(np.zeros((5, 21, 3)))


def test_a_mirrored_duet_is_the_scene_reflected_both_people_together():
    from engine.methods.duet_data import mirror_caption, pair_item, training_items
    from engine.representation import FEATURE_DIM, Normalizer
    from engine.skeleton import mirror_joints

    identity = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    for interaction in ("handshake", "side_by_side", "following"):
        s = make_duet(interaction, np.random.default_rng(4))
        plain, mirrored = pair_item(s, identity), pair_item(s, identity, mirror=True)
        for person in (0, 1):  # b stands on a's other side, turned the other way; a stays a
            x, z, c, sn = plain.place[person].tolist()
            np.testing.assert_allclose(mirrored.place[person].numpy(), [-x, z, c, -sn], atol=2e-3)
        from engine.representation import joints_to_features

        np.testing.assert_allclose(mirrored.motion[0].numpy(), joints_to_features(mirror_joints(s.joints_a)),
                                   atol=1e-5)
        assert not np.allclose(mirrored.motion[0].numpy(), plain.motion[0].numpy(), atol=1e-2)
        assert mirrored.captions == plain.captions  # no side words in the duet captions
    assert mirror_caption("a person waves the left hand, then the right hand") == \
        "a person waves the right hand, then the left hand"
    assert mirror_caption("leftover rights") == "leftover rights"
    samples = [make_duet("hug", np.random.default_rng(k)) for k in range(2)]
    both, plain = training_items(samples, identity, crop_every=40), training_items(samples, identity, crop_every=40,
                                                                                      mirror=False)
    assert len(both) == 2 * len(plain)
    np.testing.assert_allclose(both[0].motion.numpy(), plain[0].motion.numpy())
    np.testing.assert_allclose(both[1].place[:, 0].numpy(), -plain[0].place[:, 0].numpy(), atol=2e-3)


def test_contact_distances_map_onto_themselves_when_mirrored():
    """A right-hand handshake mirrored is a left-hand one: the contact set holds both, so the training's contact
    term treats a mirrored duet as it treats the original (columns permuted, MIRRORED_COLUMNS)."""
    from engine.methods.duet_data import few_shot, pair_item, stack_pairs
    from engine.methods.duet_losses import CONTACT_PAIRS, MIRRORED_COLUMNS, _together, contact_distances
    from engine.representation import FEATURE_DIM, Normalizer
    from engine.skeleton import mirror_joints

    assert len(CONTACT_PAIRS) == len(MIRRORED_COLUMNS) and sorted(MIRRORED_COLUMNS) == list(range(len(CONTACT_PAIRS)))
    s = make_duet("handshake", np.random.default_rng(2))
    ja, jb = torch.from_numpy(s.joints_a).double(), torch.from_numpy(s.joints_b).double()
    d = contact_distances(ja, jb)
    dm = contact_distances(torch.from_numpy(mirror_joints(s.joints_a)), torch.from_numpy(mirror_joints(s.joints_b)))
    torch.testing.assert_close(dm[..., list(MIRRORED_COLUMNS)], d.to(dm.dtype))
    touch = s.labels["contacts"][0]
    frames = slice(touch["start"], touch["end"])
    assert d[frames, 0].min() < 0.1 and dm[frames, 5].min() < 0.1  # right hands meet; mirrored, left hands do
    # the same through the training's own path: features, placements, the people put together
    identity = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    samples = few_shot("test", per_interaction=1)
    plain = _together(stack_pairs([pair_item(x, identity) for x in samples])[0], identity)
    mirrored = _together(stack_pairs([pair_item(x, identity, mirror=True) for x in samples])[0], identity)
    torch.testing.assert_close(mirrored[..., list(MIRRORED_COLUMNS)], plain, atol=2e-3, rtol=0)


def test_a_prior_that_gained_a_skip_path_is_still_the_blocks_prior():
    """The skip path acts only in inversion, never in a duet: the prior's fingerprint leaves it out (base v10 = v9 + a
    skip path runs v9's duet block), but any change to the network's own weights still tells the priors apart."""
    from dataclasses import replace as replaced

    from engine.methods.commdm import fingerprint
    from engine.model import Denoiser, ModelConfig

    plain = random_corpus_model(layers=1)
    config = ModelConfig(**{**plain.model.config.to_json(), "skip_sigma": 0.1, "skip_path": 8})
    with_path = Denoiser(config).eval()
    missing, _ = with_path.load_state_dict(plain.model.state_dict(), strict=False)
    assert missing and all(k.startswith("skip_path.") for k in missing)
    torch.nn.init.normal_(with_path.skip_path.conv_out.weight)
    assert fingerprint(replaced(plain, model=with_path)) == fingerprint(plain)
    with torch.no_grad():
        with_path.out_proj.bias[0] += 1e-2
    assert fingerprint(replaced(plain, model=with_path)) != fingerprint(plain)
