"""A checkbox's label toggles its box, as on any web page.

Bokeh 3.9 draws a ``Checkbox`` as an ``<input type=checkbox>`` followed by a ``<div class="bk-label">`` in the
widget's shadow root, not inside a ``<label>``: clicking the words did nothing (only the small box worked). One
listener per page forwards a click on such a label to its box (every checkbox of every tab, built now or later).
"""
from __future__ import annotations

from bokeh.models import CustomJS

LABEL_CLICKS_JS = """
if (!window.moattnLabelClicks) {
  window.moattnLabelClicks = {forwarded: 0};
  const boxOf = (el) => {
    if (!(el instanceof Element) || !el.classList.contains("bk-label")) return null;
    const box = el.previousElementSibling;
    return box && box.tagName === "INPUT" && box.type === "checkbox" ? box : null;
  };
  document.addEventListener("click", (event) => {
    const box = boxOf(event.composedPath()[0]);
    if (!box || box.disabled) return;
    window.moattnLabelClicks.forwarded += 1;
    box.click();  // toggles it and fires its change event, which Bokeh sends to the server
  }, true);
  document.addEventListener("pointerover", (event) => {
    const label = event.composedPath()[0];
    if (boxOf(label)) label.style.cursor = "pointer";
  }, true);
}
"""


def labels_toggle_boxes(doc) -> None:
    """Once the page is up, clicking a checkbox's label toggles its box."""
    doc.js_on_event("document_ready", CustomJS(code=LABEL_CLICKS_JS))
