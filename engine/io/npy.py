"""Read and write single motions as ``.npy`` files: joints (T, 22, 3) or features (T, 263).

Reading never unpickles: the header is inspected first (pickled files, ``.npz`` archives and
object arrays are refused with a message saying so) and the array is then loaded with
``allow_pickle=False``. The kind is told by the shape: (T, 22, 3) (or flattened (T, 66)) are
joint positions in metres, (T, 263) are HumanML3D feature vectors.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.lib.format as npy_format

from engine.io.errors import DEFAULT_MAX_BYTES, MotionIOError, check_file_size
from engine.representation import FEATURE_DIM
from engine.skeleton import NUM_JOINTS

NpyKind = Literal["joints", "vecs"]
_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGIC = b"PK\x03\x04"


def classify_motion_array(array: np.ndarray, *, name: str = "array") -> tuple[NpyKind, np.ndarray]:
    """Check a motion array and tell its kind; returns ("joints", (T, 22, 3)) or ("vecs", (T, 263)), float32.

    Raises :class:`MotionIOError` for other shapes, non-float dtypes, zero frames, NaN or inf.
    """
    array = np.asarray(array)
    if array.dtype.hasobject:
        raise MotionIOError(f"{name} is an object array; only plain float arrays are accepted")
    if not np.issubdtype(array.dtype, np.floating):
        raise MotionIOError(f"{name} has dtype {array.dtype}; expected floating point (float16/32/64)")
    shape = array.shape
    kind: NpyKind
    if array.ndim == 3 and shape[1:] == (NUM_JOINTS, 3):
        kind = "joints"
    elif array.ndim == 2 and shape[1] == NUM_JOINTS * 3:
        kind, array = "joints", array.reshape(shape[0], NUM_JOINTS, 3)
    elif array.ndim == 2 and shape[1] == FEATURE_DIM:
        kind = "vecs"
    else:
        raise MotionIOError(f"{name} has shape {shape}: {_shape_hint(shape)}")
    if len(array) == 0:
        raise MotionIOError(f"{name} has shape {shape}: it contains zero frames")
    finite = np.isfinite(array).reshape(len(array), -1).all(axis=1)
    if not finite.all():
        raise MotionIOError(f"{name} contains NaN or infinite values (first at frame {int(np.argmin(finite))})")
    return kind, array.astype(np.float32)


def _shape_hint(shape: tuple[int, ...]) -> str:
    expected = f"expected joints (T, {NUM_JOINTS}, 3) or HumanML3D features (T, {FEATURE_DIM})"
    if len(shape) == 4 and shape[2:] == (NUM_JOINTS, 3):
        return f"a batch of {shape[0]} motions; save one motion per file ({expected})"
    if len(shape) == 3 and shape[0] and shape[2] == FEATURE_DIM:
        return f"a batch of {shape[0]} feature sequences; save one motion per file ({expected})"
    if shape == (NUM_JOINTS, 3):
        return f"a single pose without a time axis; use shape (1, {NUM_JOINTS}, 3) ({expected})"
    if len(shape) == 3 and shape[2] == 3:
        return f"{shape[1]} joints per frame, but the skeleton has {NUM_JOINTS} ({expected})"
    if len(shape) == 2 and shape[1] == 251:
        return f"251 dims look like KIT-ML features, which are not supported ({expected})"
    return expected


def load_npy(path: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES) -> tuple[NpyKind, np.ndarray]:
    """Load a motion ``.npy``: ("joints", (T, 22, 3)) or ("vecs", (T, 263)), float32.

    Never unpickles; refuses files over ``max_bytes``, pickles, ``.npz`` archives, object
    arrays, other shapes and dtypes, empty arrays and NaN/inf, each with a clear message.
    """
    path = Path(path)
    return classify_motion_array(read_array(path, max_bytes=max_bytes), name=path.name)


def load_duet_npy(path: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES) -> np.ndarray:
    """Load two people's joints (2, T, 22, 3) float32 (as ``moattn duet`` writes them), with load_npy's checks."""
    path = Path(path)
    array = read_array(path, max_bytes=max_bytes)
    if array.ndim != 4 or array.shape[0] != 2 or array.shape[2:] != (22, 3) or array.shape[1] < 1:
        raise MotionIOError(f"{path.name} is not a duet: expected joints of shape (2, T, 22, 3), got {array.shape}")
    if not np.issubdtype(array.dtype, np.floating):
        raise MotionIOError(f"{path.name} holds {array.dtype} values; joints must be floats")
    if not np.isfinite(array).all():
        raise MotionIOError(f"{path.name} contains NaN or infinite values")
    return array.astype(np.float32)


def read_array(path: Path, *, max_bytes: int = DEFAULT_MAX_BYTES) -> np.ndarray:
    """A plain array from a .npy file, never unpickled (size, magic, header and dtype checked first)."""
    check_file_size(path, max_bytes=max_bytes, kind="NPY")
    with path.open("rb") as handle:
        head = handle.read(len(_NPY_MAGIC))
        if head.startswith(_ZIP_MAGIC):
            raise MotionIOError(f"{path.name} is an .npz archive; save a single motion with np.save (.npy)")
        if head[:1] == b"\x80":
            raise MotionIOError(
                f"{path.name} contains pickled data, which is never loaded (allow_pickle=False); "
                "save a plain float array with np.save"
            )
        if head != _NPY_MAGIC:
            raise MotionIOError(f"{path.name} is not a .npy file (it does not start with the NumPy magic bytes)")
        handle.seek(0)
        try:
            version = npy_format.read_magic(handle)
            if version == (1, 0):
                shape, _, dtype = npy_format.read_array_header_1_0(handle)
            else:
                shape, _, dtype = npy_format.read_array_header_2_0(handle)
        except ValueError as exc:
            raise MotionIOError(f"{path.name} has a corrupt .npy header: {exc}") from None
    if dtype.hasobject:
        raise MotionIOError(
            f"{path.name} holds an object array (dtype {dtype}), which would need pickle to load; refused"
        )
    try:
        array = np.load(path, allow_pickle=False)
    except ValueError as exc:
        raise MotionIOError(f"{path.name} could not be read as a .npy array (truncated or corrupt?): {exc}") from None
    return array


def save_npy(
    path: str | os.PathLike[str], array: np.ndarray, *, kind: NpyKind | None = None
) -> Path:
    """Write a motion array as float32 ``.npy`` (exactly ``path``; no suffix is added).

    ``kind`` ("joints" or "vecs"), when given, must match the array's shape.
    """
    path = Path(path)
    found, checked = classify_motion_array(array, name="the motion to save")
    if kind is not None and kind != found:
        raise MotionIOError(f"expected {kind} but the array has shape {np.shape(array)} ({found})")
    with path.open("wb") as handle:
        np.save(handle, checked, allow_pickle=False)
    return path
