"""Import a motion file (BVH, joints or 263-dim vectors .npy) and export motions and attention maps."""
from __future__ import annotations

import asyncio
import io
import threading

import panel as pn
import param

from app.components.number_box import FloatBox
from app.session.items import upload_limit_text
from app.session.state import StudioState
from app.tabs.files import exports
from app.tabs.files.exports import EXPORTS, export_filename
from app.uploads import display_name, import_window


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
        # number boxes that never show "NaN": an emptied Start is the beginning, an emptied Seconds the whole file
        self.start = FloatBox(label="Start (s)", value=0.0, start=0.0, step=0.5, width=100, empty=0.0,
                              placeholder="0 (the beginning)", css_classes=["import-start"])
        self.seconds = FloatBox(label="Seconds", value=None, start=2 / FPS, end=self.limit_s, step=0.5,
                                placeholder="to the end", width=100, css_classes=["import-seconds"])
        self.again = pn.widgets.Button(label="Import window", disabled=True, sizing_mode="stretch_width",
                                       css_classes=["import-again"])
        self._upload: tuple[bytes, str] | None = None
        # the file and its name: an empty file arrives as a name with no content (Panel reads its "" as None)
        self._input.param.watch(self._on_upload, ["value", "filename"])
        self.again.on_click(lambda *_: self.import_upload())

    def _max_frames(self) -> int:
        """The model's limit (its config's max_frames); the default model's when none is loaded."""
        if self.state.has_model:
            return int(self.state.model.model.config.max_frames)
        from engine.model import ModelConfig

        return ModelConfig().max_frames

    def _on_upload(self, *events):
        """A file was picked: import it, or say why not, by the user's file name. An empty file comes as its name
        and no content; it is refused by name, and "Import window" does not go back to an earlier upload."""
        changed = {e.name for e in events}
        data, filename = self._input.value, self._input.filename
        if filename is None and data is None:
            return  # the field was cleared
        if not data:
            name = display_name(filename)
            self._upload = None  # "Import window" must not go back to an earlier file
            # the field is cleared before anything is said: once the message shows, the page has the cleared field
            # (clearing replaces the file input; a file picked while that happened went to the old one, unheard)
            self._input.clear()
            self.again.disabled = True
            self.state.error(f"Could not import {name}: it is empty (0 bytes)")
            return
        if "value" not in changed:
            return  # a new name only: its content follows (or is the same bytes: nothing new to import)
        self._upload = (data, display_name(filename) if filename else "the upload")
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

        def work():
            parsed, error = parse()  # here, on the worker thread: only the result goes to the session's thread
            self.state.post(lambda: self._apply_import(name, start, parsed, error))

        threading.Thread(target=work, name="moattn-import", daemon=True).start()
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
            self._input.clear()  # the field does not go on naming a file that was refused ("Import window" retries);
            self.state.error(f"Could not import {name}: {error}")  # cleared first, as for an empty file
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
                data = await asyncio.to_thread(exports.export_bytes, item, fmt, selection=selection)
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
