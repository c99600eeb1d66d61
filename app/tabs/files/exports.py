"""The Files tab's exports: one motion (or a duet's two people) as BVH, .npy, GLB, GIF/MP4, or its attention maps."""
from __future__ import annotations

import io
import re
import tempfile
from pathlib import Path

from app.session.duets import DuetPair
from app.session.items import MotionItem
from viz.export import VIDEO_SIZE, write_picture  # noqa: F401 (VIDEO_SIZE: the exports' size, read by tests)


EXPORTS = {
    "bvh": "BVH",
    "joints.npy": "joints .npy",
    "vecs.npy": "vectors .npy",
    "glb": "GLB",
    "gif": "GIF",
    "mp4": "MP4",
    "attention.png": "attention PNG",
    "attention.json": "attention JSON",
}




def slug(text: str, limit: int = 40) -> str:
    s = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")
    return (s[:limit].rstrip("_") or "motion")


def export_filename(item: MotionItem, fmt: str) -> str:
    name = slug(item.name.removesuffix(" · a").removesuffix(" · b")) if _duet(item) is not None else slug(item.name)
    return f"{name}.{fmt}" + (".zip" if fmt == "bvh" and _duet(item) is not None else "")


def _duet(item: MotionItem):
    """The two people of a duet ``item`` belongs to (exports hold both), else None."""
    pair = item.info.get("duet")
    return pair if isinstance(pair, DuetPair) else None


def export_duet_bytes(pair, fmt: str, *, title: str) -> bytes:
    """A duet's export: both people in one frame (.npy (2, T, ...), a zip of two BVH files, one GLB scene with a
    skeleton each, one scene on video)."""
    import zipfile

    from engine.io import format_bvh
    from engine.representation import joints_to_features

    joints = pair.joints  # (2, T, 22, 3)
    if fmt == "bvh":
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
            for person, j in zip("ab", joints):
                zf.writestr(f"{slug(title)}_{person}.bvh", format_bvh(j, fps=20.0))
        return buf.getvalue()
    if fmt in ("joints.npy", "vecs.npy"):
        import numpy as np

        data = joints if fmt == "joints.npy" else np.stack([joints_to_features(j) for j in joints])
        buf = io.BytesIO()
        np.save(buf, np.asarray(data, dtype=np.float32), allow_pickle=False)
        return buf.getvalue()
    if fmt == "glb":
        from engine.io import format_glb
        from engine.units import FPS

        return format_glb(joints, fps=FPS, name=title[:60] or "duet")
    if fmt in ("gif", "mp4"):
        from engine.methods.duet import by_person

        people = by_person(joints)  # one shared space: no side-by-side offsets
        return video_bytes(people, fmt, title=title, offsets={role: (0.0, 0.0, 0.0) for role in people})
    raise ValueError(f"a duet has no {EXPORTS.get(fmt, fmt)} export")


def export_bytes(item: MotionItem, fmt: str, *, selection: dict | None = None) -> bytes:
    """The bytes of one export of ``item`` (``fmt`` a key of ``EXPORTS``)."""
    from engine.io import format_bvh, save_npy
    from engine.representation import joints_to_features

    if fmt not in EXPORTS:
        raise ValueError(f"unknown export format {fmt!r}; one of {', '.join(EXPORTS)}")
    joints = item.joints
    pair = _duet(item)
    if pair is not None and not fmt.startswith("attention."):
        return export_duet_bytes(pair, fmt, title=item.name.removesuffix(" · a").removesuffix(" · b"))
    if fmt == "bvh":
        return format_bvh(joints, fps=20.0).encode()
    if fmt == "glb":  # an animated glTF binary for Blender / three.js (engine.io.glb)
        from engine.io import format_glb
        from engine.units import FPS

        return format_glb(joints, fps=FPS, name=item.name[:60] or "motion")
    if fmt.startswith("attention."):
        if item.attention is None:
            raise ValueError(f"{item.name!r} has no recorded attention (only generated motions do)")
        sel = selection or {"step": item.attention.steps[-1], "layer": None, "head": None}
        if fmt == "attention.json":
            data = item.attention.to_json_dict(**sel)
            data["prompt"] = item.prompt
            import json

            return json.dumps(data).encode()
        return item.attention.to_png_bytes(**sel, title=item.prompt)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"export.{fmt.split('.')[-1]}"
        if fmt == "joints.npy":
            save_npy(path, joints, kind="joints")
        elif fmt == "vecs.npy":
            save_npy(path, joints_to_features(joints), kind="vecs")
        elif fmt in ("gif", "mp4"):
            return video_bytes(joints, fmt, title=item.name)
        return path.read_bytes()


def video_bytes(motions, fmt: str, *, title: str, offsets: dict | None = None) -> bytes:
    """A GIF or MP4 of ``motions`` (one (T, 22, 3) or role -> motion) as the Export buttons make it: written by
    ``viz.export.write_picture`` (the exporter ``moattn generate --out x.gif`` uses too), VIDEO_SIZE, the full
    ``title`` (wrapped, never cut), a frame counter, the camera following the body, at real speed."""
    if fmt not in ("gif", "mp4"):
        raise ValueError(f"{fmt!r} is not a video export (gif, mp4)")
    with tempfile.TemporaryDirectory() as tmp:
        return write_picture(motions, Path(tmp) / f"export.{fmt}", title=title, offsets=offsets).read_bytes()
