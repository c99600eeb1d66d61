"""`moattn control`: follow a root path and wrist paths at once (PriorMDM control, DiffusionBlending).

The method and the blend weights are :class:`engine.methods.control_options.ControlOptions` fields: their flags,
defaults and help come from there (the studio's Control tab reads the same declaration), and the blend-weight rule
(:func:`~engine.methods.control_options.blend_shares`) is the engine's; this module reads the path files.
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, check_outputs
from engine.cli.options import add_options, add_sample_options, sample_config
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.methods.control_options import (CONTROLS, LABELS, ControlOptions, WRITE_COMMAND, bench_verdict,
                                            option_info)
from engine.options import option
from engine.paths import CONTROL_DIR
from engine.runtime import add_runtime_arguments, runtime_from_args


@dataclass(frozen=True, kw_only=True)
class ControlFiles:
    """`moattn control`'s own settings besides ControlOptions: the prompt, the path files' shorthands, the folders."""

    prompt: str = option(required=True, help="what the person does")
    inpaint: bool = option(False, help="the same as --method inpainting (the baseline)")
    weights: tuple[float, ...] | None = option(
        None, nargs="+", metavar="W", help="the blend weights at once, in the order root, left wrist, right wrist of "
        "the paths given (instead of the --*-weight flags)")
    controls: Path = option(CONTROL_DIR, help="control model folders")
    out: Path = option(required=True, type=Path, help="the motion (.npy or .bvh), in the path's world frame")
    render: Path | None = option(None, help="a picture (.gif, .mp4 or .png) by the studio's exporter, titled with "
                                 "the prompt, method and paths")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("control", help="PriorMDM control: follow a root path and both wrists' paths (DiffusionBlending)",
                       description="Generate a motion that follows a root path on the floor and/or paths of the left "
                       "and right wrist, any of them at once. PATH.json: {\"points\": [[x, z], ...], \"times\": "
                       "[seconds, ...]} (times optional) for the root (metres, world floor); [[x, y, z], ...] for a "
                       "wrist in the body frame (x to the person's left, y height, z forward). --method blending (the "
                       "default) blends the fine-tuned control model of every path given, each with its weight "
                       "(scaled to sum 1); --method inpainting (or --inpaint) uses the base model with plain "
                       f"inpainting instead. The report says which of the two the control bench has ahead "
                       f"(`{WRITE_COMMAND}` records it).")
    add_options(p, ControlFiles, only=("prompt",))
    for name in CONTROLS:
        p.add_argument(f"--{name.replace('_', '-')}", type=Path, default=None, metavar="PATH.json",
                       help=f"{LABELS[name].removesuffix(' path')} path JSON")
    # the method, the blend weights and the length: declared on ControlOptions (the Control tab reads them too)
    add_options(p, ControlOptions, only=("method",), given_only=True)
    add_options(p, ControlFiles, only=("inpaint",))
    add_options(p, ControlOptions, skip=("method", "seconds", "planted_feet"), given_only=True,
                notes={ControlOptions.weight_field(n): "blending only" for n in CONTROLS})
    add_options(p, ControlFiles, only=("weights",))
    add_options(p, ControlOptions, only=("seconds", "planted_feet"))
    add_sample_options(p)
    add_options(p, ControlFiles, skip=("prompt", "inpaint", "weights"))
    add_runtime_arguments(p)
    add_library_arguments(p)
    p.set_defaults(run=run)


def options_from_args(args: argparse.Namespace, names: list[str]) -> ControlOptions:
    """The command line's method and weights as ControlOptions (``names``: the controls whose paths are given)."""
    if args.inpaint and args.method not in (None, "inpainting"):
        raise ValueError(f"--inpaint and --method {args.method} disagree: give one")
    method = "inpainting" if args.inpaint else (args.method or option_info(ControlOptions, "method").default)
    flags = {n: getattr(args, ControlOptions.weight_field(n)) for n in CONTROLS}
    given = {n: w for n, w in flags.items() if w is not None}
    if args.weights is not None:
        if given:
            raise ValueError("give the blend weights either with --weights or with the --*-weight flags, not both")
        if len(args.weights) != len(names):
            raise ValueError(f"--weights: {len(args.weights)} weight{'s' * (len(args.weights) != 1)} for "
                             f"{len(names)} path{'s' * (len(names) != 1)} ({', '.join(LABELS[n] for n in names)})")
        given = dict(zip(names, args.weights))
    unused = [n for n in given if n not in names]
    if unused:
        raise ValueError(f"a blend weight for the {', '.join(LABELS[n] for n in unused)} without its path: give "
                         f"--{unused[0].replace('_', '-')} PATH.json too")
    if given and method == "inpainting":
        raise ValueError("blend weights apply to blending (the fine-tuned control models), not to inpainting")
    return ControlOptions(method=method, planted_feet=args.planted_feet,
                          **{ControlOptions.weight_field(n): w for n, w in given.items()})


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
    """The command line's paths as Controls (root, left wrist, right wrist: those given), plus the root frame (to
    place the motion in the path's world)."""
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


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.evaluation.metrics import foot_skate
    from engine.generate import frames_for
    from engine.io import save_motion
    from engine.methods.control import control_base, controlled, load_controls
    from engine.methods.paths import path_error, to_world

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    frames_for(args.seconds)  # the length first: a path is resampled to it (--seconds 1e9 must not allocate)
    given_paths = [n for n in CONTROLS if getattr(args, n) is not None]
    options = options_from_args(args, given_paths)
    blending = options.method == "blending"
    shares = options.shares(given_paths) if blending and given_paths else None  # the engine's rule, before any work
    controls, frame = build_controls(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    try:
        found = load_controls(args.controls, runtime=loaded.runtime)
    except ValueError:  # a broken control folder: the inpainting baseline does not need it
        if blending:
            raise
        found = {}
    # the base control runs on: the loaded one, or the control models' own (args.controls/prior) when they were
    # fine-tuned on another vocabulary; inpainting runs on it too, so both methods read the same prompt
    run_base = control_base(loaded, found, folder=args.controls)
    if run_base.note:
        print(f"note: {run_base.note}", file=sys.stderr)
    tokens = run_base.loaded.tokenizer.encode(args.prompt)  # read by the model that runs it
    models = None
    if blending:
        missing = [c.name for c in controls if c.name not in found]
        if missing:
            raise FileNotFoundError(f"no fine-tuned control model for {', '.join(missing)} in {args.controls} "
                                    "(train one with `moattn train control --control NAME --init-from assets/model`, "
                                    "or use --method inpainting)")
        other = [c.name for c in controls if c.name not in run_base.models]
        if other:
            raise ValueError(f"the control models for {', '.join(other)} in {args.controls} were fine-tuned from "
                             f"another base model than {args.model}: use the base they came from, or --method inpainting")
        models = run_base.models
    sample = sample_config(args)
    gen = controlled(run_base.loaded, args.prompt, controls, seconds=args.seconds, models=models,
                     weights=options.weights() if blending else None, sample=sample, planted_feet=options.planted_feet)
    joints = gen.joints[0]
    report = {"out": str(args.out), "method": options.method, "planted_feet": options.planted_feet,
              "controls": [c.name for c in controls],
              "base": str(run_base.loaded.folder) if run_base.on_prior else str(args.model)}
    if shares is not None:
        report["weights"] = {n: round(s, 6) for n, s in zip(given_paths, shares)}
    report["bench"] = bench_verdict(args.controls).message
    if run_base.note:
        report["base_note"] = run_base.note
    if tokens.notes():
        report["notes"] = tokens.notes()
        print(f"notes: {'; '.join(tokens.notes())}", file=sys.stderr)
    if frame is not None:
        joints = to_world(joints, frame)
        report["root_error"] = path_error(joints, frame["target"])
    report["foot_skate"] = round(foot_skate(joints), 4)  # share of floor foot frame pairs that slide
    save_motion(joints, args.out)
    title = f"{args.prompt} · {options.method} ({', '.join(report['controls'])})"[:200]
    keep(args, joints, kind="control", stream=sys.stderr, title=title,
         recipe=cli_recipe(args, made_by="moattn control", prompt=args.prompt, frames=len(joints),
                           model=run_base.loaded.folder,
                           control={"method": options.method, "controls": report["controls"],
                                    "weights": report.get("weights")}))
    if args.render is not None:  # the studio's exporter, titled as kept
        from viz.export import write_picture

        write_picture(joints, args.render, title=title)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2))
    return 0
