"""`moattn` command line: one parser, each subcommand's work lives in the library.

Subcommands register themselves through (name, add_parser, run) entries below, one module per command in this
package (engine/cli/generate.py, engine/cli/edit.py, ...); their modules are imported lazily so `moattn --help`
stays fast and a broken optional piece cannot break the rest. This package is the one place where the engine,
viz/ and app/ meet: the engine's library code imports neither (tests/test_layers.py).

Every user error is one line on stderr, ``moattn <command>: error: ...``, and exit status 2: argparse's
own (a bad flag, a seed out of range: :func:`seed_argument`), and those raised by the work (``CLIError``,
``ValueError`` -- the readers' MotionIOError, a model folder's ModelFolderError, ... -- and ``OSError``).
Output paths are checked before any model loads or sampling starts (:func:`check_outputs`).
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

# name -> module providing `add_parser(subparsers)` and `run(args) -> int`
SUBCOMMANDS: dict[str, str] = {
    "convert": "engine.cli.convert",
    "render": "engine.cli.convert",
    "corpus": "engine.cli.corpus",
    "train": "engine.cli.train",
    "eval": "engine.cli.eval",
    "export-model": "engine.cli.export",
    "evaluator": "engine.cli.eval",
    "generate": "engine.cli.generate",
    "edit": "engine.cli.edit",
    "invert": "engine.cli.invert",
    "transfer": "engine.cli.transfer",
    "analyze-qk": "engine.cli.transfer",
    "compose": "engine.cli.compose",
    "control": "engine.cli.control",
    "duet": "engine.cli.duet",
    "serve": "engine.cli.serve",
    "bench": "engine.cli.bench",
    "library": "engine.cli.library",
}

SEED_LIMIT = 2**32  # seeds are 0 <= seed < 2**32: derived seeds (seed * 7919 + step, seed * 1009 + slot, seed + 17)
#                     must stay within torch.manual_seed's 64-bit range; numpy's default_rng takes them too
MOTION_SUFFIXES: tuple[str, ...] = (".npy", ".bvh")  # engine.io.SUPPORTED_SUFFIXES
RENDER_SUFFIXES: tuple[str, ...] = (".png", ".gif", ".mp4")  # viz.render.SUPPORTED_EXTENSIONS (not imported: slow)


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``moattn generate: error: ...``, exit 2) that point at --help."""

    def error(self, message: str):  # noqa: D401 - argparse's hook
        self.exit(2, f"{self.prog}: error: {_one_line(message)} (see {self.prog} --help)\n")


def seed_argument(text: str) -> int:
    """argparse type of every ``--seed``: a whole number 0 <= seed < 2**32 (SEED_LIMIT)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a seed is a whole number, got {text[:40]!r}") from None
    if not 0 <= value < SEED_LIMIT:
        raise argparse.ArgumentTypeError(
            f"seed {text[:40]} is out of range: a seed is a whole number from 0 to {SEED_LIMIT - 1}")
    return value


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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="moattn",
        description="Motion Attention Studio: train, drive and edit a motion diffusion model's attention.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    seen: set[str] = set()
    for name, module_name in SUBCOMMANDS.items():
        if module_name in seen:
            continue
        seen.add(module_name)
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name and module_name.startswith(exc.name):
                continue  # that subcommand is not part of this build yet
            raise
        module.add_parser(sub)
    return parser


def _one_line(text: object) -> str:
    return " ".join(line.strip() for line in str(text).splitlines() if line.strip())


def main(argv: Sequence[str] | None = None) -> int:
    from engine.cli.train import legacy_argv

    parser = build_parser()
    args, extra = parser.parse_known_args(legacy_argv(list(sys.argv[1:] if argv is None else argv)))
    if extra:  # name the (sub)command whose flags these are not
        where = " ".join(filter(None, ["moattn", getattr(args, "command", None), getattr(args, "trainer", None)]))
        print(f"{where}: error: unrecognized arguments: {' '.join(extra)} (see {where} --help)", file=sys.stderr)
        return 2
    try:
        if getattr(args, "device", None) is not None:  # one device rule: refused before any work starts
            from engine.runtime import runtime_from_args

            runtime_from_args(args)
        return int(args.run(args) or 0)
    except (CLIError, ValueError, OSError) as exc:
        message = _one_line(exc) or type(exc).__name__
        if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
            message = f"{exc.strerror}: {exc.filename}"
        print(f"moattn {args.command}: error: {message}", file=sys.stderr)
        return 2
    except RecursionError:
        print(f"moattn {args.command}: error: an input is nested too deeply to read", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"moattn {args.command}: error: out of memory (an input or a setting is too large)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"moattn {args.command}: interrupted", file=sys.stderr)
        return 130

