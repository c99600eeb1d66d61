"""PriorMDM control's options declared once (engine.methods.control_options): the one blend-weight rule, the bench
record that says which method is ahead, and `moattn control` taking the root and both wrists at once, each with its
blend weight, on a tiny model (its refusals one line each, the engine's)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from engine.cli import main
from engine.methods.control_options import (BENCH_RECORD, CONTROLS, ControlOptions, bench_record, bench_verdict,
                                            blend_shares, judge, models_fingerprint, option_info, options,
                                            write_bench_record)

pytestmark = pytest.mark.timeout(600)


# ----------------------------------------------------------------------------- the blend-weight rule
def test_blend_shares_scale_the_weights_in_use_to_sum_one():
    assert blend_shares(None, ["root", "left_wrist", "right_wrist"]) == pytest.approx([1 / 3] * 3)
    assert blend_shares([1, 3], ["root", "left_wrist"]) == [0.25, 0.75]
    # a mapping may hold every control: only those in use count, in the order asked; a missing one weighs 1
    weights = {"root": 2.0, "left_wrist": 6.0, "right_wrist": 2.0}
    assert blend_shares(weights, ["right_wrist", "root"]) == [0.5, 0.5]
    assert blend_shares({"root": 3.0}, ["root", "left_wrist"]) == [0.75, 0.25]
    assert blend_shares(np.array([1.0, 1.0], dtype=np.float32), ["root", "right_wrist"]) == [0.5, 0.5]
    assert math.fsum(blend_shares([0.1] * 7, ["root"] * 7)) == pytest.approx(1.0)
    assert blend_shares([0.0, 2.0], ["root", "left_wrist"]) == [0.0, 1.0]  # 0 for one control is allowed


@pytest.mark.parametrize("weights, names, message", [
    ({"root": -0.5, "left_wrist": 1.0}, ["root", "left_wrist"], "must not be negative: the root path has -0.5"),
    ([0.0, 0.0], ["root", "right_wrist"], "blend weights are all 0"),
    ({"root": float("nan")}, ["root"], "the blend weight of the root path must be a finite number"),
    ([float("inf"), 1.0], ["root", "left_wrist"], "must be a finite number"),
    ([True, 1.0], ["root", "left_wrist"], "must be a finite number, got True"),
    (["1", 1.0], ["root", "left_wrist"], "must be a finite number, got '1'"),
    ([1.0], ["root", "left_wrist"], "1 blend weight for 2 controls (root path, left wrist)"),
    (None, [], "no control to blend"),
])
def test_blend_shares_refuse_with_one_line(weights, names, message):
    with pytest.raises(ValueError) as refused:
        blend_shares(weights, names)
    assert message in str(refused.value) and "\n" not in str(refused.value)


def test_engine_normalized_weights_follow_the_same_rule():
    from engine.methods.control import normalized_weights

    assert normalized_weights([1, 3], 2) == blend_shares([1, 3], ["a", "b"])
    with pytest.raises(ValueError, match="must not be negative"):
        normalized_weights([-1, 2], 2)
    with pytest.raises(ValueError, match="all 0"):
        normalized_weights([0, 0], 2)


def test_control_options_declare_every_option_once():
    declared = {o.name: o for o in options(ControlOptions)}
    assert list(declared) == ["seconds", "method", "root_weight", "left_wrist_weight", "right_wrist_weight",
                              "planted_feet"]
    assert declared["planted_feet"].default is True and declared["planted_feet"].help
    from engine.units import MAX_SECONDS, MIN_SECONDS

    assert declared["seconds"].default == 6.0 and declared["seconds"].bounds == (MIN_SECONDS, MAX_SECONDS)
    assert declared["method"].choices == ("blending", "inpainting") and declared["method"].default == "blending"
    for name in CONTROLS:
        info = option_info(ControlOptions, ControlOptions.weight_field(name))
        assert info.bounds == (0.0, math.inf) and info.soft == (0.0, 1.0) and info.help
        assert info.flag == f"--{name.replace('_', '-')}-weight"
    # a wrist's model weighs a quarter of the root's by default (an equal share cost the walk on drawn paths)
    assert ControlOptions().shares(["root", "left_wrist"]) == [0.8, 0.2]
    assert ControlOptions().shares(["root", "left_wrist", "right_wrist"]) == pytest.approx([2 / 3, 1 / 6, 1 / 6])
    assert ControlOptions().shares(["right_wrist"]) == [1.0]
    o = ControlOptions(root_weight=3.0, left_wrist_weight=1.0, right_wrist_weight=1.0)
    assert o.weights() == {"root": 3.0, "left_wrist": 1.0, "right_wrist": 1.0}
    assert o.shares(["root", "right_wrist"]) == [0.75, 0.25]
    with pytest.raises(ValueError, match="unknown control method 'blend'"):
        ControlOptions(method="blend")
    with pytest.raises(ValueError, match="unknown control 'wrist'"):
        ControlOptions.weight_field("wrist")
    with pytest.raises(TypeError):
        ControlOptions("inpainting")  # keyword-only


# ----------------------------------------------------------------------------- which method the bench has ahead
def _result(blending: dict, inpainting: dict, *, paths: int = 9) -> dict:
    """What ``bench_control`` returns, reduced to what the record reads."""
    rows = {m: {"paths": paths, "error_m": 0.02, "off_0_5m": 0.0, **figs}
            for m, figs in (("blending", blending), ("inpainting", inpainting))}
    return {"drawn": {"tasks": {"root+left_wrist": rows}}, "steps": 50, "motions": 64, "truth_skate": 0.05,
            "planted_feet": True}


def test_judge_needs_a_lead_and_no_loss_for_a_leader():
    assert judge({"blending": {"skate": 0.1, "action_match": 0.5},
                  "inpainting": {"skate": 0.3, "action_match": 0.2}})[0] == "blending"
    assert judge({"blending": {"skate": 0.4, "action_match": 0.1},
                  "inpainting": {"skate": 0.3, "action_match": 0.2}})[0] == "inpainting"
    leader, said = judge({"blending": {"skate": 0.78, "action_match": 0.0},
                          "inpainting": {"skate": 0.84, "action_match": 0.22}})
    assert leader is None
    assert said == "foot skate 0.78 vs 0.84 (blending ahead), prompted action 0.00 vs 0.22 (inpainting ahead)"
    # ahead on one figure and even on the other is a lead; even on both, or a missing figure, is none
    leader, said = judge({"blending": {"skate": 0.06, "action_match": 0.78},
                          "inpainting": {"skate": 0.24, "action_match": 0.78}})
    assert leader == "blending" and said.endswith("prompted action 0.78 vs 0.78 (even)")
    assert judge({"blending": {"skate": 0.3, "action_match": 0.2},
                  "inpainting": {"skate": 0.3, "action_match": 0.4}})[0] == "inpainting"
    assert judge({"blending": {"skate": 0.3, "action_match": 0.2},
                  "inpainting": {"skate": 0.3, "action_match": 0.2}})[0] is None
    leader, said = judge({"blending": {"skate": 0.1, "action_match": None},
                          "inpainting": {"skate": 0.3, "action_match": 0.2}})
    assert leader is None and "prompted action not measured" in said


def _controls(folder, names=CONTROLS):
    for name in names:
        (folder / name).mkdir(parents=True)
        (folder / name / "weights.pt").write_bytes(name.encode() * 100)
    return folder


def test_the_bench_record_speaks_for_the_models_it_measured(tmp_path):
    folder = _controls(tmp_path / "control")
    assert bench_verdict(folder).leader is None and "No control bench is recorded" in bench_verdict(folder).message
    path = write_bench_record(_result({"skate": 0.1, "action_match": 0.6}, {"skate": 0.3, "action_match": 0.2}),
                              folder=folder)
    record = json.loads(path.read_text())
    assert path.name == BENCH_RECORD and record["models"] == models_fingerprint(folder) and len(record["models"]) == 3
    assert record["figures"]["blending"]["skate"] == 0.1 and record["run"] == {"drawn_paths": 9, "steps": 50,
                                                                                "motions": 64, "planted_feet": True}
    verdict = bench_verdict(folder)
    assert "planted feet on" in verdict.message
    assert verdict.leader == "blending" and verdict.opening_method(blending_offered=True) == "blending"
    assert verdict.opening_method(blending_offered=False) == "inpainting"
    assert verdict.message.startswith("The control bench has blending ahead of inpainting on drawn root + left wrist")
    assert "(moattn bench --control, 9 drawn paths, 50 steps, planted feet on)" in verdict.message and "\n" not in verdict.message
    # a model retrained since: the record no longer speaks for the folder
    (folder / "left_wrist" / "weights.pt").write_bytes(b"retrained")
    verdict = bench_verdict(folder)
    assert verdict.leader is None and "other control models" in verdict.message
    assert verdict.opening_method(blending_offered=True) == "inpainting"
    # a bench without both drawn rows cannot be recorded
    with pytest.raises(ValueError, match="no drawn root\\+left_wrist row"):
        bench_record({"drawn": {"tasks": {"root+left_wrist": {"inpainting": {}}}}}, folder=folder)
    with pytest.raises(ValueError, match="--drawn > 0"):
        bench_record({"tasks": {}}, folder=folder)


def test_the_shipped_record_speaks_for_the_shipped_control_models():
    """assets/control/bench.json measured these very models (re-run `moattn bench --control --write` after
    re-fine-tuning them); its verdict names what each method is ahead on."""
    from engine.paths import CONTROL_DIR

    record = json.loads((CONTROL_DIR / BENCH_RECORD).read_text())
    assert record["models"] == models_fingerprint(CONTROL_DIR) and set(record["models"]) == set(CONTROLS)
    verdict = bench_verdict(CONTROL_DIR)
    assert "foot skate" in verdict.message and "prompted action" in verdict.message
    assert verdict.leader == judge(record["figures"])[0]


def test_moattn_bench_write_flags_are_checked_before_any_work(capsys):
    assert main(["bench", "--write"]) == 2
    assert "--write goes with --edits --calibrate, --tempo or --control" in capsys.readouterr().err
    assert main(["bench", "--control", "--write", "--drawn", "0"]) == 2
    assert "--drawn must be above 0" in capsys.readouterr().err
    assert main(["bench", "--calibrate"]) == 2
    assert "--calibrate and --write go with --edits" in capsys.readouterr().err


# ----------------------------------------------------------------------------- the engine and `moattn control`
def test_inpainting_takes_no_blend_weights():
    from engine.generate import SampleConfig
    from engine.methods.control import Control, controlled
    from tests.conftest import random_corpus_model

    loaded = random_corpus_model(layers=1)
    root = Control("root", np.zeros((20, 3)))
    with pytest.raises(ValueError, match="blend weights apply to blending"):
        controlled(loaded, "a person walks", [root], seconds=1.0, weights=[1.0], sample=SampleConfig(steps=1))


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    from engine.methods.drawn_paths import letter

    folder = tmp_path_factory.mktemp("paths")
    (folder / "root.json").write_text(json.dumps({"points": [[0, 0], [0, 2], [1, 3]]}))
    for side, char in (("left", "L"), ("right", "O")):
        p = letter(char, side=side)
        (folder / f"{side}.json").write_text(json.dumps({"points": p.points, "times": p.times}))
    return folder


@pytest.fixture(scope="module")
def tiny_controls(tiny_model_dir, tmp_path_factory):
    """A 'control model' per control: the tiny model's copy marked fine-tuned for it (the same base: blendable)."""
    from tests.test_priormdm import controls_with_prior

    return controls_with_prior(tiny_model_dir, tmp_path_factory.mktemp("controls") / "control", CONTROLS, prior=False)


def test_moattn_control_blends_the_root_and_both_wrists(tiny_model_dir, tiny_controls, paths, tmp_path, capsys):
    from engine.methods.control import control_dims
    from engine.methods.paths import WristPath
    from engine.representation import joints_to_features

    out = tmp_path / "c.npy"
    common = ["control", "--prompt", "a person walks", "--root", str(paths / "root.json"), "--left-wrist",
              str(paths / "left.json"), "--right-wrist", str(paths / "right.json"), "--seconds", "3", "--steps", "3",
              "--model", str(tiny_model_dir), "--controls", str(tiny_controls), "--out", str(out)]
    assert main([*common, "--root-weight", "2", "--right-wrist-weight", "0.5"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "blending" and report["controls"] == ["root", "left_wrist", "right_wrist"]
    # the left wrist keeps its default weight, 0.25
    assert report["weights"] == pytest.approx({"root": 2 / 2.75, "left_wrist": 0.25 / 2.75, "right_wrist": 0.5 / 2.75})
    assert "No control bench is recorded" in report["bench"]
    assert report["root_error"]["mean_m"] < 0.05
    # each wrist followed its own letter: its height (up to the one offset of the floor that joints_to_features
    # re-estimates) and its distance from the body's vertical axis, which do not depend on the heading (the tiny
    # model's body need not face where its root turns), match that letter's path
    feats = joints_to_features(np.load(out))
    for side in ("left", "right"):
        spec = json.loads((paths / f"{side}.json").read_text())
        target = WristPath(points=tuple(map(tuple, spec["points"])), times=tuple(spec["times"])).controls(3.0)
        got = feats[:, control_dims(f"{side}_wrist")]
        n = min(len(got), len(target))
        height = np.ptp(got[:n, 1] - target[:n, 1])
        reach = np.abs(np.hypot(got[:n, 0], got[:n, 2]) - np.hypot(target[:n, 0], target[:n, 2])).mean()
        assert height < 0.02 and reach < 0.02, (side, height, reach)
    # --weights gives them at once, in the order of the paths given
    assert main([*common, "--weights", "2", "0.25", "0.5"]) == 0
    assert json.loads(capsys.readouterr().out)["weights"] == report["weights"]
    # the baseline
    assert main([*common, "--method", "inpainting"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "inpainting" and "weights" not in report and report["planted_feet"] is True
    assert 0.0 <= report["foot_skate"] <= 1.0
    # the paper's sampling, feet free to slide
    assert main([*common, "--no-planted-feet"]) == 0
    assert json.loads(capsys.readouterr().out)["planted_feet"] is False


def test_planted_feet_stop_the_shipped_model_sliding_along_a_drawn_path():
    """The shipped base inpainting a drawn S-curve: with the planted-feet correction (the default) the feet slide
    on fewer floor frames than without it, on the same noise, and the root follows the path the same."""
    from engine.checkpoint import load_model
    from engine.evaluation.bench_control import drawn_cases, drawn_errors
    from engine.evaluation.metrics import foot_skate
    from engine.generate import SampleConfig
    from engine.methods.control import controlled

    loaded = load_model("assets/model")
    case = drawn_cases("root", 1)[0]
    runs = {feet: controlled(loaded, case.prompt, case.controls, seconds=case.seconds,
                             sample=SampleConfig(steps=20, seed=0), planted_feet=feet).joints[0]
            for feet in (False, True)}
    skate = {feet: foot_skate(j) for feet, j in runs.items()}
    assert skate[False] > 0.1 and skate[True] < 0.5 * skate[False], skate
    assert abs(drawn_errors(runs[True], case).mean() - drawn_errors(runs[False], case).mean()) < 0.01


@pytest.mark.parametrize("extra, message", [
    (["--root-weight", "-1"], "blend weights must not be negative: the root path has -1"),
    (["--root-weight", "0", "--left-wrist-weight", "0"], "blend weights are all 0"),
    (["--root-weight", "nan"], "the blend weight of the root path must be a finite number"),
    (["--weights", "1", "2", "3"], "--weights: 3 weights for 2 paths (root path, left wrist)"),
    (["--weights", "1", "2", "--root-weight", "1"], "either with --weights or with the --*-weight flags"),
    (["--right-wrist-weight", "2"], "a blend weight for the right wrist without its path"),
    (["--inpaint", "--root-weight", "2"], "blend weights apply to blending"),
    (["--method", "inpainting", "--weights", "1", "1"], "blend weights apply to blending"),
    (["--inpaint", "--method", "blending"], "--inpaint and --method blending disagree"),
])
def test_moattn_control_refuses_bad_weights_in_one_line(tiny_model_dir, tiny_controls, paths, tmp_path, capsys,
                                                       extra, message):
    out = tmp_path / "c.npy"
    assert main(["control", "--prompt", "a person walks", "--root", str(paths / "root.json"), "--left-wrist",
                 str(paths / "left.json"), "--seconds", "3", "--steps", "2", "--model", str(tiny_model_dir),
                 "--controls", str(tiny_controls), "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("moattn control: error: ") and message in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_a_bench_run_becomes_the_record_the_studio_reads(tiny_model_dir, tiny_controls, tmp_path):
    """The control bench (tiny: 2 motions, 2 steps, 1 drawn path per task) -> write_bench_record -> bench_verdict:
    the record holds the drawn root + left wrist row of both methods and speaks for the models benchmarked."""
    import shutil

    from engine.checkpoint import load_model
    from engine.evaluation.bench_control import ControlBenchConfig, bench_control
    from engine.evaluation.evaluator import load_evaluator
    from engine.paths import EVALUATOR_DIR

    result = bench_control(load_model(tiny_model_dir), load_evaluator(EVALUATOR_DIR),
                           ControlBenchConfig(motions=2, steps=2, drawn_paths=1), folder=tiny_controls,
                           log=lambda _: None)
    folder = tmp_path / "control"
    shutil.copytree(tiny_controls, folder)
    record = json.loads(write_bench_record(result, folder=folder).read_text())
    drawn = result["drawn"]["tasks"]["root+left_wrist"]
    for method in ("blending", "inpainting"):
        assert record["figures"][method]["skate"] == drawn[method]["skate"]
        assert record["figures"][method]["action_match"] == drawn[method]["action_match"]
    # the record counts the paths of the task it speaks for: 3 x --drawn (ControlBenchConfig.verdict_factor)
    assert record["run"] == {"drawn_paths": 3, "steps": 2, "motions": 2, "planted_feet": True}
    verdict = bench_verdict(folder)
    assert verdict.figures == record["figures"] and verdict.leader == judge(record["figures"])[0]
    assert "(moattn bench --control, 3 drawn paths, 2 steps, planted feet on)" in verdict.message
