"""The Transfer tab (MoMo) without a server, on the tiny model: a transfer from two prompts and one from an
imported motion through the tab's widgets, the derived state (three roles side by side, analysis sized to the
frames, inversion error shown), frame picking from the analysis views, skeletons coloured by cluster, and bad
input refused with a clear message."""
from __future__ import annotations

import numpy as np
import pytest

from app.main import Studio
from app.tabs.transfer.job import TransferJob
from engine.generate import frames_for


@pytest.fixture(scope="module")
def studio(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    st.state.param.update(steps=8, seed=4)
    yield st
    st.close()


def _run(studio) -> None:
    s, tab = studio.state, studio.transfer
    before = len(s.notices)
    assert s.launch(TransferJob(session=s, settings=tab.settings)), s.notices[-1:]
    assert s.wait(180) and not s.running
    errors = [n for n in s.notices[before:] if n[0] == "error"]
    assert not errors, errors


def _set_prompts(tab, leader: str, follower: str, *, seconds: tuple[float, float] = (3.0, 2.5)) -> None:
    for picker, text, sec in ((tab.leader, leader, seconds[0]), (tab.follower, follower, seconds[1])):
        picker.kind.value = "prompt"
        picker.prompt.value = text
        picker.seconds.value = sec


def test_transfer_from_two_prompts(studio):
    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice")
    assert "word-left-out" not in tab.leader.words.object and "walks" in tab.leader.words.object
    seen = []
    s.param.watch(lambda e: seen.append(e.new), "progress")
    _run(studio)
    view = tab.settings.result
    n, m = frames_for(3.0), frames_for(2.5)
    # three roles, each a session motion of the right length, side by side in the viewer (leader, follower, out)
    assert view.frames == {"leader": n, "follower": m, "out": n}
    for role in ("leader", "follower", "out"):
        item = s.items[view.names[role]]
        assert item.joints.shape == (view.frames[role], 22, 3) and item.info["role"] == role
    assert [it.name for it in s.shown_items] == [view.names[r] for r in ("leader", "follower", "out")]
    spec = studio.viewer.spec()
    assert len(spec.motions) == 3 and [len(j) for _, j in spec.motions] == [n, m, n] and s.n_frames == n
    assert max(seen) == 8 and tab.progress.value == 0  # progress per sampling step; empty once idle
    assert not np.allclose(s.items[view.names["out"]].joints, s.items[view.names["follower"]].joints[:1])
    # the analysis is sized to each stream's frames
    a = view.analysis
    assert {r: len(a.q_labels[r]) for r in a.q_labels} == {"leader": n, "follower": m, "out": n}
    assert {r: len(a.k_labels[r]) for r in a.k_labels} == {"leader": n, "follower": m, "out": n}
    assert a.nearest.shape == (n,) and a.nearest.min() >= 0 and a.nearest.max() < m
    assert a.maps["mixed"].shape == (n, m) and a.maps["leader"].shape == (n, n) and a.maps["follower"].shape == (m, m)
    # ... and so are the views: one cell per frame and role in each strip panel, three film strip rows
    plots = tab.plots
    assert len(plots.strip_src.data["x"]) == 2 * (n + m + n)
    assert len(set(plots.strip_src.data["color"])) > 1  # not one uniform colour
    assert len(plots.cells_src.data["x"]) == m + 2 * n
    assert plots.map_srcs["mixed"][0].data["image"][0].shape == (n, m)
    assert "swatch" in plots.legend.object
    assert "walks forward → a person jumps twice" in tab.result.object and "inversion" not in tab.result.object


def test_picking_frames_and_cluster_colours(studio):
    s, tab = studio.state, studio.transfer
    view, plots = tab.settings.result, tab.plots
    n = view.frames["leader"]
    plots.pick("strips", 12.4)  # a Q cell
    assert s.frame == 12
    plots.pick("strips", plots._offset + 20.6)  # a K cell (right panel)
    assert s.frame == 20
    plots.pick("film", 33.2, 1.5)
    assert s.frame == 33
    plots.pick("mixed", 3.0, 41.7)  # a row of the mixed map = a leader (query) frame
    assert s.frame == 41
    row = view.analysis.per_query(41)
    np.testing.assert_allclose(plots.query_src["mixed"].data["y"], row["mixed"])
    assert "leader frame 41" in plots.query.title.text
    plots.pick("query", 5.2)
    assert s.frame == 5
    plots.pick("strips", 10_000)
    assert s.frame == n - 1  # clamped
    # skeletons coloured by cluster: one colour per frame, the cluster's colour in the strips
    tab.color.value = "K cluster"
    spec = studio.viewer.spec()
    colours = dict(spec.role_colors)
    assert len(colours) == 3 and "K cluster" in spec.title
    leader_rgb = colours[spec.motions[0][0]]
    assert leader_rgb.shape == (n, 3) and leader_rgb.dtype == np.uint8
    from app.tabs.transfer.colors import cluster_colors, hex_rgb, n_clusters

    expected = hex_rgb(cluster_colors(view.analysis.k_labels["leader"], n_clusters(view)))
    np.testing.assert_array_equal(leader_rgb, expected)
    scene = studio.viewer.player.scene  # what the browser draws: each role coloured per frame by its clusters
    assert [r["frame_colors"] is not None for r in scene["roles"]] == [True, True, True]
    tab.color.value = "roles"
    assert studio.viewer.spec().role_colors == ()
    # another motion shown: the trio goes, and nothing is compared with it any more (no carry-over);
    # the tab's button brings the trio back
    s.show(view.names["out"])
    assert s.also == [] and s.compare == "" and len(studio.viewer.spec().motions) == 1
    tab.show.clicks += 1
    assert len(studio.viewer.spec().motions) == 3


def test_transfer_from_an_imported_motion(studio):
    from engine.synth import Corpus

    s, tab = studio.state, studio.transfer
    joints = Corpus("test").sample(3).joints
    item = s.show_motion(joints, title="imported: corpus 3")
    tab.leader.kind.value = "motion"  # the "imported motion" button
    assert item.name in tab.leader.motion.options and tab.settings.leader.motion == item.name
    assert "DDIM-inverted" in tab.leader.info.object and not tab.leader.seconds.visible
    tab.leader.prompt.value = ""  # the description is optional
    tab.follower.kind.value = "prompt"
    tab.follower.prompt.value = "a person jumps twice"
    tab.color.value = "Q cluster"  # skeletons coloured by clusters: the new trio is painted as it is first shown
    scenes = []
    watcher = studio.viewer.player.param.watch(lambda e: scenes.append(e.new), "scene")
    try:
        _run(studio)
    finally:
        studio.viewer.player.param.unwatch(watcher)
        tab.color.value = "roles"
    view = tab.settings.result
    first = next(m for m in scenes if len(m["roles"]) == 3)  # (before it: the imported motion shown alone)
    assert [r["frame_colors"] is not None for r in first["roles"]] == [True, True, True]
    n = view.frames["leader"]
    assert abs(n - min(len(joints), 196)) <= 1 and view.frames["out"] == n
    assert view.analysis.nearest.shape == (n,) and view.analysis.maps["mixed"].shape == (n, view.frames["follower"])
    inv = view.inversion["leader"]
    assert inv is not None and np.isfinite(inv["mean_m"]) and inv["max_m"] >= inv["mean_m"]
    assert 0 <= inv["pose_mean_m"] and np.isfinite(inv["noise_std"])  # the figures of roundtrip_error, one home
    assert view.inversion["follower"] is None  # generated from text
    assert "inversion error" in tab.result.object and " m mean" in tab.result.object and "(pose " in tab.result.object
    assert "inversion error" in tab.leader.info.object and "inversion" not in tab.follower.info.object
    tab.leader.kind.value = "prompt"


def test_footwork_option_reaches_the_engine(studio):
    from app.tabs.transfer.job import prepare

    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice")
    assert prepare(s, tab.settings).config.feet is False
    tab.feet.value = True
    try:
        assert tab.settings.feet is True and prepare(s, tab.settings).config.feet is True
        assert prepare(s, tab.settings).description.endswith("leader's footwork)")
    finally:
        tab.feet.value = False


def test_root_and_directions_reach_the_engine(studio):
    """The tab's root and direction widgets come from the engine's declarations (default, labels, bounds, help)
    and reach the config; a transfer with the direction trick runs and shows the follower as given."""
    from app.tabs.transfer.job import prepare
    from app.tabs.transfer.settings import ROOT_LABELS
    from engine.methods.transfer_config import ROOT_CHOICES, ROOT_DEFAULT, option_info

    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice", seconds=(2.0, 2.0))
    assert tab.settings.root == ROOT_DEFAULT and prepare(s, tab.settings).config.root == ROOT_DEFAULT
    assert tab.root.options == ROOT_LABELS and set(ROOT_LABELS.values()) == set(ROOT_CHOICES)
    assert (tab.directions.start, tab.directions.end) == option_info("directions").bounds and tab.directions.value == 1
    assert ROOT_CHOICES[ROOT_DEFAULT][1][1:40] in tab.root_help.object
    other = next(m for m in ROOT_CHOICES if m != ROOT_DEFAULT)
    try:
        tab.root.value = other
        tab.directions.value = 3
        plan = prepare(s, tab.settings)
        assert plan.config.root == other and plan.config.directions == 3
        assert f"root: {other}, 3 directions" in plan.description
        assert "3 copies of its follower" in tab.root_help.object
        _run(studio)
        view = tab.settings.result
        assert list(view.frames) == ["leader", "follower", "out"]  # the copies are read, not shown
        tab.more.value = "a person runs\na person waves\na person kicks\na person claps\na person hops"
        tab.directions.value = 4
        assert s.launch(TransferJob(session=s, settings=tab.settings)) is False
        level, text = s.notices[-1]
        assert level == "error" and "6 followers x 4 directions make 24 follower streams, at most 16" in text
    finally:
        tab.more.value = ""
        tab.root.value = ROOT_DEFAULT
        tab.directions.value = 1


def test_one_leader_onto_several_followers(studio):
    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice", seconds=(3.0, 2.0))
    tab.more.value = "a person runs forward\n\n  a person waves with the right hand  "
    assert tab.settings.more_followers.splitlines()[0] == "a person runs forward"
    try:
        n_items = len(s.items)
        _run(studio)
    finally:
        tab.more.value = ""
    view = tab.settings.result
    n, m = frames_for(3.0), frames_for(2.0)
    assert list(view.frames) == ["leader", "follower", "out", "follower 2", "out 2", "follower 3", "out 3"]
    assert view.frames == {"leader": n, "follower": m, "out": n, "follower 2": m, "out 2": n, "follower 3": m,
                           "out 3": n}
    assert len(s.items) == n_items + 7
    assert s.items[view.names["follower 3"]].prompt == "a person waves with the right hand"
    assert s.items[view.names["out 2"]].prompt == "a person runs forward"
    # leader, follower, out, then the other outs, side by side
    assert [it.name for it in s.shown_items] == [view.names[r] for r in ("leader", "follower", "out", "out 2",
                                                                          "out 3")]
    outs = [s.items[view.names[r]].joints for r in ("out", "out 2", "out 3")]
    assert not np.allclose(outs[0], outs[1]) and not np.allclose(outs[1], outs[2])  # each its own follower's
    assert "+ 2 more" in tab.result.object and "out 3: " in tab.result.object
    # the analysis views show the first follower, and any other on request (its maps, its out's cluster colours)
    assert len(view.analyses) == 3 and view.analysis is view.analyses[0] and tab.analysed_row.visible
    plots = tab.plots
    np.testing.assert_allclose(plots.map_srcs["mixed"][0].data["image"][0], view.analyses[0].maps["mixed"])
    tab.analysed.value = 3
    assert tab.settings.analysed == 3
    np.testing.assert_allclose(plots.map_srcs["mixed"][0].data["image"][0], view.analyses[2].maps["mixed"])
    assert not np.allclose(view.analyses[2].maps["mixed"], view.analyses[0].maps["mixed"])
    tab.color.value = "Q cluster"
    coloured = set(s.frame_colors)
    assert coloured == {view.names[r] for r in ("leader", "follower 3", "out 3")}
    tab.color.value = "roles"
    tab.analysed.value = 1
    assert set(view.focus(1).names.values()) == {view.names[r] for r in ("leader", "follower", "out")}


@pytest.mark.parametrize("change, message", [
    (lambda tab, s: setattr(tab.more, "value", "a person runs\na person glorps"), "follower 3"),
    (lambda tab, s: setattr(tab.more, "value", "\n".join(["a person runs"] * 8)), "at most 8 followers"),
    (lambda tab, s: setattr(tab.leader.prompt, "value", "   "), "type a prompt for the leader"),
    (lambda tab, s: setattr(tab.follower.prompt, "value", "a person flumps twice"), "flumps"),
    (lambda tab, s: setattr(tab.settings, "layers", (1, 5)), "do not exist"),
    (lambda tab, s: setattr(tab.follower.seconds, "value", 30.0), "duration"),
    (lambda tab, s: tab.settings.leader.param.update(kind="motion", motion="no such motion"),
     "no longer in the session"),
])
def test_bad_input_is_refused_with_a_message(studio, change, message):
    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice")
    tab.settings.layers = None
    n_items = len(s.items)
    change(tab, s)
    assert s.launch(TransferJob(session=s, settings=tab.settings)) is False  # refused up front: no worker, no crash
    level, text = s.notices[-1]
    assert level == "error" and text.startswith("cannot transfer") and message in text, text
    assert not s.running and len(s.items) == n_items
    if "flumps" in message:
        # the engine refuses it (nothing else says a motion): flagged as typed, with its message, Run disabled
        assert "word-left-out" in tab.follower.words.object and "prompt-refused" in tab.follower.words.object
        assert tab.run.disabled
    tab.settings.layers = None
    tab.settings.leader.param.update(kind="prompt", motion="")
    tab.follower.seconds.value = 2.5
    tab.more.value = ""


def test_cancel_stops_the_transfer_and_keeps_the_session(studio):
    import time

    s, tab = studio.state, studio.transfer
    _set_prompts(tab, "a person walks forward", "a person jumps twice")
    s.steps = 120
    n_items, last = len(s.items), tab.settings.result
    try:
        assert s.launch(TransferJob(session=s, settings=tab.settings)) and s.running and not tab.cancel.disabled
        end = time.monotonic() + 60
        while s.progress < 2 and s.running and time.monotonic() < end:
            time.sleep(0.01)
        tab.cancel.clicks += 1
        assert s.wait(120) and not s.running
    finally:
        s.steps = 8
    assert s.notices[-1] == ("info", "transfer cancelled")
    assert len(s.items) == n_items and tab.settings.result is last  # nothing half-made was added
    assert not tab.run.disabled and tab.cancel.disabled


def test_the_leaders_own_upload_refuses_an_empty_file_by_name_and_imports_a_motion(studio):
    import base64
    import io

    from engine.synth import Corpus

    s, tab = studio.state, studio.transfer
    picker = tab.leader
    picker.upload._process_events({"filename": "empty.npy", "value": "", "mime_type": ""})  # Panel reads None
    assert s.notices[-1] == ("error", "Could not import empty.npy: it is empty (0 bytes)")
    buf = io.BytesIO()
    np.save(buf, Corpus("test").sample(5).joints[:40].astype(np.float32))
    errors = sum(kind == "error" for kind, _ in s.notices)
    picker.upload._process_events({"filename": "walk.npy", "value": base64.b64encode(buf.getvalue()).decode(),
                                   "mime_type": ""})
    assert sum(kind == "error" for kind, _ in s.notices) == errors and tab.settings.leader.kind == "motion"
    assert tab.settings.leader.motion == "imported: walk.npy" and "imported: walk.npy" in s.items


def test_an_imported_leader_is_described_by_its_own_recipe_never_by_the_earlier_prompt(studio):
    """Issue #35: switching the leader to an imported motion kept the prompt typed before as the inversion's
    description, silently. Now the description is that motion's own prompt (when its recipe knows one) or none,
    the source box says which, and the typed prompt comes back with the prompt mode."""
    from app.session.items import MotionItem
    from app.tabs.transfer.job import prepare
    from engine.synth import Corpus

    s, tab = studio.state, studio.transfer
    picker, src = tab.leader, tab.settings.leader
    picker.kind.value = "prompt"
    picker.prompt.value = "a person walks forward"
    plain = s.show_motion(Corpus("test").sample(6).joints, title="imported: plain 6")
    picker.kind.value = "motion"
    picker.motion.value = plain.name
    assert src.motion == plain.name and src.prompt == "" and picker.prompt.value == ""
    assert "without a description" in picker.info.object
    assert prepare(s, tab.settings).leader.prompt is None  # inverted without text, not with the old prompt
    known = MotionItem(name="imported: known 7", joints=Corpus("test").sample(7).joints.astype(np.float32),
                       source="imported", prompt="a person waves")
    s.add_item(known)
    picker.motion.value = known.name
    assert src.prompt == "a person waves" and "“a person waves”" in picker.info.object
    assert prepare(s, tab.settings).leader.prompt == "a person waves"
    picker.prompt.value = "a person waves both arms"  # the user's own description is kept while the motion stays
    assert "“a person waves both arms”" in picker.info.object
    picker.kind.value = "prompt"
    assert src.prompt == "a person walks forward" and picker.info.object == ""
