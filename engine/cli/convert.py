"""`moattn convert` and `moattn render`: thin wrappers over engine.io and viz.export (the studio's exporter)."""
from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    convert = sub.add_parser(
        "convert",
        help="convert a motion between BVH and .npy (joints (T,22,3) or HumanML3D vectors (T,263)), or to an "
             "animated .glb",
        description="Read a .bvh or .npy motion and write .npy (joints or 263-dim vectors), .bvh, or .glb (an "
                    "animated glTF binary for Blender and three.js: a node, sphere and bones per joint, rotation "
                    "and translation keys at 20 fps).",
    )
    convert.add_argument("input", type=Path, help="input .bvh or .npy")
    convert.add_argument("output", type=Path, help="output .npy, .bvh or .glb")
    convert.add_argument("--to", choices=("joints", "vecs"), default="joints",
                         help="what an .npy output holds (default: joints)")
    add_window_args(convert, what="the part of the input to write")
    from engine.library.cli_support import add_library_arguments

    add_library_arguments(convert)  # the motion read is kept in the library as an import
    convert.set_defaults(run=run_convert)

    render = sub.add_parser(
        "render",
        help="render a motion to PNG (one frame), GIF or MP4 with the studio's exporter",
        description="Render a .bvh or .npy motion with the studio's exporter (viz/export.py, the same picture as "
                    "the studio's Export buttons and `moattn generate --out`): 640x480, the camera following the "
                    "body from a 3/4 front view, the title (wrapped, never cut) upper left and a frame counter "
                    "upper right; a GIF or MP4 holds every frame at the motion's real speed (20 fps), a PNG one "
                    "frame (--frame). Earlier versions drew with the pyvista scene: a fixed camera, no title or "
                    "counter, and GIFs at 480x360.",
    )
    render.add_argument("input", type=Path, help="input .bvh or .npy")
    render.add_argument("--out", type=Path, required=True, help="output .png, .gif or .mp4")
    render.add_argument("--frame", type=int, default=None, help="frame to draw for a .png (default 0)")
    render.add_argument("--title", default=None,
                        help="text drawn upper left (default: the input's file name; '' for none)")
    render.set_defaults(run=run_render)


def add_window_args(p: argparse.ArgumentParser, *, what: str) -> None:
    """``--start`` / ``--seconds``: the window of a longer motion file (engine.io.window holds the rule)."""
    p.add_argument("--start", type=float, default=None, metavar="SECONDS",
                   help=f"{what}: starts this many seconds into the file (default 0)")
    p.add_argument("--seconds", type=float, default=None, metavar="SECONDS",
                   help=f"{what}: this many seconds from --start (default: to the end)")


def load_window(path: Path, args: argparse.Namespace, *, max_frames: int | None = None):
    """Joints (T, 22, 3) of ``path`` in the window ``args.start`` / ``args.seconds``; with ``max_frames`` (a model's
    limit) a longer window, or a longer file given without one, is refused with a hint naming the flags."""
    from engine.io import load_motion, pick_window

    return pick_window(load_motion(path), start=args.start, seconds=args.seconds, max_frames=max_frames,
                       name=Path(path).name)


def run_convert(args: argparse.Namespace) -> int:
    from engine.cli.common import MOTION_SUFFIXES, CLIError, check_outputs
    from engine.generate import FPS
    from engine.io import save_motion

    check_outputs([args.output], MOTION_SUFFIXES + (".glb",), flag="output")  # .glb: written by convert only
    suffix = args.output.suffix.lower()
    if args.to == "vecs" and suffix in (".bvh", ".glb"):
        raise CLIError(f"--to vecs writes 263-dim features to .npy; a {suffix} output holds joints")
    joints = load_window(args.input, args)
    save_motion(joints, args.output, to=args.to)
    print(f"wrote {args.output} ({len(joints)} frames at {FPS} fps)")
    keep_import(args, joints, args.input)
    return 0


def keep_import(args: argparse.Namespace, joints, path: Path, *, title: str | None = None, library=None):
    """Keep a motion read from ``path`` in the library (kind "import"; the same file and window again: the same
    entry, re-made) unless ``--no-library``."""
    from engine.library.cli_support import keep

    path = Path(path)
    window = {"start": getattr(args, "start", None), "seconds": getattr(args, "seconds", None)}
    return keep(args, joints, kind="import", title=title or f"imported: {path.name}", reuse=True, library=library,
                recipe={"source": {"file": str(path.expanduser().resolve()), "name": path.name,
                                   **{k: v for k, v in window.items() if v is not None}},
                        "operation": {"made_by": f"moattn {getattr(args, 'command', None) or 'convert'}"}})


def run_render(args: argparse.Namespace) -> int:
    from engine.cli.common import RENDER_SUFFIXES, CLIError, check_outputs
    from engine.io import load_motion

    check_outputs([args.out], RENDER_SUFFIXES)
    suffix = args.out.suffix.lower()
    if args.frame is not None and suffix != ".png":
        raise CLIError(f"--frame picks the frame of a .png; a {suffix} holds every frame: drop --frame")
    joints = load_motion(args.input)  # a missing, unreadable or empty motion is refused here (one-line error)
    if args.frame is not None and not 0 <= args.frame < len(joints):
        raise CLIError(f"--frame {args.frame} is outside the motion's {len(joints)} frames (0..{len(joints) - 1})")
    from viz.export import write_picture  # the studio's exporter: one picture of a motion

    title = args.input.name if args.title is None else args.title
    write_picture(joints, args.out, title=title, frame=args.frame or 0)
    n = 1 if suffix == ".png" else len(joints)
    print(f"wrote {args.out} ({n} frame{'' if n == 1 else 's'})")
    return 0
