"""The PriorMDM benchmarks end to end on tiny models, and their measurements on known joints."""
from __future__ import annotations

import json

import numpy as np

from engine.evaluation import metrics
from engine.evaluation.bench_compose import (
    ComposeBenchConfig, adherence_shares, bench_compose, build_sequences, format_table, interiors, interval_adherence,
    interval_crops, jerk, windows,
)
from engine.evaluation.bench_control import ControlBenchConfig, bench_control, control_error
from tests.test_eval_run import tiny_evaluator, tiny_model  # noqa: F401  (fixtures)


def test_jerk_and_windows():
    t = np.arange(41) / 20
    still = np.zeros((41, 22, 3))
    cubic = still.copy()
    cubic[..., 1] = t[:, None] ** 3  # d³/dt³ = 6
    assert jerk(still) == 0.0 and abs(jerk(cubic) - 6.0) < 1e-6
    assert [len(w) for w in windows(np.zeros((100, 22, 3)), [5, 50, 98], 40)] == [41, 41, 41]
    assert interiors([100, 180], 300) == [50, 140, 240]  # the middle of each of the three intervals
    assert jerk is metrics.jerk  # one home for the physical metrics


def test_interval_crops_and_adherence_shares():
    joints = np.arange(300)[:, None, None] * np.ones((1, 22, 3))
    crops = interval_crops(joints, [100, 180])
    assert [len(c) for c in crops] == [100, 80, 120] and crops[1][0, 0, 0] == 100  # cut at the transition centres
    assert sum(len(c) for c in crops) == 300
    verdicts = [{"action": True, "count": False}, {"action": False, "count": None}, {"action": None, "count": None},
                {"action": True, "count": True}, {"action": True, "count": None}]
    shares = adherence_shares(verdicts)
    assert shares["intervals"] == 5 and shares["action_checked"] == 4 and shares["count_checked"] == 2
    assert shares["action"] == 3 / 4 and shares["count"] == 1 / 2
    assert shares["action_and_count"] == 2 / 4  # a failed count spoils a matched action; an unstated one does not
    none = adherence_shares([{"action": None, "count": None}])
    assert none["action"] is None and none["count"] is None and none["action_and_count"] is None


def test_interval_adherence_reads_the_true_sequences():
    seqs = build_sequences(ComposeBenchConfig(sequences=2))
    crops = [c for s in seqs for c in interval_crops(s.truth, s.boundaries)]
    prompts = [iv.prompt for s in seqs for iv in s.intervals]
    own = interval_adherence(crops, prompts)
    assert own["intervals"] == len(crops) == len(prompts) and own["action_checked"] == len(crops)
    assert own["action"] >= 0.75  # the truth's intervals, cut at its boundaries, do what their prompts say
    shifted = interval_adherence(crops, prompts[1:] + prompts[:1])  # each crop read with its neighbour's prompt
    assert shifted["action"] < own["action"]
    frozen = [np.repeat(c[:1], len(c), axis=0) for c in crops]  # a seam that ate every action: nothing moves
    assert interval_adherence(frozen, prompts)["action"] < own["action"]


def test_sequences_have_true_transitions():
    seqs = build_sequences(ComposeBenchConfig(sequences=2))
    for s in seqs:
        assert len(s.boundaries) == len(s.intervals) - 1
        assert len(s.truth) >= sum(round(iv.seconds * 20) for iv in s.intervals)


def test_sequences_keep_only_captions_the_model_reads():
    config = ComposeBenchConfig(sequences=4)
    plain = build_sequences(config)
    refused = {plain[0].intervals[0].prompt}  # a model that refuses one caption of the first sequence
    kept = build_sequences(config, readable=lambda caption: caption not in refused)
    assert len(kept) == 4 and all(iv.prompt not in refused for s in kept for iv in s.intervals)
    assert [s.intervals for s in kept[:1]] != [s.intervals for s in plain[:1]]


def test_control_error_is_zero_on_the_truth():
    from engine.synth import Corpus

    j = Corpus(split="test").sample(1).joints
    for name in ("root", "left_wrist"):
        assert control_error(j, j, name).max() < 1e-6
    moved = j.copy()
    moved[..., 0] += 1.0
    assert abs(control_error(moved, j, "root").mean() - 1.0) < 1e-6


def test_tiny_end_to_end(tiny_model, tiny_evaluator):  # noqa: F811
    compose = bench_compose(tiny_model, tiny_evaluator, ComposeBenchConfig(sequences=2, steps=2, long_intervals=3),
                            log=lambda line: None)
    for m in ("doubletake", "first_take", "naive"):
        assert np.isfinite(compose[m]["transition_fid"]) and compose[m]["jerk"] > 0
        assert np.isfinite(compose[m]["interior_fid"])
    assert compose["seconds_60s"] > 0 and compose["long_motion_seconds"] == 13.0
    # the floor: true transitions of other sequences are not the same windows, so their FID is above 0
    assert compose["truth_redraw"]["transitions"] > 0 and compose["truth_redraw"]["transition_fid"] > 0
    assert compose["truth_redraw"]["interior_fid"] > 0
    assert "the floor" in format_table(compose)
    # restated transition figures: ratios of the reported figures to the truth's same windows
    truth_skate = compose["ground_truth_foot_skate"]
    assert 0.0 <= truth_skate <= 1.0 and compose["ground_truth_jerk"] > 0
    for m in ("doubletake", "first_take", "naive"):
        row = compose[m]
        assert 0.0 <= row["foot_skate"] <= 1.0
        assert row["jerk_vs_truth"] == row["jerk"] / compose["ground_truth_jerk"]
        if truth_skate > 0:
            assert row["foot_skate_vs_truth"] == row["foot_skate"] / truth_skate
        else:
            assert row["foot_skate_vs_truth"] is None
    assert f"{compose['naive']['jerk_vs_truth']:.2f}" in format_table(compose).split("jerk / truth")[1]
    # the same figures inside the intervals (the model's own floor), and DoubleTake over the first take
    for m in ("doubletake", "first_take", "naive"):
        row = compose[m]
        assert row["interior_jerk"] > 0 and 0.0 <= row["interior_foot_skate"] <= 1.0
        assert row["interior_jerk_vs_truth"] == row["interior_jerk"] / compose["ground_truth_interior_jerk"]
    vs = compose["vs_first_take"]
    assert vs["jerk"] == compose["doubletake"]["jerk"] / compose["first_take"]["jerk"]
    assert f"jerk {vs['jerk']:.2f}" in format_table(compose) and "target <= 0.8 on both" in format_table(compose)
    # adherence on each interval: every interval of every sequence checked, for the truth and each method
    intervals = sum(len(s.intervals) for s in build_sequences(ComposeBenchConfig(sequences=2)))
    for a in (compose["ground_truth_adherence"], *(compose[m]["adherence"] for m in ("doubletake", "first_take", "naive"))):
        assert a["intervals"] == intervals and 0 <= a["count_checked"] <= a["intervals"]
        for key in ("action", "count", "action_and_count"):
            assert a[key] is None or 0.0 <= a[key] <= 1.0
        if a["action"] is not None and a["action_and_count"] is not None:
            assert a["action_and_count"] <= a["action"]
    assert "adherence per interval" in format_table(compose)
    control = bench_control(tiny_model, tiny_evaluator, ControlBenchConfig(motions=2, steps=2, drawn_paths=2),
                            models={"root": tiny_model, "left_wrist": tiny_model}, log=lambda line: None)
    assert set(control["tasks"]["root+left_wrist"]) == {"inpainting", "blending"}
    assert "fine_tuned" not in control["tasks"]["right_wrist"]
    assert control["tasks"]["root"]["fine_tuned"]["error_m"] < 0.01
    assert control["truth_redraw_fid"] > 0
    assert control["base"]["control_prior"] is False and control["base"]["note"] == ""  # compatible: as before
    check_drawn(control)
    json.dumps({"compose": compose, "control": control})


def check_drawn(control: dict) -> None:
    """The drawn-path figures beside the true-path ones: same tasks and methods, per path, ratios, table rows."""
    from engine.evaluation.bench_control import TASKS
    from engine.evaluation.bench_control import format_table as control_table

    drawn = control["drawn"]
    assert ControlBenchConfig().drawn_paths > ControlBenchConfig.quick().drawn_paths > 0
    assert set(drawn["tasks"]) == set(TASKS) == set(drawn["paths"])
    for task, rows in drawn["tasks"].items():
        assert set(rows) == set(control["tasks"][task])  # every method of the true paths, on the drawn ones
        # the task the studio's verdict reads draws verdict_factor (3) times as many paths; the other-feet rows don't
        n = 2 * (ControlBenchConfig().verdict_factor if task == "root+left_wrist" else 1)
        assert ControlBenchConfig().verdict_factor == 3
        assert len(drawn["paths"][task]) == n and all(p["seconds"] >= 3.0 for p in drawn["paths"][task])
        assert len(control["drawn_other_feet"]["paths"][task]) == 2
        for method, r in rows.items():
            assert r["paths"] == n and [p["path"] for p in r["per_path"]] == [p["name"] for p in drawn["paths"][task]]
            assert np.isfinite(r["error_m"]) and 0 <= r["off_0_5m"] <= 1 and 0 <= r["skate"] <= 1
            ratio, true_error = control["drawn_vs_true_error"][task][method], control["tasks"][task][method]["error_m"]
            assert ratio == (r["error_m"] / true_error if true_error >= 0.005 else None)
    assert [p["name"] for p in drawn["paths"]["root"]] == ["s_curve_left", "circle_left"]
    assert "left" in drawn["paths"]["root+left_wrist"][0]["name"] and "walks" in drawn["paths"]["root"][0]["prompt"]
    # the root's control features are inpainted on every frame: both methods follow the drawn root path
    for method in ("fine_tuned", "inpainting"):
        assert drawn["tasks"]["root"][method]["error_m"] < 0.02
        assert control["drawn_vs_true_error"]["root"][method] is None  # no ratio of two round-offs
    assert 0 <= control["truth_skate"] <= 1
    # adherence of the prompted action beside every error: true and drawn rows, with the detectors' yardsticks
    from engine.evaluation.adherence import ATTRIBUTES

    assert control["truth_adherence"]["action_n"] == 2
    for task, rows in drawn["tasks"].items():
        assert drawn["prompt_truth_adherence"][task]["action_n"] == len(drawn["paths"][task])
        for method, r in rows.items():
            verdicts = [p["adherence"] for p in r["per_path"]]
            assert all(set(v) == set(ATTRIBUTES) for v in verdicts)
            assert r["action_match"] == np.mean([v["action"] for v in verdicts]) == r["adherence"]["action"]
            true = control["tasks"][task][method]
            assert true["adherence"]["action_n"] == 2 and 0 <= true["action_match"] <= 1
    table = control_table(control)
    assert "share of the motions whose prompted action is detected" in table
    assert f"; root+left_wrist: {len(drawn['paths']['root+left_wrist'])} paths" in table  # not only the root's list
    true_row = next(i for i, line in enumerate(table.splitlines()) if line.startswith("root ") and "true" in line)
    assert "drawn" in table.splitlines()[true_row + 1]  # drawn-path row right under the true-path row
    assert "drawn / true path error" in table


def test_drawn_cases_prompts_and_targets():
    """Drawn-path prompts are in the model's vocabulary and ask for the action the path implies; the
    root target is what the root controls decode to, so perfect controls measure 0 m."""
    from engine.evaluation.bench_control import TASKS, drawn_cases, drawn_errors
    from engine.intent import parse_intent
    from engine.representation import features_to_joints
    from engine.synth import vocabulary
    from engine.text import Tokenizer

    tokenizer = Tokenizer(vocabulary())
    for task in TASKS:
        cases = drawn_cases(task, 4)
        assert len(cases) == 4 and len({c.name for c in cases}) == 4
        for c in cases:
            tokenizer.encode(c.prompt)  # raises on a word the model does not know
            intent = parse_intent(c.prompt)
            actions = {intent.segments[0].action}
            if intent.segments[0].overlay is not None:
                actions.add(intent.segments[0].overlay.action)
            assert [x.name for x in c.controls] == list(TASKS[task])
            assert {"root": {"walk"}, "root+left_wrist": {"walk", "wave"}}.get(task, actions) == actions
            assert actions <= {"walk", "wave", "stand"} and c.seconds >= 3.0
            waving = intent.segments[0].overlay if task == "root+left_wrist" else intent.segments[0]
            if waving.action == "wave":  # with the hand that draws
                assert waving.side == ("right" if task == "right_wrist" else "left")
    case = drawn_cases("root", 2)[1]  # a full circle
    feats = np.zeros((len(case.controls[0].values), 263))
    feats[:, :3], feats[:, 3] = case.controls[0].values, 0.9
    joints = features_to_joints(feats)
    assert drawn_errors(joints, case).max() < 1e-4
    shifted = joints.copy()
    shifted[..., 2] += 0.3
    assert abs(drawn_errors(shifted, case).mean() - 0.3) < 1e-4


def test_control_bench_runs_on_the_control_models_own_base(tiny_model, tiny_evaluator, monkeypatch):  # noqa: F811
    """A loaded base with another vocabulary: the bench runs both methods on the prior the control models belong
    to (``folder/prior``), and says so."""
    from dataclasses import replace

    from engine.evaluation.bench_control import format_table as control_table
    from engine.methods import control
    from engine.text import Tokenizer

    new = replace(tiny_model, tokenizer=Tokenizer([*tiny_model.tokenizer.words[1:], "zorbs"]))
    asked = []
    monkeypatch.setattr(control, "load_prior", lambda folder, **k: asked.append(folder) or tiny_model)
    used = []
    real = control.controlled
    monkeypatch.setattr("engine.evaluation.bench_control.controlled",
                        lambda loaded, *a, **k: used.append(loaded) or real(loaded, *a, **k))
    result = bench_control(new, tiny_evaluator, ControlBenchConfig(motions=2, steps=1, drawn_paths=0),
                           models={"root": tiny_model}, folder="somewhere", log=lambda line: None)
    assert asked == ["somewhere"] and used and all(m is tiny_model for m in used)
    assert result["base"]["control_prior"] and "re-fine-tune" in result["base"]["note"]
    assert set(result["tasks"]["root"]) == {"inpainting", "fine_tuned"} and result["models"] == ["root"]
    table = control_table(result)
    assert "the control models' own base, not the loaded one" in table and "note: control runs on the" in table
