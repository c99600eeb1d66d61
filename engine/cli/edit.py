"""`moattn edit <kind>`: MotionCLR edits from the command line (same functions as the app's Edit tab)."""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, check_outputs
from engine.cli.options import add_options, add_sample_options, from_args, sample_config
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.analysis.counting import CountingConfig
from engine.methods.edit_kinds import INPUTS, KINDS, REGISTRY, kinds_reading
from engine.methods.edit_options import EditOptions
from engine.options import option
from engine.methods.spans import spans_text
from engine.runtime import add_runtime_arguments, runtime_from_args
from engine.units import EDIT_SECONDS


def _reads(field: str) -> str:
    return "read by " + ", ".join(kinds_reading(field))


@dataclass(frozen=True, kw_only=True)
class EditFiles:
    """`moattn edit`'s own settings: the length of a generated motion, the output files."""

    seconds: float = option(EDIT_SECONDS, help="length of the motion generated to edit, in seconds")
    out: Path = option(Path("edited.npy"), help="edited motion (.npy or .bvh)")
    render: Path | None = option(None, type=Path, help="before/after picture (.gif, .mp4 or .png) by the studio's "
                                 "exporter, titled with the edit")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("edit", help="training-free attention edits (MotionCLR): " + ", ".join(KINDS),
                       description="Run an attention edit and write the edited motion (.npy/.bvh) and a side-by-side "
                       "before/after render (.gif/.mp4/.png). Kinds: "
                       + " ".join(f"{name}: {k.help}" for name, k in REGISTRY.items()))
    # the edit's options, declared once on EditOptions (the Edit tab reads the same fields)
    reads = {n: _reads(n) for n in INPUTS if n not in ("weight", "mode", "frames", "seed") and kinds_reading(n)}
    add_options(p, EditOptions, notes=reads)
    p.add_argument("--from-frame", type=int, default=None, help="first frame the edit touches (one span; or --frames)")
    p.add_argument("--to-frame", type=int, default=None,
                   help="frame after the last one the edit touches (default: the motion's end)")
    add_options(p, CountingConfig, only=("method",))
    add_options(p, EditFiles)
    add_sample_options(p)
    add_runtime_arguments(p)
    add_library_arguments(p)
    p.set_defaults(run=run)


def _source(text: str | None, what: str):
    if text is None:
        raise ValueError(f"{what} is required")
    path = Path(text)
    if path.suffix.lower() in (".bvh", ".npy"):
        from engine.io import load_motion

        return load_motion(path)
    return text


def check_read(args: argparse.Namespace) -> None:
    """A flag the kind does not read is refused in one line, naming the kinds that read it (given with its
    default's value it changes nothing and passes)."""
    from engine.options import spec

    entry = REGISTRY[args.kind]
    for name in sorted(INPUTS - {"seed"} - entry.inputs):
        declared = spec(EditOptions, name)
        if hasattr(args, declared.dest) and getattr(args, declared.dest) != declared.default:
            readers = kinds_reading(name)
            raise ValueError(f"{declared.flag} is not read by {args.kind}"
                             + (f" (it is read by {', '.join(readers)})" if readers else ""))
    if (args.from_frame is not None or args.to_frame is not None) and "frames" not in entry.inputs:
        raise ValueError(f"--from-frame/--to-frame are not read by {args.kind} "
                         f"(they are read by {', '.join(kinds_reading('frames'))})")


def options_from_args(args: argparse.Namespace):
    """The command line's options as the shared ``EditOptions`` (the Edit tab builds the same object)."""
    check_read(args)
    span = args.frames
    if args.from_frame is not None or args.to_frame is not None:
        if span is not None:
            raise ValueError("give the frames as --frames or as --from-frame/--to-frame, not both")
        from engine.generate import frames_for

        span = (args.from_frame or 0, args.to_frame if args.to_frame is not None else frames_for(args.seconds))
    entry = REGISTRY[args.kind]
    source = args.prompt
    if entry.source or not entry.is_edit:  # the prompt may be a motion file: an example, a content, a motion to count
        source = _source(args.prompt, f"{'an' if entry.source_label[0] in 'AEIOU' else 'a'} "
                         f"{entry.source_label.lower()} prompt or file" if entry.is_edit else "a prompt or a motion file")
    return from_args(EditOptions, args, check=False, prompt=source, frames=span, seed=args.seed,
                     style=_source(args.style, "--style") if "style" in entry.inputs else None)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model
    from engine.generate import frames_for
    from engine.io import save_motion
    from engine.methods import edits
    from engine.methods.edit_options import REGISTRY, run_edit, with_defaults

    check_outputs([args.out], MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    options = options_from_args(args)
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    frames = frames_for(args.seconds)
    sample = sample_config(args)

    report: dict = {"kind": args.kind}
    if args.kind == "count":
        source = options.prompt
        run = edits.CountingRun(counting=from_args(CountingConfig, args))
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
        # shown before the run: the user sees what maps onto what
        report["alignment"] = alignment.describe(swapped=options.swapped)
        print(report["alignment"], file=sys.stderr, flush=True)
    options = with_defaults(options, loaded.config)  # the mode and weight left out: this model's (calibrated) ones
    if "weight" in REGISTRY[args.kind].inputs:
        report.update(weight=options.weight, **({"mode": options.mode} if "mode" in REGISTRY[args.kind].inputs else {}))
    out = run_edit(loaded, options, frames=frames, sample=sample)
    save_motion(out.after, args.out)
    report["out"] = str(args.out)
    prompt = options.prompt if isinstance(options.prompt, str) else None  # None: the edit started from a file
    source = prompt or (Path(args.prompt).name if args.prompt else None)  # a motion file: named by its file name
    title = f"{args.kind}: {options.edited or source or args.kind}"[:200]
    keep(args, out.after, kind="edit", stream=sys.stderr, title=title,
         recipe=cli_recipe(args, made_by="moattn edit", prompt=prompt, frames=frames, edit=args.kind))
    if args.kind == "ground":
        report["spans"] = spans_text(out.extra.get("spans", ()))
    if "toward" in out.extra:  # intensity mode: the prompt the motion was guided towards
        report["toward"] = out.extra["toward"]
        print(f"guided towards {out.extra['toward']!r}", file=sys.stderr, flush=True)
    if REGISTRY[args.kind].sized and options.word:  # did the action grow (shrink)? the bench's measure
        from engine.analysis.action_size import size_change

        size = size_change(options.word, before=out.before, after=out.after)
        if size is not None:
            report["action_size"] = size.to_json()
            print(f"action size {size.describe()}", file=sys.stderr, flush=True)
    if args.kind == "example":
        report.update(chunk_frames=options.chunk_frames, outputs=options.count)
    if args.render is not None:  # the studio's exporter: before and after side by side, titled as kept
        from viz.export import write_picture

        write_picture({f"before ({out.before_role})": out.before, f"after ({out.after_role})": out.after},
                      args.render, title=title)
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2, ensure_ascii=False))
    return 0
