"""Studio components without a server: state, prompt checks, the generation worker, recorded attention,
the attention explorer, the frame renderer and the exports (a tiny model trained for the session)."""
from __future__ import annotations

import asyncio
import concurrent.futures
import io
import json
import time

import numpy as np
import pytest
from PIL import Image

from app.attention_record import estimate_bytes, plan_steps
from app.main import Studio
from app.session.state import StudioState
from app.bench.testing import tiny_model
from app.session.items import MAX_UPLOAD_BYTES
from app.tabs.files.exports import EXPORTS, export_bytes
from app.uploads import import_bytes


@pytest.fixture(scope="module")
def studio(tiny_model_dir):
    """One session with one generated motion (8 steps, all recorded)."""
    st = Studio(model_dir=tiny_model_dir, initial=None)
    s = st.state
    s.param.update(prompt="a person jumps twice", seconds=3.0, steps=8, record_steps=8, seed=1)
    assert s.generate()
    assert s.wait(120)
    assert not s.running and s.item is not None, s.notices
    yield st
    st.close()


def _decode(jpeg: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(jpeg)).convert("RGB"))


def _skeleton_pixels(img: np.ndarray) -> int:
    """Pixels of the default (blue) skeleton: strongly blue, not the grey floor or the white sky."""
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return int(((b - r > 60) & (b > 120)).sum())


# ---------------------------------------------------------------------------------------------- basics
def test_state_validates_motion():
    state = StudioState()
    with pytest.raises(ValueError, match="shape"):
        state.show_motion(np.zeros((10, 21, 3)), title="bad")
    item = state.show_motion(np.zeros((10, 22, 3)), title="zeros")
    assert state.n_frames == 10 and state.frame == 0 and state.current == item.name


def test_import_bytes_parses_npy_and_refuses_bad_files(real_joints):
    buf = io.BytesIO()
    np.save(buf, real_joints)
    joints = import_bytes(buf.getvalue(), "walk.npy")
    assert joints.shape == real_joints.shape
    with pytest.raises(ValueError, match="empty"):
        import_bytes(b"", "x.npy")
    with pytest.raises(ValueError, match="only .bvh and .npy"):
        import_bytes(b"abc", "x.txt")
    with pytest.raises(ValueError, match="uploads are limited to 20 MiB"):  # the limit the import box states
        import_bytes(b"0" * (MAX_UPLOAD_BYTES + 1), "big.bvh")
    pickled = io.BytesIO()
    np.save(pickled, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError):
        import_bytes(pickled.getvalue(), "evil.npy")
    with pytest.raises(ValueError):
        import_bytes(b"HIERARCHY\nROOT Hips\n{\n", "broken.bvh")


def test_recording_plan_and_memory_budget():
    assert plan_steps(50, 10)[0] == 0 and plan_steps(50, 10)[-1] == 49 and len(plan_steps(50, 10)) == 10
    assert plan_steps(50, 1) == [49] and plan_steps(5, 99) == [0, 1, 2, 3, 4]
    # the design's figure: 50 steps x 6 layers x 4 heads x 196^2 x 2 B ~ 90 MB; 10 steps is a fifth
    full = estimate_bytes(num_steps=50, record_steps=50, layers=6, heads=4, frames=196, words=0)
    assert 85e6 < full < 95e6
    assert estimate_bytes(num_steps=50, record_steps=10, layers=6, heads=4, frames=196, words=0) == full // 5


# ---------------------------------------------------------------------------------------------- prompt
def test_the_prompt_box_shows_what_the_engine_will_do_and_never_blocks_over_a_word(tiny_model_dir):
    """Issue #32 item 5: before generating, the box shows the engine's own notes (Tokenizer.encode: typo read as,
    read by meaning, left out) and Generate stays enabled; only a prompt the engine refuses disables it."""
    from app.generation import prompt_analysis

    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s, c = st.state, st.controls
        tokenizer = s.tokenizer()
        s.prompt = "a persn jumsp twice"  # typos: read as the one known word they are a slip of
        assert s.reading.notes == tokenizer.encode(s.prompt).notes() == ["read 'persn' as 'person'",
                                                                         "read 'jumsp' as 'jumps'"]
        assert not c.generate.disabled and not s.reading.blocked
        assert "read &#x27;persn&#x27; as &#x27;person&#x27;" in c.words.object and "word-read" in c.words.object
        assert c.suggestion_row.objects == []  # nothing left out: nothing to pick
        # a word left out: noted, Generate still enabled; suggestions only where the engine offers them
        c.prompt.value_input = "a person jumps flibbers"
        assert s.reading.left_out == ("flibbers",) and s.reading.notes == ["left out: flibbers"]
        assert "left out: flibbers" in c.words.object and "word-left-out" in c.words.object
        assert not c.generate.disabled
        assert [b.label for b in c.suggestion_row.objects] == [
            f"flibbers → {x}" for x in tokenizer.encode(s.prompt).suggestions["flibbers"][:3]]
        # the engine refuses (nothing says a motion): its one-line message, Generate disabled
        c.prompt.value_input = "a person flurbs"
        assert s.reading.blocked and c.generate.disabled
        assert "prompt-refused" in c.words.object and "nothing else in the prompt says what to do" in c.words.object
        c.prompt.value_input = ""
        assert s.reading.blocked and c.generate.disabled  # the engine refuses an empty prompt too
        c.prompt.value_input = "a person jumps twice"
        assert not c.generate.disabled and s.reading.notes == [] and "prompt-note" not in c.words.object
        # one rule: the app's reading is the engine's
        r = prompt_analysis(tokenizer, "a tired guy walks over")
        assert r.tokens == tokenizer.encode("a tired guy walks over") and not r.blocked
        assert prompt_analysis(None, "a flurb").notes == [] and not prompt_analysis(None, "").blocked
    finally:
        st.close()


@pytest.mark.parametrize("change, message", [
    ({"prompt": ""}, "prompt is empty"),
    ({"prompt": "a person flurbs"}, "unknown word"),
    ({"seconds": 30.0}, "duration must be between"),
    ({"seconds": 0.2}, "duration must be between"),
])
def test_bad_input_is_a_notification_not_a_crash(tiny_model_dir, change, message):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.param.update(**change)
        assert s.generate() is False
        assert not s.running and s.active_run is None
        level, text = s.notices[-1]
        assert level == "error" and message in text
        assert s.notice[2] == text
    finally:
        st.close()


def test_missing_model_is_reported_and_import_still_works(tmp_path, real_joints):
    st = Studio(model_dir=tmp_path / "nothing", initial=None)
    try:
        assert any("no model" in t for _, t in st.state.notices)
        assert st.controls.generate.disabled
        assert st.state.generate() is False
        st.state.show_motion(real_joints[:30], title="imported: walk")
        assert st.viewer.player.scene["n_frames"] == 30
    finally:
        st.close()


# ---------------------------------------------------------------------------------------------- generation
def test_generation_runs_on_a_worker_and_records_attention(studio, tiny_model_dir):
    s = studio.state
    item = s.item
    assert item.source == "generated" and item.prompt == "a person jumps twice"
    assert item.joints.shape == (60, 22, 3) and np.isfinite(item.joints).all()
    assert s.progress == s.progress_total == 8 * s.tries  # steps x tries (a tiny model follows nothing: every try)
    assert studio.controls.progress.max == 8 * s.tries and studio.controls.progress.value == 0  # empty when idle
    assert studio.controls.cancel.disabled and not studio.controls.generate.disabled
    rec = item.attention
    assert rec.words == ("a", "person", "jumps", "twice")
    assert rec.steps == tuple(range(8)) and rec.num_steps == 8
    assert rec.self_maps.shape == (8, 2, 2, 60, 60) and rec.self_maps.dtype == np.float16
    assert rec.cross_maps.shape == (8, 2, 2, 60, 4)
    # rows are softmax distributions
    np.testing.assert_allclose(rec.self_map(step=7, layer=0, head=0).sum(1), 1.0, atol=2e-2)
    np.testing.assert_allclose(rec.cross_map(step=7, layer=1, head=1).sum(1), 1.0, atol=2e-2)
    # defaults: last recorded step, the first content word highlighted
    assert s.att_step == 7 and s.word == 2


def test_generation_is_deterministic_and_sessions_are_isolated(studio, tiny_model_dir):
    other = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        assert other.state.items == {} and other.state.model is studio.state.model  # shared, read-only
        o = other.state
        o.param.update(prompt="a person jumps twice", seconds=3.0, steps=8, record_steps=2, seed=1)
        assert o.generate() and o.wait(120)
        np.testing.assert_allclose(o.item.joints, studio.state.item.joints, atol=1e-5)
        assert o.item.attention.steps == (0, 7)
        assert len(studio.state.items) == 1  # the first session saw nothing
    finally:
        other.close()


def test_cancel_stops_the_worker(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.param.update(prompt="a person walks", steps=1000, record_steps=0)
        assert s.generate()
        assert st.controls.cancel.disabled is False and st.controls.generate.disabled
        deadline = time.monotonic() + 30
        while s.progress < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        s.cancel()
        assert s.wait(30)
        assert not s.running and s.items == {}
        assert s.notices[-1] == ("info", "generation cancelled")
        assert st.controls.cancel.disabled and not st.controls.generate.disabled
    finally:
        st.close()


# ---------------------------------------------------------------------------------------------- attention views
def test_layer_head_step_switch_uses_recorded_maps(studio):
    # how fast a switch is, in the browser, is `moattn bench --app`'s figure (not a timed test)
    s, ex = studio.state, studio.attention
    rec = s.attention
    for layer, head, step in [(0, None, 7), (1, 0, 3), (None, None, None), (1, 1, 0)]:
        s.param.update(layer=layer, head=head, att_step=step)
        assert s.attention is rec  # nothing was sampled again
        np.testing.assert_allclose(ex.heat_src.data["image"][0], rec.self_map(step=step, layer=layer, head=head))
        curves = ex.curve_src.data["ys"]
        np.testing.assert_allclose(curves[2], rec.word_curve(2, step=step, layer=layer, head=head))
        # the y axis spans the curves (ends on multiples of 0.05, less than 0.05 beyond them), not 0..1
        lo, hi = float(np.min(curves)), float(np.max(curves))
        y = ex.curves.y_range
        assert y.start <= lo and hi <= y.end, (y.start, lo, hi, y.end)
        assert lo - y.start <= 0.0501 and y.end - hi <= 0.0501, (y.start, lo, hi, y.end)
        assert abs(y.start / 0.05 - round(y.start / 0.05)) < 1e-6 and abs(y.end / 0.05 - round(y.end / 0.05)) < 1e-6
    assert ex.layer.value == 1 and ex.head.value == 1 and ex.step.value == 0
    # the widgets drive the state
    ex.layer.value = -1
    assert s.layer is None
    ex.step.value = 7
    assert s.att_step == 7
    assert len(ex.timings) >= 6  # every switch updated the maps


def test_picking_a_frame_moves_the_viewer_and_highlights_the_row(studio):
    s, ex, viewer = studio.state, studio.attention, studio.viewer
    ex.pick_cell(17, key_frame=40)
    assert s.frame == 17 and viewer.player.frame == 17
    assert (ex.row_box.bottom, ex.row_box.top) == (17, 18)
    np.testing.assert_allclose(ex.row_src.data["y"], ex.heat_src.data["image"][0][17])
    assert ex.curve_cursor.location == 17
    # a tap on the curves picks a frame too
    from bokeh.events import Tap

    ex._on_curve_tap(Tap(ex.curves, x=33.4, y=0.2))
    assert s.frame == 33 and viewer.player.frame == 33
    # clicking a curve highlights its word
    ex.curve_src.selected.indices = [3]
    assert s.word == 3 and ex.curve_src.data["width"][3] > ex.curve_src.data["width"][2]
    assert ex.words.value == 3
    ex.words.value = 2
    assert s.word == 2
    s.pick_frame(10_000)
    assert s.frame == s.n_frames - 1


def _scene_joints(role: dict) -> np.ndarray:
    import base64

    return np.frombuffer(base64.b64decode(role["joints"]), dtype="<f4").reshape(role["n_frames"], 22, 3)


def test_viewer_sends_the_browser_one_scene_per_change_and_compares(studio, real_joints):
    s, viewer = studio.state, studio.viewer
    scene = viewer.player.scene
    assert scene["n_frames"] == s.item.n_frames and scene["title"] == s.current
    (role,) = scene["roles"]
    np.testing.assert_allclose(_scene_joints(role), s.item.joints, atol=1e-6)  # one motion: no offset
    assert role["frame_colors"] is None and len(role["joint_colors"]) == 66
    # the denoising history: every step's x̂0, the last one the motion itself, the recorded steps named
    d = scene["denoising"]
    assert d["steps"] == list(range(1, 9)) and d["num_steps"] == 8 and d["recorded"] == list(range(1, 9))
    import base64

    mm = np.frombuffer(base64.b64decode(d["joints_mm"]), dtype="<i2").reshape(8, -1, 22, 3)
    np.testing.assert_allclose(mm[-1] / 1000.0, s.item.joints, atol=1.5e-3)
    assert np.abs(mm[0] - mm[-1]).mean() > 1.0  # the first step's x̂0 is not yet the motion
    key = viewer.motion_key
    # colouring by the highlighted word's attention: the same motions, colours per frame
    s.word = 2
    s.color_by_word = True
    coloured = viewer.player.scene
    assert viewer.motion_key == key and coloured["roles"][0]["frame_colors"] is not None
    assert '"' in coloured["title"]
    s.color_by_word = False
    # camera follow / root path are the page's business: no new scene
    before = viewer.player.scene
    s.follow = False
    s.show_path = False
    assert viewer.player.scene is before and viewer.player.follow is False and viewer.player.show_path is False
    s.follow, s.show_path = True, True
    # compare: an imported motion beside the generated one, side by side (never overlapping), a new key
    generated = s.current
    s.show_motion(real_joints[:50], title="imported: walk")
    s.show(generated)
    s.compare = "imported: walk"
    pair = viewer.player.scene
    assert viewer.motion_key > key and [r["n_frames"] for r in pair["roles"]] == [s.item.n_frames, 50]
    assert pair["denoising"] is None and pair["n_frames"] == max(s.item.n_frames, 50)
    a, b = (_scene_joints(r) for r in pair["roles"])
    n = min(len(a), len(b))
    assert (b[:n, :, 0].min(axis=1) - a[:n, :, 0].max(axis=1)).min() >= 0.6 - 1e-5  # 0.6 m apart at every frame
    assert viewer.compare_select.value == "imported: walk"
    viewer.compare_select.value = "(none)"
    assert s.compare == "" and len(viewer.player.scene["roles"]) == 1


def test_viewer_shows_the_running_generation_live(tiny_model_dir):
    """While sampling, the viewer gets the x̂0 motion (first step always), then the result's scene."""
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        sent = []
        st.viewer.player._send_msg = sent.append
        s = st.state
        s.param.update(prompt="a person jumps twice", seconds=2.0, steps=12, record_steps=2, seed=3, tries=1)
        assert s.generate() and s.wait(120)
        previews = [m for m in sent if m["type"] == "preview"]
        assert previews and previews[0]["step"] == 1 and all(m["num_steps"] == 12 for m in previews)
        assert [m["step"] for m in previews] == sorted(m["step"] for m in previews)
        assert all(m["key"] == st.viewer.motion_key and m["n_frames"] == 40 for m in previews)
        assert st.viewer.player.scene["denoising"]["recorded"] == [1, 12] and s.preview is None
        # a cancelled run drops its live motion: the page goes back to what it showed
        sent.clear()
        s.param.update(steps=1000, seed=4)
        assert s.generate()
        deadline = time.monotonic() + 60
        while not any(m["type"] == "preview" for m in sent) and time.monotonic() < deadline:
            time.sleep(0.02)
        s.cancel()
        assert s.wait(60)
        assert sent[-1] == {"type": "preview_end"}
    finally:
        st.close()


def _run_async(coro):
    """Run a coroutine to its end on its own event loop (a worker thread: the browser tests' Playwright keeps a
    loop running on this one)."""
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, coro).result()


def test_an_export_button_shows_a_spinner_until_its_file_is_ready(studio, monkeypatch):
    from app.tabs.files import exports

    button = studio.exports.buttons["gif"]
    seen = []

    def export(item, fmt, *, selection=None):
        seen.append((fmt, button.loading))
        return b"GIF89a..."

    monkeypatch.setattr(exports, "export_bytes", export)
    data = _run_async(button.callback())
    assert data.read() == b"GIF89a..." and seen == [("gif", True)] and not button.loading

    def broken(item, fmt, *, selection=None):
        raise RuntimeError("disk full")

    monkeypatch.setattr(exports, "export_bytes", broken)
    with pytest.raises(RuntimeError):
        _run_async(button.callback())
    assert not button.loading and "disk full" in studio.state.notices[-1][1]


def test_exports_give_valid_files(studio, real_joints, tmp_path):
    s = studio.state
    item = s.item
    sel = s.selection()
    bvh = export_bytes(item, "bvh").decode()
    assert bvh.startswith("HIERARCHY") and "MOTION" in bvh and "Frames: 60" in bvh
    joints = np.load(io.BytesIO(export_bytes(item, "joints.npy")), allow_pickle=False)
    np.testing.assert_allclose(joints, item.joints, atol=1e-6)
    vecs = np.load(io.BytesIO(export_bytes(item, "vecs.npy")), allow_pickle=False)
    assert vecs.shape == (59, 263)
    data = json.loads(export_bytes(item, "attention.json", selection=sel))
    assert data["words"] == list(item.words) and len(data["self_attention"]) == 60
    assert len(data["cross_attention"][0]) == 4 and data["prompt"] == item.prompt
    png = export_bytes(item, "attention.png", selection=sel)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and Image.open(io.BytesIO(png)).size[0] > 500
    short = s.show_motion(real_joints[:12], title="imported: short")
    assert export_bytes(short, "gif")[:6] in (b"GIF89a", b"GIF87a")
    assert b"ftyp" in export_bytes(short, "mp4")[:16]
    with pytest.raises(ValueError, match="no recorded attention"):
        export_bytes(short, "attention.json")
    assert set(studio.exports.buttons) == set(EXPORTS)
    assert studio.exports.buttons["attention.png"].disabled  # the imported motion is shown now
    s.show(item.name)
    assert not studio.exports.buttons["attention.png"].disabled
    assert studio.exports.buttons["bvh"].filename.endswith(".bvh")


def test_preload_loads_the_control_and_duet_models_once_per_server(tiny_model_dir, tmp_path, monkeypatch):
    """``moattn serve`` loads them before the first page; building a page then loads nothing more."""
    from app.tabs.control import models as controlling
    from app.tabs.duet import models as dueting
    from app.main import preload
    from app.model_cache import get_model
    from engine.methods import control, duet

    loaded = get_model(tiny_model_dir)
    controls, duet_dir = tmp_path / "control", tmp_path / "duet"  # empty: their tabs say why, nothing fails
    controls.mkdir()
    preload(loaded, controls_dir=controls, duet_dir=duet_dir)
    assert controls.resolve() in controlling._models
    assert (duet_dir.resolve(), id(loaded)) in dueting._cache
    calls = []
    monkeypatch.setattr(control, "load_controls", lambda *a, **k: calls.append("control") or {})
    monkeypatch.setattr(duet, "load_duet", lambda *a, **k: calls.append("duet"))
    st = Studio(model_dir=tiny_model_dir, initial=None, controls_dir=controls, duet_dir=duet_dir)
    try:
        assert calls == []  # served from the caches
        assert "no duet model" in dueting.duet_model(duet_dir, loaded)[1]
    finally:
        st.close()
    del controlling._models[controls.resolve()]  # not preloaded: the page loads them itself
    st = Studio(model_dir=tiny_model_dir, initial=None, controls_dir=controls, duet_dir=duet_dir)
    st.close()
    assert calls == ["control"]


def test_generate_box_shows_the_parsed_intent(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.prompt = "a woman waves the left hand twice, then walks forward"
        line = st.controls.intent.object
        assert "asked for: wave (left side, ×2) → walk (forward)" in line and "intent-full" in line
        s.prompt = "a person staggers"  # a gait verb the lexicon lacks: read as a walk with its manner
        assert "asked for: walk; style: drunk" in st.controls.intent.object
        assert "intent-full" in st.controls.intent.object
        s.prompt = "a person walks mysteriously"  # a word it cannot read: said, not hidden
        assert "not understood: mysteriously" in st.controls.intent.object
        assert "intent-partial" in st.controls.intent.object
        s.prompt = ""
        assert st.controls.intent.object == ""
    finally:
        st.close()


def test_no_intent_line_when_the_model_knows_words_beyond_the_action_lexicon():
    """A model trained on a real dataset knows 'cartwheels'; the action lexicon does not (not even by meaning): no
    amber line then. With a word the model does not know either, the line says so."""
    from app.components.words import intent_line

    assert intent_line("someone cartwheels twice") == ""
    assert "not understood: cartwheels" in intent_line("someone cartwheels twice", unknown=["cartwheels"])
    assert "asked for: walk" in intent_line("someone walks and cartwheels")
    assert "asked for: turn" in intent_line("someone pirouettes twice")  # read by meaning (a spin)


def test_the_generate_box_reads_inflections_and_words_by_meaning(tiny_model_dir):
    """'jumped' is read as 'jumps' (another form: no note); 'tired' is read by meaning as the engine reads it, said
    under the chips before generating ('jump' itself is a corpus word since the grammar says "does a jump")."""
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.prompt = "a tired person jumped"
        tokens = s.tokenizer().encode(s.prompt)
        assert s.reading.read_as == {"tired": "wearily", "jumped": "jumps"} == tokens.read_as
        assert s.reading.read_by == {"tired": "meaning", "jumped": "form"}
        assert s.reading.notes == ["read 'tired' as 'wearily'"]  # another form of a known word is not noted
        assert 'title="read as jumps"' in st.controls.words.object
        assert "read &#x27;tired&#x27; as &#x27;wearily&#x27;" in st.controls.words.object
        assert not st.controls.generate.disabled and st.controls.suggestion_row.objects == []
        # a suggestion (when the engine offers one for a left-out word) still rewrites the prompt
        s.replace_word("tired", "~wearily")
        assert s.prompt == "a person jumped wearily" and s.reading.notes == []
        assert not st.controls.generate.disabled
    finally:
        st.close()
