"""The Control tab without a server, on the tiny model: paths set programmatically and as canvas strokes,
inpainting when no control model exists (and why), the generated root following the drawn path (path_error),
the root and both wrists at once (blended with the shipped control models on the shipped base), bad paths with clear messages, blend
weights judged by the engine's one rule (its message shown, nothing clamped), the method the tab opens on chosen by
the control bench's record, and blending with a tiny fine-tuned root model."""
from __future__ import annotations

import numpy as np
import pytest

from app.tabs.control.paths import DEFAULT_ROOT, thin
from app.tabs.control.settings import ControlSettings
from app.main import Studio
from engine.methods.paths import RootPath
from tests.test_control_options import tiny_controls  # noqa: F401  (fixture: blendable tiny control models)

pytestmark = pytest.mark.timeout(600)


def _studio(tiny_model_dir, **folders) -> Studio:
    st = Studio(model_dir=tiny_model_dir, initial=None, **folders)
    st.state.param.update(steps=6, seed=1)
    return st


@pytest.fixture()
def studio(tiny_model_dir, tiny_controls):
    st = _studio(tiny_model_dir, controls_dir=tiny_controls)
    yield st
    st.close()


@pytest.fixture()
def shipped_studio():
    """The studio as `make run` opens it: the shipped base model and the shipped control models beside it."""
    st = Studio(initial=None)
    st.state.param.update(steps=6, seed=1)
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
    assert "No control bench is recorded" in tab.bench_note.object and "opens on inpainting" in tab.bench_note.object
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
    tab.use_wrists["right_wrist"].value = True
    assert not tab.generate() and "right wrist path: draw it on the front-view canvas" in s.notices[-1][1]
    k.right_wrist_points = [(-0.3, 1.0), (-2.5, 1.0)]
    assert not tab.generate() and "right wrist: wrist path: points must stay within" in s.notices[-1][1]
    k.seconds = 12.0
    assert not tab.generate() and "between 1.0 and 9.8" in s.notices[-1][1]


def test_front_view_draws_either_wrist(studio):
    tab = studio.control
    k = tab.settings
    left, right = tab.front.layers["left_wrist"], tab.front.layers["right_wrist"]
    assert k.drawing == "left_wrist" and tab.front.fig.toolbar.active_drag is left.freehand
    left.stroke_src.data = dict(xs=[[0.2, 0.4, 0.5, 0.3]], ys=[[1.0, 1.3, 1.6, 1.7]])  # what the freehand tool sends
    assert len(k.left_wrist_points) == 4 and k.right_wrist_points == []
    tab.drawing.value = "right_wrist"  # the drags now draw the right wrist
    assert tab.front.fig.toolbar.active_drag is right.freehand
    right.points_src.data = dict(x=[-0.2, -0.4], y=[1.0, 1.4])  # the point tool
    assert k.right_wrist_points == [(-0.2, 1.0), (-0.4, 1.4)] and len(k.left_wrist_points) == 4
    assert "right wrist (pink) (drawing): 2 points" in tab.wrist_info.object
    tab.clear_wrist.clicks += 1  # clears the wrist being drawn only
    assert k.right_wrist_points == [] and len(k.left_wrist_points) == 4
    tab.example_wrists.clicks += 1  # a letter per hand, from engine.methods.drawn_paths; both turned on
    assert k.use_left_wrist and k.use_right_wrist and len(k.left_wrist_points) == 3  # "L"
    assert len(right.points_src.data["x"]) == len(k.right_wrist_points) > 10  # "O"
    assert k.active == ["root", "left_wrist", "right_wrist"]


def test_root_and_both_wrists_together_blended(shipped_studio):
    """The root path and both wrists at once, blended with the shipped control models on the shipped base (one per
    control, each with its weight): the motion follows all three and the readout shows each error and the blend."""
    studio = shipped_studio
    s, tab = studio.state, studio.control
    k = tab.settings
    assert k.available == ["left_wrist", "right_wrist", "root"]
    tab.example_wrists.clicks += 1
    k.seconds = 4.0
    tab.method.value = "blending"
    assert all(tab.weights[n].visible for n in ("root", "left_wrist", "right_wrist"))
    k.weights = {"root": 2.0, "left_wrist": 1.0, "right_wrist": 1.0}
    assert "0.50 × root path + 0.25 × left wrist + 0.25 × right wrist" in tab.shares.object
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert not [n for n in s.notices if n[0] == "error"], s.notices
    r = k.result
    assert r.method == "blending" and r.controls == ["root", "left_wrist", "right_wrist"]
    assert r.weights == {"root": 0.5, "left_wrist": 0.25, "right_wrist": 0.25}
    assert set(r.wrist_errors) == {"left_wrist", "right_wrist"} and r.root_error["mean_m"] < 0.05
    for e in r.wrist_errors.values():  # inpainted wrist dims: each wrist within 10 cm of its own path (swapped
        assert e["mean_m"] < 0.10, r.wrist_errors  # paths would be 0.3 m off: the letters are 0.3 m apart)
    assert len(r.guides) == 3 and len({c for c, _ in r.guides}) == 3
    for label in ("left wrist error, mean", "right wrist error, mean", "0.50 × root path"):
        assert label in tab.readout.object
    assert "pink tube: the right wrist target" in tab.readout.object
    assert np.isfinite(s.item.joints).all()


def test_blend_weights_follow_the_engines_rule(studio):
    """The tab neither clamps nor re-normalises: the engine's blend_shares decides, and its one-line message is what
    the tab shows and what Generate refuses with."""
    import re
    import threading
    from dataclasses import replace

    from app.tabs.control.job import prepare, run_job
    from engine.methods.control_options import blend_shares

    s, tab = studio.state, studio.control
    k = tab.settings
    k.use_right_wrist = True
    k.right_wrist_points = [(-0.2, 1.0), (-0.4, 1.4)]
    tab.method.value = "blending"
    k.weights = {"root": 3.0, "right_wrist": 1.0, "left_wrist": 5.0}  # the left wrist is off: not in the blend
    assert k.shares() == {"root": 0.75, "right_wrist": 0.25}
    assert "0.75 × root path + 0.25 × right wrist" in tab.shares.object
    # the job hands the engine the weights as typed (the engine scales them); its shares are for the readout
    plan = prepare(s, k)
    assert plan.weights == {"root": 3.0, "right_wrist": 1.0} and plan.shares == {"root": 0.75, "right_wrist": 0.25}
    # so the engine's own check fires from the studio: typed weights it refuses fail with its one-line message
    for typed in ({"root": -1.0, "right_wrist": 1.0}, {"root": 0.0, "right_wrist": 0.0}):
        with pytest.raises(ValueError) as refused:
            blend_shares(typed, ["root", "right_wrist"])
        with pytest.raises(ValueError, match=f"^{re.escape(str(refused.value))}$"):
            run_job(s.model, replace(plan, weights=typed), on_step=lambda done, total: None,
                    cancel=threading.Event())
    for weights in ({"root": -1.0, "right_wrist": 1.0}, {"root": 0.0, "right_wrist": 0.0},
                    {"root": float("nan"), "right_wrist": 1.0}):
        k.weights = {**k.weights, **weights}
        with pytest.raises(ValueError) as refused:
            blend_shares(k.weights, ["root", "right_wrist"])
        message = str(refused.value)
        assert "\n" not in message
        with pytest.raises(ValueError, match=message.split(":")[0]):
            k.shares()
        assert message in tab.shares.object.replace("&#x27;", "'")  # shown as the engine says it
        assert not tab.generate() and s.notices[-1] == ("error", f"cannot generate with control: {message}")
    assert k.weights["root"] != k.weights["root"]  # kept as set (NaN), never clamped
    tab.weights["root"].value = 0.4  # (the slider could not show NaN: it stayed where it was)
    assert k.weights["root"] == 0.4 and "0.29 × root path + 0.71 × right wrist" in tab.shares.object
    tab.weights["root"].value = 0.0  # the sliders reach 0 for every control: all 0 is the engine's refusal too
    tab.weights["right_wrist"].value = 0.0
    assert "blend weights are all 0" in tab.shares.object
    tab.method.value = "inpainting"  # the weights do not apply: inpainting runs whatever they are
    assert "apply to fine-tuned models only" in tab.shares.object


def _bench_result(blending: dict, inpainting: dict) -> dict:
    """What bench_control returns, reduced to what the bench record reads."""
    rows = {m: {"paths": 3, "error_m": 0.02, "off_0_5m": 0.0, **figs}
            for m, figs in (("blending", blending), ("inpainting", inpainting))}
    return {"drawn": {"tasks": {"root+left_wrist": rows}}, "steps": 20, "motions": 8, "truth_skate": 0.05}


def test_the_tab_opens_on_the_method_the_control_bench_has_ahead(tiny_model_dir, tmp_path):
    """Blending only when the bench record beside the control models has it ahead of inpainting (less skate or the
    action kept more often, and behind on neither); otherwise inpainting, and the tab says which one is ahead."""
    from engine.methods.control_options import BENCH_RECORD, write_bench_record
    from tests.test_priormdm import controls_with_prior

    folder = controls_with_prior(tiny_model_dir, tmp_path / "control", ("root", "left_wrist"), prior=False)
    cases = [({"skate": 0.10, "action_match": 0.6}, {"skate": 0.30, "action_match": 0.2}, "blending",
              "has blending ahead of inpainting"),
             ({"skate": 0.40, "action_match": 0.1}, {"skate": 0.30, "action_match": 0.2}, "inpainting",
              "has inpainting ahead of blending"),
             ({"skate": 0.78, "action_match": 0.0}, {"skate": 0.84, "action_match": 0.22}, "inpainting",
              "neither method ahead")]
    for blending, inpainting, opened, said in cases:
        write_bench_record(_bench_result(blending, inpainting), folder=folder)
        studio = _studio(tiny_model_dir, controls_dir=folder)
        try:
            tab, k = studio.control, studio.control.settings
            assert k.available == ["left_wrist", "root"] and k.method == opened and tab.method.value == opened
            note = tab.bench_note.object
            assert said in note and f"The tab opens on {opened}" in note, note
            assert f"foot skate {blending['skate']:.2f} vs {inpainting['skate']:.2f}" in note
        finally:
            studio.close()
    # blending ahead, but the models were retrained since the record: it no longer speaks for them
    write_bench_record(_bench_result(*cases[0][:2]), folder=folder)
    with open(folder / "root" / "weights.pt", "ab") as fh:
        fh.write(b"\0")
    k = ControlSettings(controls_dir=folder)
    assert k.method == "inpainting" and "other control models" in k.verdict.message
    (folder / BENCH_RECORD).write_text("{not json")
    assert "cannot be read" in ControlSettings(controls_dir=folder).verdict.message


def test_the_shipped_record_says_which_method_is_ahead(shipped_studio):
    """The shipped control models come with their bench record (assets/control/bench.json): the tab opens on the
    method it has ahead (inpainting unless blending is ahead on a figure and behind on none) and says what each one is
    ahead on."""
    studio = shipped_studio
    tab, k = studio.control, studio.control.settings
    assert k.available == ["left_wrist", "right_wrist", "root"]  # fine-tuned from the shipped base: no prior needed
    verdict = k.verdict
    assert verdict.record is not None and "other control models" not in verdict.message  # it speaks for these models
    assert k.method == ("blending" if verdict.leader == "blending" else "inpainting")
    note = tab.bench_note.object
    assert verdict.message.split(":")[0] in note and f"The tab opens on {k.method}" in note
    for figure in ("foot skate", "prompted action"):
        assert figure in note and " ahead)" in note


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
    tab.use_wrists["left_wrist"].value = True  # no fine-tuned wrist model: refused with a clear message
    k.left_wrist_points = [(0.2, 1.0), (0.4, 1.4)]
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


def test_planted_feet_checkbox_reaches_the_engine(studio):
    """The Control tab's "Keep planted feet still" box is the engine's declared option (on by default), and what it
    says is what the job runs with."""
    from app.tabs.control.job import prepare
    from engine.methods.control_options import ControlOptions, option_info

    tab, k = studio.control, studio.control.settings
    info = option_info(ControlOptions, "planted_feet")
    assert k.planted_feet is info.default is True
    assert tab.planted_feet.value is True and tab.planted_feet.name == "Keep planted feet still"
    assert prepare(studio.state, k).planted_feet is True
    tab.planted_feet.value = False
    assert k.planted_feet is False and prepare(studio.state, k).planted_feet is False
    assert tab.generate() and studio.state.wait(300), studio.state.notices[-1:]
    assert not [n for n in studio.state.notices if n[0] == "error"], studio.state.notices
    r = k.result
    assert r.planted_feet is False and 0.0 <= r.skate <= 1.0
    assert "feet sliding on the floor" in tab.readout.object and "(planted feet off)" in tab.readout.object
