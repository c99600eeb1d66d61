"""The studio page: one StudioState per browser session, views reading it."""
from __future__ import annotations

from pathlib import Path

import panel as pn

from app.state import StudioState
from app.views.files import ImportPanel
from app.views.viewer import SkeletonViewer
from engine.paths import ASSETS

EXAMPLE = ASSETS / "examples" / "walk.npy"


def create_app(*, initial: Path | None = None) -> pn.template.BaseTemplate:
    """A fresh page for one session."""
    state = StudioState()
    path = initial or EXAMPLE
    if path.exists():
        from engine.io import load_motion

        state.show_motion(load_motion(path), title=path.name)
    viewer = SkeletonViewer(state=state)
    imports = ImportPanel(state=state)
    status = pn.pane.Markdown(state.param.message, css_classes=["status"])

    def notify(event):
        if event.new and pn.state.notifications is not None:
            pn.state.notifications.error(event.new, duration=8000)

    state.param.watch(notify, "error")
    template = pn.template.FastListTemplate(
        title="Motion Attention Studio", sidebar=[imports], main=[pn.Column(status, viewer)],
        theme_toggle=False,
    )
    return template


def serve(*, port: int = 5006, show: bool = False, address: str = "localhost", initial: Path | None = None) -> None:
    pn.extension(notifications=True)
    pn.serve(lambda: create_app(initial=initial), port=port, address=address, show=show, title="Motion Attention Studio",
             websocket_origin=[f"{address}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"],
             threaded=True)
