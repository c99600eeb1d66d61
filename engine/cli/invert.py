"""`moattn invert`: DDIM-invert a real motion and report the round-trip error in metres."""
from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

from engine.cli.common import check_outputs
from engine.cli.options import add_options, add_sample_options, from_args
from engine.cli.convert import add_window_args, load_window
from engine.methods.inversion_options import InversionConfig
from engine.options import option
from engine.runtime import add_runtime_arguments, runtime_from_args


@dataclass(frozen=True, kw_only=True)
class InvertFiles:
    """`moattn invert`'s input and outputs."""

    input: Path = option(positional=True, help=".bvh or .npy motion (at most the model's 9.8 s: pick a longer file's "
                         "window with --start/--seconds)")
    out: Path | None = option(None, help="save the noise as .npy (1, T, 263)")
    json: bool = option(False, help="print the report as JSON")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("invert", help="DDIM-invert a motion (BVH/.npy) to noise and measure the round trip",
                       description="Motion -> noise -> motion with the model; prints the joint error in metres.")
    add_options(p, InvertFiles, only=("input",))
    add_sample_options(p, only=("model",))
    add_options(p, InversionConfig)
    add_options(p, InvertFiles, skip=("input",))
    add_window_args(p, what="the part of the input to invert")
    add_runtime_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from engine.checkpoint import load_model
    from engine.io.window import seconds_of
    from engine.methods.inversion import invert, reconstruct, roundtrip_figures

    check_outputs([args.out], (".npy",))
    config = from_args(InversionConfig, args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    joints = load_window(args.input, args, max_frames=loaded.model.config.max_frames)
    inverted = invert(loaded, joints, config)  # once: the round trip and --out share it
    report = {"input": str(args.input), "start_s": args.start or 0.0, "seconds": seconds_of(len(joints)),
              **roundtrip_figures(inverted, reconstruct(loaded, inverted, config)), "steps": args.steps,
              "refine": args.refine, "landing": args.landing, "prompt": args.prompt}
    if args.out is not None:
        np.save(args.out, inverted.noise.numpy(), allow_pickle=False)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        window = "" if args.start is None and args.seconds is None else \
            f" from {report['start_s']:g} s"
        print(f"{args.input}: {report['seconds']:.1f} s{window}, {report['frames']} frames, round-trip error mean "
              f"{report['mean_m'] * 100:.2f} cm, max {report['max_m'] * 100:.2f} cm (the pose, relative to the root: "
              f"{report['pose_mean_m'] * 100:.2f} cm), noise std "
              f"{report['noise_std']:.3f} (pure noise: 1; steps {args.steps}, refine {args.refine}, "
              f"landing {args.landing})")
    return 0
