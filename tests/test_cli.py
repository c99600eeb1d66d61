"""The `moattn` command line as a whole: a flag is its full name, never a prefix of one (``--to kicks`` is not
``--to-frame kicks``), in every (sub)parser; ``python -m engine.cli`` is the `moattn` script."""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from engine.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


def _parsers(parser: argparse.ArgumentParser, prog: str = "moattn"):
    yield prog, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, f"{prog} {name}")


def test_every_parser_refuses_abbreviations():
    allowing = [prog for prog, parser in _parsers(build_parser()) if parser.allow_abbrev]
    assert not allowing, allowing


@pytest.mark.parametrize("argv, flag", [
    (["edit", "replace", "a person walks", "--edited", "a person jumps", "--to", "kicks"], "--to"),
    (["generate", "a person walks", "--se", "2"], "--se"),
    (["train", "base", "--ste", "2"], "--ste"),
])
def test_an_abbreviated_flag_is_refused_with_argparses_error(argv, flag, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("moattn: error: unrecognized arguments: " + flag) and "\n" not in err

    assert main(argv) == 2  # the command line itself names the subcommand: one line, nothing run
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"moattn {argv[0]}") and f"error: unrecognized arguments: {flag}" in err and "\n" not in err


def test_the_full_flag_still_parses():
    args = build_parser().parse_args(["edit", "replace", "a person walks", "--edited", "a person jumps",
                                      "--to-frame", "40"])
    assert args.to_frame == 40


def test_python_dash_m_engine_cli_is_the_moattn_script():
    out = subprocess.run([sys.executable, "-m", "engine.cli", "--help"], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert "usage: moattn" in out.stdout and "generate" in out.stdout and "serve" in out.stdout
