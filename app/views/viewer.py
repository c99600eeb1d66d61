"""The skeleton viewer: a pyvista scene rendered offscreen, built once per motion, frames updated in place."""
from __future__ import annotations

import io

import numpy as np
import panel as pn
import param
from PIL import Image

from app.state import StudioState

SIZE = (640, 480)


class SkeletonViewer(pn.viewable.Viewer):
    """Play / pause / scrub a motion; the pyvista scene is rebuilt only when the motion changes."""

    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        self._scene = None
        self._image = pn.pane.PNG(None, width=SIZE[0], height=SIZE[1], sizing_mode="fixed",
                                  css_classes=["skeleton-view"])
        self._player = pn.widgets.Player(start=0, end=1, value=0, step=1, interval=50, loop_policy="loop",
                                         width=SIZE[0], show_value=True)
        self._player.link(self.state, value="frame")
        self.state.param.watch(self._on_motion, "joints")
        self.state.param.watch(self._on_frame, "frame")
        if self.state.joints is not None:
            self._on_motion()

    def _on_motion(self, *_):
        from viz.scene import SkeletonScene

        if self._scene is not None:
            self._scene.close()
            self._scene = None
        joints = self.state.joints
        if joints is None:
            self._image.object = None
            return
        self._scene = SkeletonScene(joints, size=SIZE, follow=True)
        self._player.end = max(1, len(joints) - 1)
        self._player.value = 0
        self._draw(0)

    def _on_frame(self, event):
        self._draw(event.new)

    def _draw(self, frame: int) -> None:
        if self._scene is None:
            return
        frame = int(np.clip(frame, 0, self._scene.n_frames - 1))
        self._scene.set_frame(frame)
        buf = io.BytesIO()
        Image.fromarray(self._scene.screenshot()).save(buf, format="PNG", compress_level=1)
        self._image.object = buf.getvalue()

    def __panel__(self):
        return pn.Column(self._image, self._player)
