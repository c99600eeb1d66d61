"""`moattn generate`: text -> motion file(s) with the shipped model."""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, CLIError, check_outputs
from engine.cli.options import add_options, add_sample_options, sample_config
from engine.duration import AUTO, model_tempo, resolve_seconds
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.methods.generate_options import GenerateOptions
from engine.runtime import add_runtime_arguments, runtime_from_args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("generate", help="generate a motion from a prompt (.npy joints/vecs, .bvh, .png/.gif/.mp4)",
                       description="Generate motions from a text prompt and write them (the extension of each --out "
                       "decides: .npy joints, .bvh, .png/.gif/.mp4 renders; --vecs writes 263-dim features to .npy).")
    add_options(p, GenerateOptions, only=("prompt",))
    p.add_argument("--out", type=Path, action="append", default=None,
                   help="output file; repeat for several (none: the motion is only kept in the library)")
    add_options(p, GenerateOptions, skip=("prompt",), describe_with=lambda spec: spec.help)
    add_sample_options(p)
    add_library_arguments(p)
    add_runtime_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from engine.checkpoint import load_model, read_config
    from engine.generate import FPS, Request, frames_for, generate
    from engine.io import save_motion
    from engine.methods.sequence import generate_sequence, plan, timeline_frames

    args.out = args.out or []
    if not args.out and args.no_library:
        raise CLIError("nothing would be kept: give --out FILE, or drop --no-library to keep the motion in the library")
    check_outputs(args.out, MOTION_SUFFIXES + RENDER_SUFFIXES)  # every --out, before the model loads
    if args.vecs and any(out.suffix.lower() == ".bvh" for out in args.out):
        raise CLIError("--vecs writes 263-dim features to .npy; a .bvh --out holds joints: drop --vecs or the .bvh")
    tempo = model_tempo(read_config(args.model))  # the model's count tempo: what an auto length reads
    try:  # a prompt of several actions in order: one interval per clause (engine.methods.sequence)
        intervals = plan(args.prompt, seconds=None if args.seconds == AUTO else float(args.seconds),
                         sequence=args.sequence, tempo=tempo)
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    if intervals is None:
        seconds = resolve_seconds(args.seconds, args.prompt, tempo=tempo)
        frames = frames_for(seconds)  # one take: within the model's longest motion
    else:  # clause by clause: each clause within it, the joined motion as long as they make it
        frames = timeline_frames(intervals)
        seconds = frames / FPS
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    config = sample_config(args, sampler=args.sampler)
    if intervals is not None:
        print("clause by clause: " + " -> ".join(f"{iv.prompt!r} ({iv.seconds:.1f} s)" for iv in intervals),
              file=sys.stderr)
    from engine.analysis.followed import follow_generated, misses, take_tries
    from engine.methods.held_direction import held_plan, held_take, plan_of

    def one_take(seed: int) -> tuple:
        """(seed, joints, features, tokens, follow, notes, held: whether it walked a held path) of the take from
        ``seed``."""
        attempt = f"try {seed - args.seed + 1}/{args.tries}, seed {seed}: " if args.tries > 1 else ""

        def progress(state):
            print(f"\r{attempt}step {state.step + 1}/{state.num_steps}", end="", file=sys.stderr, flush=True)

        take = replace(config, seed=seed)
        held = None
        if held_take(args.prompt, try_index=seed - args.seed, one_take=intervals is None):  # the corpus's path
            held = held_plan(loaded, args.prompt, frames=frames, sample=take)
        if intervals is None:
            path = plan_of(held)
            gen = generate(loaded, Request(prompts=[args.prompt], frames=[frames], noise=path.noise), take,
                           on_step=progress, hooks=path.hooks, denoiser=path.denoiser)
            joints, features, tokens = gen.joints[0], gen.features[0, :frames], gen.tokens[0]
        else:
            composed = generate_sequence(loaded, intervals, take, on_step=progress)
            joints, features, tokens = composed.joints, composed.features, loaded.tokenizer.encode(args.prompt)
        # what was and was not followed: the prompt's intent beside what the detectors see in the motion
        follow, notes = follow_generated(args.prompt, joints, tokens)
        return seed, joints, features, tokens, follow, notes + (() if held is None else (held.note,)), held is not None

    kept, tries = take_tries(one_take, seed=args.seed, tries=args.tries, report=lambda t: t[4])
    print(file=sys.stderr)
    seed, joints, features, tokens, follow, notes, held_path = tries[kept]
    if args.tries > 1:
        along = [str(t[0]) for t in tries if t[6]]  # the takes that walked the corpus's path for the gait
        print(f"tried seed{'s' * (len(tries) > 1)} {', '.join(str(t[0]) for t in tries)}"
              + (f" ({', '.join(along)} along the corpus's path)" if along else "") + f": kept seed {seed} ("
              + ("it followed every checked attribute)" if misses(follow) == 0 else
                 "none followed everything: it missed fewest)"), file=sys.stderr)
    for out in args.out:
        suffix = out.suffix.lower()
        if suffix in (".png", ".gif", ".mp4"):
            from viz.export import write_picture  # the studio's exporter: one picture of a motion

            write_picture(joints, out, title=args.prompt)
        else:
            save_motion(joints, out, to="vecs" if args.vecs else "joints")
        print(f"wrote {out}")
    keep(args, joints, kind="generate", title=f"{args.prompt} · seed {seed}",
         features=features,
         recipe=cli_recipe(args, made_by="moattn generate", prompt=args.prompt, seed=seed,
                           seconds=None if args.seconds == AUTO else seconds, sampler=args.sampler,
                           seconds_used=seconds, sequence=args.sequence, held_path=held_path,
                           clauses=None if intervals is None else [iv.prompt for iv in intervals]))
    for line in follow_lines(follow, notes):
        print(printable(line, sys.stdout))
    print(json.dumps({"prompt": args.prompt, "seconds": seconds, "seconds_from": "prompt" if args.seconds == AUTO
                      else "given", "frames": len(joints),
                      "clauses": None if intervals is None else [iv.prompt for iv in intervals], "seed": seed, "tries": len(tries), "held_path": held_path, "steps": args.steps,
                      "guidance": args.guidance, "guidance_from": args.guidance_from, "eta": args.eta,
                      "followed": follow.to_json() if not isinstance(follow, str) else {"error": follow},
                      "notes": list(notes)}))
    return 0


def follow_lines(follow, notes) -> list[str]:
    """The lines `moattn generate` prints after writing a motion (one sample)."""
    lines = [f"followed: {follow if isinstance(follow, str) else follow.describe()}"]
    if notes:
        lines.append(f"notes: {'; '.join(notes)}")
    return lines


_ASCII = {"\u2713": "[yes]", "\u2717": "[no]", "\u00d7": "x", "\u2192": "->", "\u00b7": "-"}


def printable(text: str, stream) -> str:
    """``text`` as ``stream`` can encode it (✓ and ✗ spelled out on a terminal that has no such signs)."""
    try:
        text.encode(getattr(stream, "encoding", None) or "utf-8")
        return text
    except (UnicodeEncodeError, LookupError):
        for sign, plain in _ASCII.items():
            text = text.replace(sign, plain)
        return text.encode("ascii", "replace").decode("ascii")
