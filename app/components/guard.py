"""A guard for writes a view makes to its own widgets, so their watchers do not echo them back into the state."""
from __future__ import annotations

from collections.abc import Callable


class SyncGuard:
    """True while :meth:`run` runs; watchers return early when the guard is up."""

    def __init__(self) -> None:
        self.active = False

    def __bool__(self) -> bool:
        return self.active

    def run(self, fn: Callable[[], object]) -> None:
        was, self.active = self.active, True
        try:
            fn()
        finally:
            self.active = was
