"""The Duet tab (ComMDM) without a server, on the tiny model and a tiny trained block: a duet from a prompt (two
session motions shown together in one scene, in two colours), a completion of an example prefix (the prefix
kept, its frames greyed), the block off, checks with clear messages (unknown words, lengths, bad uploads, no
duet model), and the duet's exports holding both people."""
from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from app.session.duets import is_duet
from app.tabs.duet.job import PREFIX_COLOR, DuetJob
from app.tabs.duet.models import EXAMPLE
from app.main import Studio
from app.tabs.files.exports import export_bytes, export_filename
from viz.colors import default_joint_colors

pytestmark = pytest.mark.timeout(600)


@pytest.fixture()
def studio(tiny_model_dir, tiny_duet_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None, duet_dir=tiny_duet_dir)
    st.state.param.update(steps=4, seed=1)
    yield st
    st.close()


def _run(studio) -> bool:
    s = studio.state
    studio.duet.bar.run.clicks += 1
    return s.wait(300)


def test_duet_from_a_prompt_is_shown_in_one_scene(studio):
    s, tab = studio.state, studio.duet
    d = tab.settings
    assert "ComMDM block after layer 2 of 2" in tab.model_note.object
    tab.prompt.value = "two people give each other a high five"
    tab.seconds.value = 2.0
    assert _run(studio) and not [n for n in s.notices if n[0] == "error"], s.notices
    r = d.result
    assert r is not None and r.mode == "text" and r.communicate and r.n_frames == 40
    a, b = (s.items[n] for n in r.names)
    assert s.current == a.name and s.also == [b.name]
    assert is_duet(s.shown_items) and a.info["duet"] is b.info["duet"]
    np.testing.assert_array_equal(a.info["duet"].joints[1], b.joints)
    spec = studio.viewer.spec()
    assert spec.together and len(spec.motions) == 2  # one shared space, not side by side
    assert f"{r.distance_m:.2f} m" in tab.readout.object and "person b orange" in tab.readout.object
    # showing one other motion ends the shared scene
    s.show_motion(np.zeros((10, 22, 3), dtype=np.float32) + np.arange(22)[None, :, None] * 0.05, title="x")
    assert not studio.viewer.spec().together
    # the finished job's status line belongs to its mode: switching to completion clears it
    assert tab.bar.status.object
    tab.mode.value = "prefix"
    assert tab.bar.status.object == "" and s.status == ""


def test_completion_of_an_example_keeps_and_greys_the_prefix(studio):
    from app.tabs.duet.models import example

    s, tab = studio.state, studio.duet
    tab.mode.value = "prefix"
    assert tab.prefix_box.visible and tab.seconds.value == 3.0
    assert tab.prefix.value == EXAMPLE + "handshake" and EXAMPLE + "hug" in tab.prefix.options
    tab.prompt.value = ""  # unconditional, as in the paper
    tab.prefix.value = EXAMPLE + "push"
    tab.seconds.value = 2.0
    tab.communicate.value = False
    assert _run(studio), s.notices
    r = tab.settings.result
    assert r.mode == "prefix" and r.prefix_frames == 20 and r.n_frames == 60 and not r.communicate
    ex = example(EXAMPLE + "push")
    a, b = (s.items[n] for n in r.names)
    np.testing.assert_allclose(a.joints[:20], ex.joints_a[:20], atol=2e-3)
    np.testing.assert_allclose(b.joints[:20], ex.joints_b[:20], atol=2e-3)
    colors = s.frame_colors[a.name]
    np.testing.assert_array_equal(colors[5], default_joint_colors(PREFIX_COLOR))
    assert not np.array_equal(colors[30], colors[5])
    assert "no block" in a.name and "first 20 given" in tab.readout.object
    # the duet just made is offered as a prefix too
    assert a.name in tab.prefix.options


@pytest.mark.parametrize("change, message", [
    ({"prompt": "two people flibber"}, "flibber"),
    ({"prompt": "  "}, "type what the two people do"),
    ({"seconds": 30.0}, "between 1 and 9.8 s"),
    ({"mode": "prefix", "seconds": 9.5}, "must fit in"),
    ({"mode": "prefix", "prefix_seconds": float("nan")}, "number of seconds"),
])
def test_bad_input_gets_a_clear_message(studio, change, message):
    s, d = studio.state, studio.duet.settings
    d.param.update(**change)
    assert not studio.duet.settings.mode == "text" or not d.reading.left_out or "flibber" in message
    assert not s.launch(DuetJob(session=s, settings=d))
    level, text = s.notices[-1]
    assert level == "error" and text.startswith("cannot make a duet:") and message in text, text
    assert not s.running


def test_unknown_words_are_flagged_and_block_the_button(studio):
    tab = studio.duet
    tab.prompt.value_input = "two people smooch"
    assert "smooch" in tab.flag.object and tab.bar.run.disabled
    tab.prompt.value_input = "two people hug"
    assert tab.flag.object == "" and not tab.bar.run.disabled
    # the browser may send the typed text and Enter in one message: both events reach one watcher at once
    tab.prompt.param.update(value="two people snog", value_input="two people snog")
    assert "snog" in tab.flag.object and tab.settings.prompt == "two people snog"


@pytest.mark.parametrize("tab_name, widget", [("compose", "rows"), ("control", "prompt"), ("transfer", "leader"),
                                              ("edit", "edited")])
def test_every_text_input_takes_batched_events(studio, tab_name, widget):
    tab = getattr(studio, tab_name)
    if widget == "rows":
        box = tab.rows[0].prompt
    elif widget == "leader":
        box = tab.leader.prompt
    else:
        box = getattr(tab, widget)
    box.param.update(value="a person waves", value_input="a person waves")  # no error raised
    assert box.value == "a person waves"


def test_uploads_are_parsed_as_data(studio, tmp_path):
    s, tab = studio.state, studio.duet
    good = np.stack([_walker(0.0), _walker(1.0)])
    buf = io.BytesIO()
    np.save(buf, good)
    tab.upload.filename = "pair.npy"
    tab.upload.value = buf.getvalue()
    assert tab.settings.prefix == "upload: pair.npy" and tab.prefix.value == "upload: pair.npy"
    bad = io.BytesIO()
    np.save(bad, np.zeros((30, 22, 3), dtype=np.float32))
    tab.upload.filename = "single.npy"
    tab.upload.value = bad.getvalue()
    assert s.notices[-1][0] == "error" and "(2, T, 22, 3)" in s.notices[-1][1]
    tab.upload.filename = "evil.npy"
    tab.upload.value = b"\x80\x04pickled"
    assert s.notices[-1][0] == "error" and "evil.npy" in s.notices[-1][1]
    assert tab.settings.prefix == "upload: pair.npy"  # nothing lost


def _walker(x: float) -> np.ndarray:
    from engine.synth import Corpus

    j = Corpus("test").sample(3).joints[:40].copy()
    j[..., 0] += x
    return j


def test_a_duet_folder_with_its_own_prior_works_beside_a_newer_studio_model(tiny_model_dir, tiny_duet_dir, tmp_path):
    """The studio's base moved on (other weights); the duet folder ships the base its block was trained on."""
    import shutil

    import torch

    newer = tmp_path / "newer"
    shutil.copytree(tiny_model_dir, newer)
    weights = torch.load(newer / "weights.pt", weights_only=True)
    name = next(k for k, v in weights.items() if v.is_floating_point())
    weights[name] = weights[name] * 0.5
    torch.save(weights, newer / "weights.pt")
    duet_dir = tmp_path / "duet"
    shutil.copytree(tiny_duet_dir, duet_dir)
    shutil.copytree(tiny_model_dir, duet_dir / "prior")
    st = Studio(model_dir=newer, initial=None, duet_dir=duet_dir)
    try:
        st.state.param.update(steps=4, seed=1)
        assert "runs on the base model it was trained on" in st.duet.model_note.object
        st.duet.prompt.value = "two people give each other a high five"
        st.duet.seconds.value = 2.0
        assert _run(st) and not [n for n in st.state.notices if n[0] == "error"], st.state.notices
        assert st.duet.settings.result is not None and st.duet.settings.result.n_frames == 40
    finally:
        st.close()

    plain = Studio(model_dir=tiny_model_dir, initial=None, duet_dir=duet_dir)
    try:  # on the base it was trained on, nothing to say
        assert "ComMDM block" in plain.duet.model_note.object
        assert "runs on the base model" not in plain.duet.model_note.object
    finally:
        plain.close()


def test_no_duet_model_is_said_once_and_refused(tiny_model_dir, tmp_path):
    st = Studio(model_dir=tiny_model_dir, initial=None, duet_dir=tmp_path / "none")
    try:
        assert "no duet model" in st.duet.model_note.object

        assert not st.state.launch(DuetJob(session=st.state, settings=st.duet.settings))
        assert "no duet model" in st.state.notices[-1][1]
    finally:
        st.close()


def test_duet_exports_hold_both_people(studio):
    s, tab = studio.state, studio.duet
    tab.seconds.value = 1.5
    assert _run(studio)
    a = s.item
    data = np.load(io.BytesIO(export_bytes(a, "joints.npy")))
    assert data.shape == (2, 30, 22, 3)
    vecs = np.load(io.BytesIO(export_bytes(a, "vecs.npy")))
    assert vecs.shape == (2, 29, 263)
    assert export_filename(a, "bvh").endswith(".bvh.zip") and " · a" not in export_filename(a, "bvh")
    with zipfile.ZipFile(io.BytesIO(export_bytes(a, "bvh"))) as zf:
        names = zf.namelist()
        assert len(names) == 2 and names[0].endswith("_a.bvh") and names[1].endswith("_b.bvh")
        assert zf.read(names[1]).startswith(b"HIERARCHY")
    gif = export_bytes(a, "gif")
    assert gif[:6] in (b"GIF89a", b"GIF87a")


def test_the_model_line_is_read_from_the_loaded_models_never_a_recorded_step(tmp_path):
    """Issue #35: the Duet tab named its base model by the step the block's config recorded (``prior_step``), not
    by the model actually loaded. The line now reads the loaded prior (its folder and its step: config.json, else
    its TRAINING.md) and the block's own folder."""
    from types import SimpleNamespace

    from app.tabs.duet.models import base_step, model_line

    shipped = tmp_path / "duet" / "prior"
    shipped.mkdir(parents=True)
    (shipped / "TRAINING.md").write_text("# Shipped model\n\nExported from `runs/base` at training step 4321.\n")
    prior = SimpleNamespace(config={}, folder=shipped, model=SimpleNamespace(num_layers=6))
    studio_base = SimpleNamespace(config={"step": 7018}, folder=tmp_path / "model")
    block = SimpleNamespace(config={"step": 3000, "samples": 48, "prior_step": 5777}, folder=tmp_path / "duet",
                            prior=prior, denoiser=SimpleNamespace(after=5))
    assert base_step(prior) == "4321" and base_step(studio_base) == "7018"
    line = model_line(block, studio_base)
    assert "5777" not in line, line
    assert "step 4321" in line and str(shipped) in line and "step 7018" in line and str(tmp_path / "duet") in line
    block.prior = studio_base
    studio_base.model = prior.model
    assert model_line(block, studio_base).endswith("It runs on the studio's base model (step 7018).")
