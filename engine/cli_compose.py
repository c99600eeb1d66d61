"""`moattn compose` (DoubleTake) and `moattn control` (control models, DiffusionBlending): PriorMDM's commands."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from engine.paths import MODEL_DIR
from engine.runtime import add_runtime_arguments, runtime_from_args


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
    p.add_argument("--second-take-text", action="store_true",
                   help="second take: denoise each transition with 'A, then B' (default: without text, as the "
                        "authors' code)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=2.5)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--out", type=Path, required=True, help="the long motion (.npy or .bvh)")
    p.add_argument("--render", type=Path, default=None, help="a render (.gif, .mp4 or .png)")
    add_runtime_arguments(p)
    p.set_defaults(run=run)
    add_control_parser(sub)


def config_from_args(args: argparse.Namespace):
    from engine.methods.doubletake import DoubleTakeConfig, SecondTake

    take = None if args.first_take_only else SecondTake(renoise=args.renoise, hard=args.hard, soft=args.soft,
                                                          ramp=args.ramp, text=args.second_take_text)
    return DoubleTakeConfig(handshake=int(round(args.handshake * 20)), second_take=take)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import SampleConfig
    from engine.io import save_motion
    from engine.methods.doubletake import Interval, compose

    intervals = [Interval.parse(text) for text in args.intervals]
    config = config_from_args(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
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


# ----------------------------------------------------------------------------- moattn control
def add_control_parser(sub: argparse._SubParsersAction) -> None:
    from engine.paths import CONTROL_DIR

    p = sub.add_parser("control", help="PriorMDM control: follow a root and/or wrist path (DiffusionBlending)",
                       description="Generate a motion that follows a root path on the floor and/or wrist paths. "
                       "PATH.json: {\"points\": [[x, z], ...], \"times\": [seconds, ...]} (times optional) for the "
                       "root (metres, world floor); [[x, y, z], ...] for a wrist in the body frame (x to the "
                       "person's left, y height, z forward). The fine-tuned control models are blended with "
                       "--weights (default equal); --inpaint uses the base model with plain inpainting instead.")
    p.add_argument("--prompt", required=True)
    p.add_argument("--root", type=Path, default=None, help="root path JSON")
    p.add_argument("--left-wrist", type=Path, default=None, help="left wrist path JSON")
    p.add_argument("--right-wrist", type=Path, default=None, help="right wrist path JSON")
    p.add_argument("--weights", type=float, nargs="+", default=None,
                   help="blend weights in the order root, left wrist, right wrist (those given); scaled to sum 1")
    p.add_argument("--inpaint", action="store_true", help="the baseline: the base model with plain inpainting")
    p.add_argument("--seconds", type=float, default=6.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=2.5)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--controls", type=Path, default=CONTROL_DIR, help=f"control model folders (default {CONTROL_DIR})")
    p.add_argument("--out", type=Path, required=True, help="the motion (.npy or .bvh), in the path's world frame")
    p.add_argument("--render", type=Path, default=None, help="a render (.gif, .mp4 or .png)")
    add_runtime_arguments(p)
    p.set_defaults(run=run_control)


def read_path(path: Path, *, dims: int) -> tuple[list, list | None]:
    """Points (and optional times) from a path JSON file: a list of points or {"points", "times"}."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a JSON path ({exc})") from None
    if isinstance(data, dict):
        points, times = data.get("points"), data.get("times")
    else:
        points, times = data, None
    if not isinstance(points, list):
        raise ValueError(f"{path}: expected a list of {dims}-D points")
    return points, times


def build_controls(args: argparse.Namespace):
    """The command line's paths as Controls, plus the root frame (to place the motion in the path's world)."""
    from engine.methods.control import Control
    from engine.methods.paths import RootPath, WristPath, root_controls

    controls, frame = [], None
    if args.root is not None:
        pts, times = read_path(args.root, dims=2)
        values, frame = root_controls(RootPath(points=tuple(map(tuple, pts)), times=times), args.seconds)
        controls.append(Control("root", values))
    for name, path in (("left_wrist", args.left_wrist), ("right_wrist", args.right_wrist)):
        if path is not None:
            pts, times = read_path(path, dims=3)
            controls.append(Control(name, WristPath(points=tuple(map(tuple, pts)), times=times).controls(args.seconds)))
    if not controls:
        raise ValueError("give at least one of --root, --left-wrist, --right-wrist")
    return controls, frame


def run_control(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import SampleConfig
    from engine.io import save_motion
    from engine.methods.control import controlled, load_controls, same_base
    from engine.methods.paths import path_error, to_world

    controls, frame = build_controls(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    loaded.tokenizer.encode(args.prompt)
    models = None
    if not args.inpaint:
        models = load_controls(args.controls, runtime=loaded.runtime)
        missing = [c.name for c in controls if c.name not in models]
        if missing:
            raise FileNotFoundError(f"no fine-tuned control model for {', '.join(missing)} in {args.controls} "
                                    "(train one with `moattn train --control NAME --init-from assets/model`, or use --inpaint)")
        other = [c.name for c in controls if not same_base(loaded, models[c.name])]
        if other:
            raise ValueError(f"the control models for {', '.join(other)} in {args.controls} were fine-tuned from another "
                             f"base model than {args.model}: use the base they came from, or --inpaint")
    sample = SampleConfig(steps=args.steps, guidance=args.guidance, seed=args.seed)
    gen = controlled(loaded, args.prompt, controls, seconds=args.seconds, models=models, weights=args.weights,
                     sample=sample)
    joints = gen.joints[0]
    report = {"out": str(args.out), "method": "inpainting" if args.inpaint else "blending",
              "controls": [c.name for c in controls]}
    if frame is not None:
        joints = to_world(joints, frame)
        report["root_error"] = path_error(joints, frame["target"])
    save_motion(joints, args.out)
    if args.render is not None:
        from viz.render import render_file

        render_file(joints, args.render)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2))
    return 0
