"""The Edit tab without a server: every edit kind through the tab on the tiny model, the replace alignment
check, the counting readout (peaks on the counting map and on the attention heatmap), and the option ->
config mapping shared with `moattn edit`."""
from __future__ import annotations

import html

import numpy as np
import pytest

from app.attention_record import AttentionRecord
from app.tabs.edit.job import alignment, run_edit, word_choice
from app.main import Studio
from app.bench.testing import tiny_model
from engine.methods.edit_options import EditOptions, build_config
from tests.conftest import cyclic_attention_map


@pytest.fixture(scope="module")
def studio(tiny_model_dir):
    """A session with a plain generation of the prompt (the reference every pair edit must reproduce)."""
    st = Studio(model_dir=tiny_model_dir, initial=None)
    s = st.state
    s.param.update(prompt="a person jumps twice", seconds=3.0, steps=8, record_steps=4, seed=3)
    assert s.generate() and s.wait(120), s.notices
    st.plain = s.item  # kept here: the session's list drops its oldest motions past 8
    yield st
    st.close()


def _plain(studio):
    return studio.plain


def _run(studio, kind: str) -> None:
    s, tab = studio.state, studio.edit
    tab.kind.value = kind
    before = len(s.notices)
    assert run_edit(s, tab.settings), s.notices[-1:]
    assert s.wait(120)
    assert not s.running
    errors = [n for n in s.notices[before:] if n[0] == "error"]
    assert not errors, errors


# ---------------------------------------------------------------------------------------------- emphasis
def test_emphasis_changes_the_edit_and_keeps_the_reference(studio):
    s, tab = studio.state, studio.edit
    plain = _plain(studio)
    # the word is picked by clicking it: the tab keeps the word (and which occurrence), not a token index
    tab.words.value = 2
    assert (tab.settings.word, tab.settings.occurrence) == ("jumps", 0)
    tab.weight.value = 0.4
    steps_seen = []
    s.param.watch(lambda e: steps_seen.append(e.new), "progress")
    _run(studio, "emphasise")
    after, before = s.item, s.compare_item
    assert before is not None and s.compare == before.name  # compare mode: before and after side by side
    assert "reference" in before.name and "emphasise 'jumps' +0.40" in after.name
    assert before.name in s.items and after.name in s.items
    np.testing.assert_allclose(before.joints, plain.joints, atol=1e-4)  # reference == plain generation, same seed
    assert np.abs(after.joints - before.joints).max() > 1e-2  # the edit did something
    assert max(steps_seen) == 8 and s.progress == s.progress_total == 8  # progress per sampling step
    spec = studio.viewer.spec()
    assert [r for r, _ in spec.motions] == [after.name[:39] + "…" if len(after.name) > 40 else after.name,
                                             before.name[:39] + "…" if len(before.name) > 40 else before.name]
    # the edited motion's attention was recorded at the session's plan (4 of 8 steps) and shows in the explorer
    assert after.attention is not None and after.attention.steps == (0, 2, 5, 7)
    assert after.attention.cross_maps.shape[-1] == 4
    assert "emphasise" in tab.result.object and tab.progress.value == 0  # the bar is empty once idle
    # the result line says whether the action grew, by the emphasis bench's own measure
    from engine.analysis.action_size import amplitude

    size = f"{amplitude(before.joints, 'jumps'):.2f} → {amplitude(after.joints, 'jumps'):.2f} m"
    assert html.escape(f"action size 'jumps' (feet's peak above the floor): {size}") in tab.result.object


def test_emphasis_weight_sign_and_multiplicative_mode(studio):
    s, tab = studio.state, studio.edit
    tab.kind.value = "emphasise"
    tab.words.value = 2
    tab.mode.value = "mul"
    assert tab.weight.start == 0.0 and tab.weight.end == 3.0
    tab.weight.value = 2.0
    tab.frames.value = (10, 40)
    tab.layers.value = [1]
    tab.steps.value = (0.0, 0.5)
    _run(studio, "emphasise")
    assert "×2.00" in s.item.name and "frames 10–40" in s.item.name
    np.testing.assert_allclose(s.compare_item.joints, _plain(studio).joints, atol=1e-4)
    tab.mode.value = "add"
    assert tab.weight.start == -0.5 and -0.5 <= tab.settings.weight <= 0.5
    tab.layers.value = []
    tab.frames.value = (0, tab.frames.end)
    tab.steps.value = (0.0, 1.0)


def test_the_emphasis_range_is_stated_once(studio, capsys):
    """The slider, the session's bounds, the CLI's help and the method's check all read WEIGHT_RANGES."""
    from engine.cli import build_parser
    from engine.methods.motionclr import WEIGHT_RANGES, ReweightConfig

    tab = studio.edit
    tab.kind.value = "emphasise"
    for mode, (lo, hi) in WEIGHT_RANGES.items():
        tab.mode.value = mode
        assert (tab.weight.start, tab.weight.end) == (lo, hi)
        ReweightConfig(word="jumps", weight=hi, mode=mode)
        with pytest.raises(ValueError, match=f"between {lo:g} and {hi:g}"):
            ReweightConfig(word="jumps", weight=hi + 0.1, mode=mode)
    tab.mode.value = "add"
    bounds = studio.edit.settings.param.weight.bounds
    assert bounds == (min(lo for lo, _ in WEIGHT_RANGES.values()), max(hi for _, hi in WEIGHT_RANGES.values()))
    with pytest.raises(SystemExit):
        build_parser().parse_args(["edit", "--help"])
    assert "add: -0.5 to 0.5; mul: 0 to 3" in " ".join(capsys.readouterr().out.split())


def test_erase_ground_shift_each_give_a_before_after_pair(studio):
    s, tab = studio.state, studio.edit
    tab.words.value = 2
    for kind, label in [("erase", "erase 'jumps'"), ("ground", "ground 'jumps'"), ("shift", "shift 50%")]:
        _run(studio, kind)
        after, before = s.item, s.compare_item
        assert label in after.name, after.name
        np.testing.assert_allclose(before.joints, _plain(studio).joints, atol=1e-4)
        # (the tiny model barely listens to its self-attention: shifting moves it by a hair)
        assert np.abs(after.joints - before.joints).max() > (1e-5 if kind == "shift" else 1e-3), kind
    # erase defaults to the last half of the frames
    tab.kind.value = "erase"
    assert tab.settings.frames == (30, 60)
    # the reference made again by another edit is reused, not added twice
    assert sum("· reference" in n for n in s.items) == 1


def test_example_based_and_style_transfer_with_session_sources(studio):
    s, tab = studio.state, studio.edit
    tab.plain["count"].value = 2
    _run(studio, "example-based")
    assert s.item.name.endswith("example-based #1") and "example" in s.compare_item.name
    assert any(n.endswith("example-based #2") for n in s.items)
    outs = [it for n, it in s.items.items() if "example-based #" in n]
    assert np.abs(outs[0].joints - outs[1].joints).max() > 1e-3  # diverse outputs
    # style transfer: sources among the session's motions. A generated one is used through its prompt, an
    # imported one as joints (DDIM-inverted by the engine function).
    from app.tabs.edit.job import resolve_source

    imported = s.show_motion(_plain(studio).joints[:41], title="imported: jumps")
    tab.kind.value = "style transfer"
    assert imported.name in tab.source.options and imported.name in tab.style_source.options
    assert isinstance(resolve_source(s, imported.name), np.ndarray)
    generated = next(n for n, it in s.items.items() if it.source == "generated" and "example" not in n)
    assert resolve_source(s, generated) == s.items[generated].prompt
    content_prompt = s.items[generated].prompt
    tab.source.value = generated
    tab.style_source.value = "(the prompt)"
    tab.style_prompt.value = "a person walks"
    _run(studio, "style transfer")
    assert "style transfer" in s.item.name and "content" in s.compare_item.name
    assert s.item.prompt == content_prompt and len(s.item.joints) == 60
    tab.source.value = "(the prompt)"


def test_replace_aligns_the_words_and_shows_how(studio):
    s, tab = studio.state, studio.edit
    tab.kind.value = "replace"
    assert tab.settings.edited == "a person kicks twice"  # a suggestion aligned with the prompt
    shown = html.unescape(tab.alignment.object)
    assert "align-ok" in shown and "aligned word by word" in shown and "'jumps' → 'kicks'" in shown, shown
    assert "'a' = 'a'" in shown and "'twice' = 'twice'" in shown
    # different word counts: aligned as prompt-to-prompt aligns them, and shown
    tab.edited.value = "a person kicks"
    shown = html.unescape(tab.alignment.object)
    assert "align-ok" in shown and "(4 → 3 words)" in shown and "'jumps twice' → 'kicks'" in shown, shown
    assert not tab.run.disabled
    tab.edited.value = "a person slowly jumps twice"
    shown = html.unescape(tab.alignment.object)
    assert "+ 'slowly' (new: its own attention)" in shown and "'jumps' = 'jumps'" in shown, shown
    # what cannot be replaced is refused with the reason
    tab.edited.value = "a person jumps twice"
    assert "align-bad" in tab.alignment.object and "the same as the prompt" in tab.alignment.object
    assert tab.run.disabled
    n_items = len(s.items)
    assert run_edit(s, tab.settings) is False  # refused with a visible error, no worker, no crash
    level, text = s.notices[-1]
    assert level == "error" and "the same as the prompt" in text
    assert not s.running and len(s.items) == n_items
    tab.kind.value = "emphasise"  # only replacement checks the edited prompt
    assert not tab.run.disabled
    tab.kind.value = "replace"
    assert tab.run.disabled
    tab.edited.value = "a person flurbs twice"  # the engine refuses it (nothing says a motion): its message
    assert "align-bad" in tab.alignment.object and "nothing else in the prompt says what to do" in tab.alignment.object
    assert tab.run.disabled
    tab.edited.value = "a person flibbers twice"  # read ... ok, but 'flibbers' in place of 'jumps' would be left out
    ok, message = tab._alignment()
    assert not ok and ("left out" in message or "cannot be read" in message), message
    assert tab.run.disabled
    tab.edited.value = "a person kicks twice"
    assert not tab.run.disabled
    _run(studio, "replace")
    assert "replace 'jumps' → 'kicks'" in s.item.name and s.item.prompt == "a person kicks twice"
    assert s.compare_item.prompt == "a person jumps twice"
    # a replacement with one word more runs too: the reference is the same motion
    tab.edited.value = "a person quickly kicks twice"
    _run(studio, "replace")
    assert "replace 'jumps' → 'quickly kicks'" in s.item.name and s.item.prompt == "a person quickly kicks twice"
    np.testing.assert_allclose(s.compare_item.joints, _plain(studio).joints, atol=1e-4)


def test_ground_to_several_spans_dragged_on_the_word_curve(studio):
    from bokeh.events import SelectionGeometry

    s, tab = studio.state, studio.edit
    assert s.generate() and s.wait(120)  # the plain motion again, shown with its attention (older ones lose theirs)
    plain = s.item
    np.testing.assert_allclose(plain.joints, _plain(studio).joints, atol=1e-4)
    tab.kind.value = "ground"
    tab.words.value = 2  # 'jumps'
    assert tab.spans_box.visible and not tab.frames.visible
    # the picked word's attention curve of the shown motion, to drag spans on
    curve = np.asarray(tab.span_curve_src.data["y"])
    assert len(curve) == 60 and np.allclose(curve, plain.attention.word_curve(2), atol=1e-6)
    assert "'jumps'" in tab.span_fig.title.text
    tab.clear_spans.clicks += 1
    assert tab.settings.spans == [] and "No span" in tab.spans_list.object

    def drag(x0, x1):  # what the browser sends when a drag on the curve ends (the x-only box select)
        tab.span_fig._trigger_event(SelectionGeometry(tab.span_fig, final=True,
                                                      geometry={"type": "rect", "x0": x0, "x1": x1, "y0": 0, "y1": 1}))

    drag(4.3, 13.6)
    drag(41.0, 30.2)  # dragged right to left
    assert tab.settings.spans == [(4, 14), (30, 41)]
    assert tab.span_src.data == {"x0": [4, 30], "x1": [14, 41]}  # drawn over the curve
    assert tab.spans_text.value == "4:14,30:41" and "<li>4–14" in tab.spans_list.object
    drag(10.0, 18.0)  # overlaps 4-14: refused, said, nothing changed
    level, text = s.notices[-1]
    assert level == "error" and "4:14 and 10:18 overlap" in text and tab.settings.spans == [(4, 14), (30, 41)]
    drag(-5.0, 2.4)  # clipped to the motion
    assert tab.settings.spans == [(0, 3), (4, 14), (30, 41)]
    # the spans as text: typed, checked the same way
    tab.spans_text.value = "4:14,30:41,48:58"
    assert tab.settings.spans == [(4, 14), (30, 41), (48, 58)]
    tab.spans_text.value = "4:14,50:70"
    level, text = s.notices[-1]
    assert level == "error" and "runs past the motion's end: it has 60 frames" in text
    assert tab.settings.spans == [(4, 14), (30, 41), (48, 58)] and tab.spans_text.value == "4:14,30:41,48:58"
    from app.tabs.edit.job import prepare

    plan = prepare(s, tab.settings)
    assert plan.options.frames == ((4, 14), (30, 41), (48, 58))
    _run(studio, "ground")
    assert "ground 'jumps' +0.30 frames 4–14, 30–41, 48–58" in s.item.name, s.item.name
    np.testing.assert_allclose(s.compare_item.joints, plain.joints, atol=1e-4)
    assert np.abs(s.item.joints - s.compare_item.joints).max() > 1e-3
    tab.clear_spans.clicks += 1
    assert tab.settings.spans == [] and tab.spans_text.value == "" and tab.span_src.data["x0"] == []
    assert prepare(s, tab.settings).options.frames is None  # no span: the whole motion
    tab.kind.value = "emphasise"
    assert tab.frames.visible and not tab.spans_box.visible


def test_example_based_chunk_size_is_a_setting(studio):
    from app.tabs.edit.job import prepare
    from engine.methods.edit_options import option_spec

    s, tab = studio.state, studio.edit
    spec = option_spec("chunk_frames")
    tab.kind.value = "example-based"
    chunk = tab.plain["chunk_frames"]
    assert chunk.visible and (chunk.start, chunk.end, chunk.value) == (4, 100, spec.default)
    assert chunk.name == spec.label and tab.plain_help["chunk_frames"].object == spec.help
    chunk.value = 10
    tab.plain["count"].value = 2
    assert prepare(s, tab.settings).options.chunk_frames == 10
    _run(studio, "example-based")
    assert s.item.name.endswith("example-based (10-frame chunks) #1"), s.item.name
    chunk.value = spec.default
    tab.kind.value = "emphasise"
    assert not chunk.visible


def test_bad_settings_are_notifications(studio):
    s, tab = studio.state, studio.edit
    tab.kind.value = "emphasise"
    tab.settings.word = ""
    assert run_edit(s, tab.settings) is False and "pick a word" in s.notices[-1][1]
    s.prompt = "a person walks"
    assert tab.settings.word == "" and list(tab.words.options) == ["a", "person", "walks"]
    s.prompt = "a person jumps twice"


def test_a_left_out_word_is_shown_and_cannot_be_pointed_at(studio):
    """The prompt runs with a word the model does not know (left out, issue #32 item 5), but an edit pointing at that
    word is refused with the engine's message; the word buttons say which words were left out."""
    s, tab = studio.state, studio.edit
    tab.kind.value = "emphasise"
    s.prompt = "a person jumps flibbers"
    assert s.reading.left_out == ("flibbers",) and not s.reading.blocked
    assert list(tab.words.options) == ["a", "person", "jumps", "flibbers (left out)"]
    tab.words.value = 3
    assert (tab.settings.word, tab.settings.occurrence) == ("flibbers", 0)
    n_items = len(s.items)
    assert run_edit(s, tab.settings) is False
    level, text = s.notices[-1]
    assert level == "error" and "'flibbers' was left out" in text and "cannot be pointed at" in text, text
    assert not s.running and len(s.items) == n_items
    tab.words.value = 2  # a word the model reads: accepted (checked, not run here)
    from app.tabs.edit.job import prepare
    assert prepare(s, tab.settings).options.word == "jumps"
    s.prompt = "a person jumps twice"


def test_cancel_stops_an_edit(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.param.update(prompt="a person walks", steps=1000, record_steps=0, seconds=2.0)
        st.edit.kind.value = "shift"
        assert run_edit(s, st.edit.settings)
        assert not st.edit.cancel.disabled and st.edit.run.disabled and st.controls.generate.disabled
        s.cancel()
        assert s.wait(60)
        assert s.notices[-1] == ("info", "edit cancelled") and s.items == {}
        assert not s.running and not st.edit.run.disabled
    finally:
        st.close()


# ---------------------------------------------------------------------------------------------- counting
def _periodic_record(n: int = 128, period: int = 32, words=("a", "person", "jumps")) -> AttentionRecord:
    """Self-attention of four hops: every frame attends to its neighbours and to the same phase of every hop."""
    sm = cyclic_attention_map(n // period, rest=0, period=period)
    self_maps = np.broadcast_to(sm, (2, 1, 1, n, n)).astype(np.float16)
    cross = np.full((2, 1, 1, n, len(words)), 1 / len(words), np.float16)
    return AttentionRecord(words=tuple(words), steps=(5, 9), num_steps=10, timesteps=(-1, -1),
                           self_maps=np.ascontiguousarray(self_maps), cross_maps=cross)


def test_counting_readout_shows_count_baseline_and_peaks(studio):
    from app.session.items import MotionItem

    s, tab, ex = studio.state, studio.edit, studio.attention
    t = np.arange(128)
    joints = np.repeat(_plain(studio).joints[:1], 128, axis=0)  # a standing pose...
    joints[:, :, 1] += 0.1 * np.maximum(0, np.sin(2 * np.pi * t / 32))[:, None]  # ...that hops four times
    s.add_item(MotionItem(name="periodic", joints=joints, source="generated", prompt="a person jumps",
                          words=("a", "person", "jumps"), attention=_periodic_record()))
    readout = s.count_result
    assert readout is not None and readout.item == "periodic"  # counted as soon as it is shown
    assert tab.count_map_box.visible
    assert readout.rounded == 4 and readout.baseline == 4 and len(readout.peaks) > 4
    assert 'class="count-attention">4.' in tab.readout.object and 'class="count-baseline">4<' in tab.readout.object
    assert 'class="count-rounded">4<' in tab.readout.object
    assert readout.period == 32 and 'class="count-period">32 frames (1.60 s)<' in tab.readout.object
    first, last = readout.span
    assert first <= 4 and last >= 123 and f'class="count-span">{first}–{last}<' in tab.readout.object
    # peaks drawn on the counting map and over the explorer's self-attention heatmap
    assert len(tab.peak_src.data["x"]) == len(readout.peaks)
    assert tab.count_src.data["image"][0].shape == (32, 32) and tab.count_src.data["dw"] == [128]
    assert len(ex.peak_src.data["x"]) == len(readout.peaks)
    assert {(int(y - 0.5), int(x - 0.5)) for x, y in zip(ex.peak_src.data["x"], ex.peak_src.data["y"])} \
        == set(readout.peaks)
    # an imported motion: no maps until Count inverts it (on the worker)
    s.show_motion(joints, title="imported: hops")
    assert s.count_result is None and "no recorded attention" in tab.readout.object
    assert ex.peak_src.data["x"] == []
    assert not tab.count_map_box.visible  # no empty map beside the text that says why there is none
    assert tab.count_button.visible  # the counting section's button, while another kind is picked
    tab.kind.value = "count"
    assert tab.run.label == "Count this motion" and not tab.count_button.visible  # never two such buttons
    assert run_edit(s, tab.settings) and s.wait(120)
    readout = s.count_result
    assert readout.item == "imported: hops" and readout.baseline == 4 and "inverted" in readout.source
    assert "count-attention" in tab.readout.object and tab.count_map_box.visible
    tab.kind.value = "emphasise"


def test_counting_method_is_chosen_and_recounts_the_same_map(studio):
    from app.session.items import MotionItem
    from engine.analysis.counting import COUNTING_METHODS, CountingConfig, count_from_attention

    s, tab = studio.state, studio.edit
    assert list(tab.count_method.options.values()) == list(COUNTING_METHODS) and s.count_method == "lag"
    joints = np.repeat(_plain(studio).joints[:1], 128, axis=0)
    s.add_item(MotionItem(name="periodic 2", joints=joints, source="generated", prompt="a person jumps",
                          words=("a", "person", "jumps"), attention=_periodic_record()))
    lag = s.count_result
    assert lag.method == "lag" and lag.rounded == 4 and 'class="count-method-used">lag<' in tab.readout.object
    try:
        for method in ("published", "rows"):
            tab.count_method.value = method
            readout = s.count_result
            assert s.count_method == method and readout.method == method and readout.item == "periodic 2"
            expected = count_from_attention(lag.self_map, CountingConfig(method=method))
            assert readout.count == expected.count and readout.peaks == expected.peaks and readout.period is None
            assert f'class="count-method-used">{method}<' in tab.readout.object
            assert f'class="count-attention">{expected.count:.2f}<' in tab.readout.object
        # an imported motion counted by inversion keeps its map: another method recounts it without inverting again
        s.show_motion(joints, title="imported: still")
        tab.count_button.clicks += 1
        assert s.wait(120) and s.count_result.item == "imported: still" and s.count_result.method == "rows"
        inverted = s.count_result
        tab.count_method.value = "published"
        assert not s.running and s.count_result.method == "published" and s.count_result.source == inverted.source
        assert np.array_equal(s.count_result.self_map, inverted.self_map)
    finally:
        tab.count_method.value = "lag"
    assert s.count_result.method == "lag"


# ---------------------------------------------------------------------------------------------- shared mapping
def test_word_choice_and_alignment_helpers():
    assert word_choice(["a", "person", "jumps", "and", "jumps"], 4) == ("jumps", 1)
    ok, message = alignment(None, "a person jumps", "a person walks")
    assert ok and "'jumps' → 'walks' (its own attention)" in message  # the default: the swapped word keeps its own
    ok, message = alignment(None, "a person jumps", "a person walks fast")
    assert ok and "(3 → 4 words)" in message and "'jumps' → 'walks fast' (their own attention)" in message, message
    ok, message = alignment(None, "a person jumps", "a person walks fast", swapped="reference")  # the paper's
    assert ok and "'jumps' → 'walks fast' (its attention shared by the 2 words)" in message, message
    assert "'jumps' → 'walks', 'high' = 'high'" in alignment(None, "a person jumps high", "a person walks high",
                                                             swapped="reference")[1]
    ok, message = alignment(None, "a person jumps and waves", "a person jumps")
    assert ok and "− 'and waves' (dropped)" in message, message
    assert not alignment(None, "a person jumps", "a person jumps")[0]
    assert not alignment(None, "a person jumps", "")[0]


def test_replace_alignment_reads_both_prompts_as_the_engine_does(tiny_model_dir):
    from engine.checkpoint import load_model

    tok = load_model(tiny_model_dir).tokenizer
    # words left out of both prompts alike keep the alignment; the engine's notes are said
    ok, message = alignment(tok, "a person jumps flibbers", "a person kicks flibbers")
    assert ok and "'jumps' → 'kicks'" in message and "left out: flibbers" in message, message
    # a swapped-in word the engine leaves out cannot replace anything
    ok, message = alignment(tok, "a person jumps and walks", "a person flibbers and walks")
    assert not ok and "'flibbers' is left out of the edited prompt" in message, message
    # a word read by meaning or as a typo can be swapped in
    ok, message = alignment(tok, "a person jumps twice", "a person kiks twice")
    assert ok and "read 'kiks' as 'kicks'" in message, message
    # a prompt the engine refuses: its message
    ok, message = alignment(tok, "a person jumps", "a person flurbs")
    assert not ok and "edited prompt cannot be read" in message and "nothing else" in message


def test_layers_that_do_not_exist_are_refused(tiny_model_dir, tmp_path, capsys):
    from engine.checkpoint import load_model
    from engine.cli import main
    from engine.generate import SampleConfig
    from engine.methods.edit_options import run_edit

    loaded = load_model(tiny_model_dir)
    n = loaded.model.num_layers
    options = EditOptions(kind="emphasize", prompt="a person jumps", word="jumps", layers=(0, n))
    with pytest.raises(ValueError, match=rf"layers \[{n}\] do not exist: the model has layers 0..{n - 1}"):
        run_edit(loaded, options, frames=20, sample=SampleConfig(steps=2))
    out = tmp_path / "e.npy"
    assert main(["edit", "emphasize", "a person jumps", "--word", "jumps", "--layers", str(n + 3), "--steps", "2",
                 "--seconds", "1", "--model", str(tiny_model_dir), "--out", str(out)]) == 2
    assert "do not exist" in capsys.readouterr().err and not out.exists()
    assert main(["edit", "emphasize", "a person jumps", "--word", "jumps", "--layers", str(n - 1), "--steps", "2",
                 "--seconds", "1", "--model", str(tiny_model_dir), "--out", str(out)]) == 0
    assert out.exists()


@pytest.mark.parametrize("argv, said", [
    (["emphasize", "a person jumps", "--word", "jumps", "--fraction", "0.3"],
     "--fraction is not read by emphasize (it is read by shift)"),
    (["erase", "a person jumps", "--word", "jumps", "--weight", "0.2"],
     "--weight is not read by erase (it is read by emphasize, ground)"),
    (["replace", "a person jumps", "--edited", "a person kicks", "--word", "jumps"], "--word is not read by replace"),
    (["shift", "a person jumps", "--to-frame", "9"], "--from-frame/--to-frame are not read by shift"),
    (["emphasize", "a person jumps", "--word", "jumps", "--copy-self-attention"],
     "--copy-self-attention is not read by emphasize (it is read by replace)"),
])
def test_a_flag_the_kind_does_not_read_is_refused(argv, said):
    from engine.cli.common import Parser
    from engine.cli.edit import add_parser, options_from_args

    parser = Parser(prog="moattn")
    add_parser(parser.add_subparsers())
    with pytest.raises(ValueError) as refused:
        options_from_args(parser.parse_args(["edit", *argv]))
    assert str(refused.value).startswith(said), refused.value
    # the same flag at its declared default's value changes nothing: not refused
    options_from_args(parser.parse_args(["edit", "emphasize", "a person jumps", "--word", "jumps", "--fraction", "0.5"]))


def test_cli_and_tab_share_the_option_mapping():
    from engine.cli.edit import add_parser, options_from_args
    from engine.cli.common import Parser

    parser = Parser(prog="moattn")  # the CLI's own: no abbreviated flags
    add_parser(parser.add_subparsers())
    args = parser.parse_args(["edit", "emphasize", "a person jumps twice", "--word", "jumps", "--weight", "0.5",
                              "--from-frame", "10", "--to-frame", "30", "--step-window", "0.2", "0.8",
                              "--layers", "1", "0"])
    options = options_from_args(args)
    assert options == EditOptions(kind="emphasize", prompt="a person jumps twice", word="jumps", weight=0.5,
                                  frames=(10, 30), step_window=(0.2, 0.8), layers=(1, 0))  # count: the declared default
    cfg = build_config(options, frames=60)
    assert cfg.frames == (10, 30) and cfg.window.layers == (0, 1) and (cfg.window.start, cfg.window.end) == (0.2, 0.8)
    erase = build_config(EditOptions(kind="erase", word="jumps"), frames=60)
    assert erase.mode == "mul" and erase.weight == 0.1 and erase.frames == (30, 60)
    assert build_config(EditOptions(kind="shift"), frames=60).window.end == 0.4  # the method's default window
    with pytest.raises(ValueError, match="needs a word"):
        build_config(EditOptions(kind="ground"), frames=60)
    # replacement copies the cross-attention (the paper); --copy-self-attention adds the self-attention (authors' code)
    plain = parser.parse_args(["edit", "replace", "a person jumps", "--edited", "a person kicks"])
    assert not build_config(options_from_args(plain), frames=60).self_attention
    both = parser.parse_args(["edit", "replace", "a person jumps", "--edited", "a person kicks",
                              "--copy-self-attention"])
    assert build_config(options_from_args(both), frames=60).self_attention


def test_a_session_opens_on_its_models_calibrated_emphasis_mode(tiny_model_dir, tmp_path, capsys):
    """A model calibrated to multiply (config.json "edits") opens the Edit tab on x2; switching the mode takes the
    new mode's default weight (+0.3 added is not x0.3 multiplied); `moattn edit` without --mode reports the same."""
    import json
    import shutil

    from engine.cli import main
    from engine.evaluation.calibrate_edits import write_calibration
    from engine.methods.edit_options import DEFAULT_WEIGHTS

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    write_calibration(folder, {"mode": "mul", "layers": [0], "response": 0.5, "change": 0.1})
    st = Studio(model_dir=folder, initial=None)
    try:
        tab = st.edit
        assert (tab.settings.mode, tab.settings.weight) == ("mul", DEFAULT_WEIGHTS["mul"])
        assert (tab.weight.start, tab.weight.end, tab.weight.value) == (0.0, 3.0, 2.0)
        tab.mode.value = "add"
        assert (tab.settings.weight, tab.weight.value) == (DEFAULT_WEIGHTS["add"],) * 2
        tab.weight.value = 0.45
        tab.mode.value = "mul"
        assert tab.settings.weight == DEFAULT_WEIGHTS["mul"]
        assert tab.settings.layers == [0] and tab.layers.value == [0]  # the layers calibrated for mul
        tab.mode.value = "guide"  # the word erased in every layer: the calibrated layers are mul's
        assert (tab.weight.start, tab.weight.end, tab.settings.weight) == (-1.0, 1.0, DEFAULT_WEIGHTS["guide"])
        assert tab.settings.layers == [] and tab.layers.value == []
        tab.mode.value = "mul"
        assert tab.settings.layers == [0]
    finally:
        st.close()
    plain = Studio(model_dir=tiny_model_dir, initial=None)  # no calibrated mode: the paper's add, +0.3
    try:
        assert (plain.edit.settings.mode, plain.edit.settings.weight) == ("add", DEFAULT_WEIGHTS["add"])
    finally:
        plain.close()
    out = tmp_path / "e.npy"
    assert main(["edit", "emphasize", "a person jumps", "--word", "jumps", "--steps", "2", "--seconds", "1",
                 "--model", str(folder), "--out", str(out), "--no-library"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert (report["mode"], report["weight"]) == ("mul", 2.0)
    from engine.analysis.action_size import amplitude

    size = report["action_size"]  # the edited motion's action, measured as the bench measures it
    assert size["word"] == "jumps" and size["measure"] == "feet's peak above the floor"
    assert size["after_m"] == pytest.approx(amplitude(np.load(out), "jumps"), abs=1e-3)


def test_a_model_calibrated_to_intensity_falls_back_for_a_word_the_corpus_does_not_scale(tiny_model_dir, tmp_path):
    """Intensity mode has no intensity word for "punches": picking that word moves the calibrated mode to the
    calibration's fallback (with its layers) and picking "jumps" again moves it back; a mode the user chose stays."""
    import shutil

    from engine.evaluation.calibrate_edits import write_calibration
    from engine.methods.edit_options import DEFAULT_WEIGHTS

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    write_calibration(folder, {"mode": "intensity", "layers": [0, 1], "fallback": {"mode": "mul", "layers": [1]},
                               "response": 0.9, "change": 0.5})
    st = Studio(model_dir=folder, initial=None)
    try:
        tab, s = st.edit, st.state
        tab.kind.value = "emphasise"
        s.prompt = "a person jumps then punches"
        assert (tab.settings.mode, tab.settings.weight) == ("intensity", DEFAULT_WEIGHTS["intensity"])
        tab.words.value = 4  # punches
        assert (tab.settings.word, tab.settings.mode, tab.settings.weight) == ("punches", "mul", DEFAULT_WEIGHTS["mul"])
        assert tab.settings.layers == [1] and tab.layers.value == [1]  # the fallback's own calibrated layers
        assert tab.layers.visible
        tab.words.value = 2  # jumps
        assert (tab.settings.word, tab.settings.mode) == ("jumps", "intensity")
        assert not tab.layers.visible  # intensity guides through another prompt: no layers to choose
        from app.tabs.edit.job import prepare

        tab.settings.layers = [0, 1]  # what the box held stays unsent: the edit is prepared, not refused
        plan = prepare(s, tab.settings)
        assert plan.options.layers is None and plan.options.mode == "intensity"
        tab.mode.value = "add"  # the user's choice is kept whatever the word
        tab.words.value = 4
        assert tab.settings.mode == "add"
    finally:
        st.close()


def test_switching_to_ground_after_a_multiplied_emphasis_takes_a_grounding_weight(tiny_model_dir, tmp_path):
    """Emphasis opens at x2 on a model calibrated to multiply; grounding adds a weight in (0, 1]: switching kinds
    must not hand it the 2 (it was refused: "the grounding weight must be in (0, 1]")."""
    import shutil

    from engine.evaluation.calibrate_edits import write_calibration
    from engine.methods.edit_options import DEFAULT_WEIGHTS

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    write_calibration(folder, {"mode": "mul", "layers": [0], "response": 0.5, "change": 0.1})
    st = Studio(model_dir=folder, initial=None)
    try:
        s, tab = st.state, st.edit
        s.param.update(prompt="a person jumps twice", seconds=2.0, steps=4, record_steps=2, seed=1)
        assert s.generate() and s.wait(120), s.notices
        assert (tab.settings.mode, tab.settings.weight) == ("mul", 2.0)
        tab.kind.value = "ground"
        assert (tab.settings.mode, tab.settings.weight) == ("add", DEFAULT_WEIGHTS["add"])
        tab.words.value = 2
        before = len(s.notices)
        assert run_edit(s, tab.settings) and s.wait(120)
        assert not [n for n in s.notices[before:] if n[0] == "error"], s.notices[before:]
        tab.kind.value = "emphasise"  # back: the calibrated x2 again
        assert (tab.settings.mode, tab.settings.weight) == ("mul", 2.0)
    finally:
        st.close()
