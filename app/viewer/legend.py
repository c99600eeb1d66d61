"""What the viewer's colours mean: the legend drawn in the corner of the 3-D view, one per colour mode.

* role colours (the default): one swatch per motion shown, with its name; limbs lighter on the left, darker on the
  right;
* colour by word attention: the plasma scale from 0 to the highlighted word's highest attention, with the word;
* per-frame colours set by a tab (Transfer's Q/K clusters, Compose's intervals and handshakes, Duet's given prefix):
  one swatch per colour, named when the colour is one the tab uses, else by the frames it covers.

The legend travels in the scene message (``legend``) and the page draws it (``app/components/viewer3d/legend.js``),
so it is part of the picture (and of its PNG).
"""
from __future__ import annotations

import re

import numpy as np

MAX_SWATCHES = 10
GRADIENT_STOPS = 9
LEFT_RIGHT = "limbs: lighter = left, darker = right"


def _hex(rgb) -> str:
    return "#{:02x}{:02x}{:02x}".format(*(int(c) for c in rgb))


def _short(text: str, n: int = 30) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def _ranges(frames: np.ndarray) -> str:
    """'frames 0–39, 80–99' for the sorted frame indices (two ranges at most, then '…')."""
    if not len(frames):
        return ""
    cuts = np.flatnonzero(np.diff(frames) > 1)
    starts = [frames[0], *frames[cuts + 1]]
    ends = [*frames[cuts], frames[-1]]
    parts = [f"{a}" if a == b else f"{a}–{b}" for a, b in zip(starts, ends)]
    return "frames " + ", ".join(parts[:2]) + (", …" if len(parts) > 2 else "")


def frame_color_swatches(role_colors, names: dict[str, str] | None = None) -> list[dict]:
    """Swatches of per-frame colours: ``role_colors`` (role, (T, 3) or (T, 22, 3) uint8) -> [{label, color}]; a
    skeleton's colour is its pelvis joint's (the base colour, limbs shaded). ``names``: '#rrggbb' -> what the colour
    stands for, as the tab that painted it says (the session's ``color_names``); other colours are named by the
    frames they cover."""
    known = {k.lower(): v for k, v in (names or {}).items()}
    seen: dict[str, dict] = {}
    for role, colors in role_colors:
        rgb = np.asarray(colors)
        base = rgb[:, 0] if rgb.ndim == 3 else rgb
        base = np.asarray(base, dtype=np.uint8)
        for color in dict.fromkeys(_hex(c) for c in base):
            if color in seen:
                continue
            frames = np.flatnonzero((base == np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])).all(axis=1))
            label = known.get(color) or _ranges(frames)
            seen[color] = {"label": label if len(role_colors) == 1 else f"{_short(role, 16)}: {label}",
                           "color": color}
    return list(seen.values())  # colours named alike ("interval": they alternate) keep a swatch each


def scene_legend(*, roles: list[str], role_colors=(), note: str = "", names: dict[str, str] | None = None,
                 word: str | None = None, values: np.ndarray | None = None, word_wanted: bool = False,
                 why_no_word: str = "") -> dict:
    """The legend of a scene: ``roles`` shown (in order), the per-frame colours, their ``note`` and the ``names``
    of their colours (see :func:`frame_color_swatches`), the word
    attention ``values`` of ``word`` (first role) when the viewer colours by them; ``word_wanted`` with no values:
    the legend says why not (``why_no_word``)."""
    from viz.colors import ROLE_PALETTE, values_to_rgb

    coloured = {r for r, _ in role_colors}
    if values is not None and len(roles) and roles[0] not in coloured:
        hi = float(np.max(values)) if np.size(values) and np.max(values) > 0 else 1.0
        stops = values_to_rgb(np.linspace(0.0, 1.0, GRADIENT_STOPS), cmap="plasma", clim=(0.0, 1.0))
        return {"kind": "gradient", "title": f'attention on "{_short(word or "?", 24)}"',
                "stops": [_hex(c) for c in stops], "low": "0", "high": f"{hi:.2f}", "note": LEFT_RIGHT}
    items: list[dict] = []
    if role_colors:
        items += frame_color_swatches(list(role_colors), names)
    plain = [r for r in roles if r not in coloured]
    items += [{"label": _short(r), "color": ROLE_PALETTE[roles.index(r) % len(ROLE_PALETTE)]} for r in plain]
    title = re.sub(r"\s*\(legend in the [^)]*\)", "", note).removeprefix("colour: ").strip() if role_colors else ""
    more = max(0, len(items) - MAX_SWATCHES)
    legend = {"kind": "swatches", "title": title or "motion colours", "items": items[:MAX_SWATCHES], "more": more,
              "note": LEFT_RIGHT}
    if word_wanted and why_no_word:
        legend["title"] = "no word colours: " + why_no_word
    return legend
