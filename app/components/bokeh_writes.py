"""Writes the studio makes to its own Bokeh models (a ColumnDataSource's data, a range, a span, a title).

Panel runs a button's click outside the document lock when the click reaches the server while a typed value is
still pending (its event then goes through an unlocked coroutine). Panel's own widgets send their changes inside
``panel.io.unlocked`` and are safe there; a Bokeh model written directly is not: Bokeh raised "_pending_writes
should be non-None when we have a document lock" and the page stopped updating. Every method that writes Bokeh
models directly is wrapped in :func:`sends_bokeh`: its changes are held and sent to the page's connections at its
end, locked or not (and with no server, as in the unit tests, it just runs).
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

import panel as pn

F = TypeVar("F", bound=Callable)


def sends_bokeh(method: F) -> F:
    """``method`` writes Bokeh models directly: run it inside ``panel.io.unlocked`` (see the module doc)."""

    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        with pn.io.unlocked():
            return method(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
