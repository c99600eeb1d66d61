"""Import a motion file (BVH, joints or 263-dim vectors .npy) into the session."""
from __future__ import annotations

import tempfile
from pathlib import Path

import panel as pn
import param

from app.state import StudioState

MAX_UPLOAD_BYTES = 20 * 1024 * 1024


def import_bytes(data: bytes, filename: str):
    """Parse an uploaded file as data (never unpickled) -> joints (T, 22, 3)."""
    from engine.io import load_motion

    if not data:
        raise ValueError(f"{filename} is empty")
    if len(data) > MAX_UPLOAD_BYTES:
        raise ValueError(f"{filename} is {len(data) / 1e6:.1f} MB; uploads are limited to {MAX_UPLOAD_BYTES / 1e6:.0f} MB")
    suffix = Path(filename).suffix.lower()
    if suffix not in (".bvh", ".npy"):
        raise ValueError(f"{filename}: only .bvh and .npy files can be imported")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"upload{suffix}"
        path.write_bytes(data)
        return load_motion(path)


class ImportPanel(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        self._input = pn.widgets.FileInput(accept=".bvh,.npy", multiple=False)
        self._input.param.watch(self._on_upload, "value")

    def _on_upload(self, event):
        if not event.new:
            return
        name = self._input.filename or "upload"
        try:
            joints = import_bytes(event.new, name)
        except Exception as exc:  # any parse problem is the user's file, not a crash
            self.state.error = f"Could not import {name}: {exc}"
            return
        self.state.show_motion(joints, title=name)

    def __panel__(self):
        return pn.Column("### Import", "BVH, joints (T,22,3) or HumanML3D vectors (T,263) as .npy", self._input)
