"""`moattn serve`: start the studio on localhost."""
from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="start the studio in the browser (Panel server on localhost)")
    p.add_argument("--port", type=int, default=5006)
    p.add_argument("--address", default="localhost")
    p.add_argument("--show", action="store_true", help="open a browser tab")
    p.add_argument("--motion", type=Path, default=None, help="a .bvh/.npy motion to show first")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from app.main import serve

    print(f"Motion Attention Studio: http://{args.address}:{args.port}/")
    serve(port=args.port, show=args.show, address=args.address, initial=args.motion)
    return 0
