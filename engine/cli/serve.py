"""`moattn serve`: start the studio in the browser (Panel server on localhost)."""
from __future__ import annotations

import argparse
import ipaddress
import os
import sys
from pathlib import Path

from engine.runtime import add_runtime_arguments, runtime_from_args


def add_parser(sub: argparse._SubParsersAction) -> None:
    from engine.paths import CONTROL_DIR, DUET_DIR, MODEL_DIR, shown_folder

    p = sub.add_parser("serve", help="start the studio in the browser (Panel server on localhost)")
    p.add_argument("--port", type=int, default=5006)
    p.add_argument("--address", default="localhost",
                   help="where to listen (default: localhost); another address exposes the studio to the network")
    p.add_argument("--token", default=None,
                   help="require this password on a login page (for --address other than localhost); "
                        "default: the MOATTN_TOKEN environment variable, if set")
    p.add_argument("--show", action="store_true", help="open a browser tab")
    p.add_argument("--motion", type=Path, default=None, help="a .bvh/.npy motion to show first")
    p.add_argument("--model", type=Path, default=MODEL_DIR,
                   help=f"model folder (config.json, weights.pt, Mean.npy, Std.npy); default {shown_folder(MODEL_DIR)}")
    p.add_argument("--controls", type=Path, default=CONTROL_DIR,
                   help=f"folder of fine-tuned control models (Control tab); default {shown_folder(CONTROL_DIR)}")
    p.add_argument("--duet-model", type=Path, default=DUET_DIR,
                   help=f"the ComMDM block trained on --model (Duet tab); default {shown_folder(DUET_DIR)}")
    from engine.library.cli_support import add_library_arguments

    add_library_arguments(p)  # --workspace, --library-mb, --no-library
    add_runtime_arguments(p)
    p.set_defaults(run=run)


def is_loopback(address: str) -> bool:
    """Whether ``address`` listens on this machine only (localhost, 127.x, ::1)."""
    if address.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(address.strip("[]")).is_loopback
    except ValueError:
        return False  # a host name: it may resolve to a public interface


def run(args: argparse.Namespace) -> int:
    from app.main import serve
    from app.model_cache import use_runtime

    runtime = runtime_from_args(args)
    token = args.token or os.environ.get("MOATTN_TOKEN") or None
    if not is_loopback(args.address):
        if token:
            print(f"the studio listens on {args.address}: visitors must log in with the token", file=sys.stderr)
        else:
            print(f"warning: the studio listens on {args.address} and anyone who can reach it may use it "
                  "(and this machine's CPU/GPU); pass --token SECRET to require a password", file=sys.stderr)
    use_runtime(runtime)
    print(f"Motion Attention Studio: http://{args.address}:{args.port}/ (model: {args.model}, on {runtime.describe()})",
          flush=True)
    from app.main import LibrarySettings

    library = None if args.no_library else LibrarySettings(workspace=args.workspace, limit_mb=args.library_mb)
    serve(port=args.port, show=args.show, address=args.address, initial=args.motion, model_dir=args.model,
          controls_dir=args.controls, duet_dir=args.duet_model, token=token, library=library)
    return 0
