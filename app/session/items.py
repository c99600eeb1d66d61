"""The session core's motion items: what a session can show, and how many it keeps (no tab, no view).

Tabs build ``MotionItem``s from their results and hand them to the session (``StudioState.add_item``); imports go
one way: tabs -> core.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.attention_record import AttentionRecord
from app.generation import Denoising, GenerationSettings

MAX_ITEMS = 24  # motions are small (a 10-s motion is 140 KB); a transfer onto 8 followers adds 17
MAX_ITEMS_WITH_ATTENTION = 3
MAX_UPLOAD_BYTES = 20 * 1024 * 1024  # an uploaded motion file (the import box and the Duet tab state it)


def upload_limit_text() -> str:
    """The upload limit as every message states it ("20 MiB")."""
    return f"{MAX_UPLOAD_BYTES / 2**20:g} MiB"


@dataclass
class MotionItem:
    """A motion the session can show: generated (with attention) or imported."""

    name: str
    joints: np.ndarray  # (T, 22, 3) float32
    source: str  # "generated" | "imported"
    prompt: str = ""
    words: tuple[str, ...] = ()
    attention: AttentionRecord | None = None
    features: np.ndarray | None = None
    settings: GenerationSettings | None = None
    info: dict = field(default_factory=dict)
    evicted: bool = False  # its recorded attention was dropped to keep memory bounded (re-record: same seed)
    denoising: Denoising | None = None  # x̂0 after each sampling step (generated motions; the newest few keep it)

    @property
    def n_frames(self) -> int:
        return len(self.joints)
