"""The studio page: one StudioState per browser session, views reading it, a template with a sidebar."""
from __future__ import annotations

import logging
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import panel as pn

from app.components.checkbox_labels import labels_toggle_boxes
from app.components.lazy_tabs import LazyTabs
from app.hosts import allowed_hosts, host_guard
from app.session.items import MAX_UPLOAD_BYTES
from app.session.state import SettingsFactory, StudioState
from app.tabs.attention.view import AttentionExplorer
from app.tabs.compose.settings import ComposeSettings
from app.tabs.compose.view import ComposeTab
from app.tabs.control.canvas import allow_hold_then_draw
from app.tabs.control.settings import ControlSettings
from app.tabs.control.view import ControlTab
from app.tabs.duet.settings import DuetSettings
from app.tabs.duet.view import DuetTab
from app.tabs.edit.settings import EditSettings
from app.tabs.edit.view import EditTab
from app.tabs.files.view import ExportPanel, ImportPanel
from app.tabs.generate.view import GenerateControls
from app.tabs.transfer.settings import TransferSettings
from app.tabs.transfer.view import TransferTab
from app.theme import Fast as OfflineFast
from app.viewer.view import SkeletonViewer
from engine.paths import ASSETS, MODEL_DIR

EXAMPLE = ASSETS / "examples" / "walk.npy"
# the narrowest window with the viewer (at least 500 px) beside the tabs (600 px): the 340-px sidebar, both, gaps
SIDE_BY_SIDE_PX = 1460
log = logging.getLogger("moattn.app")


@dataclass(frozen=True)
class LibrarySettings:
    """Where a server's sessions keep their motions: each session opens the library in ``workspace`` (None: the
    default workspace, engine.library.workspace) bounded at ``limit_mb`` (None: as stored or the default)."""

    workspace: Path | None = None
    limit_mb: float | None = None

    def open(self):
        from engine.library import MotionLibrary

        return MotionLibrary(workspace=self.workspace, limit_mb=self.limit_mb)


#: the tabs on the right, in order: (title, the view's class, the name of its settings in the session's
#: ``tab_settings``, None: it has none); the first is built with the page, each other one the first time it is selected
TAB_VIEWS = (("Attention", AttentionExplorer, None), ("Edit", EditTab, "edit"), ("Transfer", TransferTab, "transfer"),
             ("Compose", ComposeTab, "compose"), ("Control", ControlTab, "control"), ("Duet", DuetTab, "duet"))


def tab_settings(*, controls_dir: Path | None = None, duet_dir: Path | None = None) -> dict[str, SettingsFactory]:
    """Each tab's settings, made by the session as it starts (``state.tab_settings["edit"]``, ...) and handed to the
    tab's view and jobs: they exist (and keep their rules, e.g. counting a shown motion) whether or not the tab's
    view was ever built."""
    return {"edit": EditSettings.for_session, "transfer": TransferSettings.for_session,
            "compose": ComposeSettings.for_session,
            "control": partial(ControlSettings.for_session, controls_dir=controls_dir),
            "duet": partial(DuetSettings.for_session, duet_dir=duet_dir)}


class Studio:
    """One session: its state and views (no Panel server needed to build or drive it). The tabs' views are built
    the first time they are shown (or read: ``studio.edit`` builds the Edit tab)."""

    def __init__(self, *, model_dir: Path | None = MODEL_DIR, initial: Path | None = None, doc=None,
                 controls_dir: Path | None = None, duet_dir: Path | None = None, library=None):
        """``library``: the motion library this session keeps its motions in and starts with (an
        ``engine.library.MotionLibrary``; None: the session's motions last as long as it does)."""
        self.state = StudioState(model_dir=model_dir, tabs=tab_settings(controls_dir=controls_dir, duet_dir=duet_dir),
                                 library=library)
        if doc is not None:
            self.state.attach_document(doc)
        self.controls = GenerateControls(state=self.state)
        self.viewer = SkeletonViewer(state=self.state)
        self.tabs = LazyTabs(tabs=[(title, partial(view, state=self.state, **self._settings(name)))
                                   for title, view, name in TAB_VIEWS],
                             width=600, css_classes=["right-tabs"])
        self.imports = ImportPanel(state=self.state)
        self.exports = ExportPanel(state=self.state)
        path = initial
        latest = self._latest_kept() if path is None or Path(path) == EXAMPLE else None
        if latest is not None:  # a returning user: the page opens on their newest motion, not on the example
            self.state.show(latest)
            prompt = self.state.items[latest].prompt
            if prompt:  # and its prompt in the Generate box, not the default one
                self.state.prompt = prompt
        elif path is not None:
            try:
                from engine.io import load_motion

                self.state.show_motion(load_motion(path), title=f"imported: {Path(path).name}")
            except Exception as exc:
                self.state.error(f"could not open {path}: {exc}")
        if not self.state.has_model:
            try:
                self.state.model
            except Exception as exc:
                self.state.error(f"no model loaded, generation is off: {exc}")

    def _latest_kept(self) -> str | None:
        """The newest motion the library keeps (the session's list is oldest first), or None (no library, or an
        empty one)."""
        kept = [name for name, item in self.state.items.items() if item.library_id]
        return kept[-1] if kept else None

    def _settings(self, name: str | None) -> dict:
        """A tab view's own settings, handed to it explicitly ({} for a tab without settings)."""
        return {} if name is None else {"settings": self.state.tab_settings[name]}

    @property
    def attention(self) -> AttentionExplorer:
        return self.tabs.view("Attention")

    @property
    def edit(self) -> EditTab:
        return self.tabs.view("Edit")

    @property
    def transfer(self) -> TransferTab:
        return self.tabs.view("Transfer")

    @property
    def compose(self) -> ComposeTab:
        return self.tabs.view("Compose")

    @property
    def control(self) -> ControlTab:
        return self.tabs.view("Control")

    @property
    def duet(self) -> DuetTab:
        return self.tabs.view("Duet")

    def close(self) -> None:
        self.state.close()
        self.viewer.close()

    def template(self) -> pn.template.BaseTemplate:
        # the viewer beside the tabs; in a window too narrow for both (under about 1460 px) the tabs wrap below it
        # instead of being cut off at the right edge. Side by side, the viewer stays in sight while a long tab
        # scrolls (sticky in the page's scroll box); stacked, it scrolls away with the page so it never covers a tab.
        main = pn.FlexBox(
            pn.Column("### Viewer", self.viewer, sizing_mode="stretch_width", min_width=500, max_width=760,
                      css_classes=["viewer-column"], styles={"flex": "1 1 500px", "align-self": "flex-start"},
                      stylesheets=[f"@media (min-width: {SIDE_BY_SIDE_PX}px) {{ :host {{ position: sticky; top: 0px; "
                                   "z-index: 2; }} }}"]),
            self.tabs,
            flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width",
        )
        return pn.template.FastListTemplate(
            title="Motion Attention Studio",
            sidebar=[self.controls, pn.layout.Divider(), self.imports, self.exports],
            main=[main], sidebar_width=340, theme_toggle=False, main_layout=None,
            font="system-ui, -apple-system, Segoe UI, Roboto, sans-serif", font_url="data:text/css,",  # no CDN
            design=OfflineFast,
            # no header spinner toggled around every server callback: each toggle is two more messages to the page
            # (a layer switch sent three instead of one); long work shows its own progress bar (JobBar)
            busy_indicator=None,
        )


def create_app(*, model_dir: Path | None = MODEL_DIR, initial: Path | None = None, controls_dir: Path | None = None,
               duet_dir: Path | None = None, library: LibrarySettings | None = None) -> pn.template.BaseTemplate:
    """A fresh page for one browser session (``library``: where its motions are kept; None: nowhere)."""
    doc = pn.state.curdoc
    studio = Studio(model_dir=model_dir, initial=initial, doc=doc, controls_dir=controls_dir, duet_dir=duet_dir,
                    library=None if library is None else library.open())
    notifications = pn.state.notifications

    def notify(event):
        _, level, text = event.new
        if not text:
            return
        log.info("notice [%s] %s", level, text)
        area = notifications or pn.state.notifications
        if area is None:
            return
        if level == "error":
            area.error(text, duration=10000)
        elif level == "warning":
            area.warning(text, duration=8000)
        else:
            area.info(text, duration=5000)

    studio.state.param.watch(notify, "notice")
    # notices raised while building the page (e.g. no model) are shown once the page is up
    for level, text in list(studio.state.notices):
        pn.state.onload(lambda level=level, text=text: studio.state._notify(level, text))
    if doc is not None:
        allow_hold_then_draw(doc)
        labels_toggle_boxes(doc)
        if doc.session_context is not None:
            doc.on_session_destroyed(lambda _ctx: studio.close())
    page = studio.template()
    page.moattn_studio = studio  # reachable for debugging
    return page

# one websocket message at most: an upload (base64, 4/3 of its bytes) and room for the page's own messages; a larger
# message closes the connection before the server buffers it (a 140-MB upload used to cost the server +936 MB)
MAX_MESSAGE_BYTES = MAX_UPLOAD_BYTES * 4 // 3 + 4 * 2**20


def serve(*, port: int = 5006, show: bool = False, address: str = "localhost", initial: Path | None = None,
          model_dir: Path | None = MODEL_DIR, controls_dir: Path | None = None, duet_dir: Path | None = None,
          token: str | None = None, library: LibrarySettings | None = LibrarySettings()) -> None:
    """Start the Panel server (blocks). The model is loaded once, before the first page.

    Each page opens ``initial`` (default: the shipped example walk) so a new user sees a motion.
    """
    if initial is None and EXAMPLE.exists():
        initial = EXAMPLE
    from app.model_cache import get_model

    pn.extension(notifications=True)
    # every component is built in the page's design: otherwise each pane starts in Panel's default design and
    # takes the template's on its first update, and that swap of stylesheets makes Bokeh re-index the whole
    # document (0.15-0.35 s per pane; the first generation's first frame waited for three of them)
    pn.config.design = OfflineFast
    pn.config.exception_handler = _exception_handler
    if model_dir is not None:
        try:
            preload(get_model(model_dir), controls_dir=controls_dir, duet_dir=duet_dir)
        except Exception as exc:
            print(f"warning: {exc} (the studio starts without generation)")
    origins = [f"{address}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"]
    auth = {}
    if token:  # Panel's basic auth: a login page asks for the token; the session cookie is signed per run
        import secrets

        auth = dict(basic_auth=token, cookie_secret=secrets.token_hex(32))
    if library is not None:  # opened once here: a bad workspace stops the server before any page
        opened = library.open()
        print(f"motion library: {opened.root} ({opened.count()} motions, {opened.total_bytes() / 2**20:.1f} of "
              f"{opened.limit_mb:g} MB)", flush=True)
        for problem in opened.problems:
            print(f"warning: {problem}", flush=True)
    pn.serve(lambda: create_app(model_dir=model_dir, initial=initial, controls_dir=controls_dir, duet_dir=duet_dir,
                                library=library),
             port=port, address=address, show=show,
             title="Motion Attention Studio", websocket_origin=origins, threaded=False,
             websocket_max_message_size=MAX_MESSAGE_BYTES, liveness=True,
             transforms=[host_guard(allowed_hosts(address, port))], **auth)


def preload(loaded, *, controls_dir: Path | None = None, duet_dir: Path | None = None) -> None:
    """Load the control models and the duet model on the base model, and import what a generation needs, before
    the first page (each is cached per server, so the first visitor's page builds as fast as the next ones). A
    missing or unusable folder is not an error here: its tab says why."""
    from app.tabs.control.models import control_models
    from app.tabs.duet.models import duet_model
    from engine.paths import CONTROL_DIR, DUET_DIR

    control_models(controls_dir or CONTROL_DIR, base=loaded)
    duet_model(duet_dir or DUET_DIR, loaded)
    # what the first generation needs besides the model: every generated motion is counted when it is shown, and
    # the counting's first import (scipy.signal) took 1.8 s of the first click -> first frame
    import engine.analysis.counting  # noqa: F401


def _exception_handler(exc: Exception) -> None:
    """Any uncaught error in a callback becomes a visible notification; the server keeps running."""
    log.exception("callback failed", exc_info=exc)
    if pn.state.notifications is not None:
        pn.state.notifications.error(f"Something went wrong: {exc}", duration=10000)
