"""What a command that makes motions adds to keep them in the library (torch-free).

    add_library_arguments(parser)            # --workspace DIR, --library-mb MB, --no-library
    keep(args, joints, kind="edit", title=..., recipe={...}, features=..., parents=[...])

``keep`` prints one line ("kept in the library as <id>") and, when the bound removed older motions, one line
saying which; with ``--no-library`` it does nothing. A library that cannot be written (a read-only workspace) is a
warning on stderr, never the command's failure: the motion files asked for were written already.
"""
from __future__ import annotations

import argparse
import functools
import hashlib
import sys
from pathlib import Path

from engine.library.store import Added, MotionLibrary
from engine.library.workspace import DEFAULT_LIMIT_MB, LIMIT_ENV, WORKSPACE_ENV, check_limit_mb
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE_FROM, FPS


def add_library_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("motion library", "every motion made is kept in the workspace's library "
                             "(see `moattn library list`)")
    g.add_argument("--workspace", type=Path, default=None, metavar="DIR",
                   help=f"the workspace folder (default: ${WORKSPACE_ENV}, else the user-data folder)")
    g.add_argument("--library-mb", type=library_mb_argument, default=None, metavar="MB",
                   help=f"the library's size bound: past it the least recently made unpinned motions are removed "
                        f"(default: ${LIMIT_ENV}, else the stored `moattn library limit`, else {DEFAULT_LIMIT_MB:g})")
    g.add_argument("--no-library", action="store_true", help="do not keep the motions made in the library")


def library_mb_argument(text: str) -> float:
    """argparse type of ``--library-mb``: a number of MB (at least MIN_LIMIT_MB)."""
    try:
        return check_limit_mb(text, what="--library-mb")
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def open_library(args: argparse.Namespace, *, quiet: bool = False) -> MotionLibrary:
    """The library the command's flags name (problems found are reported on stderr, one line each)."""
    report = None if quiet else (lambda line: print(line, file=sys.stderr))
    return MotionLibrary(workspace=getattr(args, "workspace", None), limit_mb=getattr(args, "library_mb", None),
                         report=report)


def keep(args: argparse.Namespace, joints, *, kind: str, title: str, recipe: dict | None = None, features=None,
         parents=(), reuse: bool = False, library: MotionLibrary | None = None, stream=None) -> Added | None:
    """Keep one motion in the library unless ``--no-library``; print what happened (on ``stream``, default stdout:
    commands whose stdout is one JSON report say it on stderr); None when not kept."""
    if getattr(args, "no_library", False):
        return None
    try:
        library = library or open_library(args)
        added = library.add(joints, kind=kind, title=title, recipe=recipe, features=features, parents=parents,
                            reuse=reuse)
    except (OSError, ValueError) as exc:  # sqlite3 errors included (OperationalError is an Exception: below)
        print(f"warning: not kept in the library: {exc}", file=sys.stderr)
        return None
    except Exception as exc:  # sqlite3.Error and the like: the motion files were written, say why and go on
        print(f"warning: not kept in the library: {type(exc).__name__}: {exc}", file=sys.stderr)
        return None
    print(say_added(added, library), file=stream or sys.stdout)
    if added.evicted:
        print(say_evicted(added), file=sys.stderr)
    return added


def cli_recipe(args: argparse.Namespace, *, made_by: str, prompt: str | None = None, frames: int | None = None,
               seconds: float | None = None, guidance: float | None = None, model=None, seed: int | None = None,
               **operation) -> dict:
    """The recipe a command keeps with a motion it made: the sampling flags every such command has (``--seed``,
    ``--steps``, ``--guidance``, ``--model``; ``guidance`` / ``model`` / ``seed`` given where the command chose
    others, e.g. the seed of the try kept), the motion's length (``frames``, or ``seconds`` as asked) and what the
    operation was (``operation``, as given)."""
    if frames is not None:
        seconds = frames / FPS
    return {"prompt": prompt, "seed": args.seed if seed is None else seed, "steps": args.steps,
            "guidance": args.guidance if guidance is None else guidance,
            "guidance_from": getattr(args, "guidance_from", DEFAULT_GUIDANCE_FROM),
            "eta": getattr(args, "eta", DEFAULT_ETA), "seconds": seconds,
            "model": model_info(args.model if model is None else model),
            "operation": {**operation, "made_by": made_by}}


def say_added(added: Added, library: MotionLibrary) -> str:
    what = "already in the library as" if added.reused else "kept in the library as"
    return f"{what} {added.entry.id} ({library.root})"


def say_evicted(added: Added) -> str:
    """One line: which motions the bound removed."""
    n = len(added.evicted)
    names = ", ".join(repr(e.title[:40]) for e in added.evicted[:3]) + (" ..." if n > 3 else "")
    line = (f"library over its {added.limit_bytes / 2**20:g} MB bound: removed the {n} least recently made unpinned "
            f"motion{'s' if n != 1 else ''} ({names})")
    if added.over_limit:
        line += f"; still {added.total_bytes / 2**20:.1f} MB (pinned motions are never removed)"
    return line


@functools.lru_cache(maxsize=16)
def _weights_digest(path: str, size: int, mtime: float) -> str | None:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()[:16]


def model_info(folder: str | Path | None) -> dict | None:
    """The model a motion was made with, as its recipe names it: folder, name and a short digest of its weights
    (so a later run can tell whether it has the same model)."""
    if folder is None:
        return None
    folder = Path(folder).expanduser()
    try:
        folder = folder.resolve()
    except OSError:
        pass
    info = {"folder": str(folder), "name": folder.name}
    weights = folder / "weights.pt"
    try:
        st = weights.stat()
        info["weights_sha256"] = _weights_digest(str(weights), st.st_size, st.st_mtime)
    except OSError:
        info["weights_sha256"] = None
    return info
