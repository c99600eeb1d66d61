"""Read and write single motions as ``.npy`` files: joints (T, 22, 3) or features (T, 263).

Reading never unpickles: the header is inspected first (pickled files, ``.npz`` archives and
object arrays are refused with a message saying so) and the array is then loaded with
``allow_pickle=False``. The kind is told by the shape: (T, 22, 3) (or flattened (T, 66)) are
joint positions in metres, (T, 263) are HumanML3D feature vectors.

Nothing the size of the array is allocated before the header has been checked: its shape and dtype
must describe no more data than the file holds (a header claiming 10^12 elements is refused, not
allocated) and, for a motion, the shape must be an accepted one with at most MAX_IMPORT_FRAMES
poses (:mod:`engine.io.errors`: MAX_IMPORT_SECONDS at 20 fps).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Callable, Literal

import numpy as np
import numpy.lib.format as npy_format

from engine.io.errors import (
    DEFAULT_MAX_BYTES,
    IMPORT_FPS,
    MAX_IMPORT_FRAMES,
    MAX_IMPORT_SECONDS,
    MotionIOError,
    check_file_size,
)
from engine.representation import FEATURE_DIM
from engine.skeleton import NUM_JOINTS

NpyKind = Literal["joints", "vecs"]
_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGIC = b"PK\x03\x04"


def motion_kind(shape: tuple[int, ...], dtype: np.dtype, *, name: str = "array",
                max_frames: int | None = None) -> NpyKind:
    """The kind of a motion array of ``shape`` and ``dtype`` (what an .npy header declares), checked before any
    data is read: "joints" for (T, 22, 3) or (T, 66), "vecs" for (T, 263); floats only, 1 to ``max_frames``
    frames (None: no limit). Raises :class:`MotionIOError` saying what is wrong."""
    dtype = np.dtype(dtype)
    if dtype.hasobject:
        raise MotionIOError(f"{name} is an object array; only plain float arrays are accepted")
    if not np.issubdtype(dtype, np.floating):
        raise MotionIOError(f"{name} has dtype {dtype}; expected floating point (float16/32/64)")
    shape = tuple(shape)
    kind: NpyKind
    if len(shape) == 3 and shape[1:] == (NUM_JOINTS, 3):
        kind = "joints"
    elif len(shape) == 2 and shape[1] == NUM_JOINTS * 3:
        kind = "joints"
    elif len(shape) == 2 and shape[1] == FEATURE_DIM:
        kind = "vecs"
    else:
        raise MotionIOError(f"{name} has shape {shape}: {_shape_hint(shape)}")
    if shape[0] == 0:
        raise MotionIOError(f"{name} has shape {shape}: it contains zero frames")
    if max_frames is not None and shape[0] > max_frames:
        raise MotionIOError(_too_long(name, shape[0], max_frames))
    return kind


def _too_long(name: str, frames: int, max_frames: int) -> str:
    return (f"{name} holds {frames:,} frames ({frames / IMPORT_FPS:.1f} s at {IMPORT_FPS} fps), longer than the limit "
            f"of {MAX_IMPORT_SECONDS:g} s ({max_frames:,} frames)")


def classify_motion_array(array: np.ndarray, *, name: str = "array",
                          max_frames: int | None = None) -> tuple[NpyKind, np.ndarray]:
    """Check a motion array and tell its kind; returns ("joints", (T, 22, 3)) or ("vecs", (T, 263)), float32.

    Raises :class:`MotionIOError` for other shapes, non-float dtypes, zero frames, more than ``max_frames`` frames
    (None: no limit), NaN or inf.
    """
    array = np.asarray(array)
    kind = motion_kind(array.shape, array.dtype, name=name, max_frames=max_frames)
    if kind == "joints" and array.ndim == 2:
        array = array.reshape(array.shape[0], NUM_JOINTS, 3)
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
    array = read_array(path, max_bytes=max_bytes, check=lambda shape, dtype: motion_kind(
        shape, dtype, name=path.name, max_frames=MAX_IMPORT_FRAMES))
    return classify_motion_array(array, name=path.name, max_frames=MAX_IMPORT_FRAMES)


def load_duet_npy(path: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES) -> np.ndarray:
    """Load two people's joints (2, T, 22, 3) float32 (as ``moattn duet`` writes them), with load_npy's checks."""
    path = Path(path)

    def check(shape: tuple[int, ...], dtype: np.dtype) -> None:
        if len(shape) != 4 or shape[0] != 2 or shape[2:] != (NUM_JOINTS, 3) or shape[1] < 1:
            raise MotionIOError(f"{path.name} is not a duet: expected joints of shape (2, T, 22, 3), got {shape}")
        if dtype.hasobject or not np.issubdtype(dtype, np.floating):
            raise MotionIOError(f"{path.name} holds {dtype} values; joints must be floats")
        if shape[1] > MAX_IMPORT_FRAMES:
            raise MotionIOError(_too_long(path.name, shape[1], MAX_IMPORT_FRAMES))

    array = read_array(path, max_bytes=max_bytes, check=check)
    check(array.shape, array.dtype)
    if not np.isfinite(array).all():
        raise MotionIOError(f"{path.name} contains NaN or infinite values")
    return array.astype(np.float32)


def read_array(path: Path, *, max_bytes: int = DEFAULT_MAX_BYTES,
               check: Callable[[tuple[int, ...], np.dtype], object] | None = None) -> np.ndarray:
    """A plain array from a .npy file, never unpickled (size, magic, header and dtype checked first).

    Before any data is read, the header's shape and dtype must describe no more bytes than the file holds after
    the header (so a header cannot ask for more memory than the file's size, itself at most ``max_bytes``), and
    ``check(shape, dtype)``, when given, may refuse them by raising :class:`MotionIOError`.
    """
    path = Path(path)
    size = check_file_size(path, max_bytes=max_bytes, kind="NPY")
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
            elif version in ((2, 0), (3, 0)):
                shape, _, dtype = npy_format.read_array_header_2_0(handle)
            else:
                raise ValueError(f"unsupported .npy format version {version[0]}.{version[1]}")
        except Exception as exc:  # noqa: BLE001 - numpy's header parser raises many types (tokenize.TokenError, ...)
            raise MotionIOError(f"{path.name} has a corrupt .npy header: {_one_line(exc)}") from None
        data_bytes = size - handle.tell()
    if dtype.hasobject:
        raise MotionIOError(
            f"{path.name} holds an object array (dtype {dtype}), which would need pickle to load; refused"
        )
    if any(n < 0 for n in shape):
        raise MotionIOError(f"{path.name} has a corrupt .npy header: negative shape {shape}")
    needed = math.prod(shape) * dtype.itemsize
    if dtype.itemsize == 0 or needed > data_bytes:
        declared = "items of zero size" if dtype.itemsize == 0 else f"{needed:,} bytes of data"
        raise MotionIOError(f"{path.name} could not be read as a .npy array (truncated or corrupt?): its header "
                            f"declares {declared} but the file holds {data_bytes:,} after the header")
    if check is not None:
        check(shape, dtype)
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, TypeError, MemoryError) as exc:
        raise MotionIOError(
            f"{path.name} could not be read as a .npy array (truncated or corrupt?): {_one_line(exc)}"
        ) from None
    return array


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:200] + ("..." if len(text) > 200 else "")


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
