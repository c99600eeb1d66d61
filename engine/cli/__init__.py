"""`moattn` command line: one parser, each subcommand's work lives in the library.

Subcommands register themselves through (name, add_parser, run) entries below, one module per command in this
package (engine/cli/generate.py, engine/cli/edit.py, ...); their modules are imported lazily so `moattn --help`
stays fast and a broken optional piece cannot break the rest. This package is the one place where the engine,
viz/ and app/ meet: the engine's library code imports neither (tests/test_layers.py).

Every user error is one line on stderr, ``moattn <command>: error: ...``, and exit status 2: argparse's own (a bad
flag, an abbreviated one, a seed out of range: :func:`engine.cli.common.seed_argument`), and those raised by the work
(``CLIError``, ``ValueError`` -- the readers' MotionIOError, a model folder's ModelFolderError, ... -- and
``OSError``). Output paths are checked before any model loads or sampling starts
(:func:`engine.cli.common.check_outputs`). What the subcommands share lives in :mod:`engine.cli.common`.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from engine.cli.common import CLIError, Parser, one_line

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


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
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
        message = one_line(exc) or type(exc).__name__
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

