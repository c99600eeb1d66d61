"""One browser session's state, ``StudioState``: put together from the session core's parts, each in its own module,

- ``GenerateBox`` (app.session.generation): the sampling settings every tab uses, the prompt as the engine reads
  it, Generate and Re-record;
- ``MotionList`` (app.session.motion_list): the motions and the motion library behind them;
- ``ViewerRule`` (app.session.viewer_rule): what the viewer shows (current / compare / also), the playhead and the
  attention selection;
- ``JobRunner`` (app.session.jobs): the one job runner (``launch``) every method runs through;

and what holds them together here: the session's thread (``post``), its model, its notices, the counting method and
each tab's settings (``tab_settings``, made by the factories the page hands over: the core never imports a tab).

Every session gets its own ``StudioState``; only the loaded model (read-only) is shared between sessions. Work that
takes time (sampling) runs on a worker thread and *posts* its results back with :meth:`StudioState.post`, which
runs them on the session's document thread when served (or directly in tests), so parameters are only ever changed
from one thread at a time.
"""
from __future__ import annotations

import threading
import traceback
from collections.abc import Callable, Mapping
from pathlib import Path

import param

from app.session.counting import auto_count
from app.session.generation import GenerateBox
from app.session.jobs import JobRunner
from app.session.motion_list import MotionList
from app.session.viewer_rule import ViewerRule
from engine.analysis.counting import COUNTING_LABELS, COUNTING_METHODS, CountingConfig

#: a tab's settings made for one session (``StudioState(tabs={"compose": ComposeSettings.for_session, ...})``)
SettingsFactory = Callable[["StudioState"], param.Parameterized]


class StudioState(GenerateBox, MotionList, ViewerRule, JobRunner):
    """Everything a session's views read; each browser session gets its own instance."""

    notice = param.Tuple(default=(0, "", ""), length=3, doc="(serial, level, text) of the last notification")
    count_result = param.Parameter(default=None, doc="CountReadout of the shown motion (or None): counted from its "
                                                     "recorded maps as it is shown, or by the Edit tab's Count")
    count_method = param.Selector(default=CountingConfig.method,
                                  objects={COUNTING_LABELS[m]: m for m in COUNTING_METHODS}, label="Counting method",
                                  doc="how a self-attention map becomes a count (engine.analysis.counting)")

    def __init__(self, *, model_dir: str | Path | None = None, tabs: Mapping[str, SettingsFactory] | None = None,
                 library=None, **params):
        """``tabs``: name -> a factory of that tab's settings for this session; they are made now, into
        ``tab_settings`` (the session holds every tab's settings, its view built or not), and handed to each tab's
        view and jobs by the page.

        ``library``: the motion library (an ``engine.library.MotionLibrary``; None: motions live only as long as
        the session): every motion added is kept there, and the session starts with all of its motions."""
        super().__init__(**params)
        self.model_dir = Path(model_dir) if model_dir is not None else None
        self.library = library
        self._doc = None
        self._loop = None  # the server's event loop, the one thread that touches the document (attach_document)
        self._loop_thread: int | None = None
        self._counter = 0
        self.notices: list[tuple[str, str]] = []  # history (level, text), newest last
        self._closed = False
        self._page_seen = False  # a page has been connected to this session (see _page_gone)
        self.param.watch(self._analyse_prompt, "prompt")
        # counted after the new motion has reached the page (served: the next tick), not before its scene
        self.param.watch(lambda *_: self.post(lambda: auto_count(self)), "current")
        self.param.watch(lambda *_: self.post(lambda: auto_count(self)), "count_method")
        self.param.watch(self._check_compared, ["compare", "also"])
        self._analyse_prompt()
        if self.library is not None:
            self.library.report = lambda line: self.post(lambda: self.warning(line))
            for problem in list(self.library.problems):  # found as it opened (an unusable index set aside)
                self.warning(str(problem))
            self.library.check()  # damaged or foreign entries: one line each, skipped
            self.sync_library()
        self.tab_settings: dict[str, param.Parameterized] = {name: make(self) for name, make in (tabs or {}).items()}

    # ------------------------------------------------------------------ threading
    def attach_document(self, doc) -> None:
        """Bind the session's Bokeh document: posted callbacks then run on its event loop (the loop running here,
        on the server's thread, where Panel builds a session's page)."""
        import asyncio

        self._doc = doc
        try:
            self._loop = asyncio.get_running_loop()  # the server's (tornado runs on asyncio)
            self._loop_thread = threading.get_ident()
        except RuntimeError:  # no loop running here: callbacks are added from whichever thread posts them
            self._loop, self._loop_thread = None, None

    @property
    def served(self) -> bool:
        """Whether this session has a live document (a browser page), so that work may leave its thread."""
        return self._doc is not None and self._doc.session_context is not None

    def post(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the session's document thread (served) or right away (no server); dropped once the
        session is closed (its document is gone: a late worker result must not touch it)."""
        if self._closed:
            return
        doc = self._doc
        if doc is None or doc.session_context is None:
            fn()
            return
        from panel.io.state import set_curdoc

        def run():
            if self._page_gone(doc):
                return  # its page was closed or reloaded: nobody to show it to (Bokeh would warn on every send)
            with set_curdoc(doc):
                try:
                    fn()
                except Exception as exc:  # never let a UI update kill the loop
                    traceback.print_exc()
                    self._notify("error", f"internal error: {exc}")

        def schedule():
            try:
                doc.add_next_tick_callback(run)
            except Exception:  # the session is gone
                pass

        if self._loop is None or threading.get_ident() == self._loop_thread:
            schedule()
        else:
            # From a worker thread the callback is added on the loop's own thread (call_soon_threadsafe is safe
            # from any thread). Bokeh's document is not: while the loop holds it (Panel holds it around every change
            # from the page), an added callback is one of its held events, and unhold() reads and clears that list
            # without a lock, so a callback added from another thread at that moment could be lost: the likely cause
            # of the refused import whose message, now and then, never came (a browser test's rare timeout).
            self._loop.call_soon_threadsafe(schedule)

    def _page_gone(self, doc) -> bool:
        """Whether the session's page has been connected and is no more (its session lingers until discarded).

        A page being built has no connection yet: what is posted then is part of what it will receive."""
        context = doc.session_context
        session = None if context is None else context.session
        if session is None:
            return False
        if session.connection_count > 0:
            self._page_seen = True
            return False
        return self._page_seen

    # ------------------------------------------------------------------ model
    @property
    def model(self):
        """The shared, read-only loaded model (raises if there is none)."""
        from app.model_cache import get_model

        if self.model_dir is None:
            raise FileNotFoundError("no model folder was given")
        return get_model(self.model_dir)

    @property
    def has_model(self) -> bool:
        try:
            self.model
            return True
        except Exception:
            return False

    @property
    def vocabulary(self) -> tuple[str, ...]:
        try:
            return self.model.tokenizer.words[1:]
        except Exception:
            return ()

    def tokenizer(self):
        try:
            return self.model.tokenizer
        except Exception:
            return None

    # ------------------------------------------------------------------ notifications
    def _notify(self, level: str, text: str) -> None:
        self._counter += 1
        self.notices.append((level, text))
        del self.notices[:-50]
        self.notice = (self._counter, level, text)

    def error(self, text: str) -> None:
        self._notify("error", text)

    def warning(self, text: str) -> None:
        self._notify("warning", text)

    def info(self, text: str) -> None:
        self._notify("info", text)

    def close(self) -> None:
        """The session ended: stop the worker."""
        self._closed = True
        if self.active_run is not None:
            self.active_run.cancel.set()
