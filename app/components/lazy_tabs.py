"""Tabs whose views are built the first time they are selected (a placeholder before): a page load builds the
first tab only, not every tab of the studio."""
from __future__ import annotations

from collections.abc import Callable, Sequence

import panel as pn
from panel.viewable import Viewable


class LazyTabs(pn.viewable.Viewer):
    """``pn.Tabs`` of (title, make-the-view) pairs; ``view(title)`` builds a tab's view on demand (once)."""

    def __init__(self, *, tabs: Sequence[tuple[str, Callable[[], Viewable]]], **tabs_params):
        super().__init__()
        self._makers = dict(tabs)
        self._titles = list(self._makers)
        self._views: dict[str, Viewable] = {}
        self._boxes = {title: pn.Column(pn.pane.Markdown(f"*{title}…*", css_classes=["tab-placeholder"]),
                                        sizing_mode="stretch_width") for title in self._titles}
        self.tabs = pn.Tabs(*self._boxes.items(), **tabs_params)
        self.tabs.param.watch(lambda event: self.view(self._titles[event.new]), "active")
        self.view(self._titles[self.tabs.active])

    @property
    def built(self) -> list[str]:
        """The titles whose views exist, in the order they were built."""
        return list(self._views)

    def view(self, title: str) -> Viewable:
        """The tab's view, built (and put in its place) on the first call."""
        if title not in self._views:
            self._views[title] = view = self._makers[title]()
            self._boxes[title].objects = [view]
        return self._views[title]

    def __panel__(self):
        return self.tabs
