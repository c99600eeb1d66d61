"""Import a motion file (BVH, joints or 263-dim vectors .npy) and export motions and attention maps."""
from __future__ import annotations

import asyncio
import io
import re
import tempfile
import threading
from pathlib import Path

import panel as pn
import param

from app.model_cache import VTK_LOCK
from app.items import MAX_UPLOAD_BYTES, MotionItem, upload_limit_text
from app.state import StudioState


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


def import_bytes(data: bytes, filename: str):
    """Parse an uploaded file as data (never unpickled) -> joints (T, 22, 3)."""
    from engine.io import load_motion

    if not data:
        raise ValueError(f"{filename} is empty")
    if len(data) > MAX_UPLOAD_BYTES:
        raise ValueError(f"{filename} is {len(data) / 2**20:.1f} MiB; uploads are limited to {upload_limit_text()}")
    suffix = Path(filename).suffix.lower()
    if suffix not in (".bvh", ".npy"):
        raise ValueError(f"{filename}: only .bvh and .npy files can be imported")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"upload{suffix}"
        path.write_bytes(data)
        joints = load_motion(path)
    if len(joints) < 2:
        raise ValueError(f"{filename} has {len(joints)} frame(s); at least 2 are needed")
    return joints


WINDOW_FIELDS = ("Start", "Seconds")  # the import's window fields, as the window's messages name them


def import_window(data: bytes, filename: str, *, start: float | None = None, seconds: float | None = None,
                  max_frames: int | None = None):
    """An upload's joints in the window ``start`` / ``seconds`` (seconds; None: from the beginning / to the end)
    and the whole file's length in frames. With ``max_frames`` (the model's limit) a longer window, or a longer
    file with no window, is refused with a one-line hint naming the Start/Seconds fields (engine.io.window)."""
    from engine.io import pick_window

    joints = import_bytes(data, filename)
    if seconds is None and start is not None and float(start) == 0.0:
        start = None  # no window asked for: a file over the limit gets the "pick a window" hint
    return pick_window(joints, start=start, seconds=seconds, max_frames=max_frames, name=filename,
                       flags=WINDOW_FIELDS), len(joints)


def slug(text: str, limit: int = 40) -> str:
    s = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")
    return (s[:limit].rstrip("_") or "motion")


def export_filename(item: MotionItem, fmt: str) -> str:
    name = slug(item.name.removesuffix(" · a").removesuffix(" · b")) if _duet(item) is not None else slug(item.name)
    return f"{name}.{fmt}" + (".zip" if fmt == "bvh" and _duet(item) is not None else "")


def _duet(item: MotionItem):
    """The two people of a duet ``item`` belongs to (exports hold both), else None."""
    from app.dueting import DuetPair

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
        from viz.render import render_together

        options = ({"size": (320, 240), "title": title[:40]} if fmt == "gif"
                   else {"size": (640, 480), "title": title[:50], "frame_label": True})
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / f"export.{fmt}"
            with VTK_LOCK:
                render_together(by_person(joints), path, follow=True, **options)
            return path.read_bytes()
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
        elif fmt == "gif":
            from viz.render import render_gif

            with VTK_LOCK:
                render_gif(joints, path, size=(320, 240), follow=True, title=item.name[:40])
        elif fmt == "mp4":
            from viz.render import render_mp4

            with VTK_LOCK:
                render_mp4(joints, path, size=(640, 480), follow=True, title=item.name[:50], frame_label=True)
        return path.read_bytes()


class ImportPanel(pn.viewable.Viewer):
    """Upload a motion file; Start / Seconds pick the window of a file longer than the model's limit (the Seconds
    field's bound is that limit), and "Import window" re-reads the last upload with another window."""

    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        from engine.generate import FPS
        from engine.io import seconds_of

        super().__init__(**params)
        self.max_frames = self._max_frames()
        self.limit_s = seconds_of(self.max_frames)
        self._input = pn.widgets.FileInput(accept=".bvh,.npy", multiple=False, css_classes=["import-input"],
                                           sizing_mode="stretch_width")
        self.start = pn.widgets.FloatInput(label="Start (s)", value=0.0, start=0.0, step=0.5, width=100,
                                           css_classes=["import-start"])
        self.seconds = pn.widgets.FloatInput(label="Seconds", value=None, start=2 / FPS, end=self.limit_s, step=0.5,
                                             placeholder="to the end", width=100, css_classes=["import-seconds"])
        self.again = pn.widgets.Button(label="Import window", disabled=True, sizing_mode="stretch_width",
                                       css_classes=["import-again"])
        self._upload: tuple[bytes, str] | None = None
        self._input.param.watch(self._on_upload, "value")
        self.again.on_click(lambda *_: self.import_upload())

    def _max_frames(self) -> int:
        """The model's limit (its config's max_frames); the default model's when none is loaded."""
        if self.state.has_model:
            return int(self.state.model.model.config.max_frames)
        from engine.model import ModelConfig

        return ModelConfig().max_frames

    def _on_upload(self, event):
        if event.new is None:
            return
        if not event.new:  # an empty file is bytes too: say so (it used to pass without a word)
            self.state.error(f"Could not import {self._input.filename or 'the file'}: it is empty")
            self._input.clear()
            return
        self._upload = (event.new, self._input.filename or "upload")
        self.again.disabled = False
        self.import_upload()

    def import_upload(self) -> bool:
        """Import the last upload in the window Start / Seconds; False (and a one-line message) if refused.

        Served, the file is parsed on a worker thread (a large BVH no longer blocks every session's event loop)
        and the result is applied on the session's document; True then means it was started."""
        if self._upload is None:
            self.state.error("upload a .bvh or .npy file first")
            return False
        data, name = self._upload
        start, seconds = self.start.value, self.seconds.value

        def parse():
            try:
                return import_window(data, name, start=start, seconds=seconds, max_frames=self.max_frames), None
            except Exception as exc:  # any parse or window problem is the user's input, not a crash
                return None, exc

        if not self.state.served:
            return self._apply_import(name, start, *parse())
        self.again.disabled = True
        threading.Thread(target=lambda: self.state.post(lambda: self._apply_import(name, start, *parse())),
                         name="moattn-import", daemon=True).start()
        return True

    def _apply_import(self, name: str, start, parsed, error: Exception | None) -> bool:
        from engine.io.window import seconds_of

        self.again.disabled = self._upload is None
        if error is None:
            joints, total = parsed
            cut = len(joints) < total
            begin = float(start or 0.0)
            title = f"imported: {name}" + (f" [{begin:g}–{begin + seconds_of(len(joints)):g} s]" if cut else "")
            try:
                self.state.show_motion(joints, title=title)
            except ValueError as exc:
                error = exc
        if error is not None:
            self.state.error(f"Could not import {name}: {error}")
            self._input.clear()  # the field does not go on naming a file that was refused ("Import window" retries)
            return False
        window = f" from {begin:g} s of its {seconds_of(total):.1f} s" if cut else ""
        self.state.info(f"imported {name}: {len(joints)} frames ({seconds_of(len(joints)):.1f} s){window}")
        return True

    def __panel__(self):
        return pn.Column("#### Import", "BVH, joints (T,22,3) or HumanML3D vectors (T,263) as .npy "
                         f"(up to {upload_limit_text()}); a file over the model's {self.limit_s:.1f} s: "
                         "pick its window (Start, Seconds)", self._input,
                         pn.Row(self.start, self.seconds), self.again, sizing_mode="stretch_width")


class ExportPanel(pn.viewable.Viewer):
    """Download buttons for the motion shown (and its attention for the current selection)."""

    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        self.buttons = {}
        for fmt, label in EXPORTS.items():
            button = pn.widgets.FileDownload(callback=self._callback(fmt), filename=f"motion.{fmt}", label=label,
                                             color="light", width=140, height=34, margin=(2, 4),
                                             css_classes=[f"export-{fmt.replace('.', '-')}"])
            self.buttons[fmt] = button
        self.state.param.watch(self._on_current, "current")
        self._on_current()

    def _callback(self, fmt: str):
        async def callback():
            item = self.state.item
            if item is None:
                self.state.error("nothing to export yet: generate or import a motion first")
                raise ValueError("nothing to export")
            selection = self.state.selection()
            button = self.buttons[fmt]
            button.loading = True  # a GIF or MP4 takes seconds: the button shows a spinner until the file is ready
            try:
                data = await asyncio.to_thread(export_bytes, item, fmt, selection=selection)
            except Exception as exc:
                self.state.error(f"export {EXPORTS[fmt]} failed: {exc}")
                raise
            finally:
                button.loading = False
            return io.BytesIO(data)

        return callback

    def _on_current(self, *_):
        item = self.state.item
        for fmt, button in self.buttons.items():
            button.filename = export_filename(item, fmt) if item is not None else f"motion.{fmt}"
            button.label = EXPORTS[fmt]
            button.disabled = item is None or (fmt.startswith("attention.") and item.attention is None)

    def __panel__(self):
        return pn.Column("#### Export", pn.FlexBox(*self.buttons.values()), sizing_mode="stretch_width")
