"""The model, loaded once per server process and shared read-only by every session.

Sessions never mutate the loaded model: attention recording and edits are controllers passed to
each sampling call (``engine.generate`` does that). Every model lives on the server's one device
(``moattn serve --device``); sampling is serialised with one process-wide slot, so sessions' jobs
queue on that device (and two sessions on a two-core laptop do not thrash each other).
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

from engine.checkpoint import LoadedModel, load_model
from engine.runtime import CPU, Runtime

_lock = threading.Lock()
_cache: dict[Path, LoadedModel] = {}
_runtime: list[Runtime] = [CPU]  # the server's device, set once by `moattn serve` before any model loads

class SamplingQueue:
    """One sampling run at a time per process; waiting sessions are served first come, first served, and each
    is told its place in the queue whenever it changes."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._waiting: list[object] = []
        self._busy = False

    def acquire(self, *, cancelled: Callable[[], bool], on_place: Callable[[int], None] | None = None) -> bool:
        """Wait for the slot (True), or give up when ``cancelled()`` turns true (False). ``on_place(n)``: n
        runs are ahead (the running one included), called when n changes, never for an immediate slot."""
        ticket = object()
        with self._cond:
            self._waiting.append(ticket)
            told = None
            try:
                while self._busy or self._waiting[0] is not ticket:
                    if cancelled():
                        return False
                    place = self._waiting.index(ticket) + int(self._busy)
                    if place != told and on_place is not None:
                        on_place(place)
                        told = place
                    self._cond.wait(timeout=0.2)
                self._busy = True
                return True
            finally:
                self._waiting.remove(ticket)
                self._cond.notify_all()

    def release(self) -> None:
        with self._cond:
            self._busy = False
            self._cond.notify_all()

    @property
    def waiting(self) -> int:
        with self._cond:
            return len(self._waiting)


#: One generation at a time per process (sessions queue for it, in order).
SAMPLING_SLOT = SamplingQueue()


def use_runtime(runtime: Runtime) -> None:
    """Put every model this process loads from now on on ``runtime``'s device (models already loaded move)."""
    with _lock:
        _runtime[0] = runtime
        for loaded in _cache.values():
            loaded.model.to(runtime.device)
            loaded.model.autocast_dtype = runtime.dtype


def runtime() -> Runtime:
    """Where the server's models run."""
    return _runtime[0]


def get_model(folder: str | Path) -> LoadedModel:
    """The model in ``folder``, loaded on first use (thread safe; later calls return the same object)."""
    key = Path(folder).expanduser().resolve()
    with _lock:
        loaded = _cache.get(key)
        if loaded is None:
            if not key.exists():
                raise FileNotFoundError(
                    f"no model at {key}: train one with `moattn train --out {key}` or pass --model DIR")
            loaded = load_model(key, runtime=_runtime[0])
            _cache[key] = loaded
        return loaded


def is_loaded(folder: str | Path) -> bool:
    with _lock:
        return Path(folder).expanduser().resolve() in _cache


def clear() -> None:
    """Forget loaded models (tests)."""
    with _lock:
        _cache.clear()
