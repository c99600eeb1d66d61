"""Errors raised by the motion file readers and writers, and the shared file-size guard.

Every error is a ``ValueError`` subclass whose message says what is wrong and, for text
formats, on which line, so the CLI and the app can show it to the user unchanged.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

DEFAULT_MAX_BYTES = 50 * 1024 * 1024  # motion files larger than this (50 MiB) are refused


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
