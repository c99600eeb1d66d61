"""`moattn` command line: one parser, each subcommand's work lives in the library.

Subcommands register themselves through (name, add_parser, run) entries below; their modules are
imported lazily so `moattn --help` stays fast and a broken optional piece cannot break the rest.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

# name -> module providing `add_parser(subparsers)` and `run(args) -> int`
SUBCOMMANDS: dict[str, str] = {
    "convert": "engine.cli_io",
    "render": "engine.cli_io",
    "corpus": "engine.cli_corpus",
    "train": "engine.cli_train",
    "eval": "engine.cli_eval",
    "export-model": "engine.cli_export",
    "evaluator": "engine.cli_eval",
    "generate": "engine.cli_generate",
    "edit": "engine.cli_edit",
    "invert": "engine.cli_invert",
    "transfer": "engine.cli_transfer",
    "analyze-qk": "engine.cli_transfer",
    "compose": "engine.cli_compose",
    "control": "engine.cli_compose",
    "duet": "engine.cli_duet",
    "serve": "app.cli_serve",
    "bench": "engine.cli_bench",
}


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if getattr(args, "device", None) is not None:  # one device rule: refused before any work starts
            from engine.runtime import runtime_from_args

            runtime_from_args(args)
        return int(args.run(args) or 0)
    except (CLIError, ValueError, FileNotFoundError) as exc:
        print(f"moattn {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"moattn {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
