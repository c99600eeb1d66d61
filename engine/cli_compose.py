"""`moattn compose` (DoubleTake) and `moattn control` (control models, DiffusionBlending): PriorMDM's commands."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from engine.cli import MOTION_SUFFIXES, RENDER_SUFFIXES, check_outputs, seed_argument
from engine.paths import MODEL_DIR
from engine.runtime import add_runtime_arguments, runtime_from_args
from engine.units import DEFAULT_GUIDANCE, FPS


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compose", help="DoubleTake: a long motion from PROMPT:SECONDS intervals",
                       description="Generate a long motion from intervals, each 'PROMPT:SECONDS' (up to 9.8 s), "
                       "joined by handshakes (PriorMDM's DoubleTake). Consecutive intervals share the handshake "
                       "frames, so the motion lasts the sum of the intervals minus one handshake per transition.")
    p.add_argument("intervals", nargs="+", metavar="PROMPT:SECONDS")
    # defaults: the engine's DoubleTakeConfig / SecondTake (the studio's Compose tab reads them too)
    p.add_argument("--handshake", type=float, default=None, help="handshake length in seconds (default 1)")
    p.add_argument("--first-take-only", action="store_true", help="skip the second take")
    p.add_argument("--renoise", type=float, default=None, help="second take: T' as a fraction of the timesteps "
                   "(default 0.7)")
    p.add_argument("--hard", type=float, default=None, help="second take: M_hard (handshake; default 0.85)")
    p.add_argument("--soft", type=float, default=None, help="second take: M_soft (context; default 0.1)")
    p.add_argument("--ramp", type=int, default=None, help="second take: b, ramp frames (default 10)")
    p.add_argument("--second-take-text", action="store_true",
                   help="second take: denoise each transition with 'A, then B' (default: without text, as the "
                        "authors' code)")
    p.add_argument("--seed", type=seed_argument, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=DEFAULT_GUIDANCE)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--out", type=Path, required=True, help="the long motion (.npy or .bvh)")
    p.add_argument("--render", type=Path, default=None, help="a render (.gif, .mp4 or .png)")
    add_runtime_arguments(p)
    p.set_defaults(run=run)
    add_control_parser(sub)


def config_from_args(args: argparse.Namespace):
    from engine.methods.doubletake import DoubleTakeConfig, SecondTake

    given = {name: getattr(args, name) for name in ("renoise", "hard", "soft", "ramp") if getattr(args, name) is not None}
    take = None if args.first_take_only else SecondTake(**given, text=args.second_take_text)
    if args.handshake is None:
        return DoubleTakeConfig(second_take=take)
    return DoubleTakeConfig(handshake=int(round(args.handshake * FPS)), second_take=take)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import SampleConfig
    from engine.io import save_motion
    from engine.methods.doubletake import Interval, compose

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    intervals = [Interval.parse(text) for text in args.intervals]
    config = config_from_args(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    notes = {}
    for iv in intervals:  # a prompt with nothing readable fails before any sampling; other words are noted
        if said := loaded.tokenizer.encode(iv.prompt).notes():
            notes[iv.prompt] = said
            print(f"notes: {iv.prompt!r}: {'; '.join(said)}", file=sys.stderr)
    result = compose(loaded, intervals, config, sample=SampleConfig(steps=args.steps, guidance=args.guidance,
                                                                    seed=args.seed))
    save_motion(result.joints, args.out)
    report = {"out": str(args.out), "frames": int(len(result.joints)), "seconds_of_motion": len(result.joints) / 20,
              "intervals": [{"prompt": iv.prompt, "start_frame": s} for iv, s in zip(intervals, result.starts)],
              "transitions": result.transitions, "wall_seconds": round(result.seconds, 2)}
    if notes:
        report["notes"] = notes
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
    p.add_argument("--seed", type=seed_argument, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=DEFAULT_GUIDANCE)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--controls", type=Path, default=CONTROL_DIR, help=f"control model folders (default {CONTROL_DIR})")
    p.add_argument("--out", type=Path, required=True, help="the motion (.npy or .bvh), in the path's world frame")
    p.add_argument("--render", type=Path, default=None, help="a render (.gif, .mp4 or .png)")
    add_runtime_arguments(p)
    p.set_defaults(run=run_control)


MAX_PATH_BYTES = 2**20  # a path JSON file larger than this (1 MiB) is refused
MAX_PATH_POINTS = 10_000  # points of one path
MAX_PATH_COORD = 1000.0  # metres: the largest coordinate a point may have
MAX_PATH_TIME = 3600.0  # seconds: the largest time a point may have


def read_path(path: Path, *, dims: int) -> tuple[tuple[tuple[float, ...], ...], tuple[float, ...] | None]:
    """Points (and optional times) from a path JSON file: a list of ``dims``-D points or {"points", "times"}.

    Everything is checked here: at most MAX_PATH_BYTES, UTF-8 JSON, 2 to MAX_PATH_POINTS points of ``dims``
    finite numbers within MAX_PATH_COORD, times (when given) one finite number per point within MAX_PATH_TIME.
    Every problem is one :class:`engine.io.MotionIOError` (a ValueError) naming the file; the returned values
    are plain floats (engine.methods.paths then checks speeds, reach and timing).
    """
    from engine.io.errors import MotionIOError, check_file_size

    path = Path(path)
    check_file_size(path, max_bytes=MAX_PATH_BYTES, kind="path JSON")
    try:
        data = json.loads(path.read_bytes().decode("utf-8-sig"))
    except OSError as exc:
        raise MotionIOError(f"cannot read the path file {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise MotionIOError(f"{path.name}: not a JSON path (the file is not UTF-8 text)") from None
    except RecursionError:
        raise MotionIOError(f"{path.name}: not a JSON path (nested too deeply)") from None
    except ValueError as exc:  # JSONDecodeError, or an integer with too many digits
        raise MotionIOError(f"{path.name}: not a JSON path ({' '.join(str(exc).split())[:200]})") from None
    if isinstance(data, dict):
        unknown = sorted(set(data) - {"points", "times"})
        if unknown:
            raise MotionIOError(f"{path.name}: unknown keys {[k[:40] for k in unknown[:3]]}; a path has \"points\" "
                                "and optionally \"times\"")
        points, times = data.get("points"), data.get("times")
    else:
        points, times = data, None
    if not isinstance(points, list):
        raise MotionIOError(f"{path.name}: expected a list of {dims}-D points")
    if not 2 <= len(points) <= MAX_PATH_POINTS:
        raise MotionIOError(f"{path.name}: a path has 2 to {MAX_PATH_POINTS:,} points, got {len(points):,}")
    out = []
    for i, point in enumerate(points):
        if not isinstance(point, list) or len(point) != dims:
            raise MotionIOError(f"{path.name}: point {i} is not a list of {dims} numbers ({_short(point)})")
        out.append(tuple(_number(v, f"{path.name}: point {i}", MAX_PATH_COORD, "m") for v in point))
    if times is None:
        return tuple(out), None
    if not isinstance(times, list) or len(times) != len(points):
        raise MotionIOError(f"{path.name}: \"times\" must be a list of one time per point ({len(points)} numbers)")
    return tuple(out), tuple(_number(t, f"{path.name}: time {i}", MAX_PATH_TIME, "s") for i, t in enumerate(times))


def _number(value, what: str, limit: float, unit: str) -> float:
    from engine.io.errors import MotionIOError

    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MotionIOError(f"{what} is not a number ({_short(value)})")
    if isinstance(value, int) and abs(value) > limit:
        raise MotionIOError(f"{what}: {_short(value)} {unit} is beyond the limit of {limit:g} {unit}")
    value = float(value)
    if value != value or abs(value) > limit:  # NaN, infinities and huge values (JSON allows NaN and Infinity)
        raise MotionIOError(f"{what}: {_short(value)} is not a finite number within {limit:g} {unit}")
    return value


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def build_controls(args: argparse.Namespace):
    """The command line's paths as Controls, plus the root frame (to place the motion in the path's world)."""
    from engine.methods.control import Control
    from engine.methods.paths import RootPath, WristPath, root_controls

    controls, frame = [], None
    if args.root is not None:
        pts, times = read_path(args.root, dims=2)
        values, frame = root_controls(RootPath(points=pts, times=times), args.seconds)
        controls.append(Control("root", values))
    for name, path in (("left_wrist", args.left_wrist), ("right_wrist", args.right_wrist)):
        if path is not None:
            pts, times = read_path(path, dims=3)
            controls.append(Control(name, WristPath(points=pts, times=times).controls(args.seconds)))
    if not controls:
        raise ValueError("give at least one of --root, --left-wrist, --right-wrist")
    return controls, frame


def run_control(args: argparse.Namespace) -> int:
    import sys

    from engine.checkpoint import load_model
    from engine.generate import SampleConfig, frames_for
    from engine.io import save_motion
    from engine.methods.control import control_base, controlled, load_controls
    from engine.methods.paths import path_error, to_world

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    frames_for(args.seconds)  # the length first: a path is resampled to it (--seconds 1e9 must not allocate)
    controls, frame = build_controls(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    try:
        found = load_controls(args.controls, runtime=loaded.runtime)
    except ValueError:  # a broken control folder: the --inpaint baseline does not need it
        if not args.inpaint:
            raise
        found = {}
    # the base control runs on: the loaded one, or the control models' own (args.controls/prior) when they were
    # fine-tuned on another vocabulary; inpainting runs on it too, so both methods read the same prompt
    run = control_base(loaded, found, folder=args.controls)
    if run.note:
        print(f"note: {run.note}", file=sys.stderr)
    tokens = run.loaded.tokenizer.encode(args.prompt)  # read by the model that runs it
    models = None
    if not args.inpaint:
        missing = [c.name for c in controls if c.name not in found]
        if missing:
            raise FileNotFoundError(f"no fine-tuned control model for {', '.join(missing)} in {args.controls} "
                                    "(train one with `moattn train --control NAME --init-from assets/model`, or use --inpaint)")
        other = [c.name for c in controls if c.name not in run.models]
        if other:
            raise ValueError(f"the control models for {', '.join(other)} in {args.controls} were fine-tuned from another "
                             f"base model than {args.model}: use the base they came from, or --inpaint")
        models = run.models
    sample = SampleConfig(steps=args.steps, guidance=args.guidance, seed=args.seed)
    gen = controlled(run.loaded, args.prompt, controls, seconds=args.seconds, models=models, weights=args.weights,
                     sample=sample)
    joints = gen.joints[0]
    report = {"out": str(args.out), "method": "inpainting" if args.inpaint else "blending",
              "controls": [c.name for c in controls],
              "base": str(run.loaded.folder) if run.on_prior else str(args.model)}
    if run.note:
        report["base_note"] = run.note
    if tokens.notes():
        report["notes"] = tokens.notes()
        print(f"notes: {'; '.join(tokens.notes())}", file=sys.stderr)
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
