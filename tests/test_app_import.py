"""The studio's import (app/tabs/files/view.py): the Start / Seconds window of a long file, bounded by the model's limit;
bad input is a one-line message and the session goes on."""
from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np
import pytest

from app import model_cache
from app.session.state import StudioState
from app.tabs.files.view import ImportPanel
from app.uploads import import_window


def _npy(frames: int) -> bytes:
    rng = np.random.default_rng(0)
    joints = np.tile(rng.normal(0, 0.3, (1, 22, 3)).astype(np.float32), (frames, 1, 1))
    joints[:, :, 0] += np.arange(frames, dtype=np.float32)[:, None] * 0.01  # pelvis x: the frame number in cm
    buf = io.BytesIO()
    np.save(buf, joints, allow_pickle=False)
    return buf.getvalue()


def _upload(panel: ImportPanel, data: bytes, name: str) -> None:
    """What the browser sends for a picked file: its name and content in one change (an empty file: no content)."""
    panel._input._process_events({"filename": name, "value": base64.b64encode(data).decode(), "mime_type": ""})


def test_import_window_cuts_and_refuses_with_the_fields_names():
    joints, total = import_window(_npy(208), "long.npy", start=1.0, seconds=2.5, max_frames=196)
    assert total == 208 and len(joints) == 50
    whole, _ = import_window(_npy(208), "long.npy", start=0.0, seconds=None)  # no limit: all of it
    assert len(whole) == 208 and np.allclose(joints, whole[20:70])
    with pytest.raises(ValueError, match="^long.npy is 10.4 s, longer than the model's 9.8 s: pick a window with "
                                         "Start/Seconds$"):
        import_window(_npy(208), "long.npy", start=0.0, seconds=None, max_frames=196)
    with pytest.raises(ValueError, match="^Start 11 s is beyond the end of long.npy"):
        import_window(_npy(208), "long.npy", start=11.0, seconds=None, max_frames=196)


def test_panel_picks_the_window_of_a_long_upload():
    state = StudioState()  # no model: the default model config's limit
    panel = ImportPanel(state=state)
    assert panel.max_frames == 196 and panel.seconds.end == pytest.approx(9.8) and panel.again.disabled
    _upload(panel, _npy(208), "long.npy")
    level, text = state.notices[-1]
    assert level == "error" and text == ("Could not import long.npy: long.npy is 10.4 s, longer than the model's "
                                         "9.8 s: pick a window with Start/Seconds")
    assert not state.items and not panel.again.disabled
    panel.start.value, panel.seconds.value = 0.6, 9.8
    panel.again.clicks += 1  # "Import window" re-reads the last upload
    assert state.notices[-1] == ("info", "imported long.npy: 196 frames (9.8 s) from 0.6 s of its 10.4 s")
    item = state.item
    assert item.name == "imported: long.npy [0.6–10.4 s]" and item.n_frames == 196
    panel.start.value = 20.0
    assert panel.import_upload() is False
    assert state.notices[-1][0] == "error" and "Start 20 s is beyond the end of long.npy" in state.notices[-1][1]
    assert len(state.items) == 1  # the session keeps what it had
    panel.start.value, panel.seconds.value = 0.0, None
    _upload(panel, _npy(60), "short.npy")  # a short file: whole, as before
    assert state.notices[-1] == ("info", "imported short.npy: 60 frames (3.0 s)")


def test_the_seconds_bound_is_the_loaded_models_limit(tmp_path):
    import torch

    from engine.checkpoint import LoadedModel
    from engine.model import Denoiser, ModelConfig
    from engine.representation import FEATURE_DIM, Normalizer
    from engine.text import Tokenizer

    torch.manual_seed(0)
    model = Denoiser(ModelConfig(width=32, layers=1, heads=2, text_layers=1, vocab_size=8, max_frames=100)).eval()
    loaded = LoadedModel(model=model, tokenizer=Tokenizer(["a"]), folder=tmp_path, config={},
                         normalizer=Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM)))
    key = Path(tmp_path).resolve()
    model_cache._cache[key] = loaded  # what get_model returns for this folder
    try:
        state = StudioState(model_dir=tmp_path)
        panel = ImportPanel(state=state)
        assert panel.max_frames == 100 and panel.seconds.end == pytest.approx(5.0)
        _upload(panel, _npy(120), "six.npy")
        assert "six.npy is 6.0 s, longer than the model's 5.0 s" in state.notices[-1][1]
        panel.seconds.value = 5.0
        assert panel.import_upload() and state.item.n_frames == 100
    finally:
        model_cache._cache.pop(key, None)
