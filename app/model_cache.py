"""The model, loaded once per server process and shared read-only by every session.

Sessions never mutate the loaded model: attention recording and edits are controllers passed to
each sampling call (``engine.generate`` does that). Sampling is serialised with one process-wide
slot so that two sessions on a two-core laptop do not thrash each other; the second waits.
"""
from __future__ import annotations

import threading
from pathlib import Path

from engine.checkpoint import LoadedModel, load_model

_lock = threading.Lock()
_cache: dict[Path, LoadedModel] = {}

#: One generation at a time per process (sessions queue for it).
SAMPLING_SLOT = threading.BoundedSemaphore(1)

#: VTK is not thread safe across scenes sharing globals (fonts, EGL displays): every scene build,
#: frame render and file render in the app holds this lock.
VTK_LOCK = threading.RLock()


def get_model(folder: str | Path) -> LoadedModel:
    """The model in ``folder``, loaded on first use (thread safe; later calls return the same object)."""
    key = Path(folder).expanduser().resolve()
    with _lock:
        loaded = _cache.get(key)
        if loaded is None:
            if not key.exists():
                raise FileNotFoundError(
                    f"no model at {key}: train one with `moattn train --out {key}` or pass --model DIR")
            loaded = load_model(key)
            _cache[key] = loaded
        return loaded


def is_loaded(folder: str | Path) -> bool:
    with _lock:
        return Path(folder).expanduser().resolve() in _cache


def clear() -> None:
    """Forget loaded models (tests)."""
    with _lock:
        _cache.clear()
