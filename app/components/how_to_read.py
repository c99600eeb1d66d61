"""The one-line "how to read this" caption under a plot (its text declared in ``viz.reading``)."""
from __future__ import annotations

import html

import panel as pn

from viz.reading import how_to_read

CSS = """
.how-to-read { font-size: 11.5px; line-height: 1.35; color: #5a5f66; max-width: 100%; }
.how-to-read b { color: #3d4249; font-weight: 600; }
"""


def reading_caption(plot: str, *, width: int | None = None, margin=(0, 10, 6, 10)) -> pn.pane.HTML:
    """A small grey caption, "How to read: ...", for the plot named ``plot`` (as wide as the plot when given)."""
    text = f'<div class="how-to-read"><b>How to read:</b> {html.escape(how_to_read(plot))}</div>'
    return pn.pane.HTML(text, css_classes=["how-to-read", f"how-to-read-{plot.replace('_', '-')}"], margin=margin,
                        width=width, stylesheets=[CSS])
