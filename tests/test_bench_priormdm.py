"""The PriorMDM benchmarks end to end on tiny models, and their measurements on known joints."""
from __future__ import annotations

import json

import numpy as np

from engine.evaluation.bench_compose import (
    ComposeBenchConfig, bench_compose, build_sequences, format_table, interiors, jerk, windows,
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


def test_sequences_have_true_transitions():
    seqs = build_sequences(ComposeBenchConfig(sequences=2))
    for s in seqs:
        assert len(s.boundaries) == len(s.intervals) - 1
        assert len(s.truth) >= sum(round(iv.seconds * 20) for iv in s.intervals)


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
    control = bench_control(tiny_model, tiny_evaluator, ControlBenchConfig(motions=2, steps=2),
                            models={"root": tiny_model, "left_wrist": tiny_model}, log=lambda line: None)
    assert set(control["tasks"]["root+left_wrist"]) == {"inpainting", "blending"}
    assert "fine_tuned" not in control["tasks"]["right_wrist"]
    assert control["tasks"]["root"]["fine_tuned"]["error_m"] < 0.01
    assert control["truth_redraw_fid"] > 0
    json.dumps({"compose": compose, "control": control})
