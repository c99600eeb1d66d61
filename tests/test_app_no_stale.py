"""Nothing stale, nothing silent (issue #35): the plots show the selected motion's data or say why not, an upload
always gets a message about that file by its name (never its content), an emptied number box shows its default (never
NaN), the plots are readable (ticks, legends, hints) and a long prompt does not fill the sidebar. No model, no server:
the Panel objects are driven as the browser drives them."""
from __future__ import annotations

import base64
import io

import numpy as np
import param
import pytest

from app.attention_record import AttentionRecord
from app.components.number_box import FloatBox, IntBox
from app.session.items import MotionItem
from app.session.state import StudioState
from app.tabs.attention.view import AttentionExplorer
from app.tabs.files.view import ImportPanel
from app.uploads import import_bytes


def _record(frames: int, words=("a", "person", "jumps")) -> AttentionRecord:
    rng = np.random.default_rng(0)
    selfm = rng.random((2, 1, 1, frames, frames)).astype(np.float16)
    cross = rng.random((2, 1, 1, frames, len(words))).astype(np.float16)
    return AttentionRecord(words=tuple(words), steps=(0, 1), num_steps=2, timesteps=(1, 0), self_maps=selfm,
                           cross_maps=cross)


def _motion(frames: int) -> np.ndarray:
    joints = np.zeros((frames, 22, 3), np.float32)
    joints[:, :, 1] = np.linspace(0, 1.7, 22)[None]
    return joints


def _generated(state: StudioState, frames: int) -> MotionItem:
    item = MotionItem(name=f"a person jumps ({frames})", joints=_motion(frames), source="generated",
                      prompt="a person jumps", words=("a", "person", "jumps"), attention=_record(frames))
    state.add_item(item)
    return item


def _npy_bytes(frames: int) -> bytes:
    buf = io.BytesIO()
    np.save(buf, _motion(frames), allow_pickle=False)
    return buf.getvalue()


def _browser_upload(panel: ImportPanel, data: bytes, name: str) -> None:
    """What the browser sends for a picked file: name and content together (an empty file's content is "")."""
    panel._input._process_events({"filename": name, "value": base64.b64encode(data).decode(), "mime_type": ""})


# ------------------------------------------------------------------------------------------ stale attention plots
def test_a_motion_without_attention_shows_no_plots_of_the_one_before():
    state = StudioState()
    explorer = AttentionExplorer(state=state)
    _generated(state, 100)
    state.pick_frame(80)
    assert explorer.curves.x_range.end == 99 and explorer.curve_cursor.location == 80
    assert explorer.plots.visible
    assert len(explorer.curve_src.data["xs"]) == 3

    state.show_motion(_motion(46), title="imported: short.npy")  # 46 frames, no attention
    # the plots are not left on the 100-frame motion's axes, data and cursor: they are hidden and the line says why
    assert not explorer.plots.visible
    assert explorer.curve_src.data["xs"] == [] and explorer.heat_src.data["image"][0].shape == (1, 1)
    assert explorer.curves.x_range.end <= 45 and explorer.heatmap.x_range.end == 46
    assert explorer.heatmap.y_range.start == 46 and explorer.curve_cursor.location <= 45
    text = explorer.info.object
    assert "not available" in text and "imported: short.npy" in text and "46 frames" in text
    assert "it was imported" in text

    state.show("a person jumps (100)")  # back to the motion with attention: its own plots again
    assert explorer.plots.visible
    assert explorer.curves.x_range.end == 99 and len(explorer.curve_src.data["xs"]) == 3
    assert "not available" not in explorer.info.object


def test_the_word_curves_have_a_legend_naming_each_word():
    state = StudioState()
    explorer = AttentionExplorer(state=state)
    item = MotionItem(name="two a", joints=_motion(30), source="generated", prompt="a person and a dog",
                      words=("a", "person", "a"), attention=_record(30, words=("a", "person", "a")))
    state.add_item(item)
    legend = explorer.curves.legend[0]
    assert legend in explorer.curves.below  # under the plot, not over the curves
    assert legend.items and legend.items[0].label.field == "label"
    assert explorer.curve_src.data["label"] == ["a (0)", "person", "a (2)"]  # as the word buttons name them
    assert list(explorer.words.options) == explorer.curve_src.data["label"]


# ------------------------------------------------------------------------------------------ uploads
def test_an_empty_upload_is_refused_by_name_and_import_window_does_not_go_back_to_the_one_before():
    state = StudioState()
    panel = ImportPanel(state=state)
    _browser_upload(panel, _npy_bytes(40), "walk.npy")
    assert state.notices[-1] == ("info", "imported walk.npy: 40 frames (2.0 s)") and len(state.items) == 1
    _browser_upload(panel, b"", "empty.npy")  # the browser sends "" for its content: Panel reads None
    assert state.notices[-1] == ("error", "Could not import empty.npy: it is empty (0 bytes)")
    assert panel.again.disabled
    assert panel.import_upload() is False  # "Import window" does not import walk.npy again
    assert state.notices[-1] == ("error", "upload a .bvh or .npy file first") and len(state.items) == 1
    # the field was cleared (the browser then sends no content and no name): nothing to say
    panel._input._process_events({"filename": "", "value": "", "mime_type": ""})
    assert state.notices[-1] == ("error", "upload a .bvh or .npy file first")
    # the same empty file picked again after the clear: only its name changes (its content "" was "" already)
    n = len(state.notices)
    panel._input._process_events({"filename": "empty.npy"})
    assert len(state.notices) == n + 1 and state.notices[-1] == ("error", "Could not import empty.npy: it is empty "
                                                                          "(0 bytes)")


@pytest.mark.parametrize("data, name, reason", [
    (b"my secret diary, line one\nline two\n", "diary.bvh", "line 1: expected HIERARCHY at the start of the file"),
    (b"password=hunter2\n", "notes.bvh", "line 1: expected HIERARCHY at the start of the file"),
    (b"HIERARCHY\nsome private words here\n", "x.bvh", "line 2: expected ROOT after HIERARCHY"),
    (b"just some text, not numpy\n", "motion.npy", "motion.npy is not a .npy file"),
])
def test_a_file_that_is_not_a_motion_is_named_as_the_user_named_it_and_its_text_is_not_echoed(data, name, reason):
    with pytest.raises(ValueError) as info:
        import_bytes(data, name)
    text = str(info.value)
    assert text.startswith(reason), text
    assert "upload." not in text  # not the studio's temporary copy
    for line in data.decode().splitlines():
        if line != "HIERARCHY":  # the format's keyword, not the user's text
            assert line not in text and line[:12] not in text, (line, text)
    state = StudioState()
    panel = ImportPanel(state=state)
    _browser_upload(panel, data, f"/home/me/{name}")
    level, message = state.notices[-1]
    assert level == "error" and message.startswith(f"Could not import {name}: ") and "/home/me" not in message
    assert "upload." not in message and data.decode().splitlines()[-1] not in message


def test_a_bvh_error_keeps_the_joint_names_it_needs():
    with pytest.raises(ValueError, match=r"^line 3: unbalanced braces: the file ends inside joint 'Hips' \(opened on "
                                         r"line 2\), a '\}' is missing$"):
        import_bytes(b"HIERARCHY\nROOT Hips\n{\n", "broken.bvh")


# ------------------------------------------------------------------------------------------ number boxes
class _Settings(param.Parameterized):
    seconds = param.Number(default=None, allow_None=True, doc="None: auto")
    guidance = param.Number(default=2.5, bounds=(0.0, 20.0))
    steps = param.Integer(default=50, bounds=(1, 1000))


def test_an_emptied_number_box_shows_its_default_and_never_nan():
    settings = _Settings(seconds=3.0, guidance=4.0, steps=20)
    seconds = FloatBox.from_param(settings.param.seconds, placeholder="auto 2.3")
    guidance = FloatBox.from_param(settings.param.guidance)
    steps = IntBox.from_param(settings.param.steps)
    models = {box: box.get_root() for box in (seconds, guidance, steps)}  # what the browser shows
    for box, model in models.items():
        model.value = None  # the user empties the box (the browser's null)
    # a parameter that takes None is "auto": the box is empty (its placeholder says "auto 2.3"), not NaN
    assert settings.seconds is None and models[seconds].value is None
    assert models[seconds].placeholder == "auto 2.3"
    # the others go back to their default, and the box shows it (not blank while something else is used)
    assert settings.guidance == 2.5 and models[guidance].value == 2.5
    assert settings.steps == 50 and models[steps].value == 50
    assert guidance.placeholder == "default 2.5"
    # emptied again at the default: the box still shows it
    models[guidance].value = None
    assert settings.guidance == 2.5 and models[guidance].value == 2.5
    # None from the session (e.g. re-record sets auto) reaches the browser as an empty box, never NaN
    settings.seconds = 2.0
    settings.seconds = None
    assert models[seconds].value is None
    fresh = FloatBox(value=None, placeholder="to the end")
    assert fresh.get_root().value is None


def test_the_studios_number_boxes_never_show_nan():
    from app.tabs.generate.view import GenerateControls

    state = StudioState()
    controls = GenerateControls(state=state)
    panel = ImportPanel(state=state)
    for box in (controls.seconds, controls.guidance, controls.steps, controls.seed, panel.start, panel.seconds):
        model = box.get_root()
        model.value = None
        assert model.value is None or np.isfinite(model.value), box.name
    assert state.seconds is None and controls.seconds.placeholder.startswith("auto ")
    assert state.guidance == StudioState.param.guidance.default


# ------------------------------------------------------------------------------------------ a long prompt
def test_a_2000_character_prompt_shows_one_line_of_intent_that_opens_to_the_rest():
    import re

    from app.components.words import MAX_INTENT_CHARS, intent_line

    prompt = " then ".join(["a person jumps twice", "walks forward", "waves the left hand three times",
                            "kicks with the right leg", "turns around slowly"] * 20)[:2000]
    line = intent_line(prompt)
    summary = re.search(r"<summary[^>]*>(.*?)</summary>", line, re.S)
    assert summary is not None and line.startswith("<details")  # collapsed: one line until opened
    shown = re.sub(r"<[^>]+>", "", summary.group(1))
    assert len(shown) <= MAX_INTENT_CHARS + 40 and "actions in all" in shown, shown
    assert "turn (around, slowly)" in line  # all of it is there, opened on demand
    short = intent_line("a person jumps twice")
    assert short.startswith("<div") and "jump (×2)" in short  # a short intent stays one plain line


# ------------------------------------------------------------------------------------------ transfer plots
def test_the_transfer_maps_have_few_ticks_and_the_per_query_plot_is_a_hint_until_a_frame_is_picked():
    from app.main import tab_settings
    from app.tabs.transfer.plots import MAP_TICKS, TransferPlots

    state = StudioState(tabs=tab_settings())
    plots = TransferPlots(state=state, settings=state.tab_settings["transfer"])
    for fig in plots.maps.values():  # 190 px wide: a label every ~60 px, never "80100120140"
        for axis in (*fig.xaxis, *fig.yaxis):
            assert axis.ticker.desired_num_ticks == MAP_TICKS <= 3
    # before a frame is picked: a line saying what to do, not an empty box
    assert plots.query_hint.visible and not plots.query_box.visible
    assert "pick a frame" in plots.query_hint.object


# ------------------------------------------------------------------------------------------ the viewer's legends
def test_every_colour_mode_of_the_viewer_has_a_legend():
    from app.tabs.compose.job import COLOR_NAMES, INTERVAL_COLORS, TRANSITION_COLOR
    from app.tabs.transfer.colors import cluster_names, cluster_palette, hex_rgb
    from app.viewer.legend import scene_legend
    from app.viewer.view import SkeletonViewer
    from viz.colors import ROLE_PALETTE, default_joint_colors

    # role colours (the default): one swatch per motion shown, and what the shading means
    legend = scene_legend(roles=["a walk", "a jump"])
    assert legend["kind"] == "swatches" and [i["label"] for i in legend["items"]] == ["a walk", "a jump"]
    assert [i["color"] for i in legend["items"]] == list(ROLE_PALETTE[:2]) and "left" in legend["note"]
    # colour by word attention: the scale, from 0 to the word's highest attention
    legend = scene_legend(roles=["m"], word="jumps", values=np.array([0.0, 0.1, 0.42]), word_wanted=True)
    assert legend["kind"] == "gradient" and legend["title"] == 'attention on "jumps"'
    assert legend["low"] == "0" and legend["high"] == "0.42" and len(legend["stops"]) >= 5
    # asked for but not possible: the legend says why
    legend = scene_legend(roles=["m"], word_wanted=True, why_no_word="no recorded attention")
    assert legend["title"] == "no word colours: no recorded attention"
    # Transfer's clusters: one swatch per cluster id used, named
    palette = cluster_palette(10)
    labels = np.array([0, 0, 3, 3, 3, 7])
    colors = hex_rgb([palette[k] for k in labels])
    legend = scene_legend(roles=["out"], role_colors=(("out", colors),), names=cluster_names("Q", 10),
                          note="colour: Q cluster (legend in the Transfer tab)")
    assert legend["title"] == "Q cluster"
    assert [i["label"] for i in legend["items"]] == ["Q cluster 0", "Q cluster 3", "Q cluster 7"]
    # Compose's intervals and handshakes (per joint, shaded): named by what they are
    rgb = np.zeros((30, 22, 3), np.uint8)
    rgb[:10], rgb[10:15], rgb[15:] = (default_joint_colors(c) for c in (INTERVAL_COLORS[0], TRANSITION_COLOR,
                                                                         INTERVAL_COLORS[1]))
    legend = scene_legend(roles=["long"], role_colors=(("long", rgb),), names=COLOR_NAMES)
    assert [i["label"] for i in legend["items"]] == ["interval", "handshake (transition)", "interval"]
    # colours nobody named: by the frames they cover
    rgb = np.zeros((20, 3), np.uint8)
    rgb[5:9] = (10, 200, 30)
    legend = scene_legend(roles=["x"], role_colors=(("x", rgb),))
    assert [i["label"] for i in legend["items"]] == ["frames 0–4, 9–19", "frames 5–8"]

    # the scene the browser gets carries it, and follows the colour mode
    state = StudioState()
    viewer = SkeletonViewer(state=state)
    _generated(state, 40)
    assert viewer.player.scene["legend"]["kind"] == "swatches"
    state.color_by_word = True
    assert viewer.player.scene["legend"]["kind"] == "gradient"
    assert viewer.player.scene["legend"]["title"] == 'attention on "jumps"'
    state.show_motion(_motion(20), title="imported: x.npy")
    assert viewer.player.scene["legend"]["title"] == "no word colours: no recorded attention"

