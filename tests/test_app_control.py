"""The Control tab without a server, on the tiny model: paths set programmatically and as canvas strokes,
inpainting when no control model exists (and why), the generated root following the drawn path (path_error),
a wrist path, bad paths with clear messages, blend weights, and blending with a tiny fine-tuned root model."""
from __future__ import annotations

import numpy as np
import pytest

from app.tabs.control.paths import DEFAULT_ROOT, thin
from app.tabs.control.settings import ControlSettings
from app.main import Studio
from engine.methods.paths import RootPath

pytestmark = pytest.mark.timeout(600)


def _studio(tiny_model_dir, **folders) -> Studio:
    st = Studio(model_dir=tiny_model_dir, initial=None, **folders)
    st.state.param.update(steps=6, seed=1)
    return st


@pytest.fixture()
def studio(tiny_model_dir):
    st = _studio(tiny_model_dir)
    yield st
    st.close()


@pytest.fixture()
def studio_without_controls(tiny_model_dir, tmp_path):
    st = _studio(tiny_model_dir, controls_dir=tmp_path / "none")
    yield st
    st.close()


def test_inpainting_only_without_control_models(studio_without_controls):
    studio = studio_without_controls
    tab = studio.control
    k = tab.settings
    assert k.available == [] and k.method == "inpainting"
    assert list(tab.method.options.values()) == ["inpainting"]
    assert "Only inpainting is offered" in tab.method_note.object and "no fine-tuned control models" in k.problem
    k.method = "blending"  # forced (e.g. a stale page): refused with the reason, nothing runs
    assert not tab.generate()
    assert "no fine-tuned model for the root path" in studio.state.notices[-1][1]


def test_root_path_is_followed(studio):
    s, tab = studio.state, studio.control
    k = tab.settings
    k.seconds = 5.0
    k.root_points = [(0.0, 0.0), (0.5, 1.0), (1.5, 2.0), (2.5, 2.5)]
    assert "4 points" in tab.root_info.object and "m/s" in tab.root_info.object
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert not [n for n in s.notices if n[0] == "error"], s.notices
    r = k.result
    assert r.method == "inpainting" and r.controls == ["root"] and s.current == r.name
    # the generated root follows the drawn path (world frame: starts at its first point)
    root = s.item.joints[:, 0, [0, 2]]
    target = RootPath(points=tuple(k.root_points)).frames(5.0)
    assert r.root_error["mean_m"] < 0.05 and r.root_error["off_0_5m"] == 0.0
    assert np.linalg.norm(root[0] - [0.0, 0.0]) < 0.05 and np.linalg.norm(root[-1] - target[len(root) - 1]) < 0.1
    assert "root error, mean" in tab.readout.object and f"{r.root_error['mean_m']:.3f} m" in tab.readout.object
    # the target path is shown in 3-D beside the motion (a guide of the viewer's scene)
    spec = studio.viewer.spec()
    assert len(spec.guides) == 1 and spec.guides[0][2].shape[1] == 3
    guide = studio.viewer.player.scene["guides"]  # what the browser draws, shifted like its role
    assert len(guide) == 1 and guide[0]["n"] == len(spec.guides[0][2])


def test_strokes_become_paths(studio):
    tab = studio.control
    k = tab.settings
    xs = np.linspace(0, 2, 200)
    tab.top.stroke_src.data = dict(xs=[xs.tolist()], ys=[(xs ** 2).tolist()])  # what the freehand tool sends
    assert 5 < len(k.root_points) <= 80 and k.root_points[0] == (0.0, 0.0) and k.root_points[-1] == (2.0, 4.0)
    assert tab.top.stroke_src.data["xs"] == [] and len(tab.top.points_src.data["x"]) == len(k.root_points)
    assert tab.top.start_src.data["x"] == [0.0]
    tab.top.points_src.data = dict(x=[0.0, 1.0, 1.0], y=[0.0, 0.0, 1.0])  # the point tool: add / drag
    assert k.root_points == [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
    tab.example_root.clicks += 1
    assert k.root_points == list(DEFAULT_ROOT)
    tab.clear_root.clicks += 1
    assert k.root_points == [] and tab.top.points_src.data["x"] == [] and "no root path" in tab.root_info.object
    assert thin([(0, 0), (0.01, 0), (0.02, 0), (1, 1)]) == [(0.0, 0.0), (1.0, 1.0)]


@pytest.mark.parametrize("points, message", [
    ([(0.0, 0.0), (float("nan"), 1.0), (1.0, 2.0)], "point 1 is not a finite number"),
    ([(0.0, 0.0)], "at least 2 points"),
    ([(0.0, 0.0), (0.0, 40.0)], "faster than a person runs"),
    ([(1.0, 1.0), (1.0, 1.0)], "do not move"),
])
def test_bad_root_paths(studio, points, message):
    s, tab = studio.state, studio.control
    tab.settings.root_points = points
    assert not tab.generate()
    level, text = s.notices[-1]
    assert level == "error" and text.startswith("cannot generate with control:") and message in text, text
    assert not s.running


def test_bad_inputs(studio):
    s, tab = studio.state, studio.control
    k = tab.settings
    # a word the model does not know never blocks (issue #32 item 5): the engine's note, Run stays enabled
    tab.prompt.value_input = "a person walks flibbers"
    assert "left out: flibbers" in tab.flag.object and tab.flag.visible and not tab.bar.run.disabled
    # only a prompt the engine refuses (nothing says a motion) disables Run, with the engine's one-line message
    tab.prompt.value_input = "a person zorbs"
    assert "zorbs" in tab.flag.object and "prompt-refused" in tab.flag.object and tab.flag.visible
    assert tab.bar.run.disabled
    assert not tab.generate() and "zorbs" in s.notices[-1][1]
    tab.prompt.value_input = "a person walks"
    assert not tab.flag.visible and not tab.bar.run.disabled
    tab.use_root.value = False
    assert "no control is on" in tab.shares.object
    assert not tab.generate() and "turn on at least one control" in s.notices[-1][1]
    tab.wrist.value = "right_wrist"
    k.wrist_points = [(-0.3, 1.0), (-2.5, 1.0)]
    assert not tab.generate() and "right wrist: wrist path: points must stay within" in s.notices[-1][1]
    k.seconds = 12.0
    assert not tab.generate() and "between 1.0 and 9.8" in s.notices[-1][1]


def test_wrist_and_root_together(studio):
    s, tab = studio.state, studio.control
    k = tab.settings
    tab.wrist.value = "left_wrist"
    assert tab.wrist_box.visible
    tab.front.stroke_src.data = dict(xs=[[0.2, 0.4, 0.5, 0.3]], ys=[[1.0, 1.3, 1.6, 1.7]])
    assert len(k.wrist_points) == 4
    k.seconds = 4.0
    assert tab.generate() and s.wait(300), s.notices[-1:]
    r = k.result
    assert r.controls == ["root", "left_wrist"] and r.wrist_error is not None and r.root_error["mean_m"] < 0.05
    assert len(r.guides) == 2 and "wrist error, mean" in tab.readout.object
    assert np.isfinite(s.item.joints).all()


def test_weights_are_normalised(tiny_model_dir, tmp_path):
    k = ControlSettings(controls_dir=tmp_path)
    k.wrist = "right_wrist"
    k.weights = {"root": 3.0, "right_wrist": 1.0, "left_wrist": 5.0}
    assert k.normalized_weights() == {"root": 0.75, "right_wrist": 0.25}
    k.weights = {"root": 0.0, "right_wrist": 0.0}
    assert k.normalized_weights() == {"root": 0.5, "right_wrist": 0.5}


def test_blending_with_a_fine_tuned_root_model(tiny_model_dir, tmp_path):
    from engine.cli import main

    folder = tmp_path / "control"
    assert main(["train", "--control", "root", "--init-from", str(tiny_model_dir), "--out", str(folder / "root"),
                 "--steps", "2", "--batch-size", "4", "--stats-samples", "20", "--snapshot-every", "0",
                 "--threads", "1", "--no-progress"]) == 0
    studio = _studio(tiny_model_dir, controls_dir=folder)
    s, tab = studio.state, studio.control
    k = tab.settings
    assert k.available == ["root"] and set(tab.method.options.values()) == {"blending", "inpainting"}
    tab.method.value = "blending"
    assert tab.weights["root"].visible and not tab.weights["left_wrist"].visible
    assert "1.00 × root path" in tab.shares.object
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert k.result.method == "blending" and k.result.root_error["mean_m"] < 0.05
    tab.wrist.value = "left_wrist"  # no fine-tuned wrist model: refused with a clear message
    k.wrist_points = [(0.2, 1.0), (0.4, 1.4)]
    assert not tab.generate() and "no fine-tuned model for the left wrist" in s.notices[-1][1]
    studio.close()


def test_control_runs_on_the_control_models_own_base(tiny_model_dir, tmp_path):
    """The studio's base has another vocabulary (a newer base): the tab runs control, blending and inpainting alike,
    on the base shipped beside the control models (``prior/``), says so in one visible line, and reads the prompt
    with that base's words; with a compatible base nothing changes."""
    from engine.methods.control import prior_folder
    from tests.test_priormdm import controls_with_prior, grown_base

    new = grown_base(tiny_model_dir, tmp_path / "new")
    folder = controls_with_prior(tiny_model_dir, tmp_path / "control", ("root",))
    studio = _studio(new, controls_dir=folder)
    try:
        s, tab = studio.state, studio.control
        k = tab.settings
        assert k.available == ["root"] and k.problem == ""
        assert k.run_base.on_prior and k.run_base.loaded.folder == prior_folder(folder)
        assert tab.base_note.visible and "control runs on the step-" in tab.base_note.object
        assert "re-fine-tune" in k.base_note and "\n" not in k.base_note
        k.prompt = "a person zorbs"  # a word of the studio's base only: unknown to the base control runs on
        assert k.reading.blocked and k.reading.left_out == ("zorbs",)
        k.prompt = "a person walks"
        for method in ("blending", "inpainting"):
            tab.method.value = method
            assert tab.generate() and s.wait(300), s.notices[-1:]
            assert not [n for n in s.notices if n[0] == "error"], s.notices
            assert k.result.method == method and k.result.base_note == k.base_note
            assert "control runs on the step-" in tab.readout.object
    finally:
        studio.close()
    # the compatible base: the studio's own, no note
    studio = _studio(tiny_model_dir, controls_dir=folder)
    try:
        k, tab = studio.control.settings, studio.control
        assert k.available == ["root"] and k.base_note == "" and not tab.base_note.visible
        assert k.run_base.loaded is studio.state.model and not k.run_base.on_prior
        tab.method.value = "blending"
        assert tab.generate() and studio.state.wait(300), studio.state.notices[-1:]
        assert k.result.base_note == "" and "control runs on" not in tab.readout.object
    finally:
        studio.close()
