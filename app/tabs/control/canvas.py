"""The Control tab's drawing canvases (Bokeh): a path is drawn freehand (drag) or edited point by point
(add, drag, delete with the point tool), on a metric grid.

- ``TopDownCanvas``: the floor seen from above (x, z in metres; forward +z is up, so the person's left, +x, is to
  the left of the screen); the root path, its start in green.
- ``FrontCanvas``: the person seen from the front (x: the person's left to the right of the screen, y height);
  the rest pose for scale; both wrists' paths (one layer each) on the plane ``wrist_depth`` in front of the body.

Both write to ``ControlSettings`` (a stroke is thinned to points) and redraw when it changes.

``allow_hold_then_draw(doc)``: BokehJS takes a mouse button held still for 300 ms for a "press" and then ignores
the drag that follows, so a stroke begun after a pause was silently lost; the page's press threshold is raised
(the studio uses no press gestures).
"""
from __future__ import annotations

import numpy as np
import panel as pn
from bokeh.models import ColumnDataSource, CustomJS, FreehandDrawTool, PointDrawTool, Range1d, SingleIntervalTicker
from bokeh.plotting import figure

from app.components.bokeh_writes import sends_bokeh
from app.components.guard import SyncGuard
from app.tabs.control.paths import COLORS, DEFAULT_ROOT, LABELS, WRISTS, example_wrist
from app.tabs.control.settings import ControlSettings


PRESS_THRESHOLD_MS = 60_000  # a finite delay: setTimeout fires at once for one over 2**31 - 1 ms

_HOLD_THEN_DRAW_JS = f"""
try {{
  Bokeh.require("core/ui_gestures").UIGestures.press_threshold = {PRESS_THRESHOLD_MS};
}} catch (e) {{
  console.warn("moattn: cannot raise BokehJS's press threshold; a stroke begun after a pause may be lost", e);
}}
"""


def allow_hold_then_draw(doc) -> None:
    """Once the page is up, a drag begun after holding the button still draws its stroke (see the module doc)."""
    doc.js_on_event("document_ready", CustomJS(code=_HOLD_THEN_DRAW_JS))


class PathLayer:
    """One of the settings' paths on a figure: a freehand stroke layer and an editable point layer, each with its tool."""

    def __init__(self, *, settings: ControlSettings, fig, kind: str):
        self.settings = settings
        self.kind = kind  # which path of the settings: "root" (x, z), "left_wrist" or "right_wrist" (x, y)
        color, label = COLORS[kind], LABELS[kind]
        self._syncing = SyncGuard()
        self.stroke_src = ColumnDataSource(dict(xs=[], ys=[]))
        self.points_src = ColumnDataSource(dict(x=[], y=[]))
        self.start_src = ColumnDataSource(dict(x=[], y=[]))
        stroke = fig.multi_line("xs", "ys", source=self.stroke_src, line_color=color, line_width=2, alpha=0.6)
        fig.line("x", "y", source=self.points_src, line_color=color, line_width=3)
        points = fig.scatter("x", "y", source=self.points_src, size=7, fill_color="white", line_color=color,
                             line_width=2)
        fig.scatter("x", "y", source=self.start_src, size=13, marker="circle", fill_color="#2ca02c",
                    line_color=color, line_width=2)
        self.freehand = FreehandDrawTool(renderers=[stroke], num_objects=1, description=f"draw the {label} (drag)")
        self.point = PointDrawTool(renderers=[points], add=True,
                                   description=f"{label}: add / drag / delete (backspace) points")
        fig.add_tools(self.freehand, self.point)
        self.stroke_src.on_change("data", self._on_stroke)
        self.points_src.on_change("data", self._on_points)
        settings.param.watch(self._redraw, f"{kind}_points")
        self._redraw()

    @property
    def points(self) -> list:
        return getattr(self.settings, f"{self.kind}_points")

    # ------------------------------------------------------------------ browser -> settings
    def _on_stroke(self, _attr, _old, new) -> None:
        if self._syncing or not new.get("xs"):
            return
        xs, ys = np.asarray(new["xs"][-1], dtype=np.float64), np.asarray(new["ys"][-1], dtype=np.float64)
        if len(xs) >= 2:
            self.settings.set_stroke(self.kind, xs.tolist(), ys.tolist())
        self._sync(lambda: setattr(self.stroke_src, "data", dict(xs=[], ys=[])))  # the points now show the path

    def _on_points(self, _attr, _old, new) -> None:
        if self._syncing:
            return
        pts = [(float(x), float(y)) for x, y in zip(new.get("x", []), new.get("y", []))]
        setattr(self.settings, f"{self.kind}_points", pts)

    # ------------------------------------------------------------------ settings -> browser
    @sends_bokeh
    def _sync(self, fn) -> None:
        self._syncing.run(fn)

    def _redraw(self, *_):
        pts = self.points
        x = [float(p[0]) for p in pts]
        y = [float(p[1]) for p in pts]

        def apply():
            self.points_src.data = dict(x=x, y=y)
            self.start_src.data = dict(x=x[:1], y=y[:1])
        self._sync(apply)


class PathCanvas:
    """A figure holding one :class:`PathLayer` per path it draws; the active layer's freehand tool takes the drags."""

    kinds: tuple[str, ...] = ("root",)
    css = "root"  # the view's CSS class: control-<css>-canvas

    def __init__(self, *, settings: ControlSettings, fig):
        self.settings = settings
        self.fig = fig
        self.layers = {kind: PathLayer(settings=settings, fig=fig, kind=kind) for kind in self.kinds}
        fig.toolbar.active_tap = None
        self.activate(self.kinds[0])
        self.view = pn.pane.Bokeh(fig, margin=(0, 10), css_classes=[f"control-{self.css}-canvas"])

    def activate(self, kind: str) -> None:
        """Drags draw ``kind``'s path."""
        self.fig.toolbar.active_drag = self.layers[kind].freehand

    # the first layer's sources (the root canvas has one layer)
    @property
    def stroke_src(self):
        return self.layers[self.kinds[0]].stroke_src

    @property
    def points_src(self):
        return self.layers[self.kinds[0]].points_src

    @property
    def start_src(self):
        return self.layers[self.kinds[0]].start_src


def _grid(fig) -> None:
    for axis in (fig.xaxis, fig.yaxis):
        axis.ticker = SingleIntervalTicker(interval=1.0, num_minor_ticks=2)
    for grid in (fig.xgrid, fig.ygrid):
        grid.ticker = SingleIntervalTicker(interval=0.5)
        grid.grid_line_color = "#c9d1dc"
    fig.title.text_font_size = "11px"


class TopDownCanvas(PathCanvas):
    kinds = ("root",)

    def __init__(self, *, settings: ControlSettings):
        fig = figure(width=400, height=400, x_range=Range1d(3.5, -3.5), y_range=Range1d(-1.5, 5.5),
                     tools="reset", toolbar_location="right", match_aspect=True,
                     title="Floor from above (m): forward +z up, +x to the left",
                     x_axis_label="x (m)", y_axis_label="z (m)", css_classes=["control-topdown"])
        fig.background_fill_color = "#f4f6f9"
        fig.scatter([0], [0], marker="cross", size=12, line_color="#667", line_width=2)  # the origin
        _grid(fig)
        super().__init__(settings=settings, fig=fig)

    def example(self) -> None:
        self.settings.root_points = list(DEFAULT_ROOT)


class FrontCanvas(PathCanvas):
    """Both wrists' paths on one front view (purple: left, pink: right); ``settings.drawing`` picks which one the
    drags draw (the toolbar's tools name their wrist too)."""

    kinds, css = WRISTS, "wrist"

    def __init__(self, *, settings: ControlSettings):
        from engine.skeleton import PARENTS, Skeleton

        fig = figure(width=400, height=360, x_range=Range1d(-1.2, 1.2), y_range=Range1d(0.0, 2.2),
                     tools="reset", toolbar_location="right", match_aspect=True,
                     title="Front view (m), +x = the person's left; purple: left wrist, pink: right",
                     x_axis_label="x (m)", y_axis_label="height (m)", css_classes=["control-front"])
        fig.background_fill_color = "#f7f4fa"
        rest = Skeleton().rest_pose()
        rest = rest - np.array([0.0, rest[:, 1].min(), 0.0])
        bones = [(j, p) for j, p in enumerate(PARENTS) if p >= 0]
        fig.multi_line([[rest[p, 0], rest[j, 0]] for j, p in bones], [[rest[p, 1], rest[j, 1]] for j, p in bones],
                       line_color="#9aa3b0", line_width=4, alpha=0.7)
        _grid(fig)
        super().__init__(settings=settings, fig=fig)
        self.activate(settings.drawing)
        settings.param.watch(lambda e: self.activate(e.new), "drawing")

    def example(self) -> None:
        """Both wrists write their example letter (engine.methods.drawn_paths), and both are turned on."""
        self.settings.param.update(**{f"{w}_points": example_wrist(w) for w in WRISTS},
                                   **{f"use_{w}": True for w in WRISTS})
