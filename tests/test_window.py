"""The window of a longer motion (engine.io.window): exact frame counts, one-line errors, and the --start/--seconds
flags of moattn convert / invert / transfer."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.cli import main
from engine.generate import FPS
from engine.io import load_motion, pick_window, seconds_of, window_slice
from engine.model import ModelConfig
from tests.conftest import random_corpus_model, real_file

LIMIT = ModelConfig().max_frames  # 196 poses, 9.8 s


def _motion(frames: int) -> np.ndarray:
    """A valid motion whose pose index is readable from it (the pelvis's x is the frame number in cm)."""
    rng = np.random.default_rng(0)
    joints = np.tile(rng.normal(0, 0.3, (1, 22, 3)).astype(np.float32), (frames, 1, 1))
    joints[..., 1] += 1.0
    joints[:, :, 0] += np.arange(frames, dtype=np.float32)[:, None] * 0.01
    return joints


def _first(window: np.ndarray) -> int:
    return int(round((window[0, 0, 0] - _motion(1)[0, 0, 0]) * 100))


def test_window_keeps_exact_frames():
    joints = _motion(208)  # 10.4 s at 20 fps
    assert FPS == 20 and seconds_of(LIMIT) == pytest.approx(9.8)
    assert pick_window(joints) is not None and len(pick_window(joints)) == 208  # no window, no limit: all of it
    w = pick_window(joints, start=1.0, seconds=5.0)
    assert len(w) == 100 and _first(w) == 20 and np.array_equal(w, joints[20:120])
    assert window_slice(208, start=0.5) == slice(10, 208)  # to the end
    assert window_slice(208, seconds=2.0) == slice(0, 40)  # from the beginning
    assert window_slice(208, start=0.026, seconds=0.1) == slice(1, 3)  # rounded to the nearest pose
    assert window_slice(208, start=0.6, seconds=9.8, max_frames=LIMIT) == slice(12, 208)  # exactly the limit
    assert window_slice(170, max_frames=LIMIT) == slice(0, 170)  # short enough: whole
    assert window_slice(LIMIT, max_frames=LIMIT) == slice(0, LIMIT)


@pytest.mark.parametrize("kwargs, message", [
    ({"max_frames": LIMIT}, "walk.bvh is 10.4 s, longer than the model's 9.8 s: pick a window with --start/--seconds"),
    ({"start": -1.0}, "--start must be 0 s or more, got -1 s"),
    ({"start": 10.4}, "--start 10.4 s is beyond the end of walk.bvh (10.4 s, 208 frames)"),
    ({"start": 12.0, "seconds": 1.0}, "--start 12 s is beyond the end"),
    ({"start": 10.35}, "the window holds 1 frame(s) of walk.bvh; at least 2 are needed"),
    ({"seconds": 0.0}, "--seconds must be more than 0 s"),
    ({"seconds": float("nan")}, "--seconds must be a number of seconds"),
    ({"start": "soon"}, "--start must be a number of seconds, got 'soon'"),
    ({"start": 5.0, "seconds": 6.0}, "the window 5 s + 6 s runs past the end of walk.bvh (10.4 s, 208 frames): at most "
                                     "5.4 s from 5 s"),
    ({"seconds": 10.0, "max_frames": LIMIT}, "--seconds 10 s is longer than the model's 9.8 s"),
    ({"start": 0.3, "max_frames": LIMIT}, "walk.bvh from 0.3 s to its end is 10.1 s, longer than the model's 9.8 s: "
                                          "add --seconds (at most 9.8)"),
])
def test_window_errors_are_one_line(kwargs, message):
    with pytest.raises(ValueError) as err:
        pick_window(_motion(208), name="walk.bvh", **kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_window_names_the_callers_fields_and_hint():
    with pytest.raises(ValueError, match="^Start must be 0 s or more"):
        pick_window(_motion(50), start=-2, flags=("Start", "Seconds"))
    with pytest.raises(ValueError, match="pick a window with Start/Seconds$"):
        pick_window(_motion(300), max_frames=LIMIT, flags=("Start", "Seconds"))
    with pytest.raises(ValueError, match="9.8 s: choose$"):
        pick_window(_motion(300), max_frames=LIMIT, hint="choose")


# ---------------------------------------------------------------------------------------------- the CLI
def test_convert_cuts_the_real_cmu_file(tmp_path, capsys):
    path = real_file("cmu_131_01_walk.bvh")
    whole = load_motion(path)
    assert len(whole) == 166  # 8.3 s at 20 fps
    out = tmp_path / "w.npy"
    assert main(["convert", str(path), str(out), "--start", "1.5", "--seconds", "4"]) == 0
    assert "(80 frames at 20 fps)" in capsys.readouterr().out
    assert np.array_equal(np.load(out), whole[30:110])
    assert main(["convert", str(path), str(out), "--start", "8"]) == 0  # to the end: 166 - 160
    assert np.load(out).shape == (6, 22, 3)
    vecs = tmp_path / "w_vecs.npy"
    assert main(["convert", str(path), str(vecs), "--to", "vecs", "--seconds", "2"]) == 0
    assert np.load(vecs).shape == (39, 263)  # 40 poses -> 39 feature frames
    capsys.readouterr()
    assert main(["convert", str(path), str(out), "--start", "9"]) == 2
    assert "--start 9 s is beyond the end of cmu_131_01_walk.bvh (8.3 s, 166 frames)" in capsys.readouterr().err
    assert main(["convert", str(path), str(out), "--start", "5", "--seconds", "5"]) == 2
    assert "runs past the end" in capsys.readouterr().err


@pytest.fixture
def tiny(monkeypatch):
    """An untrained 2-layer model stands in for the shipped one in the CLI (load_model is looked up per call)."""
    loaded = random_corpus_model(layers=2)
    monkeypatch.setattr("engine.checkpoint.load_model", lambda *a, **k: loaded)
    return loaded


def test_invert_window_and_long_file_hint(tiny, tmp_path, capsys):
    long = tmp_path / "long.npy"
    np.save(long, _motion(208))
    assert main(["invert", str(long), "--steps", "2"]) == 2
    err = capsys.readouterr().err
    assert "long.npy is 10.4 s, longer than the model's 9.8 s: pick a window with --start/--seconds" in err
    assert main(["invert", str(long), "--steps", "2", "--seconds", "10"]) == 2
    assert "--seconds 10 s is longer than the model's 9.8 s" in capsys.readouterr().err
    assert main(["invert", str(long), "--steps", "2", "--start", "0.5", "--seconds", "1.5"]) == 0
    line = capsys.readouterr().out
    assert "1.5 s from 0.5 s, 29 frames" in line and "noise std" in line
    assert main(["invert", str(long), "--steps", "2", "--start", "9", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames"] == 27 and report["seconds"] == pytest.approx(1.4) and report["start_s"] == 9.0
    assert np.isfinite(report["noise_std"]) and report["noise_std"] > 0


def test_transfer_window_of_file_sources(tiny, tmp_path, capsys):
    long = tmp_path / "long.npy"
    np.save(long, _motion(208))
    base = ["transfer", "--leader", str(long), "--follower", "a person walks", "--steps", "2",
            "--out", str(tmp_path / "out.npy")]
    assert main(base) == 2
    assert "pick a window with --start and --seconds" in capsys.readouterr().err
    assert main([*base, "--start", "1", "--seconds", "3"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["leader"] == "long.npy"
    assert np.load(tmp_path / "out.npy").shape == (59, 22, 3)  # the leader's 60 poses -> 59 frames
    assert main(["transfer", "--leader", "a person walks", "--follower", "a person runs", "--start", "1",
                 "--out", str(tmp_path / "x.npy")]) == 2
    assert "--start cuts a window of a leader/follower file" in capsys.readouterr().err
