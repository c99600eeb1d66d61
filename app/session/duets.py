"""A duet's two people as session motions: what their items share, and whether the viewer shows exactly one duet
(the viewer, the exports and the Duet tab read this; the session core owns it so no tab imports another)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class DuetPair:
    """What a duet's two session motions share (``MotionItem.info["duet"]``)."""

    first: str  # person a's motion name
    second: str  # person b's
    joints: np.ndarray  # (2, T, 22, 3), one frame


def is_duet(shown: list) -> bool:
    """Whether the motions shown are exactly one duet's two people (drawn in one shared space)."""
    pairs = [it.info.get("duet") for it in shown]
    return len(shown) == 2 and all(isinstance(p, DuetPair) for p in pairs) and pairs[0] is pairs[1]
