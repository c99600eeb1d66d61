"""Emphasis layers calibrated per model: measured, stored in config.json, used as the default everywhere."""
from __future__ import annotations

import shutil

import pytest

from engine.checkpoint import load_model
from engine.evaluation.calibrate_edits import CalibrationConfig, calibrate_emphasis, write_calibration
from engine.methods.edit_options import EditOptions, build_config, calibrated_layers, default_window

TINY = CalibrationConfig(prompts=(("a person jumps", "jumps"),), weights=(-0.4, 0.0, 0.4), seeds=1, steps=2,
                         seconds=1.0)


def test_default_window_reads_calibrated_layers():
    config = {"edits": {"emphasize_layers": [1, 4, 5]}}
    assert default_window("emphasize", config).layers == (1, 4, 5)
    assert default_window("ground", config).layers is None  # grounding acts in every layer (bench --edits)
    assert default_window("emphasize", None).layers is None and default_window("emphasize", {}).layers is None
    assert default_window("shift", config).layers is None  # only emphasis-like edits are calibrated
    assert default_window("shift", config).end == 0.4
    assert calibrated_layers({"edits": {"emphasize_layers": None}}) is None
    opts = EditOptions(kind="emphasize", word="jumps")
    assert build_config(opts, frames=40, model_config=config).window.layers == (1, 4, 5)
    # the user's layers win over the calibration
    assert build_config(EditOptions(kind="emphasize", word="jumps", layers=(0,)), frames=40,
                        model_config=config).window.layers == (0,)


def test_calibration_measures_every_layer_and_is_stored(tiny_model_dir, tmp_path):
    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    loaded = load_model(folder)
    lines = []
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": -1.0}), log=lines.append)
    layers = loaded.model.num_layers
    assert sorted(result["per_layer"]) == [str(i) for i in range(layers)]
    assert all(-1.0 <= v <= 1.0 for v in result["per_layer"].values())
    best = max(range(layers), key=lambda i: result["per_layer"][str(i)])
    assert result["history"][0]["layers"] == [best]  # forward selection starts from the best single layer
    assert result["layers"] == result["history"][-1]["layers"] and best in result["layers"]
    assert any("alone" in line for line in lines)
    write_calibration(folder, result)
    reloaded = load_model(folder)
    assert calibrated_layers(reloaded.config) == tuple(result["layers"])
    assert reloaded.config["vocabulary"] == loaded.config["vocabulary"]  # the rest of the config is kept
    # an unreachable threshold keeps no layer: emphasis then acts in every layer
    none = calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": 2.0}), log=lines.append)
    assert none["layers"] == []
    write_calibration(folder, none)
    assert calibrated_layers(load_model(folder).config) is None


def test_layers_too_weak_alone_may_qualify_together(tiny_model_dir, monkeypatch):
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    assert loaded.model.num_layers >= 2
    table = {(0,): 0.2, (1,): 0.1, (0, 1): 0.5}
    monkeypatch.setattr(cal, "response",
                        lambda _loaded, layers, _config: cal.Response(table.get(tuple(layers), -1.0), 0.1))
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": 0.3}), log=lambda _: None)
    assert result["layers"] == [0, 1] and result["response"] == 0.5  # no single layer reaches 0.3, the pair does
    table[(0, 1)] = 0.25
    assert calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": 0.3}),
                              log=lambda _: None)["layers"] == []


def test_calibration_refuses_a_word_the_model_lacks(tiny_model_dir):
    loaded = load_model(tiny_model_dir)
    bad = CalibrationConfig(**{**TINY.__dict__, "prompts": (("a person jumps", "flies"),)})
    with pytest.raises(ValueError):
        calibrate_emphasis(loaded, bad, log=lambda _: None)


def test_bench_flags_calibrate_only_with_edits(capsys):
    from engine.cli import main

    assert main(["bench", "--calibrate"]) == 2
    assert "--calibrate and --write go with --edits" in capsys.readouterr().err
    assert main(["bench", "--edits", "--write"]) == 2
    assert "add --calibrate" in capsys.readouterr().err


def test_quick_calibration_builds_sets_from_the_best_single_layers(tiny_model_dir, monkeypatch):
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    n = loaded.model.num_layers
    assert n >= 2
    seen = []
    single = {(i,): 0.1 * (i + 1) for i in range(n)}  # the last layer is the best alone, then the one before it

    def response(_loaded, layers, _config):
        seen.append(tuple(layers))
        return cal.Response(single.get(tuple(layers), 0.9 if set(layers) == {n - 1, n - 2} else 0.0), 0.1)

    monkeypatch.setattr(cal, "response", response)
    quick = CalibrationConfig.quick()
    assert quick.weights == (-0.4, 0.0, 0.4) and quick.candidates == 3
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "candidates": 2}), log=lambda _: None)
    assert result["layers"] == [n - 2, n - 1] and result["candidates"] == 2
    pairs = [s for s in seen if len(s) == 2]
    assert pairs == [(n - 2, n - 1)]  # only the two best single layers were ever combined


def test_a_tie_in_score_goes_to_the_bigger_change(tiny_model_dir, monkeypatch):
    """With three weights many sets score alike (the visible-size cap); the one that moves the action more wins."""
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    assert loaded.model.num_layers >= 2
    table = {(0,): cal.Response(0.6, 0.11), (1,): cal.Response(0.3, 0.05), (0, 1): cal.Response(0.6, 0.16)}
    monkeypatch.setattr(cal, "response", lambda _loaded, layers, _config: table.get(tuple(layers), cal.Response(-1, 0)))
    config = CalibrationConfig(**{**TINY.__dict__, "threshold": 0.3, "candidates": 2})
    result = calibrate_emphasis(loaded, config, log=lambda _: None)
    assert result["layers"] == [0, 1] and result["change"] == 0.16
    table[(0, 1)] = cal.Response(0.6, 0.12)  # a tie and about the same change: the smaller set stays
    assert calibrate_emphasis(loaded, config, log=lambda _: None)["layers"] == [0]
    table[(0, 1)] = cal.Response(0.5, 0.30)  # a lower score is not bought by a bigger change
    assert calibrate_emphasis(loaded, config, log=lambda _: None)["layers"] == [0]
