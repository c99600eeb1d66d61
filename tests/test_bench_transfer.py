"""The transfer benchmark: its pairs and measurements on known joints, one tiny end-to-end run, the CLI."""
from __future__ import annotations

import json

import numpy as np

from engine.cli import main
from engine.evaluation.bench_transfer import (
    KEYS, METHODS, MOTIF_JOINTS, RESTATED, TransferBenchConfig, bench_transfer, build_pairs, build_speed_pairs,
    format_table, measure, measure_speed, motif_region, root_speed,
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


def test_speed_pairs_take_the_followers_stride_at_the_leaders_steps():
    config = TransferBenchConfig(speed_pairs=2)
    pairs = build_speed_pairs(config)
    kinds = [(p.leader.program.segments[0].action, p.follower.program.segments[0].action) for p in pairs]
    assert kinds == [("walk", "run")] * 2 + [("run", "walk")] * 2
    assert [p.leader.captions[0] for p in pairs] == [p.leader.captions[0] for p in build_speed_pairs(config)]
    for p, (lead, follow) in zip(pairs, kinds):
        assert p.leader.program.style == "none" == p.follower.program.style and not p.ood
        assert p.truth.program.segments[0].action == follow and len(p.truth.joints) == len(p.leader.joints)
        truth, leader = root_speed(canonical(p.truth.joints)), root_speed(canonical(p.leader.joints))
        # the run's stride over the walk's (GAITS: 2.9 / 2.8 against 1.3 / 1.85 m per step): ~1.47x, or ~0.68x
        assert (1.3 < truth / leader < 1.65) if lead == "walk" else (0.6 < truth / leader < 0.77)
        assert measure_speed(canonical(p.truth.joints), p) == {"speed": truth, "speed_truth": truth, "speed_ratio": 1.0,
                                                               "speed_error": 0.0}
        copy = measure_speed(canonical(p.leader.joints), p)
        assert abs(copy["speed_ratio"] - leader / truth) < 1e-9 and copy["speed_error"] > 0.2
    assert build_speed_pairs(TransferBenchConfig(speed_pairs=0)) == []


def test_a_truth_that_stays_in_place_does_not_blow_the_speed_error_up():
    """The error is relative to the truth's speed, but at least a slow walk's (SPEED_FLOOR): a jump's truth moving
    1 cm/s against an output drifting at 0.5 m/s reads 1.0, not 50."""
    from types import SimpleNamespace

    from engine.evaluation.bench_transfer import SPEED_FLOOR

    def moving(speed: float) -> np.ndarray:  # (40, 22, 3): the root on the floor at a steady speed along x
        joints = np.zeros((40, 22, 3))
        joints[:, :, 0] = (np.arange(40) * speed / 20)[:, None]
        return joints

    standing = SimpleNamespace(reference={"truth": [moving(0.01)]})
    r = measure_speed(moving(0.5), standing)
    assert abs(r["speed_truth"] - 0.01) < 1e-9 and abs(r["speed_ratio"] - 50) < 1e-6  # the ratio says what it is
    assert abs(r["speed_error"] - (0.5 - 0.01) / SPEED_FLOOR) < 1e-9 and SPEED_FLOOR == 0.5
    walking = SimpleNamespace(reference={"truth": [moving(1.2)]})  # above the floor: relative to the truth itself
    assert abs(measure_speed(moving(0.6), walking)["speed_error"] - 0.5) < 1e-9


def test_root_speed_is_metres_per_second_on_the_floor():
    t = np.arange(41) / 20.0
    joints = np.zeros((41, 22, 3))
    joints[:, :, 0] = 1.5 * t[:, None]  # 1.5 m/s along x
    joints[:, :, 1] = 0.9 + 0.1 * np.sin(t)[:, None]  # bobbing does not count
    assert abs(root_speed(joints) - 1.5) < 1e-9
    joints[:, :, 2] = 2.0 * t[:, None]
    assert abs(root_speed(joints) - 2.5) < 1e-9


def test_tiny_end_to_end(tiny_model, tiny_evaluator):  # noqa: F811
    result = bench_transfer(tiny_model, tiny_evaluator,
                            TransferBenchConfig(pairs=2, ood_pairs=2, steps=3, distractors=8, speed_pairs=1),
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
    # the default config is one of the two root rows, run once
    from engine.methods.transfer_config import ROOT_DEFAULT

    assert result["default_root"] == ROOT_DEFAULT
    assert result["methods"]["momo"] == result["methods"][f"momo_{ROOT_DEFAULT}"]
    assert result["methods"]["momo_rotation"] != result["methods"]["momo_trajectory"]
    # speed pairs: one walk -> run, one run -> walk, every method scored against the truth's speed
    speed = result["speed"]
    assert speed["pairs"] == 2 and set(speed["rows"]) == set(METHODS) | {"truth", "leader_copy"}
    rows = speed["rows"]
    assert rows["truth"]["speed_error"] == 0.0 and rows["truth"]["walk_run_ratio"] == 1.0
    assert rows["leader_copy"]["walk_run_ratio"] < 0.8 and rows["leader_copy"]["run_walk_ratio"] > 1.25
    # "trajectory" inpaints the (pinned, exactly rebuilt) leader's root: the leader's speed, not the truth's
    for key in ("walk_run_ratio", "run_walk_ratio"):
        assert abs(rows["momo_trajectory"][key] - rows["leader_copy"][key]) < 1e-3
    assert all(np.isfinite(r["speed_error"]) and np.isfinite(r["gt_mpjpe_local_vs_leader_copy"]) for r in rows.values())
    assert result["targets"]["speed_error"] == rows["momo"]["speed_error"]
    assert result["targets"]["gt_mpjpe_local_vs_leader_copy"] == result["methods"]["momo"]["gt_mpjpe_local_vs_leader_copy"]
    choice = result["root_choice"]
    assert choice["default"] == ROOT_DEFAULT and choice["pick"] in ("rotation", "trajectory")
    assert choice["modes"]["trajectory"]["n"] == 6  # 4 main pairs and 2 speed pairs
    assert choice["modes"][choice["pick"]]["speed_error"] <= min(r["speed_error"] for r in choice["modes"].values()) + 1e-3
    table = format_table(result)
    assert f"the bench picks root={choice['pick']}" in table
    assert "motif_mpjpe_loc" in table and "mpjpe_loc/copy" in table and "|speed err|" in table
    assert f"{nn['gt_mpjpe_local_vs_leader_copy']:.3f}" in table
    assert "walk->run" in table and f"{rows['leader_copy']['walk_run_ratio']:>17.3f}" in table
    assert f"default root: {ROOT_DEFAULT}" in table and "(target <= 0.8)" in table
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
    from PIL import Image
    from viz.export import VIDEO_SIZE

    with Image.open(tmp_path / "t.png") as im:  # the studio's exporter's picture (leader | followers | outs)
        assert im.format == "PNG" and im.size == VIDEO_SIZE
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


def test_cli_root_modes_and_the_direction_trick(tiny_model_dir, tmp_path, capsys):
    from engine.cli import build_parser
    from engine.methods.transfer_config import ROOT_DEFAULT, ROOT_MODES, option_info

    parser = build_parser()
    base = ["transfer", "--leader", "a person walks", "--follower", "a person jumps", "--out", "x.npy"]
    args = parser.parse_args(base)
    assert args.root == ROOT_DEFAULT == option_info("root").default and args.directions == 1  # the config's defaults
    sub = next(a for a in parser._subparsers._group_actions[0].choices["transfer"]._actions if a.dest == "root")
    assert tuple(sub.choices) == ROOT_MODES and "paper" in sub.help
    out = tmp_path / "d.npy"
    common = ["--leader", "a person walks", "--follower", "a person jumps", "--steps", "3", "--seconds", "2",
              "--model", str(tiny_model_dir)]
    assert main(["transfer", *common, "--directions", "2", "--root", "trajectory", "--out", str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["root"] == "trajectory" and report["directions"] == 2
    assert report["direction_copies"] == [["a person jumps (seed 9)"]]
    assert np.load(out).shape == (40, 22, 3)
    assert main(["transfer", *common, "--out", str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["root"] == ROOT_DEFAULT and "direction_copies" not in report
    assert main(["transfer", *common, "--directions", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "directions must be between 1 and 8, got 0" in err and len(err.splitlines()) == 1
    assert main(["transfer", *common, "--follower", "a person runs", "--follower", "a person waves", "--directions",
                 "6", "--out", str(out)]) == 2
    assert "follower streams" in capsys.readouterr().err
