"""The studio's design: Panel's Fast design without its Google Fonts stylesheet (the studio runs offline).

Panel resolves a design's local resources by the class name, so the subclass keeps the name ``Fast``.
"""
from __future__ import annotations

from panel.theme.fast import Fast as _PanelFast


class Fast(_PanelFast):
    _resources = {kind: value for kind, value in _PanelFast._resources.items() if kind != "font"}
