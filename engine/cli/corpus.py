"""`moattn corpus`: check, export or look at the procedural corpus (engine.synth)."""
from __future__ import annotations

import argparse
import json
import sys

from engine.cli.common import seed_argument


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "corpus",
        help="procedural motion corpus: --check, export a HumanML3D folder, or --gallery",
        description="Check the procedural corpus (--check), export it as a HumanML3D-layout folder "
                    "(--n N --seed S --out DIR), or render a contact sheet (--gallery OUT.png).",
    )
    p.add_argument("--check", action="store_true", help="report physical plausibility; exit 1 if a limit fails")
    p.add_argument("--n", type=int, default=None, help="number of samples (check: 1000; export: required)")
    p.add_argument("--seed", type=seed_argument, default=0, help="corpus seed")
    p.add_argument("--split", choices=("train", "test", "ood"), default="train")
    p.add_argument("--out", default=None, help="output folder for the export")
    p.add_argument("--gallery", default=None, metavar="OUT.png", help="write a contact sheet of every action and style")
    p.add_argument("--renderer", choices=("lines", "pyvista"), default="lines",
                   help="gallery drawing: fast built-in lines (default) or the pyvista scene")
    p.add_argument("--json", action="store_true", help="print the check report as JSON")
    p.add_argument("--strict-speed", action="store_true", help="also fail when samples_per_s < 200")
    p.set_defaults(run=run)
    return p


def _bar(total: int, desc: str):
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None, (lambda k: None)
    bar = tqdm(total=total, desc=desc, unit="motion", file=sys.stderr, leave=False)
    return bar, bar.update


def run(args: argparse.Namespace) -> int:
    from engine.cli.common import check_output_folder

    check_output_folder(args.out)  # checked before any work
    did = False
    status = 0
    if args.gallery:
        from engine.synth.gallery import render_gallery

        draw = None
        if args.renderer == "pyvista":
            from viz.sheet import pyvista_gallery as draw
        path = render_gallery(args.gallery, draw=draw)
        print(f"gallery written to {path}")
        did = True
    if args.check:
        from engine.synth.check import SPEED_TARGET, check_corpus

        n = args.n or 1000
        bar, update = _bar(n, "checking")
        report = check_corpus(n, split=args.split, seed=args.seed, progress=update)
        if bar is not None:
            bar.close()
        if args.strict_speed and report["samples_per_s"] < SPEED_TARGET:
            report["failures"].append(f"samples_per_s {report['samples_per_s']} (target >= {SPEED_TARGET})")
            report["ok"] = False
        if args.json:
            print(json.dumps(report, indent=2))
        else:
            for k, v in report.items():
                if k not in ("limits", "failures"):
                    print(f"{k:>28}: {v}")
            for f in report["failures"]:
                print(f"FAIL {f}")
        status = 0 if report["ok"] else 1
        did = True
    if args.out:
        from engine.synth.export import export_corpus

        if not args.n:
            raise ValueError("--out needs --n N")
        bar, update = _bar(args.n, f"writing {args.split}")
        path = export_corpus(args.out, n=args.n, seed=args.seed, split=args.split, progress=update)
        if bar is not None:
            bar.close()
        print(f"wrote {args.n} {args.split} samples to {path}")
        did = True
    if not did:
        raise ValueError("nothing to do: give --check, --out DIR (with --n) or --gallery OUT.png")
    return status
