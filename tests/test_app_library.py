"""The studio keeps a person's work in the motion library (no server, a tiny model): every motion made, edited or
imported survives a new session; the Motion list searches, filters by kind, pins and deletes; a motion read back
has no attention and Re-record regenerates that very motion; nothing is dropped silently (no limit of 24), and the
size bound says what it removed."""
from __future__ import annotations

import numpy as np
import pytest

from app.main import Studio
from app.tabs.edit.job import run_edit
from engine.library import MotionLibrary


def _open(tiny_model_dir, workspace, **kw) -> Studio:
    return Studio(model_dir=tiny_model_dir, initial=None, library=MotionLibrary(workspace=workspace, **kw))


def _generate(st: Studio, prompt: str, seed: int) -> None:
    s = st.state
    s.param.update(prompt=prompt, seconds=2.0, steps=6, record_steps=3, seed=seed)
    assert s.generate() and s.wait(120), s.notices[-1:]
    assert not s.running


def _walk(real_joints, frames: int = 40) -> np.ndarray:
    return np.ascontiguousarray(real_joints[:frames], dtype=np.float32)


def test_every_motion_made_edited_or_imported_survives_a_new_session(tiny_model_dir, workspace, real_joints):
    first = _open(tiny_model_dir, workspace)
    try:
        s = first.state
        _generate(first, "a person jumps twice", 3)
        generated = s.current
        joints = s.item.joints.copy()
        s.show_motion(_walk(real_joints), title="imported: walk.npy")
        s.show(generated)
        first.edit.kind.value = "emphasise"
        first.edit.words.value = 2
        assert run_edit(s, first.edit.settings) and s.wait(120), s.notices[-1:]
        edited, reference = s.current, s.compare
        names = list(s.items)
        assert not [n for n in s.notices if n[0] == "error"], s.notices
    finally:
        first.close()
    lib = MotionLibrary(workspace=workspace)
    kinds = {e.title: e.kind for e in lib.entries()}
    assert kinds[generated] == "generate" and kinds["imported: walk.npy"] == "import" and kinds[edited] == "edit"
    recipe = lib.recipe(next(e.id for e in lib.entries() if e.title == generated))
    assert (recipe["prompt"], recipe["seed"], recipe["steps"], recipe["guidance"], recipe["seconds"]) == (
        "a person jumps twice", 3, 6, s.guidance, 2.0)
    from app.session.library import settings_from_recipe
    from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE_FROM

    assert recipe["guidance_from"] == DEFAULT_GUIDANCE_FROM and recipe["eta"] == DEFAULT_ETA  # Re-record samples as it was made
    assert settings_from_recipe(recipe).guidance_from == DEFAULT_GUIDANCE_FROM
    assert settings_from_recipe(recipe).eta == DEFAULT_ETA
    older = {k: v for k, v in recipe.items() if k not in ("guidance_from", "eta")}  # kept before either existed
    assert settings_from_recipe(older).guidance_from == 0 and settings_from_recipe(older).eta == 0.0
    assert recipe["model"]["folder"] == str(tiny_model_dir.resolve()) and recipe["model"]["weights_sha256"]
    edit = next(e for e in lib.entries() if e.title == edited)
    ref_id = next(e.id for e in lib.entries() if e.title == reference)
    assert edit.parents == (ref_id,)  # the edit remembers what it was made from
    assert lib.recipe(edit.id)["operation"]["edit"].startswith("emphasise")

    second = _open(tiny_model_dir, workspace)  # a reload, or the server restarted: a new session
    try:
        t, view = second.state, second.attention
        assert list(t.items) == names  # everything, in the order it was made
        assert t.current == names[-1]  # the page opens on the newest motion kept (here the edit)
        assert second.viewer.show_select.options == names
        t.show(generated)
        item = t.item
        np.testing.assert_allclose(item.joints, joints, atol=1e-6)
        assert item.from_library and item.attention is None and item.settings.seed == 3
        # no attention is stored: said, and Re-record offered
        assert "not attention maps" in view.info.object and view.rerecord.visible
        n_items = len(t.items)
        view.rerecord.clicks += 1
        assert t.wait(120) and not t.running, t.notices[-1:]
        assert t.current == generated and len(t.items) == n_items  # that motion, not a new one
        assert t.item.attention is not None and len(t.item.attention.steps) == 3
        np.testing.assert_allclose(t.item.joints, joints, atol=1e-3)
        assert not view.rerecord.visible and "not attention maps" not in view.info.object
        t.show("imported: walk.npy")
        assert "it was imported" in view.info.object and not view.rerecord.visible
    finally:
        second.close()


def test_the_motion_list_searches_filters_pins_and_deletes(tiny_model_dir, workspace, real_joints):
    st = _open(tiny_model_dir, workspace)
    try:
        s, viewer = st.state, st.viewer
        _generate(st, "a person waves", 1)
        _generate(st, "a person jumps twice", 2)
        s.show_motion(_walk(real_joints), title="imported: walk.npy")
        waves, jumps = list(s.items)[:2]
        s.motion_search = "WAVES"
        assert viewer.show_select.options == [waves, "imported: walk.npy"]  # the shown one stays listed
        s.show(waves)
        assert viewer.show_select.options == [waves]
        s.motion_search = ""
        s.motion_kind = "import"
        assert viewer.show_select.options == [waves, "imported: walk.npy"]
        s.motion_kind = ""
        assert viewer.show_select.options == [waves, jumps, "imported: walk.npy"]
        # pin from the list
        viewer.pin.value = True
        assert s.item.pinned and MotionLibrary(workspace=workspace).get(s.item.library_id).pinned
        # delete: from the session and the library; another motion is shown
        s.show(jumps)
        viewer.delete.clicks += 1
        assert jumps not in s.items and s.current and s.current != jumps
        assert s.notices[-1] == ("info", f"deleted {jumps!r}")
        assert jumps not in {e.title for e in MotionLibrary(workspace=workspace).entries()}
    finally:
        st.close()
    again = _open(tiny_model_dir, workspace)
    try:
        assert list(again.state.items) == [waves, "imported: walk.npy"]
        assert again.state.items[waves].pinned
        again.viewer.show_select.value = waves
        assert again.viewer.pin.value is True
    finally:
        again.close()


def test_nothing_is_dropped_at_24_and_the_bound_is_said(tiny_model_dir, workspace, real_joints):
    st = _open(tiny_model_dir, workspace)
    try:
        s = st.state
        for k in range(30):  # more than the old silent limit of 24
            s.show_motion(_walk(real_joints, 20 + k), title=f"imported: clip {k}.npy")
        assert len(s.items) == 30 and "imported: clip 0.npy" in s.items
        assert len(st.viewer.show_select.options) == 30
        assert "30 motions kept" in s.library_status
        s.show("imported: clip 0.npy")
        st.viewer.pin.value = True
        # a library too small for them all: the least recently made unpinned go first, and the studio says so
        size = MotionLibrary(workspace=workspace).get(s.items["imported: clip 29.npy"].library_id).bytes
        lib = MotionLibrary(workspace=workspace, limit_mb=12 * size / 2**20)
        small = Studio(model_dir=tiny_model_dir, initial=None, library=lib)
        try:
            t = small.state
            t.show_motion(_walk(real_joints, 60), title="imported: one more.npy")
            level, text = t.notices[-1]
            assert level == "warning" and "reached its" in text and "least recently made unpinned" in text
            assert "'imported: clip 1.npy'" in text
            assert "imported: clip 0.npy" in t.items  # pinned: kept
            assert "imported: clip 1.npy" not in t.items and "imported: one more.npy" in t.items
            assert lib.total_bytes() <= lib.limit_bytes
        finally:
            small.close()
    finally:
        st.close()


def test_the_same_file_imported_again_is_the_same_motion(tiny_model_dir, workspace, real_joints):
    st = _open(tiny_model_dir, workspace)
    try:
        s = st.state
        first = s.show_motion(_walk(real_joints), title="imported: walk.npy")
        _generate(st, "a person waves", 1)
        again = s.show_motion(_walk(real_joints), title="imported: walk.npy")
        assert again is first and s.current == first.name and len(s.items) == 2
    finally:
        st.close()
    reload = _open(tiny_model_dir, workspace)  # every page opens on the example walk: still one entry
    try:
        reload.state.show_motion(_walk(real_joints), title="imported: walk.npy")
        assert len(reload.state.items) == 2 and MotionLibrary(workspace=workspace).count() == 2
    finally:
        reload.close()


def test_a_damaged_motion_is_said_and_skipped_never_fatal(tiny_model_dir, workspace, real_joints):
    st = _open(tiny_model_dir, workspace)
    try:
        for k in range(2):
            st.state.show_motion(_walk(real_joints, 30 + k), title=f"imported: {k}.npy")
        ids = [it.library_id for it in st.state.items.values()]
    finally:
        st.close()
    lib = MotionLibrary(workspace=workspace)
    (lib.motions / ids[0] / "joints.npy").write_bytes(b"not a numpy file")
    broken = lib.motions / "someone-elses-folder"
    broken.mkdir()
    import os

    os.utime(broken, (0, 0))
    again = _open(tiny_model_dir, workspace)
    try:
        s = again.state
        assert any("someone-elses-folder" in text for level, text in s.notices if level == "warning")
        s.show("imported: 0.npy")  # its file is damaged: said, taken off the list, the session goes on
        assert s.notices[-1][0] == "error" and "cannot be shown" in s.notices[-1][1]
        assert "imported: 0.npy" not in s.items and "imported: 1.npy" in s.items
        s.show("imported: 1.npy")
        assert s.item.n_frames == 31
    finally:
        again.close()


def test_without_a_library_the_session_keeps_everything_in_memory(tiny_model_dir, real_joints):
    st = Studio(model_dir=tiny_model_dir, initial=None)  # library=None: nothing written anywhere
    try:
        for k in range(26):
            st.state.show_motion(_walk(real_joints, 20 + k), title=f"imported: {k}.npy")
        assert len(st.state.items) == 26 and st.state.library_status == ""
        assert not st.viewer.pin.visible
    finally:
        st.close()


@pytest.mark.parametrize("flag", ["--no-library"])
def test_serve_takes_the_library_flags(flag, tmp_path):
    import engine.cli.serve as serve
    from engine.cli.common import Parser

    parser = Parser(prog="moattn")
    serve.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["serve", "--workspace", str(tmp_path), "--library-mb", "64"])
    assert args.workspace == tmp_path and args.library_mb == 64 and not args.no_library
    assert parser.parse_args(["serve", flag]).no_library


def test_rerecord_repeats_the_motions_own_sampling(tiny_model_dir, workspace):
    """A motion kept before the guidance interval and eta existed (its recipe: classic guidance, deterministic DDIM)
    is re-recorded with those, not with today's defaults the Generate box does not show: the same motion."""
    from dataclasses import replace

    st = _open(tiny_model_dir, workspace)
    try:
        s = st.state
        _generate(st, "a person jumps twice", 5)
        s.item.settings = replace(s.item.settings, guidance_from=0, eta=0.0)  # as settings_from_recipe(older) gives
        launched = []
        s.launch = lambda job: launched.append(job) or True
        assert s.rerecord()
        again = launched[0].settings
        assert (again.guidance_from, again.eta, again.seed, again.prompt) == (0, 0.0, 5, "a person jumps twice")
    finally:
        st.close()


def test_a_returning_user_opens_on_their_newest_motion_not_the_example(tiny_model_dir, workspace):
    """`moattn serve` opens each page on the shipped example walk; a workspace with kept motions opens on the newest
    one instead (the person's last work), and the example is not imported again."""
    from app.main import EXAMPLE

    first = Studio(model_dir=tiny_model_dir, initial=EXAMPLE, library=MotionLibrary(workspace=workspace))
    try:
        assert first.state.current == "imported: walk.npy"  # a new user: the example
        _generate(first, "someone kicks", 3)
        newest = first.state.current
        first.state.prompt = "a person waves"  # typed, not generated: the next page opens on the motion's prompt
    finally:
        first.close()
    second = Studio(model_dir=tiny_model_dir, initial=EXAMPLE, library=MotionLibrary(workspace=workspace))
    try:
        assert second.state.current == newest and len(second.state.items) == 2
        assert second.state.prompt == "someone kicks"  # its prompt in the Generate box (not the default)
        assert second.state.param.prompt.default != "someone kicks"
    finally:
        second.close()
