"""`moattn duet`: two people from one prompt, or the completion of a two-person prefix (ComMDM)."""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.cli.common import RENDER_SUFFIXES, check_outputs
from engine.cli.options import add_options, add_sample_options, from_args, sample_config
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.methods.duet_options import DuetOptions
from engine.options import option
from engine.runtime import add_runtime_arguments, runtime_from_args


@dataclass(frozen=True, kw_only=True)
class DuetFiles:
    """`moattn duet`'s output files."""

    out: Path = option(required=True, type=Path, help="the duet (.npy, or .bvh for one file per person)")
    render: Path | None = option(None, help="a picture of both people in one space (.gif, .mp4 or .png) by the "
                                 "studio's exporter, titled with the prompt")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("duet", help="ComMDM: two people from one prompt, or complete a two-person prefix",
                       description="Generate two people who interact, from one prompt both read (e.g. 'two people "
                       "shake hands'), or with --prefix complete the next seconds of a two-person motion (text "
                       "optional). --out FILE.npy holds joints (2, T, 22, 3) in one frame; FILE.bvh writes "
                       "FILE_a.bvh and FILE_b.bvh (one skeleton each, same frame).")
    add_options(p, DuetOptions, describe_with=lambda spec: spec.help)  # each help says its default
    add_sample_options(p, skip=("guidance",), helps={"model": "the base model (the prior)"})
    add_options(p, DuetFiles)
    add_runtime_arguments(p)
    add_library_arguments(p)
    p.set_defaults(run=run)


def read_prefix(paths: list[Path]) -> tuple[np.ndarray, np.ndarray]:
    """Two people's joints from one duet .npy or two motion files."""
    from engine.io import load_motion
    from engine.io.npy import load_duet_npy

    if len(paths) == 1:
        path = paths[0]
        if path.suffix.lower() != ".npy":
            raise ValueError("a single --prefix file must be a duet .npy of shape (2, T, 22, 3)")
        data = load_duet_npy(path)
        return data[0], data[1]
    if len(paths) == 2:
        return load_motion(paths[0]), load_motion(paths[1])
    raise ValueError("--prefix takes one duet .npy or two motion files")


def write_duet(joints: np.ndarray, path: Path) -> list[Path]:
    """(2, T, 22, 3) -> FILE.npy, or FILE_a.bvh and FILE_b.bvh."""
    from engine.io import save_motion

    suffix = path.suffix.lower()
    if suffix == ".npy":
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(path, np.asarray(joints, dtype=np.float32), allow_pickle=False)
        return [path]
    if suffix == ".bvh":
        out = [path.with_name(f"{path.stem}_{p}.bvh") for p in ("a", "b")]
        for j, target in zip(joints, out):
            save_motion(j, target)
        return out
    raise ValueError(f"--out must end in .npy or .bvh, got {path.name!r}")


def render_duet(joints: np.ndarray, path: Path, *, title: str) -> Path:
    """(2, T, 22, 3) -> a picture of both people as the studio's Duet export draws them (``viz.export``): one
    shared space (no side-by-side offsets), person a and person b in their palette colours."""
    from engine.methods.duet import by_person
    from viz.export import write_picture

    people = by_person(joints)
    return write_picture(people, path, title=title, offsets={role: (0.0, 0.0, 0.0) for role in people})


def run(args: argparse.Namespace) -> int:
    from engine.train_commdm import load_trained
    from engine.methods.duet import COMPLETE_SECONDS, PREFIX_SECONDS, TEXT_SECONDS, complete, text_to_duet
    from engine.methods.duet_contact import ContactConfig

    if args.out.suffix.lower() not in (".npy", ".bvh"):
        raise ValueError(f"--out must end in .npy or .bvh, got {args.out.name!r}")
    if args.out.suffix.lower() == ".npy":  # write_duet makes the .npy's folder
        check_outputs([args.out], (".npy",), make_parents=True)
    else:  # FILE_a.bvh and FILE_b.bvh
        check_outputs([args.out, *(args.out.with_name(f"{args.out.stem}_{p}.bvh") for p in ("a", "b"))], (".bvh",))
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    if args.prompt is not None and not args.prompt.strip():
        raise ValueError("the prompt is empty: describe what the two people do, e.g. 'two people shake hands'")
    if args.prompt is None and args.prefix is None:
        raise ValueError("give a prompt (e.g. 'two people shake hands') or --prefix FILE")
    options = from_args(DuetOptions, args)
    model = load_trained(options.duet_model, args.model, runtime=runtime_from_args(args))
    notes = []
    if args.prompt is not None:  # a prompt with nothing readable fails before any sampling; other words are noted
        notes = model.tokenizer.encode(args.prompt).notes()
        if notes:
            print(f"notes: {'; '.join(notes)}", file=sys.stderr)
    guidance = options.guidance_used()
    sample = sample_config(args, guidance=guidance)
    communicate = options.communication
    if args.prefix is not None:
        a, b = read_prefix(args.prefix)
        given = args.prefix_seconds if args.prefix_seconds is not None else PREFIX_SECONDS
        duet = complete(model, a, b, prefix_seconds=given, prompt=args.prompt,
                        seconds=args.seconds or COMPLETE_SECONDS, sample=sample, communicate=communicate)
    else:
        duet = text_to_duet(model, args.prompt, seconds=args.seconds or TEXT_SECONDS, sample=sample,
                            communicate=communicate, contact=ContactConfig() if options.contact else None,
                            spacing=options.spacing)
    written = write_duet(duet.joints, args.out)
    named = (args.prompt or "completed duet")[:180]
    first = None
    for person, joints in zip("ab", duet.joints):  # person b is kept as made from person a
        kept = keep(args, joints, kind="duet", stream=sys.stderr, title=f"{named} · person {person}",
                    parents=[first.entry.id] if first is not None else (),
                    recipe=cli_recipe(args, made_by="moattn duet", prompt=args.prompt, frames=duet.frames,
                                      guidance=guidance,
                                      duet={"person": person, **({} if options.spacing else {"spacing": False})}))
        first = first or kept
    p = duet.placement
    report = {"out": [str(w) for w in written], "frames": duet.frames, "seconds": duet.frames / 20,
              "communication": communicate, "spacing": duet.spacing is not None,
              "placement_of_b_from_a": {"x_m": round(p.x, 3), "z_m": round(p.z, 3),
                                        "facing_deg": round(float(np.degrees(p.yaw)), 1)},
              "contacts": [{**c.to_json(), "interaction": duet.interaction} for c in duet.contacts]}
    if notes:
        report["notes"] = notes
    if args.render is not None:
        report["render"] = str(render_duet(duet.joints, args.render, title=named))
    print(json.dumps(report, indent=2))
    return 0
