"""`moattn compose` (DoubleTake): PriorMDM's long motions (`moattn control` is engine/cli/control.py)."""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, check_outputs
from engine.cli.options import add_options, add_sample_options, sample_config
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.methods.doubletake_config import (DoubleTakeConfig, SecondTake, check_option, option_info, options,
                                              parse_handshakes)
from engine.options import option
from engine.runtime import add_runtime_arguments, runtime_from_args


@dataclass(frozen=True, kw_only=True)
class ComposeFiles:
    """`moattn compose`'s own settings: the intervals, first take only, the output files."""

    intervals: tuple[str, ...] = option(positional=True, nargs="+", metavar="PROMPT:SECONDS",
                                        help="an interval: its prompt and its length in seconds (up to 9.8)")
    first_take_only: bool = option(False, help="skip the second take")
    out: Path = option(required=True, type=Path, help="the long motion (.npy or .bvh)")
    render: Path | None = option(None, type=Path, help="a picture (.gif, .mp4 or .png) by the studio's exporter, "
                                 "titled with the intervals' prompts")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compose", help="DoubleTake: a long motion from PROMPT:SECONDS intervals",
                       description="Generate a long motion from intervals, each 'PROMPT:SECONDS' (up to 9.8 s), "
                       "joined by handshakes (PriorMDM's DoubleTake). Consecutive intervals share the handshake "
                       "frames, so the motion lasts the sum of the intervals minus one handshake per transition.")
    add_options(p, ComposeFiles)
    # every option's default, bounds and help: engine.methods.doubletake_config (the studio's Compose tab reads it too)
    hand = option_info(DoubleTakeConfig, "handshake")
    p.add_argument("--handshake", default=None, metavar="FRAMES[,FRAMES...]",
                   help=f"{hand.help}: one value for every transition or one per transition, e.g. 20,30,15; in "
                        f"seconds with an s (1s); {hand.bounds[0]:g} to {hand.bounds[1]:g} frames (default "
                        f"{hand.default})")
    add_options(p, SecondTake, given_only=True, describe_with=_second_take_help)
    add_sample_options(p)
    add_runtime_arguments(p)
    add_library_arguments(p)
    p.set_defaults(run=run)


def _second_take_help(spec) -> str:
    if spec.bounds is None:
        return f"second take: {spec.help}"
    unit = f" {spec.unit}" if spec.unit else ""
    return f"second take: {spec.help}; {spec.bounds[0]:g} to {spec.bounds[1]:g}{unit} (default {spec.default_text()})"


def _dest(info) -> str:
    """Where argparse keeps a second-take option (its flag's name: ``--second-take-steps`` is not ``--steps``)."""
    return info.flag.replace("-", "_")


def config_from_args(args: argparse.Namespace, intervals: int | None = None):
    """The DoubleTakeConfig of the command line; ``intervals``: how many were given (checks the handshake count)."""
    given = {info.name: getattr(args, _dest(info)) for info in options(SecondTake)
             if getattr(args, _dest(info)) is not None}
    if args.first_take_only and (given or args.second_take_text or not args.planted_feet):
        flags = [f"--{option_info(SecondTake, n).flag}" for n in given]
        flags += ["--second-take-text"] if args.second_take_text else []
        flags += [] if args.planted_feet else ["--no-second-take-planted-feet"]
        raise ValueError(f"{', '.join(flags)} set the second take: leave out --first-take-only")
    for name, value in given.items():  # each against its declared bounds, named by its flag
        check_option(SecondTake, name, value, what=f"--{option_info(SecondTake, name).flag}")
    try:
        take = None if args.first_take_only else SecondTake(**given, text=args.second_take_text,
                                                                 planted_feet=args.planted_feet)
    except ValueError as exc:
        raise ValueError(f"second take: {exc}") from None
    if args.handshake is None:
        return DoubleTakeConfig(second_take=take)
    hs = parse_handshakes(args.handshake)
    config = DoubleTakeConfig(handshake=hs if len(hs) > 1 else hs[0], second_take=take)
    if intervals is not None:
        try:
            config.handshakes(intervals)
        except ValueError as exc:
            raise ValueError(f"--handshake: {exc}") from None
    return config


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.io import save_motion
    from engine.methods.doubletake import Interval, check_intervals, compose

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    intervals = [Interval.parse(text) for text in args.intervals]
    config = config_from_args(args, len(intervals))
    check_intervals(intervals, config.handshakes(len(intervals)))  # before the model loads
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    notes = {}
    for iv in intervals:  # a prompt with nothing readable fails before any sampling; other words are noted
        if said := loaded.tokenizer.encode(iv.prompt).notes():
            notes[iv.prompt] = said
            print(f"notes: {iv.prompt!r}: {'; '.join(said)}", file=sys.stderr)
    result = compose(loaded, intervals, config, sample=sample_config(args))
    save_motion(result.joints, args.out)
    title = " → ".join(iv.prompt for iv in intervals)[:200]
    keep(args, result.joints, kind="compose", stream=sys.stderr, title=title,
         recipe=cli_recipe(args, made_by="moattn compose", prompt=" / ".join(iv.prompt for iv in intervals),
                           frames=len(result.joints), compose=list(args.intervals), transitions=result.transitions))
    report = {"out": str(args.out), "frames": int(len(result.joints)), "seconds_of_motion": len(result.joints) / 20,
              "intervals": [{"prompt": iv.prompt, "start_frame": s} for iv, s in zip(intervals, result.starts)],
              "transitions": result.transitions, "handshakes": [b - a for a, b in result.transitions],
              "second_take": config.second_take is not None,
              "planted_feet": config.second_take is not None and config.second_take.planted_feet,
              "wall_seconds": round(result.seconds, 2)}
    if notes:
        report["notes"] = notes
    if args.render is not None:  # the studio's exporter, titled as kept
        from viz.export import write_picture

        write_picture(result.joints, args.render, title=title)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2))
    return 0
