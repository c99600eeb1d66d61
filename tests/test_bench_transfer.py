"""The transfer benchmark: its pairs and measurements on known joints, one tiny end-to-end run, the CLI."""
from __future__ import annotations

import json

import numpy as np

from engine.cli import main
from engine.evaluation.bench_transfer import KEYS, METHODS, TransferBenchConfig, bench_transfer, build_pairs, measure
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
