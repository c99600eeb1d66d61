"""The session core's motion items: what a session can show, and what it keeps in memory (no tab, no view).

Tabs build ``MotionItem``s from their results and hand them to the session (``StudioState.add_item``); imports go
one way: tabs -> core. Every motion is kept in the motion library when the session has one (engine.library): a
library motion's joints are read from disk when first used (``loader``) and let go again when many are loaded
(``release``), so a session's list holds the whole library without holding it in memory.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from app.attention_record import AttentionRecord
from app.generation import Denoising, GenerationSettings

MAX_ITEMS_WITH_ATTENTION = 3
MAX_LOADED_ITEMS = 48  # library motions whose joints stay in memory (the newest, and those shown); others reload
MAX_UPLOAD_BYTES = 20 * 1024 * 1024  # an uploaded motion file (the import box and the Duet tab state it)


def upload_limit_text() -> str:
    """The upload limit as every message states it ("20 MiB")."""
    return f"{MAX_UPLOAD_BYTES / 2**20:g} MiB"


@dataclass
class MotionItem:
    """A motion the session can show: generated (with attention) or imported."""

    name: str
    joints: np.ndarray = field(repr=False)  # (T, 22, 3) float32 (read through ``loader`` when None)
    source: str  # "generated" | "imported"
    prompt: str = ""
    words: tuple[str, ...] = ()
    attention: AttentionRecord | None = None
    features: np.ndarray | None = None
    settings: GenerationSettings | None = None
    info: dict = field(default_factory=dict)
    evicted: bool = False  # its recorded attention was dropped to keep memory bounded (re-record: same seed)
    denoising: Denoising | None = None  # x̂0 after each sampling step (generated motions; the newest few keep it)
    kind: str = ""  # what made it (app.session.library.item_kind reads it from ``info`` when empty)
    library_id: str | None = None  # its id in the motion library (None: not kept there)
    from_library: bool = False  # read back from the library (a reload, a restart): it has no attention maps
    pinned: bool = False  # kept in the library whatever its size bound
    frames: int = 0  # its length while its joints are not loaded
    loader: Callable[[], np.ndarray] | None = field(default=None, repr=False, compare=False)

    @property
    def n_frames(self) -> int:
        joints = self.__dict__.get("_joints")
        return len(joints) if joints is not None else self.frames

    @property
    def loaded(self) -> bool:
        return self.__dict__.get("_joints") is not None

    def release(self) -> bool:
        """Let go of the joints in memory when they can be read again (a library motion); True if it did."""
        if self.loader is None or not self.loaded:
            return False
        self.frames = len(self._joints)
        self._joints = None
        return True

    def _load_joints(self) -> np.ndarray:
        joints = self.__dict__.get("_joints")
        if joints is None and self.loader is not None:
            joints = self.loader()  # a LibraryError (a ValueError) when it is damaged or no longer in the library
            self._joints = joints
            self.frames = len(joints)
        return joints

    def _store_joints(self, joints) -> None:
        self._joints = joints
        if joints is not None:
            self.frames = len(joints)


# after the dataclass is made (its __init__ assigns ``joints`` through this property)
MotionItem.joints = property(lambda self: self._load_joints(), lambda self, joints: self._store_joints(joints),
                             doc="(T, 22, 3) float32 joints, read from the library on first use")
