"""``SkeletonView``: the studio's 3-D viewer, drawn in the browser (``viewer3d/*.js``; no CDN, no WebGL).

The server sets ``scene`` (``app.viewer.scene.scene_message``) once per change of what is shown; the
page draws every frame, orbit, pan and zoom itself, interpolating poses between the motion's frames.
While sampling, :meth:`preview` sends the current x̂0 motion as a custom message; the page shows it
until the result's scene arrives (or :meth:`end_preview`, on cancel or error).

``frame`` and ``playing`` sync both ways; while playing, the page moves the attention views' frame cursors
itself (``cursor_ids``: Bokeh ``Span`` ids) and tells the server the frame only when playback stops, so
playback costs the server nothing. ``window.moattnPlayer`` exposes counters for tests and
``moattn bench --app``: ``draws``, ``distinct``, ``draw_ms``, ``n_frames``, ``motion_key``,
``first_draw`` / ``preview_first`` (performance.now() per key), ``previews``, ``camera``.

The page's code is in ``viewer3d/``, one file a job: ``decode.js`` (payload -> frames), ``camera.js`` (orbit, zoom,
projection, limits), ``draw.js`` (sky, floor, paths, bones and joints), ``legend.js`` (the colour legend),
``player.js`` (time, play/pause, cursors), ``controls.js`` (the elements) and ``main.js`` (the glue: ``render``).
Panel's ``JSComponent`` sends ``_esm`` to the page as the text of one ES module, which the page compiles from a
string: a relative ``import "./camera.js"`` inside it has nothing to resolve against (no URL the server serves, and
the studio runs offline), and ``_importmap`` only names URLs. So :func:`viewer_source` joins the files here, read from
the package, in a fixed order (``MODULES``), each a script fragment that declares one namespace object (``const
Camera = (() => {...; return {fit, zoom, ...}})()``) used by the files after it; only ``main.js`` exports. The skeleton
(parents, pelvis, head, sizes), the floor and the field of view come in the scene payload
(``app.viewer.scene.skeleton_payload``): none is written in the JavaScript.
"""
from __future__ import annotations

from pathlib import Path

import panel as pn
import param

JS_FOLDER = Path(__file__).with_name("viewer3d")
# each file uses only the namespaces of the files before it; main.js (render) comes last
MODULES: tuple[str, ...] = ("decode", "camera", "draw", "legend", "player", "controls", "main")


def viewer_source(folder: Path = JS_FOLDER) -> str:
    """The viewer's ES module: the ``MODULES`` files of ``folder`` joined in order, each under a comment naming it."""
    parts = [f"// ---- viewer3d/{name}.js\n{(folder / f'{name}.js').read_text(encoding='utf-8')}" for name in MODULES]
    return "\n".join(parts)


class SkeletonView(pn.custom.JSComponent):
    scene = param.Dict(default={}, doc="what is drawn (app.viewer.scene.scene_message)")
    frame = param.Integer(default=0, bounds=(0, None))
    playing = param.Boolean(default=False)
    loop = param.Boolean(default=True)
    follow = param.Boolean(default=True, doc="the camera follows the pelvis")
    show_path = param.Boolean(default=True, doc="draw root paths and guides")
    cursor_ids = param.List(default=[], item_type=str, doc="Bokeh Span ids the page moves with the playhead")

    _esm = viewer_source()  # a string, not a path: see the module's docstring

    _stylesheets = ["""
.moattn-viewer3d { display: flex; flex-direction: column; gap: 4px; width: 100%; }
.moattn-viewer3d-canvas { border: 1px solid #d0d7e2; border-radius: 4px; background: #eef2f7; outline: none;
  will-change: transform; contain: strict; }
.moattn-player-bar, .moattn-step-bar { display: flex; align-items: center; gap: 8px; contain: layout paint; }
.moattn-play { min-width: 84px; padding: 4px 8px; cursor: pointer; }
.moattn-scrub, .moattn-step-scrub { flex: 1; }
.moattn-frame-label { font: 12px monospace; color: #445; min-width: 70px; }
.moattn-step-name, .moattn-step-label { font: 12px sans-serif; color: #445; }
.moattn-save-png, .moattn-reset-view { padding: 4px 8px; cursor: pointer; }
.moattn-viewer-hint { font: 11px sans-serif; color: #778; }
"""]

    def __init__(self, **params):
        super().__init__(**params)
        self.closed = False  # the session is gone: nothing more is sent

    def preview(self, message: dict) -> None:
        """Show a live x̂0 motion (``app.viewer.scene.preview_message``)."""
        if not self.closed:
            self._send_msg(message)

    def end_preview(self) -> None:
        """Drop a live preview (the job was cancelled or failed): the last result shows again."""
        if not self.closed:
            self._send_msg({"type": "preview_end"})
