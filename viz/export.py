"""The one exporter of motion pictures: a GIF, an MP4 or a PNG of one motion (or role -> motion), drawn by
``viz.flat`` (2D, a few ms a frame, no VTK): the studio's Export buttons and ``moattn generate --out x.gif`` both
write through :func:`write_picture`, so a picture of a motion looks the same whichever made it."""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

VIDEO_SIZE = (640, 480)  # GIF, MP4 and PNG (width, height)
GIF_FPS = 20.0  # frames a second kept in a GIF (the motion's 20, or fewer for a smaller file)
# x264's preset: "veryfast" gives the file size of its default in half the time; "ultrafast" files are 3x larger
MP4_PRESET = "veryfast"
PICTURE_SUFFIXES = (".png", ".gif", ".mp4")


def write_picture(motions: np.ndarray | Mapping[str, np.ndarray], path: str | Path, *, title: str,
                  offsets: dict | None = None, frame: int = 0) -> Path:
    """``motions`` to ``path`` in the format its extension names: a .gif or .mp4 at VIDEO_SIZE with the full
    ``title`` (wrapped, never cut), a frame counter, the camera following the body, at real speed (GIF at GIF_FPS
    with one palette, MP4 (H.264) at 20 fps with x264's MP4_PRESET); a .png of frame ``frame``."""
    from engine.units import FPS
    from viz.flat import FlatRenderer, write_gif, write_mp4

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in PICTURE_SUFFIXES:
        raise ValueError(f"cannot write a picture to {str(path)!r}: use one of {', '.join(PICTURE_SUFFIXES)}")
    renderer = FlatRenderer(motions, size=VIDEO_SIZE, offsets=offsets, follow=True, title=title, frame_label=True)
    if suffix == ".gif":
        return write_gif(renderer, path, fps=FPS, every=max(1, round(FPS / GIF_FPS)))
    if suffix == ".mp4":
        return write_mp4(renderer, path, fps=FPS, preset=MP4_PRESET)
    path.parent.mkdir(parents=True, exist_ok=True)
    renderer.frame(int(frame)).save(path, format="PNG")
    return path
