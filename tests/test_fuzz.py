"""Fuzzing the readers of untrusted input with hypothesis (deterministic: ``derandomize=True``, no database).

The property for every reader: it returns what it promises (a finite motion, a model, a path) or raises the
project's error type for that input, with a one-line message, quickly and with little memory; nothing else.

=========================  ==================================================  ==============================
reader                     entry points                                        the one error type
=========================  ==================================================  ==============================
BVH                        engine.io.read_bvh, load_motion (.bvh)              MotionIOError (BVHError)
.npy                       engine.io.load_npy, load_duet_npy, load_motion      MotionIOError
model folder               engine.checkpoint.load_model                        ModelFolderError (ValueError)
control path JSON          engine.cli.control.read_path + engine.methods.paths  ValueError (read_path's own:
                                                                               MotionIOError)
=========================  ==================================================  ==============================

Inputs: arbitrary bytes, mutated real files (../shared/data/real: the CMU and pymo BVH files, the HumanML3D
joints/vecs/Mean/Std .npy files; a tiny model folder made here) and structure-aware generation (any hierarchy
depth, channel lists, frame times and counts; any .npy header; any JSON). Examples that found bugs are kept as
regular tests in tests/test_hardening.py. The whole file runs in well under a minute on 2 cores.
"""
from __future__ import annotations

import json
import math
import pickle
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis.control import currently_in_test_context
from hypothesis import strategies as st

from engine.checkpoint import ModelFolderError, load_model
from engine.io import MotionIOError, format_bvh, load_motion, read_bvh
from engine.io.npy import load_duet_npy, load_npy
from engine.paths import REAL_DATA_DIR

MB = 2**20
TIME_LIMIT = 10.0  # seconds one input may take (a memory bomb takes far longer, or never ends)
# no shrinking: a failure is reported as found (shrinking a slow reader's input can take minutes)
_BASE = settings(derandomize=True, database=None, deadline=None, print_blob=False,
                 phases=(Phase.explicit, Phase.generate),
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                        HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])


def fuzz(examples: int = 60) -> settings:
    """Deterministic settings with ``examples`` inputs (the time limit per input is checked by :func:`bounded`)."""
    return settings(_BASE, max_examples=examples)


def real(name: str) -> Path:
    path = REAL_DATA_DIR / name
    assert path.exists(), f"real data missing: {path} (the project's measuring data, ../shared/data/real/)"
    return path


def bounded(fn, allowed: type[BaseException] | tuple, *, megabytes: float = 96.0, trace: bool = True):
    """Run ``fn``: its result, or None when it raised ``allowed`` (with a one-line message); any other exception
    propagates (a failure). Asserts it took under TIME_LIMIT and, with ``trace``, allocated under ``megabytes``."""
    if trace:
        tracemalloc.start()
    start = time.perf_counter()
    try:
        try:
            result = fn()
        except allowed as exc:
            message = str(exc)
            assert message and "\n" not in message, repr(message)
            assert "weights_only=False" not in message
            result = None
        if currently_in_test_context():  # statistics: pytest --hypothesis-show-statistics
            event("accepted" if result is not None else "refused")
        peak = tracemalloc.get_traced_memory()[1] if trace else 0
    finally:
        if trace:
            tracemalloc.stop()
    assert time.perf_counter() - start < TIME_LIMIT
    assert peak < megabytes * MB, f"allocated {peak / MB:.0f} MiB"
    return result


def check_motion(joints) -> None:
    if joints is not None:
        assert isinstance(joints, np.ndarray) and joints.dtype == np.float32
        assert joints.ndim == 3 and joints.shape[1:] == (22, 3) and len(joints) >= 1
        assert np.isfinite(joints).all()


def write(folder: Path, name: str, data: bytes) -> Path:
    path = Path(folder) / name
    path.write_bytes(data)
    return path


# ============================================================================================ BVH
BVH_LINES = ["HIERARCHY", "ROOT Hips", "ROOT", "{", "}", "OFFSET 0 0 0", "OFFSET 1 2", "OFFSET 0 1e308 0",
             "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation",
             "CHANNELS 3 Zrotation Xrotation Yrotation",
             "CHANNELS 0", "CHANNELS -1", "CHANNELS 99999999999999999999 Xrotation", "JOINT Spine", "JOINT LeftUpLeg",
             "JOINT Head", "End Site", "End", "MOTION", "Frames: 1", "Frames: 2", "Frames: 0", "Frames: -3",
             "Frames: 1000000000000", "Frame Time: 0.05", "Frame Time: 0", "Frame Time: 5e-324", "Frame Time: 1e9",
             "Frame Time: nan", "0 0 0", "0 0 0 0 0 0", "1e999 0 0", "nan 0 0", "", "   ", "\t{", "JOINT {", "}}"]


def _bvh_text(lines: list[str]) -> bytes:
    return ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")


def _read_bvh_bytes(data: bytes, name: str = "f.bvh"):
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp), name, data)
        bounded(lambda: read_bvh(path), MotionIOError)
        check_motion(bounded(lambda: load_motion(path), MotionIOError))


@fuzz()
@given(st.binary(max_size=3000))
def test_bvh_arbitrary_bytes(data):
    _read_bvh_bytes(data)
    _read_bvh_bytes(b"HIERARCHY\nROOT a\n{\n" + data)


@fuzz()
@given(st.lists(st.one_of(st.sampled_from(BVH_LINES), st.text(max_size=30)), max_size=60))
def test_bvh_token_soup(lines):
    _read_bvh_bytes(_bvh_text(lines))


@st.composite
def hierarchies(draw):
    """A BVH built from its structure: any depth (chains up to 90, beyond the limit), fan-out, channel subsets in
    any order, End Sites, declared vs written frame counts, and any Frame Time."""
    channel_names = ["Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"]
    depth = draw(st.integers(1, 90))
    fan = draw(st.integers(1, 3)) if depth < 8 else 1
    lines, counter, total = ["HIERARCHY"], [0], [0]

    def joint(level: int, keyword: str) -> None:
        counter[0] += 1
        lines.append(f"{keyword} j{counter[0]}")
        lines.append("{")
        lines.append("OFFSET " + " ".join(str(draw(st.sampled_from([0, 1, -2.5, 1e3]))) for _ in range(3)))
        chans = draw(st.permutations(channel_names))[:draw(st.integers(0, 6))]
        lines.append(f"CHANNELS {len(chans)} {' '.join(chans)}".rstrip())
        total[0] += len(chans)
        if level < depth:
            for _ in range(fan if level < 4 else 1):
                joint(level + 1, "JOINT")
        elif draw(st.booleans()):
            lines.extend(["End Site", "{", "OFFSET 0 1 0", "}"])
        lines.append("}")

    joint(1, "ROOT")
    valid = draw(st.integers(0, 3)) > 0  # mostly a well-formed header, so the motion is read too
    declared = draw(st.integers(1, 8) if valid else st.one_of(
        st.integers(-2, 8), st.sampled_from([10**5, 10**5 + 1, 10**9, 10**30])))
    frame_time = draw(st.sampled_from([1e-3, 0.0083333, 0.05, 0.5, 1.0]) if valid else st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.sampled_from([5e-324, 1e-300, 1e-4, 1e-3, 0.0083333, 0.05, 1.0, 1.0001, 10, 1e4, 1e5, 1e9, -0.05, 0.0])))
    written = max(0, min(declared, 8)) + (0 if valid else draw(st.integers(-1, 1)))
    values = st.floats(-1e3, 1e3) if valid else st.one_of(
        st.floats(-1e3, 1e3), st.sampled_from([0.0, 1e308, -1e308, float("nan"), 1e-320]))
    lines += ["MOTION", f"Frames: {declared}", f"Frame Time: {frame_time!r}"]
    for _ in range(max(0, written)):
        lines.append(" ".join(repr(draw(values)) for _ in range(total[0])))
    return lines


@fuzz(120)
@given(hierarchies())
def test_bvh_structure_aware(lines):
    _read_bvh_bytes(_bvh_text(lines))


@st.composite
def mutations(draw, lines: list[str]):
    """A real file's lines with a few mutations: lines deleted, duplicated or replaced, numbers made extreme,
    the file truncated."""
    lines = list(lines)
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["delete", "duplicate", "replace", "number", "number", "number", "truncate",
                                     "header", "header"]))
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "delete":
            del lines[i:i + draw(st.integers(1, 50))]
        elif kind == "duplicate":
            lines[i:i] = lines[i:i + draw(st.integers(1, 5))] * draw(st.integers(1, 3))
        elif kind == "replace":
            lines[i] = draw(st.one_of(st.sampled_from(BVH_LINES), st.text(max_size=20)))
        elif kind == "number":
            tokens = lines[i].split() or ["0"]
            odd = st.sampled_from(["1e308", "-1e308", "nan", "inf", "5e-324", "99999999999999999999999", "0x10",
                                   "1,5", "--1", "١"])
            tokens[draw(st.integers(0, len(tokens) - 1))] = draw(st.one_of(st.floats(-1e4, 1e4).map(repr), odd))
            lines[i] = " ".join(tokens)
        elif kind == "truncate":
            lines = lines[:i]
        else:  # the Frames / Frame Time lines
            j = next((k for k, line in enumerate(lines) if line.lower().startswith("frame time")), None)
            if j is not None:
                times = ["10000", "100000", "10", "1e9", "5e-324", "0.0001", "1", "0.001", "0.1"]
                lines[j] = f"Frame Time: {draw(st.sampled_from(times))}"
            if j is not None and draw(st.booleans()):
                lines[j - 1] = f"Frames: {draw(st.sampled_from(['100000', '2000001', '1', '299', str(10**12)]))}"
        if not lines:
            lines = [""]
    return lines


@pytest.fixture(scope="module")
def real_bvh_lines():
    # the real files, cut to their first 300 frames (the mutations hit the hierarchy and header as often as data)
    out = {}
    for name in ("cmu_131_01_walk.bvh", "pymo_walk.bvh"):
        lines = real(name).read_text().splitlines()
        motion = next(i for i, line in enumerate(lines) if line.strip().upper() == "MOTION")
        lines[motion + 1] = "Frames: 300"
        out[name] = lines[: motion + 3 + 300]
    return out


@fuzz(80)
@given(st.data(), st.sampled_from(["cmu_131_01_walk.bvh", "pymo_walk.bvh"]))
def test_bvh_mutated_real_files(real_bvh_lines, data, name):
    lines = data.draw(mutations(real_bvh_lines[name]))
    _read_bvh_bytes(_bvh_text(lines))


@pytest.fixture(scope="module")
def skeleton_bvh():
    return format_bvh(np.load(real("humanml3d_012314_joints.npy"), allow_pickle=False)[:6]).splitlines()


@fuzz(60)
@given(st.data())
def test_bvh_our_skeleton_with_any_motion(skeleton_bvh, data):
    """The 22-joint skeleton (so the whole import runs) with any frame count, frame time and channel values."""
    lines = list(skeleton_bvh)
    motion = lines.index("MOTION")
    channels = len(lines[motion + 3].split())
    frames = data.draw(st.integers(1, 6))
    frame_time = data.draw(st.sampled_from([0.001, 0.0083333, 0.05, 0.5, 1.0]))
    values = st.one_of(st.floats(-400, 400), st.sampled_from([1e308, -1e308, 1e30, 0.0, 360.0, 1e-300]))
    rows = [" ".join(repr(data.draw(values)) for _ in range(channels)) for _ in range(frames)]
    text = lines[:motion + 1] + [f"Frames: {frames}", f"Frame Time: {frame_time}"] + rows
    _read_bvh_bytes(_bvh_text(text))


# ============================================================================================ .npy
def _header(descr: str, fortran, shape, *, version: bytes = b"\x01\x00", raw: str | None = None) -> bytes:
    text = raw if raw is not None else repr({"descr": descr, "fortran_order": fortran, "shape": shape})
    body = text.encode("latin1", "replace")
    body += b" " * (63 - (len(body) + 10) % 64) + b"\n"
    size = len(body).to_bytes(2 if version[0] == 1 else 4, "little")
    return b"\x93NUMPY" + version + size + body


def _read_npy_bytes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp), "f.npy", data)
        kind_array = bounded(lambda: load_npy(path), MotionIOError)
        if kind_array is not None:
            kind, array = kind_array
            assert kind in ("joints", "vecs") and array.dtype == np.float32 and np.isfinite(array).all()
        duet = bounded(lambda: load_duet_npy(path), MotionIOError)
        if duet is not None:
            assert duet.shape[0] == 2 and duet.shape[2:] == (22, 3) and np.isfinite(duet).all()
        check_motion(bounded(lambda: load_motion(path), MotionIOError))


@fuzz()
@given(st.binary(max_size=2000))
def test_npy_arbitrary_bytes(data):
    _read_npy_bytes(data)
    _read_npy_bytes(b"\x93NUMPY" + data)


DESCRS = ["<f4", "<f8", "<f2", ">f4", "<f16", "<i8", "|b1", "|u1", "<c8", "|V0", "|V8", "<U10", "|S0", "|O", "<m8",
          "[('a', '<f4')]", "('<f4', (3,))", "('<f4', (100000000,))", "nonsense", "<f", ""]


@st.composite
def npy_headers(draw):
    dims = st.one_of(st.integers(0, 300), st.sampled_from([22, 3, 66, 263, 2, 12001, 12002, 10**9, 10**12, 2**63, -1]))
    shape = tuple(draw(st.lists(dims, max_size=5)))
    raw = draw(st.one_of(st.none(), st.text(max_size=80), st.sampled_from([
        "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 22, 3), 'extra': 1}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': [1, 22, 3]}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (1.5, 22, 3)}",
        "{'descr': '<f4', 'fortran_order': 'yes', 'shape': (1, 22, 3)}",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (" + "(" * 200 + ")" * 200 + ")}",
        "__import__('os')"])))
    header = _header(draw(st.one_of(st.sampled_from(DESCRS), st.text(max_size=8))), draw(st.booleans()), shape,
                     version=draw(st.sampled_from([b"\x01\x00", b"\x02\x00", b"\x03\x00", b"\x09\x00"])), raw=raw)
    items = math.prod(shape) if shape and all(0 <= d <= 300 for d in shape) else 0
    items = items if items <= 100_000 else 0  # the data written stays small; the header may claim anything
    size = draw(st.sampled_from([0, 1, 4 * items, 2 * items, 8 * items, 4 * items - 1]))
    data = draw(st.sampled_from([b"\x00", b"\xff", b"\x7f\xc0\x00\x00"]))  # zeros, NaNs, NaN floats
    return header + (data * max(0, size))[: max(0, size)]


@fuzz(200)
@given(npy_headers())
def test_npy_structure_aware_headers(data):
    _read_npy_bytes(data)


@st.composite
def byte_mutations(draw, data: bytes, *, header_bias: int = 128):
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["flip", "flip_header", "truncate", "insert", "delete"]))
        i = draw(st.integers(0, max(0, len(data) - 1)))
        if kind == "flip_header":
            i = draw(st.integers(0, min(header_bias, len(data)) - 1)) if data else 0
        if kind in ("flip", "flip_header") and data:
            data[i] = draw(st.integers(0, 255))
        elif kind == "truncate":
            del data[i:]
        elif kind == "insert":
            data[i:i] = draw(st.binary(min_size=1, max_size=16))
        elif kind == "delete":
            del data[i:i + draw(st.integers(1, 64))]
    return bytes(data)


@fuzz(80)
@given(st.data(), st.sampled_from(["humanml3d_012314_joints.npy", "humanml3d_012314_vecs.npy", "humanml3d_Mean.npy",
                                   "humanml3d_Std.npy"]))
def test_npy_mutated_real_files(data, name):
    _read_npy_bytes(data.draw(byte_mutations(real(name).read_bytes())))


# ============================================================================================ model folders
@pytest.fixture(scope="module")
def tiny_folder(tmp_path_factory) -> Path:
    from tests.test_hardening import tiny_model

    return tiny_model(tmp_path_factory.mktemp("fuzz-model") / "model")


def _load_folder(tiny: Path, *, config: bytes | None = None, weights: bytes | None = None,
                 stats: bytes | None = None) -> None:
    import shutil

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "m"
        shutil.copytree(tiny, folder)
        if config is not None:
            write(folder, "config.json", config)
        if weights is not None:
            write(folder, "weights.pt", weights)
        if stats is not None:
            write(folder, "Std.npy", stats)
        loaded = bounded(lambda: load_model(folder), ModelFolderError, trace=False)
        if loaded is not None:
            assert all(torch.isfinite(p).all() for p in loaded.model.parameters())
            assert len(loaded.tokenizer) <= loaded.model.config.vocab_size


JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=10),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
                    max_leaves=20)


@fuzz(60)
@given(st.one_of(st.binary(max_size=300), JSON.map(lambda v: json.dumps(v).encode())))
def test_model_config_arbitrary(tiny_folder, data):
    _load_folder(tiny_folder, config=data)


@fuzz(80)
@given(st.data())
def test_model_config_mutated(tiny_folder, data):
    config = json.loads((tiny_folder / "config.json").read_text())
    for _ in range(data.draw(st.integers(1, 3))):
        where = data.draw(st.sampled_from(["model", "vocabulary", "top"]))
        value = data.draw(st.one_of(JSON, st.integers(-10, 10**12), st.sampled_from([0, 1, 3, 16, 17, 10**6, 2**63])))
        if where == "model" and isinstance(config.get("model"), dict):
            key = data.draw(st.sampled_from([*config["model"], "extra"]))
            if data.draw(st.booleans()):
                config["model"].pop(key, None)
            else:
                config["model"][key] = value
        elif where == "vocabulary":
            words = data.draw(st.lists(st.one_of(st.text(max_size=6), st.integers()), max_size=30))
            config["vocabulary"] = words if data.draw(st.booleans()) else value
        elif where == "top":
            config[data.draw(st.sampled_from(["model", "vocabulary", "train"]))] = value
    _load_folder(tiny_folder, config=json.dumps(config).encode())


@fuzz(60)
@given(st.data())
def test_model_weights_mutated_and_arbitrary(tiny_folder, data):
    original = (tiny_folder / "weights.pt").read_bytes()
    weights = data.draw(st.one_of(st.binary(max_size=500), byte_mutations(original, header_bias=len(original))))
    _load_folder(tiny_folder, weights=weights)


class _Evil:
    def __reduce__(self):
        return (print, ("fuzz: this must never run",))


@st.composite
def state_dicts(draw, reference: dict):
    """Dictionaries like the tiny model's: entries dropped, renamed, reshaped, retyped, NaN, or foreign objects."""
    state = dict(reference)
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.sampled_from(sorted(state) or ["x"]))
        kind = draw(st.sampled_from(["drop", "rename", "reshape", "dtype", "nan", "object", "scalar"]))
        if kind == "drop":
            state.pop(key, None)
        elif kind == "rename":
            state[draw(st.text(max_size=8))] = state.pop(key, torch.zeros(1))
        elif kind == "reshape":
            state[key] = torch.zeros(draw(st.lists(st.integers(0, 5), max_size=3)))
        elif kind == "dtype":
            state[key] = torch.zeros(3, dtype=draw(st.sampled_from([torch.int64, torch.bool, torch.complex64,
                                                                      torch.bfloat16])))
        elif kind == "nan":
            state[key] = torch.full_like(state.get(key, torch.zeros(1)).float(), float("nan"))
        elif kind == "object":
            state[key] = draw(st.sampled_from([[1, 2], "text", None, {"a": torch.zeros(1)}]))
        else:
            return draw(st.sampled_from([[torch.zeros(1)], torch.zeros(3), 7, "weights"]))
    return state


@fuzz(50)
@given(st.data())
def test_model_weights_structure_aware(tiny_folder, data):
    import io

    reference = torch.load(tiny_folder / "weights.pt", weights_only=True)
    if data.draw(st.integers(0, 9)) == 0:
        state = {"x": _Evil()}
    else:
        state = data.draw(state_dicts(reference))
    buffer = io.BytesIO()
    torch.save(state, buffer)
    _load_folder(tiny_folder, weights=buffer.getvalue())


@fuzz(30)
@given(st.data())
def test_model_statistics_mutated(tiny_folder, data):
    _load_folder(tiny_folder, stats=data.draw(st.one_of(
        byte_mutations((tiny_folder / "Std.npy").read_bytes()), npy_headers(), st.binary(max_size=64))))


def test_model_folder_pickle_never_runs(tiny_folder, capsys):
    import io

    buffer = io.BytesIO()
    torch.save({"x": _Evil()}, buffer)
    _load_folder(tiny_folder, weights=buffer.getvalue())
    _load_folder(tiny_folder, weights=pickle.dumps(_Evil()))
    assert "must never run" not in capsys.readouterr().out


# ============================================================================================ control path JSON
def _read_path_bytes(data: bytes, dims: int) -> None:
    from engine.cli.control import read_path
    from engine.methods.paths import RootPath, WristPath, root_controls

    def run():
        points, times = read_path(path, dims=dims)
        if dims == 2:
            values, frame = root_controls(RootPath(points=points, times=times), 2.0)
            assert np.isfinite(values).all()
        else:
            assert np.isfinite(WristPath(points=points, times=times).controls(2.0)).all()

    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp), "p.json", data)
        bounded(run, ValueError)


@fuzz(60)
@given(st.one_of(st.binary(max_size=400), JSON.map(lambda v: json.dumps(v).encode())), st.sampled_from([2, 3]))
def test_control_path_arbitrary(data, dims):
    _read_path_bytes(data, dims)


@st.composite
def paths(draw):
    dims = draw(st.sampled_from([2, 3]))
    number = st.one_of(st.floats(-3, 3), st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                       st.sampled_from([0, 0.0, 1e-300, 1e308, "1", None, True]))
    point_dims = draw(st.sampled_from([dims, dims, dims, dims - 1, dims + 1]))
    points = draw(st.lists(st.lists(number, min_size=point_dims, max_size=point_dims), max_size=12))
    shape = draw(st.sampled_from(["list", "dict", "dict_times"]))
    if shape == "list":
        value = points
    elif shape == "dict":
        value = {"points": points}
    else:
        times = draw(st.one_of(st.lists(st.floats(-10, 10) | st.floats(), min_size=len(points), max_size=len(points)),
                               st.lists(number, max_size=14)))
        value = {"points": points, "times": sorted(times, key=lambda t: t if isinstance(t, float) and t == t else 0)
                 if draw(st.booleans()) else times}
    return json.dumps(value).encode(), dims


@fuzz(200)
@given(paths())
def test_control_path_structure_aware(data_dims):
    _read_path_bytes(*data_dims)
