"""Attach a controller to a model for the calls made inside a ``with`` block.

The binding lives in a context variable keyed by the model, so a model shared read-only by many
app sessions (threads) never sees another session's controller, and it is always restored on
exit, errors included. Sampling functions pass controllers explicitly; this is for direct calls.
"""
from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from collections.abc import Iterator

from torch import nn

from engine.attention.controller import AttentionController

_BINDINGS: ContextVar[tuple[tuple[int, AttentionController], ...]] = ContextVar("moattn_controllers", default=())


def attached_controller(model: nn.Module) -> AttentionController | None:
    for model_id, controller in reversed(_BINDINGS.get()):
        if model_id == id(model):
            return controller
    return None


@contextmanager
def attach(model: nn.Module, controller: AttentionController | None) -> Iterator[nn.Module]:
    token = _BINDINGS.set(_BINDINGS.get() + ((id(model), controller),))
    try:
        yield model
    finally:
        _BINDINGS.reset(token)
