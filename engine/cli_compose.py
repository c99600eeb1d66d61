"""`moattn compose`: DoubleTake long motions from intervals (same function as the Compose tab)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from engine.paths import MODEL_DIR


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compose", help="DoubleTake: a long motion from PROMPT:SECONDS intervals",
                       description="Generate a long motion from intervals, each 'PROMPT:SECONDS' (up to 9.8 s), "
                       "joined by handshakes (PriorMDM's DoubleTake). Consecutive intervals share the handshake "
                       "frames, so the motion lasts the sum of the intervals minus one handshake per transition.")
    p.add_argument("intervals", nargs="+", metavar="PROMPT:SECONDS")
    p.add_argument("--handshake", type=float, default=1.0, help="handshake length in seconds (default 1)")
    p.add_argument("--first-take-only", action="store_true", help="skip the second take")
    p.add_argument("--renoise", type=float, default=0.7, help="second take: T' as a fraction of the timesteps")
    p.add_argument("--hard", type=float, default=0.85, help="second take: M_hard (handshake)")
    p.add_argument("--soft", type=float, default=0.1, help="second take: M_soft (context)")
    p.add_argument("--ramp", type=int, default=10, help="second take: b, ramp frames")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=2.5)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--out", type=Path, required=True, help="the long motion (.npy or .bvh)")
    p.add_argument("--render", type=Path, default=None, help="a render (.gif, .mp4 or .png)")
    p.set_defaults(run=run)


def config_from_args(args: argparse.Namespace):
    from engine.methods.doubletake import DoubleTakeConfig, SecondTake

    take = None if args.first_take_only else SecondTake(renoise=args.renoise, hard=args.hard, soft=args.soft,
                                                          ramp=args.ramp)
    return DoubleTakeConfig(handshake=int(round(args.handshake * 20)), second_take=take)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import SampleConfig
    from engine.io import save_motion
    from engine.methods.doubletake import Interval, compose

    intervals = [Interval.parse(text) for text in args.intervals]
    config = config_from_args(args)
    loaded = load_model(args.model)
    for iv in intervals:
        loaded.tokenizer.encode(iv.prompt)  # unknown words fail before any sampling
    result = compose(loaded, intervals, config, sample=SampleConfig(steps=args.steps, guidance=args.guidance,
                                                                    seed=args.seed))
    save_motion(result.joints, args.out)
    report = {"out": str(args.out), "frames": int(len(result.joints)), "seconds_of_motion": len(result.joints) / 20,
              "intervals": [{"prompt": iv.prompt, "start_frame": s} for iv, s in zip(intervals, result.starts)],
              "transitions": result.transitions, "wall_seconds": round(result.seconds, 2)}
    if args.render is not None:
        from viz.render import render_file

        render_file(result.joints, args.render)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2))
    return 0
