"""Number boxes that never show "NaN" and never leave an emptied box blank while something else is used.

Panel's ``FloatInput`` sends an empty value (None) to the browser as NaN, which the box then shows as "NaN". These
boxes send None, so an empty box shows its placeholder. What emptying a box means:

* a parameter that takes None (``seconds``: None is "auto") gets None, and the box shows its placeholder ("auto 2.3");
* any other parameter goes back to its default, and the box shows that value (it is never left blank while the
  previous value is silently used).

Made with ``from_param`` like any widget (``FloatBox.from_param(settings.param.seconds)``), or directly with
``empty=`` (the value an emptied box takes; left out: None).
"""
from __future__ import annotations

import math

import panel as pn

_NONE = object()


class _NumberBox:
    """What an emptied box (the browser's null) becomes, and None (not NaN) towards the browser."""

    def __init__(self, *, empty=_NONE, **params):
        self._empty = None
        self._repaint = False
        super().__init__(**params)
        self.set_empty_value(None if empty is _NONE else empty)

    @classmethod
    def from_param(cls, parameter, **params):
        widget = super().from_param(parameter, **params)
        widget.set_empty_value(None if parameter.allow_None else parameter.default)
        return widget

    def set_empty_value(self, value) -> None:
        """What an emptied box sets from now on (None: the parameter's "auto" or "none"); shown as the placeholder."""
        self._empty = value
        if value is not None and not self.placeholder:
            self.placeholder = f"default {value:g}"

    @property
    def empty_value(self):
        """What an emptied box sets (None: the parameter's "auto" or "none")."""
        return self._empty

    def _process_param_change(self, params):
        props = super()._process_param_change(params)
        for key in ("value", "value_throttled"):
            value = props.get(key)
            if isinstance(value, float) and math.isnan(value):
                props[key] = None  # an empty box, not "NaN"
        return props

    def _process_property_change(self, msg):
        msg = super()._process_property_change(msg)
        if self._empty is not None:
            for key in ("value", "value_throttled"):
                if key in msg and msg[key] is None:
                    msg[key] = self._empty
                    self._repaint = True
        return msg

    def _process_events(self, events):
        super()._process_events(events)
        if self._repaint:  # the box was emptied: it shows the value now used (the browser still has it blank)
            self._repaint = False
            self.param.trigger("value")


class IntBox(_NumberBox, pn.widgets.IntInput):
    """An integer box (``IntBox.from_param(settings.param.steps)``)."""


class FloatBox(_NumberBox, pn.widgets.FloatInput):
    """A number box (``FloatBox.from_param(settings.param.seconds)``)."""
