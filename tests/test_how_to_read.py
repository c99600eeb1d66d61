"""Each attention plot of the studio carries its one-line "how to read this" (issue #35): the texts are declared
once (``viz.reading.HOW_TO_READ``) and every one of them is shown under its plot in a tab, as a caption a page can
find by its class."""
from __future__ import annotations

import html as _html

import panel as pn
import pytest

from app.main import Studio
from viz.reading import HOW_TO_READ


@pytest.fixture(scope="module")
def studio(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    yield st
    st.close()


def _captions(root) -> dict[str, str]:
    """class -> text of every caption pane under a Panel layout (hidden ones included)."""
    found = {}
    for pane in root.select(pn.pane.HTML):
        for cls in pane.css_classes or ():
            if cls.startswith("how-to-read-"):
                found[cls.removeprefix("how-to-read-").replace("-", "_")] = pane.object
    return found


def test_every_reading_is_one_short_line():
    assert set(HOW_TO_READ) >= {"word_curves", "self_attention", "qk_clusters", "correspondences", "qk_maps",
                                "per_query", "counting"}
    for key, text in HOW_TO_READ.items():
        assert "\n" not in text and 40 <= len(text) <= 200, (key, len(text))


def test_every_attention_plot_shows_its_reading(studio):
    shown = {}
    for tab in (studio.attention, studio.edit, studio.transfer):
        shown.update(_captions(tab.__panel__()))
    assert set(shown) == set(HOW_TO_READ), set(HOW_TO_READ) ^ set(shown)
    for key, html in shown.items():
        assert "How to read:" in html and _html.escape(HOW_TO_READ[key]) in html, key
