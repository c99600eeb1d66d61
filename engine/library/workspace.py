"""Where a person's work is kept: the workspace folder and the library's size bound.

The workspace is, first found:

1. a folder given explicitly (``--workspace DIR`` on ``moattn serve`` and the commands that make motions),
2. the ``MOATTN_WORKSPACE`` environment variable,
3. the platform's user-data folder (``platformdirs``: ``~/.local/share/moattn`` on Linux,
   ``~/Library/Application Support/moattn`` on macOS, ``%LOCALAPPDATA%\\moattn`` on Windows).

The library lives in ``<workspace>/library``. Its size bound in MB is, first found: given explicitly
(``--library-mb``), the ``MOATTN_LIBRARY_MB`` environment variable, the value stored in the library
(``moattn library limit MB``), or :data:`DEFAULT_LIMIT_MB`.

Torch-free (the CLI's ``library`` command and the studio's session core read it).
"""
from __future__ import annotations

import os
from pathlib import Path

WORKSPACE_ENV = "MOATTN_WORKSPACE"
LIMIT_ENV = "MOATTN_LIBRARY_MB"
APP_NAME = "moattn"
DEFAULT_LIMIT_MB = 500.0  # a 10-s generated motion keeps 140 KB of joints and 200 KB of features: ~1,500 of them
MIN_LIMIT_MB = 0.05  # 50 KB: a bound below that keeps no motion


def workspace_dir(explicit: str | os.PathLike | None = None) -> Path:
    """The workspace folder (not created here): ``explicit``, else $MOATTN_WORKSPACE, else the user-data folder."""
    if explicit is not None and str(explicit).strip():
        return Path(explicit).expanduser()
    env = os.environ.get(WORKSPACE_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_data_dir(APP_NAME, appauthor=False))


def library_dir(workspace: str | os.PathLike | None = None) -> Path:
    """The library folder inside the workspace."""
    return workspace_dir(workspace) / "library"


def limit_from_env() -> float | None:
    """$MOATTN_LIBRARY_MB as a number of MB, or None (unset); a bad value is a ValueError naming the variable."""
    text = os.environ.get(LIMIT_ENV, "").strip()
    if not text:
        return None
    return check_limit_mb(text, what=LIMIT_ENV)


def check_limit_mb(value, *, what: str = "the library size") -> float:
    """A size bound in MB (a number >= MIN_LIMIT_MB); ValueError otherwise."""
    try:
        mb = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} is a number of megabytes, got {str(value)[:40]!r}") from None
    if not mb == mb or mb in (float("inf"),) or mb < MIN_LIMIT_MB:  # NaN, infinite, too small
        raise ValueError(f"{what} must be at least {MIN_LIMIT_MB:g} MB, got {str(value)[:40]}")
    return mb
