"""Emphasis layers calibrated per model: measured, stored in config.json, used as the default everywhere."""
from __future__ import annotations

import shutil

import pytest

from engine.checkpoint import load_model
from engine.evaluation.calibrate_edits import CalibrationConfig, calibrate_emphasis, write_calibration
from engine.methods.edit_options import EditOptions, build_config, calibrated_layers, default_window

TINY = CalibrationConfig(prompts=(("a person jumps", "jumps"),), points=3, seeds=1, steps=2, seconds=1.0,
                         modes=("add", "mul"))  # the modes searched layer by layer
ADD = CalibrationConfig(**{**TINY.__dict__, "modes": ("add",)})  # one mode: the layer selection alone


def test_default_window_reads_calibrated_layers():
    config = {"edits": {"emphasize_layers": [1, 4, 5]}}
    assert default_window("emphasize", config).layers == (1, 4, 5)
    assert default_window("ground", config).layers is None  # grounding acts in every layer (bench --edits)
    assert default_window("emphasize", None).layers is None and default_window("emphasize", {}).layers is None
    assert default_window("shift", config).layers is None  # only emphasis-like edits are calibrated
    assert default_window("shift", config).end == 0.4
    assert calibrated_layers({"edits": {"emphasize_layers": None}}) is None
    # the layers belong to the calibrated mode ("add" where none is named): another mode acts in every layer
    assert default_window("emphasize", config, "add").layers == (1, 4, 5)
    assert default_window("emphasize", config, "guide").layers is None
    assert build_config(EditOptions(kind="emphasize", word="jumps", mode="guide"), frames=40,
                        model_config=config).window.layers is None
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
                        lambda _loaded, layers, _config, mode: cal.Response(table.get(tuple(layers), -1.0), 0.1))
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**ADD.__dict__, "threshold": 0.3}), log=lambda _: None)
    assert result["layers"] == [0, 1] and result["response"] == 0.5  # no single layer reaches 0.3, the pair does
    table[(0, 1)] = 0.25
    assert calibrate_emphasis(loaded, CalibrationConfig(**{**ADD.__dict__, "threshold": 0.3}),
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

    def response(_loaded, layers, _config, mode):
        seen.append(tuple(layers))
        return cal.Response(single.get(tuple(layers), 0.9 if set(layers) == {n - 1, n - 2} else 0.0), 0.1)

    monkeypatch.setattr(cal, "response", response)
    quick = CalibrationConfig.quick()
    assert quick.weights("add") == (-0.4, 0.0, 0.4) and quick.weights("mul") == (0.5, 1.0, 2.0)
    assert quick.candidates == 3
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**ADD.__dict__, "candidates": 2}), log=lambda _: None)
    assert result["layers"] == [n - 2, n - 1] and result["candidates"] == 2
    pairs = [s for s in seen if len(s) == 2]
    assert pairs == [(n - 2, n - 1)]  # only the two best single layers were ever combined


def test_a_tie_in_score_goes_to_the_bigger_change(tiny_model_dir, monkeypatch):
    """With three weights many sets score alike (the visible-size cap); the one that moves the action more wins."""
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    assert loaded.model.num_layers >= 2
    table = {(0,): cal.Response(0.6, 0.11), (1,): cal.Response(0.3, 0.05), (0, 1): cal.Response(0.6, 0.16)}
    monkeypatch.setattr(cal, "response", lambda _loaded, layers, _config, mode: table.get(tuple(layers), cal.Response(-1, 0)))
    config = CalibrationConfig(**{**ADD.__dict__, "threshold": 0.3, "candidates": 2})
    result = calibrate_emphasis(loaded, config, log=lambda _: None)
    assert result["layers"] == [0, 1] and result["change"] == 0.16
    table[(0, 1)] = cal.Response(0.6, 0.12)  # a tie and about the same change: the smaller set stays
    assert calibrate_emphasis(loaded, config, log=lambda _: None)["layers"] == [0]
    table[(0, 1)] = cal.Response(0.5, 0.30)  # a lower score is not bought by a bigger change
    assert calibrate_emphasis(loaded, config, log=lambda _: None)["layers"] == [0]


def test_the_better_mode_is_kept_with_its_own_layers(tiny_model_dir, monkeypatch):
    """Each mode gets its own layer search; the mode whose set responds best is kept (the first listed on a tie)."""
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    assert loaded.model.num_layers >= 2
    tables = {"add": {(0,): cal.Response(0.4, 0.1)}, "mul": {(1,): cal.Response(0.7, 0.12)}}
    seen = []

    def response(_loaded, layers, _config, mode):
        seen.append(mode)
        return tables[mode].get(tuple(layers), cal.Response(-1.0, 0.0))

    monkeypatch.setattr(cal, "response", response)
    result = calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": 0.3}), log=lambda _: None)
    assert set(seen) == {"add", "mul"}
    assert result["mode"] == "mul" and result["layers"] == [1] and result["response"] == 0.7
    assert result["modes"]["add"]["layers"] == [0] and result["modes"]["add"]["response"] == 0.4
    assert result["weights"] == {"add": [-0.4, 0.0, 0.4], "mul": [0.5, 1.0, 2.0]}
    tables["mul"][(1,)] = cal.Response(0.41, 0.1)  # within min_gain of add's, no bigger change: add, listed first
    assert calibrate_emphasis(loaded, CalibrationConfig(**{**TINY.__dict__, "threshold": 0.3}),
                              log=lambda _: None)["mode"] == "add"


def test_the_calibrated_mode_is_the_default_of_emphasis_and_its_weight_follows(tiny_model_dir, tmp_path):
    from engine.methods.edit_options import DEFAULT_WEIGHTS, calibrated_mode, with_defaults

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    write_calibration(folder, {"mode": "mul", "layers": [0], "response": 0.5, "change": 0.1})
    config = load_model(folder).config
    assert calibrated_mode(config) == "mul" and calibrated_layers(config) == (0,)
    assert calibrated_mode(None) == "add" and calibrated_mode({"edits": {"emphasize_layers": [1]}}) == "add"
    chosen = with_defaults(EditOptions(kind="emphasize", word="jumps"), config)
    assert (chosen.mode, chosen.weight) == ("mul", DEFAULT_WEIGHTS["mul"])
    cfg = build_config(EditOptions(kind="emphasize", word="jumps"), frames=40, model_config=config)
    assert (cfg.mode, cfg.weight, cfg.window.layers) == ("mul", 2.0, (0,))
    # what the user gives wins; a weight alone keeps the calibrated mode, a mode alone takes its own default weight
    given = with_defaults(EditOptions(kind="emphasize", word="jumps", mode="add"), config)
    assert (given.mode, given.weight) == ("add", DEFAULT_WEIGHTS["add"])
    assert with_defaults(EditOptions(kind="emphasize", word="jumps", weight=1.5), config).mode == "mul"
    # grounding is not calibrated: it adds, at its own default weight
    ground = with_defaults(EditOptions(kind="ground", word="jumps"), config)
    assert (ground.mode, ground.weight) == ("add", DEFAULT_WEIGHTS["add"])
    with pytest.raises(ValueError, match="unknown emphasis mode"):
        calibrated_mode({"edits": {"emphasize_mode": "pow"}})


def test_a_mode_the_calibration_measured_but_did_not_choose_acts_in_its_own_best_layers():
    edits = {"emphasize_mode": "intensity", "emphasize_layers": [0, 1, 2],
             "emphasize_fallback": {"mode": "mul", "layers": [0, 5]},
             "calibration": {"modes": {"add": {"layers": [3]}, "mul": {"layers": [0, 5]},
                                       "intensity": {"layers": [0, 1, 2]}}}}
    config = {"edits": edits}
    assert calibrated_layers(config, "add") == (3,)  # the user's --mode add: add's own best, not every layer
    assert calibrated_layers(config, "mul") == (0, 5)
    assert calibrated_layers(config, "guide") is None  # not measured: every layer
    assert calibrated_layers(config, word="punches") == (0, 5)  # no intensity word: the fallback's
    assert calibrated_layers(config, word="jumps") == (0, 1, 2)
    assert build_config(EditOptions(kind="emphasize", word="jumps", mode="add"), frames=40,
                        model_config=config).window.layers == (3,)


def test_guide_mode_is_measured_once_over_every_layer_and_kept_when_it_responds_best(tiny_model_dir, monkeypatch):
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    n = loaded.model.num_layers
    assert "guide" in CalibrationConfig().modes  # a full calibration measures it
    seen = []

    def response(_loaded, layers, _config, mode):
        seen.append((mode, tuple(layers)))
        if mode == "guide":
            return cal.Response(0.8, 0.3)
        return cal.Response(0.5 if tuple(layers) == (0,) else -1.0, 0.1)

    monkeypatch.setattr(cal, "response", response)
    config = CalibrationConfig(**{**TINY.__dict__, "modes": ("add", "guide"), "threshold": 0.3})
    result = calibrate_emphasis(loaded, config, log=lambda _: None)
    assert [s for s in seen if s[0] == "guide"] == [("guide", tuple(range(n)))]  # one measurement, every layer
    assert result["mode"] == "guide" and result["layers"] == list(range(n)) and result["response"] == 0.8
    assert result["modes"]["add"]["layers"] == [0] and result["weights"]["guide"] == [-0.5, 0.0, 1.0]


def test_intensity_mode_wins_with_a_fallback_for_words_the_corpus_does_not_scale(tiny_model_dir, tmp_path,
                                                                                  monkeypatch):
    import engine.evaluation.calibrate_edits as cal
    from engine.methods.edit_options import calibrated_mode, with_defaults

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    loaded = load_model(folder)
    n = loaded.model.num_layers
    assert "intensity" in CalibrationConfig().modes  # a full calibration measures it

    def response(_loaded, layers, _config, mode):
        if mode == "intensity":
            return cal.Response(0.9, 0.5)
        return cal.Response(0.6 if tuple(layers) == (1,) else -1.0, 0.2) if mode == "mul" else cal.Response(-1.0, 0.0)

    monkeypatch.setattr(cal, "response", response)
    config = CalibrationConfig(**{**TINY.__dict__, "modes": ("add", "mul", "intensity"), "threshold": 0.3})
    result = calibrate_emphasis(loaded, config, log=lambda _: None)
    assert result["mode"] == "intensity" and result["layers"] == list(range(n))
    assert result["fallback"] == {"mode": "mul", "layers": [1]}  # the best of the others, with its own layers
    write_calibration(folder, result)
    model_config = load_model(folder).config
    assert model_config["edits"]["emphasize_fallback"] == {"mode": "mul", "layers": [1]}
    assert "fallback" not in model_config["edits"]["calibration"]
    # "jumps" has intensity words: intensity; "punches" has none: the fallback, in its calibrated layers
    assert calibrated_mode(model_config, word="jumps") == "intensity"
    assert calibrated_mode(model_config, word="punches") == "mul"
    punch = build_config(EditOptions(kind="emphasize", word="punches"), frames=40, model_config=model_config)
    assert (punch.mode, punch.weight, punch.window.layers) == ("mul", 2.0, (1,))
    jump = with_defaults(EditOptions(kind="emphasize", word="jumps"), model_config)
    assert (jump.mode, jump.weight) == ("intensity", 0.5)
    with pytest.raises(ValueError, match="acts in no layer"):
        build_config(EditOptions(kind="emphasize", word="jumps", layers=(0,)), frames=40, model_config=model_config)
    # calibrating again with another winner drops the old fallback
    write_calibration(folder, {"mode": "mul", "layers": [0], "response": 0.5, "change": 0.1})
    assert "emphasize_fallback" not in load_model(folder).config["edits"]


def test_intensity_calibration_scores_a_word_without_intensity_words_as_no_response(tiny_model_dir, monkeypatch):
    import engine.evaluation.calibrate_edits as cal

    loaded = load_model(tiny_model_dir)
    calls = []
    monkeypatch.setattr(cal.edits, "reweight", lambda *a, **k: calls.append(a) or (_ for _ in ()).throw(AssertionError))
    config = CalibrationConfig(**{**TINY.__dict__, "prompts": (("a person punches", "punches"),), "seeds": 2})
    assert cal.response(loaded, (0,), config, mode="intensity") == cal.Response(0.0, 0.0)
    assert not calls  # nothing was sampled: the mode cannot emphasise a punch
