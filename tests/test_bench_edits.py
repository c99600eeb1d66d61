"""The edits benchmark: its measurements on known joints, and one tiny end-to-end run."""
from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from engine.analysis.action_size import amplitude
from engine.evaluation.bench_edits import (VISIBLE_CHANGE, EditBenchConfig, bench_edits, emphasis_response,
                                           format_table, grounding_spans, iou,
                                           nearer_first, root_speed, spans_hit, walk_threshold, walking_interval)
from engine.generate import SampleConfig
from tests.test_eval_run import tiny_evaluator, tiny_model  # noqa: F401  (fixtures)


def _motion(frames=100, jump=0.0, walk_until=50):
    joints = np.zeros((frames, 22, 3))
    joints[:, :, 1] = 1.0
    joints[:walk_until, 0, 2] = np.arange(walk_until) * 0.06  # 1.2 m/s
    joints[walk_until:, 0, 2] = joints[walk_until - 1, 0, 2]
    joints[70:80, :, 1] += jump * np.sin(np.linspace(0, np.pi, 10))[:, None]  # the whole body leaves the floor
    return joints


def test_measurements():
    assert abs(amplitude(_motion(jump=0.3), "jumps") - 0.3) < 0.02
    assert amplitude(_motion(jump=0.0), "jumps") < 1e-9
    # a high jump spends most of its time in the air: its height is still the feet's peak above the floor (the
    # pelvis's peak above its median, measured before session 41, read it as 0.35 m)
    airborne = np.ones((100, 22, 3))
    flights = np.zeros(100)
    for start in (5, 38, 71):  # three flights of 22 frames: two thirds of the motion in the air
        flights[start:start + 22] = np.sin(np.linspace(0, np.pi, 22))
    airborne[:, :, 1] += 0.5 * flights[:, None]
    assert abs(amplitude(airborne, "jumps") - 0.5) < 0.02
    assert amplitude(airborne, "jumps") > amplitude(_motion(jump=0.3), "jumps")
    walk = walking_interval(_motion(), 0.45)
    assert walk[5:45].all() and not walk[60:].any()
    assert iou(walk, walk) == 1.0 and iou(walk, ~walk) == 0.0
    assert abs(root_speed(_motion())[20] - 1.2) < 0.05
    # the walk is timed against half the reference's own peak speed; a reference that never walks is not timed
    assert abs(walk_threshold(_motion()) - 0.6) < 0.03
    slow = _motion()
    slow[:, 0, 2] *= 0.2  # 0.24 m/s
    assert walk_threshold(slow) is None


def test_grounding_spans_and_their_score():
    spans = grounding_spans(160, (0.125, 0.375, 0.625, 0.875))  # four jumps evenly over 8 s
    assert spans == ((10, 30), (50, 70), (90, 110), (130, 150))
    assert grounding_spans(60, (0.75, 0.25)) == ((5, 25), (35, 55))  # in order
    for bad in ((0.1, 0.2, 0.3, 0.4), (0.05,), (0.99,)):  # overlapping, before the start, past the end
        with pytest.raises(ValueError, match="do not fit"):
            grounding_spans(60, bad)
    from engine.evaluation.bench_edits import EditBenchConfig

    chosen = grounding_spans(160, EditBenchConfig().grounding_centres)
    assert sum(spans_hit([20, 60, 100, 140], chosen)) == 1  # an even spread of four jumps misses the chosen rhythm
    assert spans_hit([12, 29, 70, 95, 155], spans) == [True, False, True, False]  # [start, end): 70 is outside
    assert spans_hit([], spans) == [False] * 4


def test_nearer_first_compares_the_two_captions(tiny_evaluator):  # noqa: F811
    from engine.synth import Corpus

    corpus = Corpus(split="test")
    motions = [corpus.sample(i, with_features=False).joints for i in range(2)]
    a, b = ["a person jumps"] * 2, ["a person walks forward"] * 2
    forward, backward = nearer_first(tiny_evaluator, motions, a, b), nearer_first(tiny_evaluator, motions, b, a)
    assert forward.dtype == bool and forward.shape == (2,)
    assert not (forward & backward).any()  # never nearer both
    assert not nearer_first(tiny_evaluator, motions, a, a).any()  # a caption is not nearer than itself


def test_tiny_end_to_end(tiny_model, tiny_evaluator):  # noqa: F811
    config = EditBenchConfig(counting_samples=2, emphasis_prompts=("a person jumps",), emphasis_points=3,
                             emphasis_seeds=1, pairs=2, replacement_seeds=2, shift_prompts=2, examples=1,
                             outputs_per_example=4, steps=3, seconds=3.0, reference_samples=32,
                             grounding_centres=(0.25, 0.75), grounding_seconds=3.0, grounding_seeds=2)
    result = bench_edits(tiny_model, tiny_evaluator, config, log=lambda line: None)
    assert set(result) >= {"counting", "emphasis_spearman", "replacement_iou", "shift_order_acc", "example_based", "fid"}
    assert result["counting"]["samples"] == 2
    assert 0.0 <= result["counting"]["attention"] <= 1.0 and 0.0 <= result["counting"]["baseline"] <= 1.0
    assert -1.0 <= result["emphasis_spearman"] <= 1.0
    e = result["emphasis"]
    assert e["mode"] == "add" and set(e["other_modes"]) == {"mul", "guide", "intensity"}  # the tiny model is not calibrated
    assert e["other_modes"]["guide"]["every_layer"] and e["other_modes"]["guide"]["weights"] == [-0.5, 0.0, 1.0]
    assert all(-1.0 <= o["spearman"] <= 1.0 for o in e["other_modes"].values())
    r = result["replacement"]
    assert r["pairs"] + r["pairs_without_walk"] == 4  # 2 prompt pairs x 2 seeds
    assert sum(len(v) for v in r["per_pair"].values()) == r["pairs"]
    assert 0.0 <= result["replacement_iou"] <= 1.0 if r["pairs"] else np.isnan(result["replacement_iou"])
    assert 0.0 <= r["edit_recognized"] <= 1.0 and 0.0 <= r["edit_recognized_without_replacement"] <= 1.0
    assert result["example_based"]["samples"] == 4
    assert set(result["counting"]["by_method"]) == {"lag", "published", "rows"}
    assert result["counting"]["by_method"]["lag"] == result["counting"]["attention"]  # the same maps, the default
    g = result["grounding"]
    assert g["spans"] == [[5, 25], [35, 55]] and len(g["draws"]) == 2 and g["frames"] == 60
    for d in g["draws"]:
        for role in ("grounded", "without"):
            row = d[role]
            assert row["spans_hit"] == np.mean(row["hits"]) and len(row["hits"]) == 2
            assert row["jumps_outside"] <= row["jumps_detected"] == len(row["jump_apexes"])
    assert g["spans_hit"] == np.mean([d["grounded"]["spans_hit"] for d in g["draws"]])
    assert 0.0 <= g["spans_hit_without"] <= 1.0
    shares = [(d["grounded"]["jumps_detected"] - d["grounded"]["jumps_outside"]) / d["grounded"]["jumps_detected"]
              if d["grounded"]["jumps_detected"] else 0.0 for d in g["draws"]]
    assert g["placed"] == pytest.approx(np.mean(shares)) and 0.0 <= g["placed_without"] <= 1.0
    # the report reads the same from the result and from its saved JSON
    table = format_table(json.loads(json.dumps(result, default=float)))
    assert table == format_table(result)
    assert f"({result['counting']['samples']} motions)" in table
    assert "  in guide mode (every layer): Spearman" in table
    assert f"evaluator): {r['edit_recognized']:.2f}" in table
    assert sum(line.startswith("  a person walks forward then") for line in table.splitlines()) == len(r["per_pair"])
    assert table.splitlines()[-1].startswith("3 sampling steps, guidance 2.5, eta 1, 3.0-s motions")
    assert f"grounding to 2 spans ('a person jumps four times', 'jumps' -> 5:25,35:55 of 60 frames, weight 0.3, every " \
        f"layer): jumps land in {g['spans_hit']:.2f} of the spans" in table
    assert "same maps, by counting method: lag " in table


def test_bench_presets_take_the_steps_flag():
    from engine.cli.bench import preset
    from engine.evaluation.bench_transfer import TransferBenchConfig

    def args(**kw):
        return argparse.Namespace(**{"quick": False, "steps": None, **kw})

    assert preset(EditBenchConfig, args()) == EditBenchConfig()
    assert preset(EditBenchConfig, args(quick=True)) == EditBenchConfig.quick()
    assert preset(EditBenchConfig, args(steps=10)).steps == 10
    assert preset(EditBenchConfig, args(quick=True, steps=50)).steps == 50  # given, it wins over the quick preset
    assert preset(EditBenchConfig, args(), eta=0.0).sample(3) == SampleConfig(eta=0.0, seed=3)  # --eta 0: DDIM
    assert preset(EditBenchConfig, args(), eta=None).sample().eta == SampleConfig().eta
    quick = preset(TransferBenchConfig, args(quick=True), pairs=3, ood_pairs=None)
    assert (quick.pairs, quick.ood_pairs, quick.steps) == (3, TransferBenchConfig.quick().ood_pairs,
                                                           TransferBenchConfig.quick().steps)


def test_bench_refuses_bad_steps_before_loading_anything(capsys):
    from engine.cli import main

    assert main(["bench", "--edits", "--steps", "0", "--model", "/nonexistent"]) == 2
    assert "--steps must be between 1 and 1000, got 0" in capsys.readouterr().err


def test_emphasis_response_scores_what_a_person_sees():
    weights = (-0.4, -0.2, 0.0, 0.2, 0.4)
    tiny = emphasis_response(weights, [0.340, 0.341, 0.342, 0.343, 0.344])  # monotone, 1 % bigger: nobody sees it
    assert tiny["spearman"] == pytest.approx(1.0) and abs(tiny["change"] - 0.004 / 0.342) < 1e-9
    assert not tiny["visible"] and tiny["score"] < 0.15
    big = emphasis_response(weights, [0.30, 0.31, 0.33, 0.36, 0.40])  # +30 % of the unedited 0.33 m
    assert big["visible"] and big["score"] == pytest.approx(1.0) and abs(big["change"] - 0.10 / 0.33) < 1e-9
    smaller = emphasis_response(weights, [0.40, 0.36, 0.33, 0.31, 0.30])  # more weight, smaller action
    assert smaller["score"] == pytest.approx(-1.0) and not smaller["visible"] and smaller["change"] < 0
    edge = emphasis_response((-0.4, 0.0, 0.4), [1.0, 1.0 + VISIBLE_CHANGE / 2, 1.0 + VISIBLE_CHANGE * 1.2])  # +11 % of the unedited
    assert edge["visible"] and edge["score"] == pytest.approx(1.0)


def test_action_size_names_what_it_measures_and_skips_words_without_an_action():
    from engine.analysis.action_size import size_change

    low, high = _motion(jump=0.2), _motion(jump=0.3)
    size = size_change("jumps", before=low, after=high)
    assert size.measure == "feet's peak above the floor"
    assert size.before == pytest.approx(amplitude(low, "jumps")) and size.after == pytest.approx(amplitude(high, "jumps"))
    assert size.relative == pytest.approx((size.after - size.before) / size.before)
    assert size.describe().startswith("'jumps' (feet's peak above the floor): 0.2") and "+" in size.describe()
    assert size_change("person", before=low, after=high) is None  # no action to measure
