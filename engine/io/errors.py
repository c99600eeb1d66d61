"""Errors raised by the motion file readers and writers, and the shared file-size guard.

Every error is a ``ValueError`` subclass whose message says what is wrong and, for text
formats, on which line, so the CLI and the app can show it to the user unchanged.

The limits on what a motion file may declare live here, next to the file-size limit, and are
checked against a file's header (BVH hierarchy and ``Frames:`` / ``Frame Time:`` lines, the
``.npy`` header) before anything the size of the motion is allocated, so a small file cannot
ask for gigabytes:

======================  =====================================================================
DEFAULT_MAX_BYTES       50 MiB: larger motion files are refused
MAX_IMPORT_SECONDS      600 s (10 min): the longest motion a file may hold; a motion longer than
                        the model's 9.8 s is imported whole up to this, then a window is picked
                        (engine.io.window)
MAX_IMPORT_FRAMES       12,001 poses: MAX_IMPORT_SECONDS at the project's 20 fps (+1, the first
                        pose), the longest ``.npy`` motion (taken to be at 20 fps)
MAX_DECLARED_FRAMES     100,000: the most frames a BVH's ``Frames:`` may declare
MIN_FRAME_TIME          1/1000 s and MAX_FRAME_TIME 1 s: a BVH's ``Frame Time:`` (1 to 1000 fps)
MAX_JOINTS              256 joints (End Sites included) in a BVH hierarchy
MAX_DEPTH               64: the deepest nesting of joints in a BVH hierarchy
MAX_JOINT_FRAMES        5,000,000: frames x joints (End Sites included) of a BVH, what forward
                        kinematics allocates (e.g. 10 min at 120 fps of a 69-joint skeleton)
======================  =====================================================================
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

DEFAULT_MAX_BYTES = 50 * 1024 * 1024  # motion files larger than this (50 MiB) are refused
MAX_IMPORT_SECONDS = 600.0  # the longest motion a file may hold (10 min); see the module docstring
from engine.units import FPS as IMPORT_FPS  # noqa: E402 (.npy motions are taken to be at the project's frame rate)
MAX_IMPORT_FRAMES = int(round(MAX_IMPORT_SECONDS * IMPORT_FPS)) + 1  # poses of a MAX_IMPORT_SECONDS motion
MAX_DECLARED_FRAMES = 100_000  # a BVH's 'Frames:'
MIN_FRAME_TIME = 1.0 / 1000  # s: a BVH's 'Frame Time:' from 1/1000 s (1000 fps) ...
MAX_FRAME_TIME = 1.0  # s: ... to 1 s (1 fps)
MAX_JOINTS = 256  # joints of a BVH hierarchy, End Sites included
MAX_DEPTH = 64  # nesting depth of a BVH hierarchy
MAX_JOINT_FRAMES = 5_000_000  # frames x joints of a BVH (the size of its forward kinematics)


class MotionIOError(ValueError):
    """A motion file could not be read or written (bad content, wrong shape, too large, ...)."""


class BVHError(MotionIOError):
    """A BVH file is malformed or cannot be mapped onto the 22-joint skeleton.

    ``line`` is the 1-based line number the problem was found on (None when it is not tied
    to one line); ``source`` names the file.
    """

    def __init__(self, message: str, *, line: int | None = None, source: str | None = None) -> None:
        where = f"{source}: " if source else ""
        if line is not None:
            where += f"line {line}: "
        super().__init__(where + message)
        self.line = line
        self.source = source


def check_file_size(
    path: str | os.PathLike[str],
    *,
    max_bytes: int,
    kind: str,
    error: type[MotionIOError] = MotionIOError,
) -> int:
    """Size of ``path`` in bytes; raises ``error`` when it is missing, not a file, or too large."""
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise error(f"{kind} file not found: {path}") from None
    except OSError as exc:
        raise error(f"cannot read {kind} file {path}: {exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path} is not a regular file")
    if info.st_size > max_bytes:
        raise error(
            f"{kind} file {path} is {info.st_size / 2**20:.1f} MiB, larger than the limit of "
            f"{max_bytes / 2**20:.1f} MiB"
        )
    return info.st_size
