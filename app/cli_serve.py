"""`moattn serve`: start the studio in the browser (Panel server on localhost)."""
from __future__ import annotations

import argparse
from pathlib import Path

from engine.runtime import add_runtime_arguments, runtime_from_args


def add_parser(sub: argparse._SubParsersAction) -> None:
    from engine.paths import CONTROL_DIR, DUET_DIR, MODEL_DIR

    p = sub.add_parser("serve", help="start the studio in the browser (Panel server on localhost)")
    p.add_argument("--port", type=int, default=5006)
    p.add_argument("--address", default="localhost")
    p.add_argument("--show", action="store_true", help="open a browser tab")
    p.add_argument("--motion", type=Path, default=None, help="a .bvh/.npy motion to show first")
    p.add_argument("--model", type=Path, default=MODEL_DIR,
                   help=f"model folder (config.json, weights.pt, Mean.npy, Std.npy); default {MODEL_DIR}")
    p.add_argument("--controls", type=Path, default=CONTROL_DIR,
                   help=f"folder of fine-tuned control models (Control tab); default {CONTROL_DIR}")
    p.add_argument("--duet-model", type=Path, default=DUET_DIR,
                   help=f"the ComMDM block trained on --model (Duet tab); default {DUET_DIR}")
    add_runtime_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from app.main import serve
    from app.model_cache import use_runtime

    runtime = runtime_from_args(args)
    use_runtime(runtime)
    print(f"Motion Attention Studio: http://{args.address}:{args.port}/ (model: {args.model}, on {runtime.describe()})",
          flush=True)
    serve(port=args.port, show=args.show, address=args.address, initial=args.motion, model_dir=args.model,
          controls_dir=args.controls, duet_dir=args.duet_model)
    return 0
