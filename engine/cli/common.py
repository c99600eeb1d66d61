"""What every `moattn` subcommand shares: the parser class, ``--seed``'s type, the motion and render file
types, and the output checks made before any work (``CLIError``: a user error, one line, exit status 2)."""
from __future__ import annotations

import argparse
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from engine.sampling_options import SEED_LIMIT, parse_seed  # noqa: F401 (SEED_LIMIT: re-exported, declared there)

MOTION_SUFFIXES: tuple[str, ...] = (".npy", ".bvh")  # engine.io.SUPPORTED_SUFFIXES
RENDER_SUFFIXES: tuple[str, ...] = (".png", ".gif", ".mp4")  # viz.export.PICTURE_SUFFIXES (not imported: slow)


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``moattn generate: error: ...``, exit 2) that point at --help, and no
    abbreviated flags: ``--to kicks`` is refused, never read as ``--to-frame``. Every (sub)parser of `moattn` is
    one: ``add_subparsers`` makes its subparsers of its parser's own class."""

    def __init__(self, *args, **kwargs):
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # noqa: D401 - argparse's hook
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def seed_argument(text: str) -> int:
    """argparse type of every ``--seed``: a whole number 0 <= seed < 2**32 (SEED_LIMIT; the rule:
    :func:`engine.sampling_options.parse_seed`)."""
    try:
        return parse_seed(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def check_outputs(paths: Iterable[Path | str | None], suffixes: Sequence[str], *, flag: str = "--out",
                  make_parents: bool = False) -> None:
    """Refuse output files before any work: each path (None skipped) must end in one of ``suffixes``, must not
    be a folder, and must go into an existing writable folder (with ``make_parents``: the folders missing
    would be created, so the nearest existing one must be writable). Raises CLIError naming ``flag``."""
    for path in paths:
        if path is None:
            continue
        path = Path(path)
        if path.is_dir():
            raise CLIError(f"{flag} {path} is a folder; give a file name ending in {', '.join(suffixes)}")
        if path.suffix.lower() not in suffixes:
            raise CLIError(f"{flag} {path}: unsupported file type {path.suffix or '(no extension)'!r}; "
                           f"use {', '.join(suffixes)}")
        if path.exists() and not os.access(path, os.W_OK):
            raise CLIError(f"{flag} {path}: the file exists and cannot be overwritten (no permission)")
        _check_folder(path.parent, flag=flag, what=path, make=make_parents)


def check_output_folder(path: Path | str | None, *, flag: str = "--out") -> None:
    """Refuse an output folder before any work: it must be a folder if it exists, else creatable (the nearest
    existing folder above it writable, no file in the way)."""
    if path is None:
        return
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise CLIError(f"{flag} {path} is a file, not a folder")
    _check_folder(path, flag=flag, what=path, make=True)


def _check_folder(folder: Path, *, flag: str, what: Path, make: bool) -> None:
    folder = Path(folder) if str(folder) else Path(".")
    probe = folder
    if make:
        while not probe.exists() and probe != probe.parent:
            probe = probe.parent
    if not probe.exists():
        raise CLIError(f"{flag} {what}: the folder {folder} does not exist")
    if not probe.is_dir():
        raise CLIError(f"{flag} {what}: {probe} is a file, not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise CLIError(f"{flag} {what}: the folder {probe} is not writable")


def one_line(text: object) -> str:
    return " ".join(line.strip() for line in str(text).splitlines() if line.strip())
