"""`moattn edit <kind>`: MotionCLR edits from the command line (same functions as the app's Edit tab)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, check_outputs, seed_argument
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.analysis.counting import COUNTING_METHODS, CountingConfig
from engine.methods.edit_kinds import KINDS, REGISTRY, kinds_reading
from engine.methods.edit_options import option_spec
from engine.methods.spans import parse_spans, spans_text
from engine.paths import MODEL_DIR
from engine.runtime import add_runtime_arguments, runtime_from_args
from engine.methods.motionclr import weight_range_text
from engine.units import DEFAULT_GUIDANCE


def _reads(field: str) -> str:
    return "read by " + ", ".join(kinds_reading(field))


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("edit", help="training-free attention edits (MotionCLR): " + ", ".join(KINDS),
                       description="Run an attention edit and write the edited motion (.npy/.bvh) and a side-by-side "
                       "before/after render (.gif/.mp4/.png). Kinds: "
                       + " ".join(f"{name}: {k.help}" for name, k in REGISTRY.items()))
    p.add_argument("kind", choices=KINDS)
    p.add_argument("prompt", nargs="?", default=None,
                   help="the prompt (the reference prompt for replace); a .bvh/.npy file works as the example/content")
    p.add_argument("--word", help=f"the word the edit acts on ({_reads('word')})")
    p.add_argument("--weight", type=float, default=0.3, help=f"emphasis weight ({weight_range_text()})")
    p.add_argument("--mode", choices=("add", "mul"), default="add")
    p.add_argument("--frames", type=_spans_argument, default=None, metavar="START:END[,START:END...]",
                   help="the frame span(s) [start, end) the edit touches, e.g. 10:20; ground takes several, e.g. "
                        "10:30,50:70,90:110,130:150 (four jumps at chosen times)")
    p.add_argument("--from-frame", type=int, default=None, help="first frame the edit touches (one span; or --frames)")
    p.add_argument("--to-frame", type=int, default=None,
                   help="frame after the last one the edit touches (default: the motion's end)")
    p.add_argument("--edited", help=f"the edited prompt; its words are aligned to the prompt's as prompt-to-prompt "
                                    f"aligns them, and the alignment is printed ({_reads('edited')})")
    p.add_argument("--fraction", type=float, default=0.5,
                   help=f"the part of the motion moved to the end ({_reads('fraction')})")
    p.add_argument("--style", help=f"the style source, a prompt or .bvh/.npy ({_reads('style')})")
    p.add_argument("--count", type=int, default=4, help=f"how many outputs ({_reads('count')})")
    chunk = option_spec("chunk_frames")
    p.add_argument(chunk.flag, type=int, default=chunk.default, metavar="FRAMES",
                   help=f"{chunk.help} ({chunk.bounds[0]} to {chunk.bounds[1]}; default {chunk.default}; "
                        f"{_reads('chunk_frames')})")
    p.add_argument("--count-method", choices=tuple(COUNTING_METHODS), default=CountingConfig.method,
                   help="count: how the self-attention map becomes a count: "
                        + "; ".join(f"{name}: {text}" for name, text in COUNTING_METHODS.items()))
    p.add_argument("--step-window", type=float, nargs=2, default=None, metavar=("START", "END"),
                   help="fractions of the sampling steps the edit acts in (default: the method's)")
    p.add_argument("--layers", type=int, nargs="+", default=None, metavar="LAYER",
                   help="layers the edit acts in (default: all; emphasize: the layers calibrated for the model, "
                        "see moattn bench --edits --calibrate)")
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--seed", type=seed_argument, default=0)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--guidance", type=float, default=DEFAULT_GUIDANCE)
    p.add_argument("--model", type=Path, default=MODEL_DIR)
    p.add_argument("--out", type=Path, default=Path("edited.npy"), help="edited motion (.npy or .bvh)")
    p.add_argument("--render", type=Path, default=None, help="before/after render (.gif, .mp4 or .png)")
    add_runtime_arguments(p)
    add_library_arguments(p)
    p.set_defaults(run=run)


def _spans_argument(text: str):
    try:
        return parse_spans(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _source(text: str | None, what: str):
    if text is None:
        raise ValueError(f"{what} is required")
    path = Path(text)
    if path.suffix.lower() in (".bvh", ".npy"):
        from engine.io import load_motion

        return load_motion(path)
    return text


def options_from_args(args: argparse.Namespace):
    """The command line's options as the shared ``EditOptions`` (the Edit tab builds the same object)."""
    from engine.methods.edit_options import EditOptions

    span = args.frames
    if args.from_frame is not None or args.to_frame is not None:
        if span is not None:
            raise ValueError("give the frames as --frames or as --from-frame/--to-frame, not both")
        from engine.generate import frames_for

        span = (args.from_frame or 0, args.to_frame if args.to_frame is not None else frames_for(args.seconds))
    source = args.prompt
    if args.kind in ("example", "style", "count"):
        source = _source(args.prompt, "a prompt or a motion file" if args.kind == "count"
                         else "an example prompt or file" if args.kind == "example" else "a content prompt or file")
    return EditOptions(kind=args.kind, prompt=source, word=args.word, weight=args.weight, mode=args.mode, frames=span,
                       edited=args.edited, fraction=args.fraction,
                       style=_source(args.style, "--style") if args.kind == "style" else None, count=args.count,
                       chunk_frames=args.chunk_frames,
                       step_window=tuple(args.step_window) if args.step_window is not None else None,
                       layers=tuple(args.layers) if args.layers else None, seed=args.seed)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import SampleConfig, frames_for
    from engine.io import save_motion
    from engine.methods import edits
    from engine.methods.edit_options import run_edit

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    options = options_from_args(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    frames = frames_for(args.seconds)
    sample = SampleConfig(steps=args.steps, guidance=args.guidance, seed=args.seed)

    report: dict = {"kind": args.kind}
    if args.kind == "count":
        source = options.prompt
        run = edits.CountingRun(counting=CountingConfig(method=args.count_method))
        if isinstance(source, str):
            count, gen = edits.count_generated(loaded, source, frames=frames, sample=sample, run=run)
            joints = gen.joints[0]
        else:
            count = edits.count_motion(loaded, source, run=run)
            joints = source
        report.update(method=args.count_method, attention_count=count.attention.count,
                      attention_rounded=count.attention.rounded, baseline_count=count.baseline,
                      peaks=len(count.attention.peaks))
        save_motion(joints, args.out)
        if isinstance(source, str):  # a motion was made (a given one is only read)
            keep(args, joints, kind="generate", stream=sys.stderr, title=f"{source} · seed {args.seed}",
                 recipe=cli_recipe(args, made_by="moattn edit", prompt=source, frames=frames, edit=args.kind,
                                   counted=report))
        print(json.dumps(report, indent=2, ensure_ascii=False))
        return 0

    if args.kind == "replace" and options.prompt and options.edited:
        alignment = edits.replace_alignment(loaded, options.prompt or "", options.edited or "")
        report["alignment"] = alignment.describe()  # shown before the run: the user sees what maps onto what
        print(alignment.describe(), file=sys.stderr, flush=True)
    out = run_edit(loaded, options, frames=frames, sample=sample)
    save_motion(out.after, args.out)
    report["out"] = str(args.out)
    title = f"{args.kind}: {options.edited or options.prompt or args.kind}"[:200]
    prompt = options.prompt if isinstance(options.prompt, str) else None  # None: the edit started from a file
    keep(args, out.after, kind="edit", stream=sys.stderr, title=title,
         recipe=cli_recipe(args, made_by="moattn edit", prompt=prompt, frames=frames, edit=args.kind))
    if args.kind == "ground":
        report["spans"] = spans_text(out.extra.get("spans", ()))
    if args.kind == "example":
        report.update(chunk_frames=options.chunk_frames, outputs=options.count)
    if args.render is not None:
        from viz.render import render_file

        render_file({f"before ({out.before_role})": out.before, f"after ({out.after_role})": out.after}, args.render)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2, ensure_ascii=False))
    return 0
