"""Number boxes for parameters that take no None: an emptied box leaves the parameter as it was (nothing is
written; the next value typed is), instead of failing to set None. Made with ``from_param`` like any widget."""
from __future__ import annotations

import panel as pn


class _KeepsValue:
    """Drops an emptied box's None before it reaches the widget's value (and so the linked parameter)."""

    def _process_property_change(self, msg):
        msg = super()._process_property_change(msg)
        if "value" in msg and msg["value"] is None:
            del msg["value"]
        return msg


class IntBox(_KeepsValue, pn.widgets.IntInput):
    """An integer box (``IntBox.from_param(settings.param.steps)``)."""


class FloatBox(_KeepsValue, pn.widgets.FloatInput):
    """A number box (``FloatBox.from_param(settings.param.seconds)``)."""
