"""The Transfer tab's analysis views (MoMo): Q and K cluster strips, the correspondence film strip, the mixed and
self-attention maps and the per-query rows of a picked leader frame.

Each figure is built once per session and refilled in place when a transfer finishes. Clicking any of them
picks a frame: the viewer (leader / follower / out in sync) jumps there, and the per-query rows follow it.
"""
from __future__ import annotations

import html

import numpy as np
import panel as pn
import param
from bokeh.events import Tap
from bokeh.models import ColumnDataSource, FactorRange, FixedTicker, HoverTool, LinearColorMapper, Range1d, Span
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

from app.components.how_to_read import reading_caption
from app.session.state import StudioState
from app.tabs.transfer.colors import ROLES, cluster_colors, cluster_palette, focused, index_colors, n_clusters
from app.tabs.transfer.settings import TransferSettings
from viz.geometry import BONE_CHILDREN, BONE_PARENTS

WIDTH = 580
ROW_NAMES = {"follower": 2, "leader": 1, "replaced": 0}  # film strip rows, top to bottom
POSES = 12  # poses drawn per film strip row
MAP_TICKS = 3  # ticks per axis of the small attention maps
QUERY_HINT = ("**Per-query maps**: pick a frame (click any plot above, or scrub the viewer) to see where that "
              "leader frame attends: over the leader's own frames and over the follower's.")


def pose_strokes(joints: np.ndarray, frames: np.ndarray, *, centers: np.ndarray, base: float, sx: float,
                 sy: float) -> tuple[list, list]:
    """Bones of the poses at ``frames`` as 2-D polylines (a 3/4 view, pelvis at ``centers``, feet at ``base``)."""
    xs, ys = [], []
    for f, c in zip(frames, centers):
        pose = joints[int(f)]
        h = (pose[:, 0] - pose[0, 0]) * 0.8 + (pose[:, 2] - pose[0, 2]) * 0.6
        v = pose[:, 1] - min(pose[:, 1].min(), 0.0)
        for p, ch in zip(BONE_PARENTS, BONE_CHILDREN):
            xs.append([c + h[p] * sx, c + h[ch] * sx])
            ys.append([base + v[p] * sy, base + v[ch] * sy])
    return xs, ys


def _no_selection_look(renderer) -> None:
    """A click picks a frame (Tap events), not glyphs: keep every cell in its colour, none faded or highlighted."""
    renderer.selection_glyph = None
    renderer.nonselection_glyph = None


class TransferPlots(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=TransferSettings, doc="the session's Transfer settings (the result shown)")

    def __init__(self, **params):
        super().__init__(**params)
        self._offset = 0.0  # x of the K panel in the strips figure
        self.legend = pn.pane.HTML("", css_classes=["cluster-legend"], margin=(0, 10))
        self.sites = pn.pane.Markdown("", css_classes=["transfer-sites"], margin=(0, 10),
                                      styles={"font-size": "12px", "color": "#555"})
        self._build_strips()
        self._build_film()
        self._build_maps()
        self._build_query()
        for fig in (self.strips, self.film, self.query, *self.maps.values()):
            fig.on_event(Tap, lambda event, fig=fig: self._on_tap(fig, event))
        self.settings.param.watch(self._on_result, ["result", "analysed"])
        self.state.param.watch(self._on_frame, ["frame", "playing"])
        self._on_result()

    # ------------------------------------------------------------------ figures
    def _build_strips(self) -> None:
        self.strip_src = ColumnDataSource(dict(x=[], y=[], w=[], color=[], frame=[], cluster=[], panel=[]))
        fig = figure(height=165, width=WIDTH, y_range=FactorRange(*reversed(ROLES)), x_range=Range1d(0, 1),
                     tools="tap,hover", toolbar_location=None, title="Q clusters (left) · K clusters (right)",
                     css_classes=["cluster-strips"])
        cells = fig.rect("x", "y", width="w", height=0.8, source=self.strip_src, fill_color="color", line_color=None)
        _no_selection_look(cells)
        fig.select_one(HoverTool).tooltips = [("", "@panel of @y"), ("frame", "@frame"), ("cluster", "@cluster")]
        fig.xaxis.visible = False
        self.strip_cursors = [Span(location=0, dimension="height", line_color="black", line_width=1.5,
                                   level="overlay") for _ in range(2)]
        for span in self.strip_cursors:
            fig.add_layout(span)
        self.strips = fig

    def _build_film(self) -> None:
        self.cells_src = ColumnDataSource(dict(x=[], y=[], color=[], frame=[], row=[]))
        self.bones_src = ColumnDataSource(dict(xs=[], ys=[], color=[]))
        fig = figure(height=300, width=WIDTH, x_range=Range1d(0, 1), y_range=Range1d(-0.05, 3.0), tools="tap",
                     toolbar_location=None, x_axis_label="frame", css_classes=["correspondence"],
                     title="Nearest follower frame of each leader frame")
        for glyph in (fig.rect("x", "y", width=1.0, height=0.12, source=self.cells_src, fill_color="color",
                               line_color=None),
                      fig.multi_line("xs", "ys", source=self.bones_src, line_color="color", line_width=2.2)):
            _no_selection_look(glyph)
        fig.yaxis.ticker = FixedTicker(ticks=[2.5, 1.5, 0.5])
        fig.yaxis.major_label_overrides = {2.5: "follower", 1.5: "leader", 0.5: "leader replaced\nby neighbours"}
        fig.ygrid.visible = False
        self.film_cursor = Span(location=0, dimension="height", line_color="black", line_width=1.5,
                                line_dash="dashed", level="overlay")
        fig.add_layout(self.film_cursor)
        self.film = fig

    def _build_maps(self) -> None:
        self.map_srcs, self.maps, self.map_rows = {}, {}, {}
        titles = {"mixed": "Mixed: Q ldr · K flw", "leader": "Leader self-attention",
                  "follower": "Follower self-attention"}
        for name, title in titles.items():
            src = ColumnDataSource(dict(image=[np.zeros((1, 1), np.float32)], dw=[1], dh=[1]))
            mapper = LinearColorMapper(palette=Viridis256, low=0.0, high=1.0)
            fig = figure(height=210, width=WIDTH // 3, x_range=Range1d(0, 1), y_range=Range1d(1, 0), tools="tap",
                         toolbar_location=None, title=title, x_axis_label="key frame",
                         y_axis_label="query frame" if name == "mixed" else None, css_classes=[f"map-{name}"])
            fig.image(image="image", x=0, y=0, dw="dw", dh="dh", source=src, color_mapper=mapper)
            fig.title.text_font_size = "11px"
            # a third of the width: three ticks an axis, so their labels never run together ("80100120140")
            for axis in (fig.xaxis, fig.yaxis):
                axis.ticker.desired_num_ticks = MAP_TICKS
                axis.major_label_text_font_size = "9px"
            self.map_rows[name] = Span(location=0, dimension="width", line_color="#ff2d2d", line_width=1.5)
            fig.add_layout(self.map_rows[name])
            self.map_srcs[name], self.maps[name] = (src, mapper), fig

    def _build_query(self) -> None:
        self.query_src = {k: ColumnDataSource(dict(x=[], y=[])) for k in ("leader", "mixed")}
        fig = figure(height=230, width=WIDTH, x_range=Range1d(0, 1), tools="tap", toolbar_location=None,
                     x_axis_label="key frame", title="Per-query maps", css_classes=["per-query"])
        fig.line("x", "y", source=self.query_src["leader"], line_width=2, color="#3a6fd8",
                 legend_label="Q leader · K leader (over leader frames)")
        fig.line("x", "y", source=self.query_src["mixed"], line_width=2, color="#e8772e",
                 legend_label="Q leader · K follower (over follower frames)")
        fig.legend.label_text_font_size = "10px"
        fig.legend.orientation = "horizontal"
        fig.add_layout(fig.legend[0], "above")
        self.query_cursor = Span(location=0, dimension="height", line_color="black", line_width=1.5,
                                 line_dash="dashed", level="overlay")
        fig.add_layout(self.query_cursor)
        self.query = fig
        # until a frame is picked the plot has nothing to show: a hint stands in for it (not an empty box)
        self.query_hint = pn.pane.Markdown(QUERY_HINT, css_classes=["per-query-hint"], margin=(0, 10),
                                           styles={"font-size": "12px", "color": "#555"})
        self.query_box = pn.Column(pn.pane.Bokeh(self.query, margin=(0, 10)),
                                   reading_caption("per_query", width=WIDTH), visible=False, margin=0)

    # ------------------------------------------------------------------ state -> views
    def _on_result(self, *_):
        view = focused(self.settings)
        self._show_query(False)  # the rows of another transfer's frame are gone; a picked frame brings them back
        for src in self.query_src.values():
            src.data = dict(x=[], y=[])
        if view is None:
            self.sites.object = "Run a transfer to see the clusters, correspondences and maps."
            return
        a, frames = view.analysis, view.frames
        longest = max(frames.values())
        with pn.io.hold():
            self._fill_strips(view, longest)
            self._fill_film(view, longest)
            for name, (src, mapper) in self.map_srcs.items():
                m = np.asarray(a.maps[name], dtype=np.float32)
                src.data = dict(image=[m], dw=[m.shape[1]], dh=[m.shape[0]])
                mapper.update(low=float(m.min()), high=float(np.quantile(m, 0.995)) or 1.0)
                fig = self.maps[name]
                fig.x_range.start, fig.x_range.end = 0, m.shape[1]
                fig.y_range.start, fig.y_range.end = m.shape[0], 0
            self.query.x_range.start, self.query.x_range.end = 0, max(frames["leader"], frames["follower"]) - 1
        s = lambda site: f"layer {site.layer}, step {site.step + 1}"  # noqa: E731
        self.sites.object = (f"Clusters: Q and K at {s(a.cluster_site)} (PCA + K-Means, fitted once per server) · "
                             f"neighbours: {s(a.correspondence_site)} · maps: {s(a.maps_site)}")
        self._on_frame()

    def _fill_strips(self, view, longest: int) -> None:
        a = view.analysis
        n = n_clusters(view)
        gap = max(3.0, 0.06 * longest)
        self._offset = longest + gap
        data = dict(x=[], y=[], w=[], color=[], frame=[], cluster=[], panel=[])
        for panel, labels, x0 in (("Q", a.q_labels, 0.0), ("K", a.k_labels, self._offset)):
            for role in ROLES:
                lab = np.asarray(labels[role])
                data["x"] += list(x0 + np.arange(len(lab)) + 0.5)
                data["y"] += [role] * len(lab)
                data["w"] += [1.0] * len(lab)
                data["color"] += cluster_colors(lab, n)
                data["frame"] += list(range(len(lab)))
                data["cluster"] += [int(k) for k in lab]
                data["panel"] += [panel] * len(lab)
        self.strip_src.data = data
        self.strips.x_range.start, self.strips.x_range.end = 0, self._offset + longest
        used = sorted({int(k) for labels in (a.q_labels, a.k_labels) for v in labels.values() for k in v})
        palette = cluster_palette(n)
        swatches = " ".join(f'<span class="swatch" style="background:{palette[k % len(palette)]}"></span>{k}'
                            for k in used)
        self.legend.object = (f'<div class="legend" style="font-size:12px">Clusters: {swatches}</div>'
                              '<style>.swatch{display:inline-block;width:12px;height:12px;margin:0 3px 0 8px;'
                              'vertical-align:middle;border-radius:2px}</style>')

    def _fill_film(self, view, longest: int) -> None:
        a, joints = view.analysis, view.joints
        n, m = len(a.nearest), view.frames["follower"]
        follower_colors = index_colors(m)
        nearest = np.clip(np.asarray(a.nearest), 0, m - 1)
        leader_colors = [follower_colors[k] for k in nearest]
        rows = {"follower": (np.arange(m), follower_colors), "leader": (np.arange(n), leader_colors),
                "replaced": (np.arange(n), leader_colors)}
        cells = dict(x=[], y=[], color=[], frame=[], row=[])
        bones = dict(xs=[], ys=[], color=[])
        px_frame, px_row = WIDTH / longest, 300 / 3.1
        metre = 0.62 * px_row / 1.9  # px per metre: a 1.9 m pose fills 62 % of a row
        sx, sy = metre / px_frame, metre / px_row
        for row, (frames, colors) in rows.items():
            y = ROW_NAMES[row]
            cells["x"] += list(frames + 0.5)
            cells["y"] += [y + 0.08] * len(frames)
            cells["color"] += colors
            cells["frame"] += list(frames)
            cells["row"] += [row] * len(frames)
            picks = np.unique(np.linspace(0, len(frames) - 1, min(POSES, len(frames))).round().astype(int))
            motion, shown = (joints["follower"], nearest[picks]) if row == "replaced" else (joints[row], picks)
            xs, ys = pose_strokes(motion, shown, centers=picks + 0.5, base=y + 0.2, sx=sx, sy=sy)
            bones["xs"] += xs
            bones["ys"] += ys
            bones["color"] += [colors[p] for p in picks for _ in BONE_CHILDREN]
        self.cells_src.data = cells
        self.bones_src.data = bones
        self.film.x_range.start, self.film.x_range.end = -0.02 * longest, longest * 1.02

    def _on_frame(self, *_):
        view = focused(self.settings)
        if view is None or self.state.current not in view.names.values():
            return  # the cursors follow the transfer's own motions (moving them repaints the plots)
        frame = self.state.frame
        self.strip_cursors[0].location = frame + 0.5
        self.strip_cursors[1].location = self._offset + frame + 0.5
        self.film_cursor.location = frame + 0.5
        self.query_cursor.location = frame
        if self.state.playing:
            return
        query = int(min(frame, view.frames["leader"] - 1))
        rows = view.analysis.per_query(query)
        for name, row in rows.items():
            self.query_src[name].data = dict(x=np.arange(len(row)), y=np.asarray(row, dtype=float))
        self.map_rows["mixed"].location = self.map_rows["leader"].location = query + 0.5
        self.map_rows["follower"].location = min(frame, view.frames["follower"] - 1) + 0.5
        self.query.title.text = f"Per-query maps: leader frame {query} as the query"
        self._show_query(True)

    def _show_query(self, shown: bool) -> None:
        """The per-query plot once it has a frame's rows, the hint until then."""
        if self.query_box.visible != shown:
            self.query_box.visible = shown
        if self.query_hint.visible == shown:
            self.query_hint.visible = not shown

    # ------------------------------------------------------------------ views -> state
    def _on_tap(self, fig, event) -> None:
        if event.x is None:
            return
        if fig in self.maps.values():
            if event.y is not None:
                self.state.pick_frame(int(np.floor(event.y)))
            return
        x = float(event.x)
        if fig is self.strips and x >= self._offset:
            x -= self._offset
        self.state.pick_frame(int(np.floor(max(x, 0.0))) if fig is not self.query else int(round(x)))

    def pick(self, view: str, x: float, y: float = 0.5) -> None:
        """What a click at (x, y) on a view does: "strips", "film", "query" or a map name (used by tests)."""
        fig = {"strips": self.strips, "film": self.film, "query": self.query, **self.maps}[view]
        self._on_tap(fig, Tap(fig, x=x, y=y))

    def __panel__(self):
        return pn.Column(
            "#### Q vs K clusters", self.legend, pn.pane.Bokeh(self.strips, margin=(0, 10)),
            reading_caption("qk_clusters", width=WIDTH),
            "#### Correspondences", pn.pane.Bokeh(self.film, margin=(0, 10)),
            reading_caption("correspondences", width=WIDTH),
            "#### Attention maps", pn.Row(*(pn.pane.Bokeh(f, margin=(0, 2)) for f in self.maps.values())),
            reading_caption("qk_maps", width=WIDTH), self.query_hint, self.query_box, self.sites,
            css_classes=["transfer-plots"], sizing_mode="stretch_width")

