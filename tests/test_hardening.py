"""Hardening: what a file may declare is limited and checked before anything is allocated, every user error is
one line (``moattn <cmd>: error: ...``, exit 2), outputs are checked before any work, words in any alphabet.

The small "bomb" files are generated here; examples the fuzz suite (tests/test_fuzz.py) found are kept as
regular tests at the end.
"""
from __future__ import annotations

import json
import pickle
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import torch

from engine.checkpoint import ModelFolderError, load_model, read_config
from engine.cli import main
from engine.cli.common import SEED_LIMIT
from engine.io import BVHError, MotionIOError, format_bvh, load_motion, read_bvh
from engine.io.errors import (
    MAX_DECLARED_FRAMES,
    MAX_DEPTH,
    MAX_IMPORT_FRAMES,
    MAX_IMPORT_SECONDS,
    MAX_JOINTS,
)
from engine.io.npy import load_duet_npy, load_npy
from engine.text import Tokenizer, split_words
from tests.conftest import real_file

MB = 2**20


# ----------------------------------------------------------------------------------------------- helpers
def _joints(frames: int = 20) -> np.ndarray:
    return np.load(real_file("humanml3d_012314_joints.npy"), allow_pickle=False)[:frames]


def _bvh(tmp_path: Path, *, frames_line: str | None = None, frame_time: str | None = None, name: str = "bomb.bvh",
         extra_frames: int = 0) -> Path:
    """A valid 22-joint BVH (20 frames) with its 'Frames:' / 'Frame Time:' lines replaced."""
    lines = format_bvh(_joints()).splitlines()
    for i, line in enumerate(lines):
        if line.startswith("Frames:") and frames_line is not None:
            lines[i] = f"Frames: {frames_line}"
        elif line.startswith("Frame Time:") and frame_time is not None:
            lines[i] = f"Frame Time: {frame_time}"
    lines += lines[-1:] * extra_frames
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _bounded(fn, *, seconds: float = 2.0, megabytes: float = 16.0):
    """Run ``fn`` expecting a MotionIOError; assert it came quickly and with little memory allocated."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(MotionIOError) as info:
            fn()
        elapsed = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert elapsed < seconds, f"took {elapsed:.2f} s"
    assert peak < megabytes * MB, f"allocated {peak / MB:.1f} MiB"
    message = str(info.value)
    assert "\n" not in message
    return message


def _one_line_error(capsys, command: str) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    assert err.startswith(f"moattn {command}: error: "), err
    assert "Traceback" not in err
    return err


def tiny_model(folder: Path, *, words=("a", "person", "walks", "jumps", "forward")) -> Path:
    """A random 1-layer model folder (no training): config.json, weights.pt (fp16), Mean/Std."""
    from engine.checkpoint import export_weights, write_config
    from engine.model import Denoiser, ModelConfig
    from engine.representation import Normalizer

    torch.manual_seed(0)
    model = Denoiser(ModelConfig(width=16, layers=1, heads=2, text_layers=1, vocab_size=16, max_frames=60))
    folder.mkdir(parents=True, exist_ok=True)
    write_config(folder, model_config=model.config, vocabulary=tuple(words), extra={})
    export_weights(folder, model.state_dict())
    Normalizer(mean=np.zeros(263, np.float32), std=np.ones(263, np.float32)).save(folder)
    return folder


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    return tiny_model(tmp_path_factory.mktemp("tiny") / "model")


# ----------------------------------------------------------------------------------------------- 1. BVH limits
@pytest.mark.parametrize("frame_time,expected", [
    ("10000", "Frame Time 10000 s is outside the limits of 0.001 s to 1 s"),
    ("100000", "outside the limits"),
    ("10", "outside the limits"),
    ("1e9", "outside the limits"),
    ("5e-324", "outside the limits"),
    ("0.0001", "outside the limits"),
])
def test_bvh_frame_time_is_checked_before_allocating(tmp_path, frame_time, expected):
    path = _bvh(tmp_path, frame_time=frame_time)
    message = _bounded(lambda: load_motion(path))
    assert expected in message and "bomb.bvh: line" in message


def test_bvh_declared_frames_and_duration_are_limited(tmp_path):
    many = _bvh(tmp_path, frames_line=str(10**12))
    assert f"more than the limit of {MAX_DECLARED_FRAMES:,}" in _bounded(lambda: read_bvh(many))
    # 20,000 frames of 0.05 s = 1000 s: over the 600 s import limit, refused from the header alone
    long = _bvh(tmp_path, frames_line="20000", name="long.bvh")
    message = _bounded(lambda: read_bvh(long))
    assert f"longer than the limit of {MAX_IMPORT_SECONDS:g} s" in message and "1000.0 s of motion" in message


def test_bvh_short_file_declaring_many_frames_is_refused_before_allocating(tmp_path):
    path = _bvh(tmp_path, frames_line="99999", frame_time="0.001")  # 100 s declared, 20 frame lines present
    assert "ends after 20 of the 99999 frames" in _bounded(lambda: read_bvh(path))


def _chain(depth: int, *, frames: int = 1, frame_time: str = "0.05") -> str:
    head = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 3 Xposition Yposition Zposition"]
    for k in range(1, depth):
        head += [f"JOINT j{k}", "{", "OFFSET 0 1 0"]
    head += ["}"] * depth
    return "\n".join(head + ["MOTION", f"Frames: {frames}", f"Frame Time: {frame_time}"] + ["0 0 0"] * frames) + "\n"


def test_a_1000_deep_hierarchy_is_one_line_not_recursion_error(tmp_path, capsys):
    path = tmp_path / "deep.bvh"
    path.write_text(_chain(1000))
    message = _bounded(lambda: read_bvh(path))
    assert f"nested more than {MAX_DEPTH} joints deep" in message
    read_bvh(_write(tmp_path, "ok.bvh", _chain(MAX_DEPTH)))  # the limit itself is fine
    assert main(["convert", str(path), str(tmp_path / "out.npy")]) == 2
    assert "nested more than 64" in _one_line_error(capsys, "convert")


def test_too_many_joints_are_refused(tmp_path):
    lines = ["HIERARCHY", "ROOT r", "{", "OFFSET 0 0 0", "CHANNELS 1 Xrotation"]
    for k in range(MAX_JOINTS + 5):
        lines += [f"JOINT j{k}", "{", "OFFSET 0 1 0", "}"]
    lines += ["}", "MOTION", "Frames: 1", "Frame Time: 0.05", "0"]
    path = _write(tmp_path, "wide.bvh", "\n".join(lines) + "\n")
    assert f"more than the limit of {MAX_JOINTS}" in _bounded(lambda: read_bvh(path))


def test_joint_frames_are_limited(tmp_path):
    # 100 chained joints x 60,000 frames at 1000 fps (60 s): 6,000,000 joint-frames from a tiny header
    path = _write(tmp_path, "jf.bvh", _chain(60, frames=1, frame_time="0.001").replace("Frames: 1", "Frames: 90000"))
    assert "joint-frames, more than the limit of 5,000,000" in _bounded(lambda: read_bvh(path))


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_cli_convert_of_a_bomb_is_one_line_and_instant(tmp_path, capsys):
    path = _bvh(tmp_path, frame_time="10000")
    start = time.perf_counter()
    assert main(["convert", str(path), str(tmp_path / "out.npy")]) == 2
    assert time.perf_counter() - start < 5
    assert "Frame Time 10000 s is outside the limits" in _one_line_error(capsys, "convert")
    assert not (tmp_path / "out.npy").exists()


def test_normal_bvh_files_still_import(tmp_path):
    joints = load_motion(_bvh(tmp_path))
    assert joints.shape == (20, 22, 3) and np.isfinite(joints).all()
    for name in ("cmu_131_01_walk.bvh", "pymo_walk.bvh"):
        assert np.isfinite(load_motion(real_file(name))).all()


# ----------------------------------------------------------------------------------------------- 1. .npy limits
def _npy_header(shape, descr: str = "<f4") -> bytes:
    header = repr({"descr": descr, "fortran_order": False, "shape": tuple(shape)}).encode("latin1")
    header += b" " * (63 - (len(header) + 10) % 64) + b"\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header


@pytest.mark.parametrize("shape", [(10**12,), (10**12, 22, 3), (2, 10**11, 22, 3), (10**6, 263), (2**62, 2**62)])
def test_npy_header_claiming_huge_arrays_is_refused_before_allocating(tmp_path, shape):
    path = tmp_path / "bomb.npy"
    path.write_bytes(_npy_header(shape) + bytes(64))
    message = _bounded(lambda: load_npy(path))
    assert "truncated or corrupt" in message and "its header declares" in message
    _bounded(lambda: load_duet_npy(path))


def test_npy_longer_than_the_import_limit_is_refused_from_its_header(tmp_path):
    path = tmp_path / "long.npy"
    np.save(path, np.zeros((MAX_IMPORT_FRAMES + 1, 22, 3), np.float16))
    message = _bounded(lambda: load_npy(path))
    assert f"longer than the limit of {MAX_IMPORT_SECONDS:g} s ({MAX_IMPORT_FRAMES:,} frames)" in message
    np.save(path, np.zeros((2, MAX_IMPORT_FRAMES + 1, 22, 3), np.float16))
    assert "longer than the limit" in _bounded(lambda: load_duet_npy(path))
    np.save(path, np.zeros((MAX_IMPORT_FRAMES, 22, 3), np.float16))  # exactly the limit: fine
    assert load_npy(path)[1].shape == (MAX_IMPORT_FRAMES, 22, 3)


def test_npy_shape_and_dtype_are_checked_from_the_header(tmp_path):
    path = tmp_path / "x.npy"
    path.write_bytes(_npy_header((5, 21, 3)) + bytes(5 * 21 * 3 * 4))
    assert "21 joints per frame" in _bounded(lambda: load_npy(path))
    path.write_bytes(_npy_header((5, 263), "<i8") + bytes(5 * 263 * 8))
    assert "dtype int64; expected floating point" in _bounded(lambda: load_npy(path))


# ----------------------------------------------------------------------------------------------- 2. model folders
def _copy_model(tiny: Path, dest: Path) -> Path:
    import shutil

    shutil.copytree(tiny, dest)
    return dest


def test_tiny_model_loads(tiny):
    assert load_model(tiny).model.config.width == 16


def test_pickled_weights_are_refused_without_suggesting_weights_only_false(tiny, tmp_path, capsys):
    folder = _copy_model(tiny, tmp_path / "m")

    class Evil:
        def __reduce__(self):
            return (print, ("never run",))

    torch.save({"x": Evil()}, folder / "weights.pt")
    with pytest.raises(ModelFolderError) as info:
        load_model(folder)
    message = str(info.value)
    assert "weights.pt" in message and "never loaded" in message and "weights_only" not in message
    (folder / "weights.pt").write_bytes(pickle.dumps({"x": 1}))  # a bare pickle (not torch's zip format)
    with pytest.raises(ModelFolderError, match="not a PyTorch weights file"):
        load_model(folder)
    assert main(["generate", "a person walks", "--model", str(folder), "--out", str(tmp_path / "o.npy")]) == 2
    err = _one_line_error(capsys, "generate")
    assert "weights.pt" in err and "weights_only" not in err and "never run" not in capsys.readouterr().out


def test_wrong_shapes_truncated_and_nan_weights(tiny, tmp_path):
    folder = _copy_model(tiny, tmp_path / "m")
    config = read_config(folder)
    config["model"]["width"] = 32
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(ModelFolderError, match=r"does not fit its config.json: .* of the wrong shape"):
        load_model(folder)

    folder = _copy_model(tiny, tmp_path / "t")
    data = (folder / "weights.pt").read_bytes()
    (folder / "weights.pt").write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFolderError, match="weights.pt"):
        load_model(folder)

    folder = _copy_model(tiny, tmp_path / "n")
    state = torch.load(folder / "weights.pt", weights_only=True)
    name = next(k for k, v in state.items() if v.is_floating_point())
    state[name] = torch.full_like(state[name], float("nan"))
    torch.save(state, folder / "weights.pt")
    with pytest.raises(ModelFolderError, match="NaN"):
        load_model(folder)
    del state[name]
    torch.save(state, folder / "weights.pt")
    with pytest.raises(ModelFolderError, match="missing 1"):
        load_model(folder)


@pytest.mark.parametrize("text,expected", [
    (None, "no config.json"),
    ("{not json", "is not valid JSON"),
    ("[1, 2]", "holds a JSON list"),
    ("{}", 'no "model" section'),
    ('{"model": {"width": 1000000, "layers": 60}, "vocabulary": []}', "more than the limit"),
    ('{"model": {"width": 2048, "layers": 4, "vocab_size": 100000}, "vocabulary": []}',
     "parameters and buffers, more than"),
    ('{"model": {"width": "wide"}, "vocabulary": []}', "must be a whole number"),
    ('{"model": {"width": 16, "heads": 3}, "vocabulary": []}', "not a multiple of heads"),
    ('{"model": {"depth": 3}, "vocabulary": []}', "unknown model settings"),
    ("[" * 100_000, "nested too deeply"),
    (b"\xff\xfe{", "not UTF-8"),
])
def test_bad_config_json_is_one_clear_line(tiny, tmp_path, text, expected):
    folder = _copy_model(tiny, tmp_path / "m")
    if text is None:
        (folder / "config.json").unlink()
    elif isinstance(text, bytes):
        (folder / "config.json").write_bytes(text)
    else:
        (folder / "config.json").write_text(text)
    start = time.perf_counter()
    with pytest.raises(ModelFolderError) as info:
        load_model(folder)
    assert time.perf_counter() - start < 5
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_vocabulary_and_statistics_are_checked(tiny, tmp_path):
    folder = _copy_model(tiny, tmp_path / "m")
    config = read_config(folder)
    config["vocabulary"] = [f"w{'a' * (k + 1)}" for k in range(40)]  # more words than vocab_size 16
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(ModelFolderError, match="do not fit the model's vocab_size"):
        load_model(folder)
    folder = _copy_model(tiny, tmp_path / "s")
    np.save(folder / "Std.npy", np.zeros(263, np.float32))
    with pytest.raises(ModelFolderError, match="Std"):
        load_model(folder)
    (folder / "Mean.npy").write_bytes(_npy_header((10**12,)))
    with pytest.raises(ModelFolderError, match="Mean.npy"):
        load_model(folder)


def test_missing_model_folder(tmp_path):
    with pytest.raises(ModelFolderError, match="does not exist"):
        load_model(tmp_path / "nowhere")


# ----------------------------------------------------------------------------------------------- 2. CLI errors
def test_out_naming_a_directory_is_one_line(tmp_path, capsys):
    src = tmp_path / "in.npy"
    np.save(src, _joints())
    assert main(["convert", str(src), str(tmp_path)]) == 2
    _one_line_error(capsys, "convert")
    folder = tmp_path / "x.npy"
    folder.mkdir()
    assert main(["convert", str(src), str(folder)]) == 2
    assert "is a folder" in _one_line_error(capsys, "convert")


@pytest.mark.parametrize("command", ["generate", "edit", "transfer", "analyze-qk", "compose", "control", "duet",
                                     "corpus", "evaluator"])
def test_seed_out_of_range_is_one_line(command, capsys):
    argv = {"generate": ["generate", "a person walks"], "edit": ["edit", "emphasize", "a person walks"],
            "transfer": ["transfer", "--leader", "a", "--follower", "b", "--out", "x.npy"],
            "analyze-qk": ["analyze-qk", "--leader", "a", "--follower", "b", "--out", "x"],
            "compose": ["compose", "a:2", "--out", "x.npy"], "control": ["control", "--prompt", "a", "--out", "x.npy"],
            "duet": ["duet", "two people", "--out", "x.npy"], "corpus": ["corpus"], "evaluator": ["evaluator"]}[command]
    if command == "generate":
        argv += ["--out", "x.npy"]
    for seed in ("99999999999999999999999", str(SEED_LIMIT), "-1", "1.5"):
        with pytest.raises(SystemExit) as info:
            main([*argv, "--seed", seed])
        assert info.value.code == 2
        err = _one_line_error(capsys, command)
        assert "--seed" in err and "seed" in err


def test_seed_limit_is_accepted():
    from engine.cli.common import seed_argument

    assert seed_argument(str(SEED_LIMIT - 1)) == SEED_LIMIT - 1 and seed_argument("0") == 0
    torch.Generator().manual_seed((SEED_LIMIT - 1) * 7919 + 10**6)  # the largest derived seeds still fit
    np.random.default_rng(SEED_LIMIT - 1)


# ----------------------------------------------------------------------------------------------- 2. words
def test_words_with_accents_and_emoji():
    assert split_words("a naïve person walks to the café") == ["a", "naïve", "person", "walks", "to", "the", "café"]
    assert split_words("jumps😀twice") == ["jumps", "twice"]
    assert split_words("jumps\ufe0f 👨\u200d👩\u200d👧 twice") == ["jumps", "twice"]
    assert split_words("cafe\u0301") == ["café"]  # decomposed accents are one word too
    assert split_words("don’t jump 3x") == ["don't", "jump", "x"]
    assert split_words("नमस्ते") == ["नमस्ते"]
    tokenizer = Tokenizer(["a", "person", "walks", "naïve"])
    assert tokenizer.encode("a naïve person 😀 walks").words == ("a", "naïve", "person", "walks")
    cafe = tokenizer.encode("a person walks to the café")  # an accented word the model lacks: left out, whole
    assert cafe.words == ("a", "person", "walks") and "café" in cafe.left_out
    assert any("café" in n for n in cafe.notes()) and not any("'caf'" in n or n.endswith(" caf") for n in cafe.notes())
    with pytest.raises(ValueError) as info:  # strict: refused, the word named whole
        tokenizer.encode("a person walks to the café", strict=True)
    assert "'café'" in str(info.value) and "'caf'" not in str(info.value)
    with pytest.raises(ValueError, match="not plain words"):
        Tokenizer(["a1"])


# ----------------------------------------------------------------------------------------------- 2. invert
def test_invert_of_a_degenerate_motion_is_an_error_not_nan(tiny, tmp_path, capsys):
    path = tmp_path / "zeros.npy"
    np.save(path, np.zeros((30, 22, 3), np.float32))
    assert main(["invert", str(path), "--model", str(tiny), "--steps", "2", "--refine", "0"]) == 2
    err = _one_line_error(capsys, "invert")
    assert "degenerate" in err and "nan" not in err.lower().replace("nan)", "")


def test_invert_nan_noise_is_an_error(tiny):
    from engine.methods import inversion

    loaded = load_model(tiny)
    loaded.normalizer.std[:] = 1e-30  # features blow up to inf in the normalised space
    with pytest.raises(ValueError, match="degenerate"):
        inversion.invert(loaded, _joints(30), inversion.InversionConfig(steps=2, refine=0))


# ----------------------------------------------------------------------------------------------- 3. outputs first
@pytest.mark.parametrize("command,argv,flag", [
    ("generate", ["generate", "a person walks", "--out", "{bad}"], "--out"),
    ("edit", ["edit", "emphasize", "a person walks", "--word", "walks", "--out", "{bad}"], "--out"),
    ("edit", ["edit", "emphasize", "a person walks", "--word", "walks", "--render", "{badr}"], "--render"),
    ("invert", ["invert", "{motion}", "--out", "{bad}"], "--out"),
    ("transfer", ["transfer", "--leader", "a", "--follower", "b", "--out", "{bad}"], "--out"),
    ("transfer", ["transfer", "--leader", "a", "--follower", "b", "--out", "{ok}", "--render", "{badr}"], "--render"),
    ("analyze-qk", ["analyze-qk", "--leader", "a", "--follower", "b", "--out", "{file}"], "--out"),
    ("compose", ["compose", "a person walks:2", "--out", "{bad}"], "--out"),
    ("compose", ["compose", "a person walks:2", "--out", "{ok}", "--render", "{badr}"], "--render"),
    ("control", ["control", "--prompt", "a", "--root", "{path}", "--out", "{bad}"], "--out"),
    ("control", ["control", "--prompt", "a", "--root", "{path}", "--out", "{ok}", "--render", "{badr}"], "--render"),
    ("duet", ["duet", "two people", "--out", "{bad}"], "--out"),
    ("duet", ["duet", "two people", "--out", "{ok}", "--render", "{badr}"], "--render"),
    ("convert", ["convert", "{motion}", "{bad}"], "output"),
    ("render", ["render", "{motion}", "--out", "{badr}"], "--out"),
])
@pytest.mark.parametrize("bad", ["x.txt", "nodir/x.npy", "adir.npy"])
def test_outputs_are_checked_before_any_work(tmp_path, capsys, command, argv, flag, bad):
    motion = tmp_path / "m.npy"
    np.save(motion, _joints())
    (tmp_path / "adir.npy").mkdir()
    (tmp_path / "adir.gif").mkdir()
    (tmp_path / "file").write_text("")
    (tmp_path / "p.json").write_text("[[0, 0], [1, 1]]")
    render_bad = {"x.txt": "x.txt", "nodir/x.npy": "nodir/x.gif", "adir.npy": "adir.gif"}[bad]
    values = {"bad": str(tmp_path / bad), "badr": str(tmp_path / render_bad), "ok": str(tmp_path / "ok.npy"),
              "motion": str(motion), "file": str(tmp_path / "file"), "path": str(tmp_path / "p.json")}
    args = [a.format(**values) for a in argv]
    if command not in ("convert", "render"):
        args += ["--model", str(tmp_path / "no-model")]  # a model would fail to load: the output is checked first
    if command == "duet" and flag == "--out" and bad == "nodir/x.npy":
        args[args.index("--out") + 1] = str(tmp_path / "nodir" / "x.txt")  # a duet .npy makes its folder
    assert main(args) == 2
    err = _one_line_error(capsys, command)
    assert flag in err and "no-model" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir.gif", "adir.npy", "file", "m.npy", "p.json"]


def test_several_outputs_are_all_checked_before_the_first_is_written(tmp_path, capsys):
    outs = [tmp_path / "ok1.npy", tmp_path / "bad.txt", tmp_path / "ok2.npy"]
    argv = ["generate", "a person walks", "--model", str(tmp_path / "no-model")]
    for out in outs:
        argv += ["--out", str(out)]
    assert main(argv) == 2
    assert "bad.txt" in _one_line_error(capsys, "generate")
    assert not any(p.exists() for p in outs)
    assert main(["generate", "a person walks", "--vecs", "--out", str(tmp_path / "x.bvh"), "--model",
                 str(tmp_path / "no-model")]) == 2
    assert "--vecs" in _one_line_error(capsys, "generate")


def test_render_suffixes_match_viz():
    from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES
    from engine.io import SUPPORTED_SUFFIXES
    from viz.export import PICTURE_SUFFIXES

    assert set(RENDER_SUFFIXES) == set(PICTURE_SUFFIXES)
    assert set(MOTION_SUFFIXES) == set(SUPPORTED_SUFFIXES)


def test_generate_with_the_tiny_model_writes_every_output(tiny, tmp_path):
    outs = [tmp_path / "a.npy", tmp_path / "b.bvh"]
    argv = ["generate", "a person walks", "--model", str(tiny), "--steps", "2", "--seconds", "1"]
    for out in outs:
        argv += ["--out", str(out)]
    assert main(argv) == 0 and all(p.exists() for p in outs)


# ----------------------------------------------------------------------------------------------- control paths
@pytest.mark.parametrize("text,expected", [
    ("[[0, 0], [1, NaN]]", "not a finite number"),
    ("[[0, 0], [1, Infinity]]", "not a finite number"),
    ("[[0, 0], [1, 1e999]]", "not a finite number"),
    ("[[0, 0], [1, " + "9" * 400 + "]]", "beyond the limit"),
    ("[[0, 0], [1, \"a\"]]", "not a number"),
    ("[[0, 0], 5]", "point 1 is not a list of 2 numbers"),
    ("[[0, 0]]", "a path has 2 to"),
    ("{\"points\": [[0, 0], [1, 1]], \"times\": [0, \"x\"]}", "time 1 is not a number"),
    ("{\"points\": [[0, 0], [1, 1]], \"times\": [0]}", "one time per point"),
    ("{\"points\": [[0, 0], [1, 1]], \"speed\": 3}", "unknown keys"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ("[[0, 0], [1, " + "1" * 5000 + "]]", "not a JSON path"),
])
def test_control_path_json_is_checked(tmp_path, text, expected):
    from engine.cli.control import read_path

    path = tmp_path / "p.json"
    path.write_text(text)
    with pytest.raises(MotionIOError) as info:
        read_path(path, dims=2)
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_control_path_json_reads_points_and_times(tmp_path):
    from engine.cli.control import read_path

    path = tmp_path / "p.json"
    path.write_text('{"points": [[0, 0], [1, 2.5]], "times": [0, 1]}')
    assert read_path(path, dims=2) == (((0.0, 0.0), (1.0, 2.5)), (0.0, 1.0))
    with pytest.raises(MotionIOError, match="not found"):
        read_path(tmp_path / "none.json", dims=2)


# ----------------------------------------------------------------------------------------------- found by fuzzing
# (inputs tests/test_fuzz.py found, kept as regular tests)
def test_fuzz_found_bvh_values_so_large_the_positions_overflow(tmp_path):
    # our 22-joint skeleton with a root position of 1e308: once a bare ValueError from deep in the import
    lines = format_bvh(_joints(4)).splitlines()
    first = lines.index("MOTION") + 3
    values = lines[first].split()
    values[1] = values[2] = "1e308"
    lines[first] = " ".join(values)
    path = _write(tmp_path, "huge.bvh", "\n".join(lines) + "\n")
    read_bvh(path)  # parses: the values are finite
    with pytest.raises(BVHError, match="overflow"):
        load_motion(path)


def test_fuzz_found_npy_header_with_an_unclosed_bracket(tmp_path):
    # numpy's header parser raised tokenize.TokenError (not a ValueError) for this 1.0 header
    path = tmp_path / "tok.npy"
    path.write_bytes(_npy_header((1,)).replace(b"(1,)}", b"(263,  "))
    assert "corrupt .npy header" in _bounded(lambda: load_npy(path))


def test_npy_with_zero_size_items_is_refused(tmp_path):
    path = tmp_path / "v0.npy"
    path.write_bytes(_npy_header((10**9, 22, 3), "|V0"))
    _bounded(lambda: load_npy(path))


def test_control_checks_its_length_before_building_a_path(tmp_path, capsys):
    """`--seconds 1e9` used to resample the drawn path to a billion frames before any check."""
    from engine.cli import main

    path = tmp_path / "p.json"
    path.write_text('{"points": [[0, 0], [1, 0], [2, 1]]}')
    assert main(["control", "--prompt", "a person walks", "--root", str(path), "--seconds", "1e9",
                 "--out", str(tmp_path / "c.npy")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "the duration must be between" in err
