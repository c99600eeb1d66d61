"""The transfer benchmark: its pairs and measurements on known joints, one tiny end-to-end run, the CLI."""
from __future__ import annotations

import json

import numpy as np

from engine.cli import main
from engine.evaluation.bench_transfer import (
    KEYS, METHODS, MOTIF_JOINTS, RESTATED, TransferBenchConfig, bench_transfer, build_pairs, format_table, measure,
    motif_region,
)
from engine.methods.momo import canonical
from engine.synth.splits import is_held_out
from tests.test_eval_run import tiny_evaluator, tiny_model  # noqa: F401  (fixtures)


def test_pairs_are_deterministic_and_split_by_held_out_truth():
    config = TransferBenchConfig(pairs=3, ood_pairs=2)
    a, b = build_pairs(config), build_pairs(config)
    assert [p.leader.captions[0] for p in a] == [p.leader.captions[0] for p in b]
    assert [p.ood for p in a] == [False, False, False, True, True]
    for p in a:
        assert p.leader.program.style == "none" and len(p.leader.program.segments) == 1
        assert p.follower.program.style != "none" or p.follower.program.segments[0].overlay is not None
        assert is_held_out(p.truth.program) == p.ood
        assert len(p.truth.joints) == len(p.leader.joints)  # the leader's outline: its length


def test_measurements_on_known_outputs():
    pair = build_pairs(TransferBenchConfig(pairs=1, ood_pairs=0))[0]
    truth = measure(canonical(pair.truth.joints), pair)
    assert truth["gt_mpjpe"] < 1e-6 and truth["gt_mpjpe_local"] < 1e-6
    leader = measure(canonical(pair.leader.joints), pair)
    assert leader["foot_contact"] == 1.0 and leader["follower_loc"] == 0.0 and leader["follower_rot"] == 0.0
    follower = canonical(pair.follower.joints)
    n = len(canonical(pair.leader.joints))
    reps = np.concatenate([follower] * (n // len(follower) + 1))[:n]
    f = measure(reps, pair)
    assert f["follower_loc"] > 0.9 and f["follower_rot"] > 0.9
    # measured against other streams (momo_gen's generated leader and follower): the follower is now the "leader"
    swapped = measure(reps, pair, streams=(reps, canonical(pair.leader.joints)))
    assert swapped["foot_contact"] == 1.0 and swapped["follower_loc"] == 0.0
    assert swapped["gt_mpjpe"] == f["gt_mpjpe"]  # still against the pair's ground truth


def test_motif_region_rule():
    from engine.skeleton import JOINT_NAMES

    wave = {"style": "none", "gestures": [{"segment": 0, "action": "wave", "side": "right"}]}
    plain = {"style": "none", "gestures": []}
    assert motif_region(wave) == "arms"
    assert motif_region({"style": "zombie", "gestures": []}) == "arms"  # an arm style
    assert motif_region({"style": "old", "gestures": []}) == "body"  # a posture style
    assert motif_region({"style": "happy", "gestures": wave["gestures"]}) == "body"  # posture wins: it bends it all
    # the truth carries no motif (combine dropped the follower's wave): the follower's labels decide
    assert motif_region(plain, wave) == "arms" and motif_region(plain, {"style": "sad", "gestures": []}) == "body"
    assert motif_region({"style": "old", "gestures": []}, wave) == "body"  # the truth's own motif comes first
    assert motif_region(plain) == "body"
    assert sorted(JOINT_NAMES[j] for j in MOTIF_JOINTS["arms"]) == sorted(
        f"{side}_{part}" for side in ("left", "right") for part in ("shoulder", "elbow", "wrist"))
    assert MOTIF_JOINTS["body"] == tuple(range(1, 22))


def test_motif_error_counts_only_the_motif_joints():
    pair = build_pairs(TransferBenchConfig(pairs=1, ood_pairs=0))[0]
    truth = canonical(pair.truth.joints)
    assert measure(truth, pair)["motif_mpjpe_local"] < 1e-6
    region = pair.motif_region
    assert region == motif_region(pair.truth.labels.motifs, pair.follower.labels.motifs)
    other = [j for j in range(1, 22) if j not in MOTIF_JOINTS[region]]
    if other:  # moving joints outside the region leaves the motif error at 0 but not the pose error
        moved = truth.copy()
        moved[:, other, 0] += 0.1
        m = measure(moved, pair)
        assert m["motif_mpjpe_local"] < 1e-4 and m["gt_mpjpe_local"] > 0.01
    moved = truth.copy()
    moved[:, list(MOTIF_JOINTS[region]), 0] += 0.1  # every motif joint 10 cm aside: the motif error is 10 cm
    m = measure(moved, pair)
    assert abs(m["motif_mpjpe_local"] - 0.1) < 2e-3
    assert m["gt_mpjpe_local"] <= m["motif_mpjpe_local"] + 1e-6


def test_tiny_end_to_end(tiny_model, tiny_evaluator):  # noqa: F811
    result = bench_transfer(tiny_model, tiny_evaluator, TransferBenchConfig(pairs=2, ood_pairs=2, steps=3, distractors=8),
                            log=lambda line: None)
    assert result["pairs"] == 4 and result["ood_pairs"] == 2
    assert set(result["methods"]) == set(METHODS)
    for row in result["methods"].values():
        assert all(np.isfinite(row[k]) for k in KEYS)
        assert 0.0 <= row["foot_contact"] <= 1.0 and 0.0 <= row["r_precision_top3"] <= 1.0
        assert row["ood"]["n"] == 2
    assert result["methods"]["nn_motion"]["follower_loc"] == 1.0  # it copies follower poses
    truth, copy = result["reference"]["truth"], result["reference"]["leader_copy"]
    assert truth["gt_mpjpe"] < 1e-6 and copy["foot_contact"] == 1.0 and copy["follower_loc"] == 0.0
    assert result["targets"]["truth_follower_loc"] == truth["follower_loc"]
    # the restated figures: quotients and distances of the reported figures, per row and per ood row
    nn = result["methods"]["nn_motion"]
    assert len(result["motif_regions"]) == 4 and set(result["motif_regions"]) <= {"arms", "body"}
    for row in (*result["methods"].values(), *result["reference"].values()):
        for r, c, n, t in ((row, copy, nn, truth), (row["ood"], copy["ood"], nn["ood"], truth["ood"])):
            assert all(np.isfinite(r[k]) for k in RESTATED)
            assert r["gt_mpjpe_local_vs_leader_copy"] == r["gt_mpjpe_local"] / c["gt_mpjpe_local"]
            assert r["gt_mpjpe_local_vs_nn_motion"] == r["gt_mpjpe_local"] / n["gt_mpjpe_local"]
            assert r["foot_contact_to_truth"] == abs(r["foot_contact"] - t["foot_contact"]) >= 0.0
            assert r["follower_loc_to_truth"] == abs(r["follower_loc"] - t["follower_loc"]) >= 0.0
            assert r["motif_mpjpe_local"] >= 0.0
    assert copy["gt_mpjpe_local_vs_leader_copy"] == 1.0 and nn["gt_mpjpe_local_vs_nn_motion"] == 1.0
    assert truth["foot_contact_to_truth"] == 0.0 and truth["follower_loc_to_truth"] == 0.0
    assert truth["gt_mpjpe_local_vs_leader_copy"] < 1e-6 and truth["motif_mpjpe_local"] < 1e-6
    assert copy["follower_loc_to_truth"] == truth["follower_loc"]  # the leader copy scores 0 there
    assert copy["motif_mpjpe_local"] > 0.0
    table = format_table(result)
    assert "motif_mpjpe_loc" in table and "mpjpe_loc/copy" in table
    assert f"{nn['gt_mpjpe_local_vs_leader_copy']:.3f}" in table
    json.dumps(result)


def test_cli_transfer_and_analysis(tiny_model_dir, tmp_path, capsys):
    motion = tmp_path / "leader.npy"
    from engine.synth import Corpus

    np.save(motion, Corpus(split="test").sample(2).joints[:41])
    out = tmp_path / "out.npy"
    args = ["--leader", str(motion), "--leader-prompt", "a person walks", "--follower", "a person jumps",
            "--follower", "a person runs forward", "--steps", "3", "--seconds", "2", "--model", str(tiny_model_dir)]
    assert main(["transfer", *args, "--out", str(out), "--render", str(tmp_path / "t.png")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["out"] == [str(tmp_path / "out_1.npy"), str(tmp_path / "out_2.npy")]
    assert np.load(tmp_path / "out_1.npy").shape == (40, 22, 3)
    assert report["leader_inversion_m"]["mean_m"] >= 0 and report["follower_inversion_m"] == [None, None]
    assert (tmp_path / "t.png").stat().st_size > 1000
    figs = tmp_path / "figs"
    assert main(["analyze-qk", *args[:6], *args[8:], "--out", str(figs), "--per-prompt", "1", "--components", "3",
                 "--clusters", "3"]) == 0
    for name in ("clusters.png", "correspondence.png", "maps.png", "analysis.json"):
        assert (figs / name).stat().st_size > 1000
    data = json.loads((figs / "analysis.json").read_text())
    assert len(data["nearest"]) == 40 and len(data["q_labels"]["follower"]) == 40
    feet = tmp_path / "feet.npy"
    assert main(["transfer", "--leader", "a person walks", "--follower", "a person jumps", "--keep-feet", "--steps",
                 "3", "--seconds", "2", "--model", str(tiny_model_dir), "--out", str(feet)]) == 0
    capsys.readouterr()
    assert np.load(feet).shape == (40, 22, 3)
    assert main(["transfer", "--leader", "a person flurbs", "--follower", "a person jumps", "--out", str(out),
                 "--model", str(tiny_model_dir)]) == 2
    assert "flurbs" in capsys.readouterr().err
