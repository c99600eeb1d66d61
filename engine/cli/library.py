"""`moattn library`: the motion library from the command line (the same library the studio's Motion list reads).

    moattn library list [--search TEXT] [--kind KIND] [--pinned] [--json]
    moattn library show ID [--json]
    moattn library export ID --out FILE.npy|.bvh|.glb|.json|FOLDER/
    moattn library rm ID [ID ...]
    moattn library import FILE.bvh|FILE.npy [--title TEXT]
    moattn library pin ID [ID ...] / unpin ID [ID ...]
    moattn library limit [MB | default]

An ID may be shortened to any unique prefix. Damaged or foreign entries are reported on stderr (one line each)
and skipped. Torch is imported only to write a .bvh / .glb export.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from engine.library.cli_support import open_library
from engine.units import FPS
from engine.library.workspace import DEFAULT_LIMIT_MB, LIMIT_ENV, WORKSPACE_ENV

KIND_CHOICES = ("generate", "edit", "transfer", "compose", "control", "duet", "import")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("library", help="the motion library: list, show, export, rm, pin/unpin, limit",
                       description="Every motion the studio or the CLI makes, edits or imports is kept in the "
                       f"workspace's library (--workspace, else ${WORKSPACE_ENV}, else the user-data folder).")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True

    def common(q: argparse.ArgumentParser) -> argparse.ArgumentParser:
        q.add_argument("--workspace", type=Path, default=None, metavar="DIR",
                       help=f"the workspace folder (default: ${WORKSPACE_ENV}, else the user-data folder)")
        q.set_defaults(run=run)
        return q

    ls = common(actions.add_parser("list", help="list the motions kept, oldest first"))
    ls.add_argument("--search", default=None, metavar="TEXT", help="only motions whose prompt or title has every word")
    ls.add_argument("--kind", choices=KIND_CHOICES, default=None, help="only motions of this kind")
    ls.add_argument("--pinned", action="store_true", help="only pinned motions")
    ls.add_argument("--newest", type=int, default=None, metavar="N", help="only the N newest")
    ls.add_argument("--json", action="store_true", help="one JSON object per line")

    show = common(actions.add_parser("show", help="a motion's recipe: prompt, seed, steps, guidance, model, chain"))
    show.add_argument("id")
    show.add_argument("--json", action="store_true", help="the recipe as JSON")

    export = common(actions.add_parser("export", help="write a motion out: .npy joints, .bvh, .glb, .json recipe, "
                                                      "or a folder (joints.npy, features.npy, recipe.json)"))
    export.add_argument("id")
    export.add_argument("--out", type=Path, required=True,
                        help="FILE.npy (joints), FILE.bvh, FILE.glb, FILE.json (the recipe), or FOLDER/")
    export.add_argument("--vecs", action="store_true", help="a .npy --out holds the 263-dim features")

    rm = common(actions.add_parser("rm", help="delete motions"))
    rm.add_argument("ids", nargs="+", metavar="ID")

    pin = common(actions.add_parser("pin", help="pin motions: kept whatever the size bound"))
    pin.add_argument("ids", nargs="+", metavar="ID")
    unpin = common(actions.add_parser("unpin", help="unpin motions"))
    unpin.add_argument("ids", nargs="+", metavar="ID")

    imp = common(actions.add_parser("import", help="keep a .bvh / .npy motion file in the library"))
    imp.add_argument("input", type=Path, help="a .bvh or .npy motion")
    imp.add_argument("--title", default=None, help='its name in the library (default: "imported: <file name>")')
    imp.add_argument("--start", type=float, default=None, metavar="SECONDS", help="keep from this many seconds in")
    imp.add_argument("--seconds", type=float, default=None, metavar="SECONDS", help="keep this many seconds")

    limit = common(actions.add_parser("limit", help="show or set the library's size bound (MB), kept in the library"))
    limit.add_argument("mb", nargs="?", default=None, help=f"a number of MB, or 'default' ({DEFAULT_LIMIT_MB:g})")


def run(args: argparse.Namespace) -> int:
    from engine.library.store import INDEX_FILE
    from engine.library.workspace import library_dir

    root = library_dir(args.workspace)
    if args.action not in ("import", "limit") and not (root / INDEX_FILE).exists():  # reading creates nothing
        if args.action == "list":
            print(f"0 motions: no library yet in {root}" if not args.json else "", end="\n" if not args.json else "")
            return 0
        raise ValueError(f"no motion {getattr(args, 'id', None) or ' '.join(args.ids)} (the library in {root} "
                         f"is empty)")
    library = open_library(args)
    return {"list": _list, "show": _show, "export": _export, "rm": _rm, "pin": _pin, "unpin": _pin,
            "limit": _limit, "import": _import}[args.action](library, args)


def _when(t: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M", time.localtime(t))


def _size(n: int) -> str:
    return f"{n / 2**20:.1f} MB" if n >= 2**20 else f"{n / 1024:.0f} KB"


def _list(library, args) -> int:
    library.check()  # folders the index does not list, rows without files: reported on stderr
    entries = library.entries(search=args.search, kind=args.kind, pinned=True if args.pinned else None,
                              newest_first=args.newest is not None, limit=args.newest)
    if args.newest is not None:
        entries.reverse()
    if args.json:
        for e in entries:
            print(json.dumps(e.to_json()))
        return 0
    for e in entries:
        pin = "*" if e.pinned else " "
        print(f"{e.id}  {_when(e.created)}  {e.kind:<9} {e.seconds:5.1f} s {pin} {_printable(e.title)}")
    total, count = library.total_bytes(), library.count()
    shown = f"{len(entries)} of {count}" if len(entries) != count else f"{count}"
    print(f"{shown} motion{'s' if count != 1 else ''}, {_size(total)} of {library.limit_mb:g} MB "
          f"({library.limit_source()}) in {library.root}" + ("; * pinned" if any(e.pinned for e in entries) else ""))
    return 0


def _show(library, args) -> int:
    entry = library.get(args.id)
    recipe = library.recipe(entry.id)
    if args.json:
        print(json.dumps({**recipe, "pinned": entry.pinned, "bytes": entry.bytes}, indent=1, ensure_ascii=False))
        return 0
    print(f"{entry.id}  {entry.kind}  {_printable(entry.title)}")
    print(f"  made      {_when(entry.created)}" + (f", last re-made {_when(entry.touched)}"
                                                    if entry.touched - entry.created > 1 else ""))
    print(f"  motion    {entry.frames} frames ({entry.seconds:.2f} s at {FPS} fps), {_size(entry.bytes)} on disk"
          + (", pinned" if entry.pinned else ""))
    for key in ("prompt", "seed", "steps", "guidance", "guidance_from", "eta", "seconds"):
        value = recipe.get(key)
        if value not in (None, ""):
            print(f"  {key:<9} {_printable(str(value))}")
    model = recipe.get("model")
    if isinstance(model, dict):
        print(f"  model     {model.get('folder')}" + (f" (weights {model['weights_sha256']})"
                                                      if model.get("weights_sha256") else ""))
    for key, value in recipe.items():
        if key in ("operation", "source") and value:
            print(f"  {key:<9} {_printable(json.dumps(value, ensure_ascii=False))[:300]}")
    if entry.parents:
        present = {e.id for e in library.entries(ids=entry.parents)}
        print("  parents   " + ", ".join(p + ("" if p in present else " (gone)") for p in entry.parents))
    chain = recipe.get("chain") or []
    if len(chain) > 1:
        print("  chain     " + " > ".join(f"{step.get('kind')} {step.get('id', '?')}" for step in chain))
    return 0


def _export(library, args) -> int:
    from engine.cli.common import CLIError, check_output_folder, check_outputs

    out: Path = args.out
    entry = library.get(args.id)
    folder = str(out).endswith(("/", "\\")) or out.is_dir() or not out.suffix
    if folder:
        check_output_folder(out)
    else:
        check_outputs([out], (".npy", ".bvh", ".glb", ".json"))
    joints = library.joints(entry.id)
    recipe = library.recipe(entry.id)
    if folder:
        import numpy as np

        from engine.library.store import write_json_atomic

        out.mkdir(parents=True, exist_ok=True)
        np.save(out / "joints.npy", joints, allow_pickle=False)
        features = library.features(entry.id)
        if features is not None:
            np.save(out / "features.npy", features, allow_pickle=False)
        write_json_atomic(out / "recipe.json", recipe)
        print(f"wrote {out}/ (joints.npy{', features.npy' if features is not None else ''}, recipe.json)")
        return 0
    suffix = out.suffix.lower()
    if suffix == ".json":
        from engine.library.store import write_json_atomic

        write_json_atomic(out, recipe)
    else:
        if args.vecs and suffix != ".npy":
            raise CLIError("--vecs writes 263-dim features to .npy")
        from engine.io import save_motion

        save_motion(joints, out, to="vecs" if args.vecs else "joints")
    print(f"wrote {out} ({entry.frames} frames of {entry.id})")
    return 0


def _rm(library, args) -> int:
    ids = [library.resolve(i) for i in args.ids]
    removed = library.remove(ids)
    for e in removed:
        print(f"removed {e.id}  {_printable(e.title)}")
    gone = set(ids) - {e.id for e in removed}
    for i in sorted(gone):
        print(f"moattn library rm: {i} was not in the library", file=sys.stderr)
    return 0 if removed or not gone else 2


def _pin(library, args) -> int:
    pinned = args.action == "pin"
    for i in args.ids:
        e = library.pin(i, pinned)
        print(f"{'pinned' if pinned else 'unpinned'} {e.id}  {_printable(e.title)}")
    return 0


def _import(library, args) -> int:
    from engine.cli.convert import keep_import, load_window

    joints = load_window(args.input, args)
    return 0 if keep_import(args, joints, args.input, title=args.title, library=library) is not None else 2


def _limit(library, args) -> int:
    if args.mb is not None:
        removed = library.set_limit_mb(None if args.mb.strip().lower() == "default" else args.mb)
        for e in removed:
            print(f"removed {e.id}  {_printable(e.title)} (over the bound)")
    source = library.limit_source()
    note = {"given": "", "MOATTN_LIBRARY_MB": f" (from ${LIMIT_ENV}, which overrides the stored bound)",
            "stored": " (stored)", "default": " (the default)"}[source]
    print(f"library bound {library.limit_mb:g} MB{note}; {_size(library.total_bytes())} used by {library.count()} "
          f"motions in {library.root}")
    return 0


def _printable(text: str) -> str:
    """One line of ``text`` as stdout can encode it (a title may hold '·' or a user's accented words)."""
    text = " ".join(str(text).split())
    encoding = getattr(sys.stdout, "encoding", None) or "utf-8"
    try:
        text.encode(encoding)
        return text
    except (UnicodeEncodeError, LookupError):
        return text.replace("\u00b7", "-").encode("ascii", "replace").decode("ascii")
