"""A method's options are declared once (issue #34, item 1): one typed, torch-free options class per method holds
each field's default, bounds and help; `moattn`'s flags are generated from it (engine/cli/options.py), and one
validate refuses a value out of bounds in one line."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from engine.analysis.counting import CountingConfig
from engine.cli import build_parser, main
from engine.cli.options import SampleOptions
from engine.evaluation.bench_options import BenchOptions
from engine.methods.control_options import ControlOptions
from engine.methods.doubletake_config import SecondTake
from engine.methods.duet_options import DuetOptions
from engine.methods.edit_options import EditOptions
from engine.methods.generate_options import GenerateOptions
from engine.methods.inversion_options import InversionConfig
from engine.methods.transfer_config import TransferConfig, TransferSources
from engine.options import option, spec, specs, validate

ROOT = Path(__file__).resolve().parents[1]
MAX_ADD_ARGUMENT = 108  # half of the 216 hand-written add_argument calls before the options were declared once

# command -> (argv that parses, the options classes whose fields are its flags)
COMMANDS = {
    "generate": (["generate", "a person walks"], (GenerateOptions, SampleOptions)),
    "edit": (["edit", "emphasize", "a person walks"], (EditOptions, SampleOptions)),
    "count": (["edit", "count", "a person walks"], (CountingConfig,)),
    "transfer": (["transfer", "--leader", "a", "--follower", "b", "--out", "o.npy"],
                 (TransferConfig, TransferSources, SampleOptions)),
    "compose": (["compose", "a person walks:3", "--out", "o.npy"], (SecondTake, SampleOptions)),
    "control": (["control", "--prompt", "a person walks", "--out", "o.npy"], (ControlOptions, SampleOptions)),
    "duet": (["duet", "two people shake hands", "--out", "o.npy"], (DuetOptions,)),
    "invert": (["invert", "walk.bvh"], (InversionConfig,)),
    "bench": (["bench"], (BenchOptions,)),
}
# flags a command reads as "given or not" (None when left out), the default said in its help
GIVEN_ONLY = {("compose", SecondTake): {f.name for f in specs(SecondTake) if f.bounds is not None},
              ("control", ControlOptions): {"method", "root_weight", "left_wrist_weight", "right_wrist_weight"}}


def test_the_cli_declares_at_most_half_the_flags_by_hand():
    text = "".join(p.read_text(encoding="utf-8") for p in sorted((ROOT / "engine" / "cli").glob("*.py")))
    count = len(re.findall(r"add_argument\(", text))
    assert count <= MAX_ADD_ARGUMENT, f"{count} add_argument( calls in engine/cli/*.py (at most {MAX_ADD_ARGUMENT})"


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_option_is_a_flag_with_its_declared_default(command):
    argv, classes = COMMANDS[command]
    parser = build_parser()
    args = parser.parse_args(argv)
    sub = parser._subparsers._group_actions[0].choices[argv[0]]  # noqa: SLF001 (argparse keeps them there)
    actions = {a.dest: a for a in sub._actions}  # noqa: SLF001
    for cls in classes:
        for s in specs(cls):
            if not s.cli:
                continue
            assert s.dest in actions, f"{cls.__name__}.{s.name} has no flag in moattn {argv[0]}"
            if s.positional:
                continue
            assert s.flag in actions[s.dest].option_strings, (s.flag, actions[s.dest].option_strings)
            if s.has_default and not s.required:
                expected = None if s.name in GIVEN_ONLY.get((command, cls), ()) else s.default
                assert getattr(args, s.dest) == expected, (command, s.name, getattr(args, s.dest), expected)
            if s.help:
                assert " ".join(s.help.split())[:40] in " ".join((actions[s.dest].help or "").split()), s.name


def test_units_are_the_one_home_of_the_sampling_defaults():
    from engine.units import DEFAULT_GUIDANCE, DEFAULT_STEPS

    for argv in (["generate", "x"], ["edit", "erase", "x"], ["compose", "a:3", "--out", "o.npy"],
                 ["control", "--prompt", "x", "--out", "o.npy"], ["duet", "x", "--out", "o.npy"], ["invert", "w.bvh"]):
        args = build_parser().parse_args(argv)
        assert args.steps == DEFAULT_STEPS, argv
        assert getattr(args, "guidance", DEFAULT_GUIDANCE) in (DEFAULT_GUIDANCE, None), argv


def test_validate_refuses_a_value_out_of_bounds_in_one_line():
    with pytest.raises(ValueError) as caught:
        EditOptions(kind="example", prompt="a person jumps", chunk_frames=200)
    assert str(caught.value) == "chunk size (frames) must be between 4 and 100, got 200"
    with pytest.raises(ValueError, match=r"^directions must be between 1 and 8, got 9$"):
        TransferConfig(directions=9)
    with pytest.raises(ValueError, match=r"^renoise must be between 0.01 and 1, got 2$"):
        SecondTake(renoise=2.0)

    from dataclasses import dataclass

    @dataclass(frozen=True, kw_only=True)
    class Probe:
        level: int = option(3, bounds=(1, 5), whole=True, help="a level")
        kind: str = option("a", choices=("a", "b"), help="a kind")

    assert validate(Probe()) == Probe()
    for bad, said in ((Probe(level=0), "level must be between 1 and 5, got 0"),
                      (Probe(level=2.5), "level must be a whole number, got 2.5"),
                      (Probe(kind="c"), "kind must be one of a, b, got 'c'")):
        with pytest.raises(ValueError) as caught:
            validate(bad)
        assert str(caught.value) == said and "\n" not in said


@pytest.mark.parametrize("argv, said", [
    (["transfer", "--leader", "a", "--follower", "b", "--out", "{tmp}/o.npy", "--directions", "0"],
     "--directions must be between 1 and 8, got 0"),
    (["invert", "{tmp}/walk.bvh", "--steps", "0"], "--steps must be between 1 and 1000, got 0"),
])
def test_the_cli_names_the_flag_out_of_bounds(argv, said, tmp_path, capsys):
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert said in err and len(err.strip().splitlines()) == 1, err


def test_the_options_classes_load_without_torch():
    code = ("import sys; import engine.options, engine.methods.edit_options, engine.methods.transfer_config, "
            "engine.methods.doubletake_config, engine.methods.control_options, engine.methods.duet_options, "
            "engine.methods.generate_options, engine.methods.inversion_options, engine.evaluation.bench_options; "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "False", out.stderr


def test_duet_spacing_is_on_unless_no_spacing():
    parser = build_parser()
    assert parser.parse_args(["duet", "two people hug", "--out", "o.npy"]).spacing is True
    assert parser.parse_args(["duet", "two people hug", "--out", "o.npy", "--no-spacing"]).spacing is False
    assert spec(DuetOptions, "spacing").flag == "--no-spacing"


def test_moattn_duet_no_spacing(tmp_path, tiny_model_dir, tiny_duet_dir, capsys):
    """The spacing rule (engine/methods/duet_spacing.py) is applied by default; --no-spacing leaves the sample as
    the block made it. Person a never moves either way."""
    import json

    import numpy as np

    runs = {}
    for name, extra in (("spaced", []), ("raw", ["--no-spacing"])):
        out = tmp_path / f"{name}.npy"
        assert main(["duet", "two people hug", "--out", str(out), "--seconds", "2", "--steps", "3", "--model",
                     str(tiny_model_dir), "--duet-model", str(tiny_duet_dir), "--no-library", *extra]) == 0
        runs[name] = (json.loads(capsys.readouterr().out), np.load(out))
    assert runs["spaced"][0]["spacing"] is True and runs["raw"][0]["spacing"] is False
    np.testing.assert_array_equal(runs["spaced"][1][0], runs["raw"][1][0])


def test_the_edit_tab_and_the_cli_share_the_example_count():
    """#34: the number of example-based outputs was 4 in `moattn edit` and 3 in the Edit tab."""
    from app.tabs.edit.settings import EditSettings
    from engine.methods.edit_options import option_spec

    spec = option_spec("count")
    assert EditSettings().count == spec.default and EditSettings.param.count.bounds == spec.bounds
    assert EditSettings.param.count.label == spec.label


def _helps(parser, name=""):
    import argparse

    yield name, parser.format_help()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from _helps(child, f"{name} {sub}".strip())


def test_no_help_names_an_absolute_path_of_this_machine():
    """Defaults inside the project (the shipped model, evaluator, controls, duet block, the duet's --prior) are said
    relative to it, as shipped files name them; every command and sub-command's help is read."""
    helps = dict(_helps(build_parser()))
    assert {"generate", "bench", "serve", "eval", "train duet"} <= set(helps)
    assert not [name for name, text in helps.items() if str(ROOT) in text]
    said = {name: " ".join(text.split()) for name, text in helps.items()}
    assert "(default: assets/model)" in said["train duet"] and "(default assets/model)" in said["generate"]
    assert "default assets/control" in said["serve"] and "(default: assets/evaluator)" in said["eval"]
