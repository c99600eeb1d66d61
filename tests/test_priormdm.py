"""PriorMDM on a tiny seeded model: DoubleTake hooks, control sampling and blending, path validation, CLI."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from engine.checkpoint import LoadedModel
from tests.conftest import random_corpus_model
from engine.cli import main
from engine.diffusion import StepState
from engine.generate import SampleConfig
from engine.methods.control import (
    Control, DiffusionBlending, KnownFeatures, control_dims, controlled, normalized_weights,
)
from engine.methods.doubletake import (
    DoubleTakeConfig, Handshake, Interval, SecondTake, allowance, check_intervals, compose, offsets,
    second_take, transition_prompts, unfold,
)
from engine.methods.paths import RootPath, WristPath, path_error, root_controls, to_world
from engine.representation import SLICES, features_to_joints
from engine.synth import Corpus


@pytest.fixture(scope="module")
def loaded() -> LoadedModel:
    return random_corpus_model(layers=2)


def _state(x):
    return StepState(step=0, num_steps=1, t=10, t_next=5, x_t=x, x0_hat=x, x_prev=x)


# ----------------------------------------------------------------------------- DoubleTake
def test_handshake_blends_with_a_linear_ramp_and_both_copies_agree():
    x = torch.zeros(2, 10, 1)
    x[0] = 1.0  # interval 0 says 1, interval 1 says 0
    out = Handshake(lengths=[10, 8], h=4)(_state(x)).x_prev
    tau = out[0, 6:10, 0]
    torch.testing.assert_close(tau, torch.tensor([1.0, 0.75, 0.5, 0.25]))
    torch.testing.assert_close(out[1, :4, 0], tau)
    assert (out[0, :6] == 1).all() and (out[1, 4:] == 0).all()


def test_unfold_and_offsets():
    x = torch.arange(3 * 10, dtype=torch.float32).view(3, 10, 1)
    lengths, h = [10, 8, 9], 3
    u = unfold(x, lengths, h)
    assert u.shape[0] == sum(lengths) - 2 * h
    assert offsets(lengths, h) == [0, 7, 12]
    assert u[7, 0] == x[0, 7, 0] and u[10, 0] == x[1, 3, 0]


def test_second_take_mask_is_hard_on_the_handshake_and_soft_far_away():
    take = SecondTake(hard=0.85, soft=0.1, ramp=10)
    m = allowance(60, slice(20, 40), take)
    assert torch.allclose(m[20:40], torch.tensor(0.85)) and torch.allclose(m[:5], torch.tensor(0.1))
    assert (torch.diff(m[9:21]) >= 0).all() and 0.1 < m[15] < 0.85


def test_interval_parsing_and_checks():
    assert Interval.parse("a person walks: 4.5") == Interval("a person walks", 4.5)
    for bad in ("a person walks", ":3", "a person walks:soon"):
        with pytest.raises(ValueError):
            Interval.parse(bad)
    with pytest.raises(ValueError, match="at least"):
        check_intervals([Interval("a", 3), Interval("b", 1.0), Interval("c", 3)], 20)
    with pytest.raises(ValueError, match="length"):
        check_intervals([Interval("a", 12.0)], 20)


def test_compose_makes_one_continuous_long_motion(loaded):
    ivs = [Interval("a person walks forward", 3.0), Interval("a person jumps", 3.0), Interval("a person runs", 3.0)]
    for config in (DoubleTakeConfig(second_take=None), DoubleTakeConfig(second_take=SecondTake(context=10))):
        r = compose(loaded, ivs, config, sample=SampleConfig(steps=4, guidance=2.0))
        assert r.features.shape == (3 * 60 - 2 * 20, 263)
        assert r.transitions == [(40, 60), (80, 100)] and r.starts == [0, 40, 80]
        assert np.isfinite(r.joints).all()
    # the second take only rewrites the handshakes and their ramps
    same = np.abs(r.features - r.first_take).max(axis=1) < 1e-5
    assert same[:25].all() and same[115:].all() and not same[40:60].all()


def test_a_second_take_with_text_denoises_each_sandwich_with_both_prompts(loaded, monkeypatch):
    import engine.methods.doubletake as dt

    ivs = [Interval("a person walks forward.", 3.0), Interval("a person jumps", 3.0), Interval("a person runs", 3.0)]
    assert transition_prompts(ivs) == ["a person walks forward, then a person jumps",
                                       "a person jumps, then a person runs"]
    seen = []
    real = dt.build_condition
    monkeypatch.setattr(dt, "build_condition", lambda ld, request: (seen.append(list(request.prompts)), real(ld, request))[1])
    sample = SampleConfig(steps=4, guidance=2.0)
    plain = compose(loaded, ivs, DoubleTakeConfig(second_take=SecondTake(context=10)), sample=sample)
    texted = compose(loaded, ivs, DoubleTakeConfig(second_take=SecondTake(context=10, text=True)), sample=sample)
    assert seen == [[None, None], transition_prompts(ivs)]  # the sandwiches' prompts (the first take builds its own)
    np.testing.assert_array_equal(plain.first_take, texted.first_take)
    assert not np.allclose(plain.features[40:60], texted.features[40:60])  # the text reaches the handshakes
    first = torch.zeros(140, 263)
    with pytest.raises(ValueError, match="one prompt per transition"):
        second_take(loaded, first, [(40, 60), (80, 100)], SecondTake(text=True), sample=sample, prompts=["a person jumps"])


# ----------------------------------------------------------------------------- control
def test_paths_validate_their_input():
    with pytest.raises(ValueError, match="finite"):
        RootPath(points=((0, 0), (float("nan"), 1))).frames(3)
    with pytest.raises(ValueError, match="at least 2"):
        RootPath(points=((0, 0),)).frames(3)
    with pytest.raises(ValueError, match="faster"):
        RootPath(points=((0, 0), (40, 0))).frames(3)
    with pytest.raises(ValueError, match="increase"):
        RootPath(points=((0, 0), (1, 0), (2, 0)), times=(0, 2, 1)).frames(3)
    with pytest.raises(ValueError, match="within"):
        WristPath(points=((0, 1, 0.3), (3, 1, 0.3))).controls(3)
    with pytest.raises(ValueError, match="too fast"):
        WristPath(points=((0.3, 1, 0.3), (-0.3, 1, 0.3), (0.3, 1, 0.3)), times=(0, 0.05, 0.1)).controls(2)


def test_root_controls_decode_onto_the_path():
    th = np.linspace(0, np.pi, 9)
    pts = np.stack([2 * np.sin(th) + 1, 2 - 2 * np.cos(th)], -1)
    values, frame = root_controls(RootPath(points=tuple(map(tuple, pts))), 5.0)
    assert values.shape == (100, 3)
    f = np.zeros((100, 263))
    f[:, :3] = values
    f[:, 3] = 0.9
    err = path_error(to_world(features_to_joints(f), frame), frame["target"])
    assert err["mean_m"] < 1e-5 and err["off_0_5m"] == 0.0


def test_control_sampling_puts_the_controls_in_the_motion(loaded):
    truth = Corpus(split="test").sample(1).features[:60]
    controls = [Control("root", truth[:, control_dims("root")]), Control("left_wrist", truth[:, control_dims("left_wrist")])]
    sample = SampleConfig(steps=4, guidance=2.0)
    for models in (None, {"root": loaded, "left_wrist": loaded}):
        gen = controlled(loaded, "a person walks", controls, seconds=3.0, models=models, sample=sample)
        f = gen.features[0]
        for c in controls:
            np.testing.assert_allclose(f[:, control_dims(c.name)], c.values, atol=1e-4)
        assert np.abs(f[:, SLICES["rot6d"]]).sum() > 0
    with pytest.raises(FileNotFoundError, match="right_wrist"):
        controlled(loaded, "a person walks", [Control("right_wrist", truth[:, :3])], seconds=3.0, models={}, sample=sample)
    with pytest.raises(ValueError, match="at most once"):
        controlled(loaded, "a person walks", controls + controls[:1], seconds=3.0, sample=sample)


def test_blending_is_a_weighted_sum_with_weights_summing_to_one():
    a = lambda x, t, cond, **kw: torch.ones_like(x)  # noqa: E731
    b = lambda x, t, cond, **kw: 3 * torch.ones_like(x)  # noqa: E731
    out = DiffusionBlending([a, b], [0.25, 0.75])(torch.zeros(1, 2, 3), None, None)
    assert torch.allclose(out, torch.full((1, 2, 3), 2.5))
    with pytest.raises(ValueError, match="sum to 1"):
        DiffusionBlending([a, b], [0.5, 0.6])
    assert normalized_weights(None, 4) == [0.25] * 4
    assert normalized_weights([1, 3], 2) == [0.25, 0.75]
    for bad in ([1], [-1, 2], [0, 0], [float("nan"), 1]):
        with pytest.raises(ValueError):
            normalized_weights(bad, 2)


def test_known_features_cover_only_their_dims(loaded):
    known = KnownFeatures.of([Control("right_wrist", np.ones((5, 3)))], loaded.normalizer, frames=8, dim=263)
    dims = control_dims("right_wrist")
    assert known.mask[:5, dims].all() and not known.mask[5:].any() and known.mask.sum() == 15
    with pytest.raises(ValueError, match="unknown control"):
        control_dims("left_foot")


def test_control_fine_tune_starts_from_the_base_and_zeroes_the_control_noise(tiny_model_dir, tmp_path):
    out = tmp_path / "root"
    code = main(["train", "--control", "root", "--init-from", str(tiny_model_dir), "--out", str(out), "--steps", "3",
                 "--batch-size", "4", "--stats-samples", "20", "--snapshot-every", "0", "--threads", "1",
                 "--no-progress"])
    assert code == 0
    config = json.loads((out / "config.json").read_text())
    assert config["train"]["control"] == "root" and config["step"] == 3
    with pytest.raises(SystemExit) as refused:  # `train control` takes only the three control names
        main(["train", "--control", "wrist", "--init-from", str(tiny_model_dir), "--out", str(tmp_path / "x"),
              "--steps", "1", "--threads", "1", "--no-progress"])
    assert refused.value.code == 2 and not (tmp_path / "x").exists()


def test_cli_compose_and_control(tiny_model_dir, tmp_path, capsys):
    out = tmp_path / "long.npy"
    assert main(["compose", "a person walks forward:3", "a person jumps:2", "--steps", "3", "--model",
                 str(tiny_model_dir), "--out", str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert np.load(out).shape[0] == report["frames"] == 80 and report["transitions"] == [[40, 60]]
    plain = np.load(out)
    assert main(["compose", "a person walks forward:3", "a person jumps:2", "--steps", "3", "--model",
                 str(tiny_model_dir), "--out", str(out), "--second-take-text"]) == 0
    capsys.readouterr()
    texted = np.load(out)
    # the text reaches the handshake; the interval's own frames are in the sandwich too (M_soft), changed far less
    assert not np.allclose(texted[40:60], plain[40:60])
    assert np.abs(texted[:20] - plain[:20]).max() < np.abs(texted[40:60] - plain[40:60]).max()
    assert report["planted_feet"] is True  # the default; off: the paper's second take
    assert main(["compose", "a person walks forward:3", "a person jumps:2", "--steps", "3", "--model",
                 str(tiny_model_dir), "--out", str(out), "--no-second-take-planted-feet"]) == 0
    assert json.loads(capsys.readouterr().out)["planted_feet"] is False
    assert not np.allclose(np.load(out), plain)
    assert main(["compose", "a person walks forward:3", "a person jumps:2", "--model", str(tiny_model_dir), "--out",
                 str(out), "--first-take-only", "--no-second-take-planted-feet"]) == 2
    assert "--no-second-take-planted-feet set the second take" in capsys.readouterr().err
    path = tmp_path / "root.json"
    path.write_text(json.dumps({"points": [[0, 0], [0, 2], [1, 3]]}))
    assert main(["control", "--prompt", "a person walks", "--root", str(path), "--inpaint", "--seconds", "4",
                 "--steps", "3", "--model", str(tiny_model_dir), "--out", str(tmp_path / "c.npy")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["root_error"]["mean_m"] < 0.05
    assert np.load(tmp_path / "c.npy")[-1, 0, 2] > 2.0  # it went up the path
    assert main(["control", "--prompt", "a person walks", "--root", str(path), "--controls", str(tmp_path),
                 "--model", str(tiny_model_dir), "--out", str(tmp_path / "c.npy")]) == 2
    assert "no fine-tuned control model" in capsys.readouterr().err
    path.write_text("[[0, 0], [NaN, 1]]")
    assert main(["control", "--prompt", "a person walks", "--root", str(path), "--inpaint", "--model",
                 str(tiny_model_dir), "--out", str(tmp_path / "c.npy")]) == 2


# ----------------------------------------------------------------------------- control on its own prior (issue #32)
def grown_base(src: Path, dst: Path, words=("zorbs", "quintles", "flarp")) -> Path:
    """A copy of the model folder ``src`` whose vocabulary has ``words`` appended (the embedding grown to fit): a
    'new base' with the old words' ids kept, which control models fine-tuned on ``src`` cannot blend with."""
    import shutil

    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("train_state.pt", "log.jsonl"))
    config = json.loads((dst / "config.json").read_text())
    config["vocabulary"] = [*config["vocabulary"], *words]
    need = len(config["vocabulary"]) + 1  # the padding id first
    if need > config["model"]["vocab_size"]:
        state = torch.load(dst / "weights.pt", weights_only=True)
        for k, v in state.items():
            if k.endswith("embed.weight") and v.shape[0] == config["model"]["vocab_size"]:
                state[k] = torch.cat([v, torch.zeros(need - v.shape[0], *v.shape[1:], dtype=v.dtype)])
        torch.save(state, dst / "weights.pt")
        config["model"]["vocab_size"] = need
    (dst / "config.json").write_text(json.dumps(config))
    (dst / "vocabulary.txt").write_text("\n".join(config["vocabulary"]) + "\n")
    return dst


def controls_with_prior(base: Path, folder: Path, names=("root",), *, prior: bool = True) -> Path:
    """A controls folder: a 'control model' per name (a copy of ``base`` marked fine-tuned for it) and, when
    ``prior``, the base they came from in ``folder/prior``."""
    import shutil

    from engine.methods.control import prior_folder

    for name in names:
        shutil.copytree(base, folder / name, ignore=shutil.ignore_patterns("train_state.pt", "log.jsonl"))
        config = json.loads((folder / name / "config.json").read_text())
        config.setdefault("train", {})["control"] = name
        (folder / name / "config.json").write_text(json.dumps(config))
    if prior:
        shutil.copytree(base, prior_folder(folder), ignore=shutil.ignore_patterns("train_state.pt", "log.jsonl"))
    return folder


def test_control_runs_on_the_control_models_own_base_when_the_loaded_one_moved_on(tiny_model_dir, tmp_path):
    from engine.checkpoint import load_model
    from engine.methods.control import control_base, load_controls, prior_folder
    from engine.paths import CONTROL_DIR, CONTROL_PRIOR_DIR

    assert CONTROL_PRIOR_DIR == prior_folder(CONTROL_DIR) and CONTROL_PRIOR_DIR.parent == CONTROL_DIR
    old = load_model(tiny_model_dir)
    new = load_model(grown_base(tiny_model_dir, tmp_path / "new"))
    assert new.tokenizer.words[: len(old.tokenizer.words)] == old.tokenizer.words
    folder = controls_with_prior(tiny_model_dir, tmp_path / "control", ("root", "left_wrist"))
    models = load_controls(folder)
    # a compatible base: nothing changes (and the prior is not even read)
    same = control_base(old, models, folder=folder, prior=lambda: pytest.fail("the prior was loaded"))
    assert same.loaded is old and set(same.models) == {"root", "left_wrist"} and same.note == "" and not same.on_prior
    # a base with another vocabulary: the prior shipped beside the control models, said in one line
    run = control_base(new, models, folder=folder)
    assert run.on_prior and run.loaded.folder == prior_folder(folder) and set(run.models) == {"root", "left_wrist"}
    assert run.loaded.tokenizer.words == old.tokenizer.words and run.odd == ()
    assert "\n" not in run.note and f"step-{old.config['step']} base" in run.note and "re-fine-tune" in run.note
    assert "moattn train control --control" in run.note
    # no prior shipped: the loaded base, with the control models that cannot blend with it named
    bare = controls_with_prior(tiny_model_dir, tmp_path / "bare", ("root",), prior=False)
    none = control_base(new, load_controls(bare), folder=bare)
    assert none.loaded is new and none.models == {} and none.odd == ("root",) and none.note == ""


def test_cli_control_on_the_control_models_own_base(tiny_model_dir, tmp_path, capsys):
    from engine.methods.control import prior_folder

    new = grown_base(tiny_model_dir, tmp_path / "new")
    folder = controls_with_prior(tiny_model_dir, tmp_path / "control", ("root",))
    path = tmp_path / "root.json"
    path.write_text(json.dumps({"points": [[0, 0], [0, 2], [1, 3]]}))
    common = ["control", "--root", str(path), "--seconds", "3", "--steps", "2", "--controls", str(folder),
              "--out", str(tmp_path / "c.npy")]
    for extra in ([], ["--inpaint"]):  # blending and inpainting alike run on the prior
        assert main([*common, "--prompt", "a person zorbs and walks", "--model", str(new), *extra]) == 0
        captured = capsys.readouterr()
        report = json.loads(captured.out)
        assert report["base"] == str(prior_folder(folder)) and "re-fine-tune" in report["base_note"]
        assert report["method"] == ("inpainting" if extra else "blending")
        note = [line for line in captured.err.splitlines() if line.startswith("note: control runs on the step-")]
        assert len(note) == 1 and "moattn train control --control" in note[0]
        assert any("zorbs" in n for n in report.get("notes", [])), report  # the prior's words: 'zorbs' left out
        assert report["root_error"]["mean_m"] < 0.05
    # the compatible base: as before, no note
    assert main([*common, "--prompt", "a person walks", "--model", str(tiny_model_dir)]) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert report["base"] == str(tiny_model_dir) and "base_note" not in report and "note:" not in captured.err
    # no prior beside the control models: refused with the reason
    bare = controls_with_prior(tiny_model_dir, tmp_path / "bare", ("root",), prior=False)
    assert main([*common[:-4], "--controls", str(bare), "--out", str(tmp_path / "c.npy"), "--prompt",
                 "a person walks", "--model", str(new)]) == 2
    assert "fine-tuned from another base model" in capsys.readouterr().err


def test_the_shipped_control_models_blend_with_the_shipped_base():
    """Each shipped control model was fine-tuned from the shipped base (same vocabulary and feature statistics), so
    control runs on the studio's own base and no older prior ships beside them (issue #33)."""
    from engine.checkpoint import load_model
    from engine.methods.control import control_base, control_name, load_controls, same_base
    from engine.paths import CONTROL_DIR, CONTROL_PRIOR_DIR, MODEL_DIR

    base = load_model(MODEL_DIR)
    models = load_controls(CONTROL_DIR)
    assert sorted(models) == ["left_wrist", "right_wrist", "root"]
    for name, model in models.items():
        assert control_name(model) == name and same_base(base, model), name
    run = control_base(base, models, folder=CONTROL_DIR)
    assert run.loaded is base and not run.on_prior and not run.odd
    assert not CONTROL_PRIOR_DIR.exists()
