"""Render motions to images and files: PNG, GIF, MP4, frame lists for contact sheets.

Every function builds one ``SkeletonScene`` and reuses it for all frames (points updated in
place). ``joints`` is one motion (T, 22, 3) or a mapping role -> motion (several skeletons
side by side); extra keyword options go to ``SkeletonScene`` (``follow``, ``azimuth``,
``colors``, ``title``, ``frame_label``, ...).
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import imageio.v2 as imageio_v2
import imageio.v3 as iio
import numpy as np

from viz.scene import SkeletonScene
from viz.sheet import contact_sheet

__all__ = [
    "contact_sheet",
    "render_file",
    "render_frames",
    "render_gif",
    "render_mp4",
    "render_png",
    "SUPPORTED_EXTENSIONS",
]

Motion = np.ndarray | Mapping[str, np.ndarray]
SUPPORTED_EXTENSIONS: tuple[str, ...] = (".png", ".gif", ".mp4")


@contextmanager
def _scene(joints: Motion, *, size: tuple[int, int], options: Mapping[str, Any]) -> Iterator[SkeletonScene]:
    scene = SkeletonScene(joints, size=size, **options)
    try:
        yield scene
    finally:
        scene.close()


def _frame_indices(n_frames: int, *, every: int, frames: Sequence[int] | None) -> list[int]:
    if frames is not None:
        idx = [int(k) for k in frames]
        bad = [k for k in idx if not 0 <= k < n_frames]
        if bad:
            raise IndexError(f"frames {bad} out of range 0..{n_frames - 1}")
        return idx
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    return list(range(0, n_frames, every))


def _prepare(path: str | Path) -> Path:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    return out


def render_frames(
    joints: Motion,
    *,
    every: int = 1,
    frames: Sequence[int] | None = None,
    size: tuple[int, int] = (320, 240),
    **scene_options: Any,
) -> list[np.ndarray]:
    """Images (H, W, 3) uint8 of frames 0, every, 2*every, ... (or exactly ``frames``)."""
    with _scene(joints, size=size, options=scene_options) as scene:
        images = []
        for k in _frame_indices(scene.n_frames, every=every, frames=frames):
            scene.set_frame(k)
            images.append(scene.screenshot())
        return images


def render_png(
    joints: Motion,
    path: str | Path,
    *,
    frame: int = 0,
    size: tuple[int, int] = (640, 480),
    **scene_options: Any,
) -> Path:
    """Render one frame to a PNG file; returns the path."""
    out = _prepare(path)
    (image,) = render_frames(joints, frames=[frame], size=size, **scene_options)
    iio.imwrite(out, image, extension=".png")
    return out


def render_gif(
    joints: Motion,
    path: str | Path,
    *,
    fps: float = 20.0,
    every: int = 1,
    size: tuple[int, int] = (480, 360),
    loop: int = 0,
    **scene_options: Any,
) -> Path:
    """Render frames 0, every, ... to an animated GIF played at real speed; returns the path.

    Each GIF frame lasts ``every / fps`` seconds (GIF delays are whole centiseconds, so
    20 fps is exact). ``loop=0`` loops forever. Pillow merges identical consecutive frames
    (adding up their delays), so a motion that stands still can give fewer GIF frames.
    """
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    out = _prepare(path)
    # a GIF is a 256-colour palette: supersampled edges buy little there and cost 60 % more render time
    scene_options = {"anti_aliasing": None, **scene_options}
    images = render_frames(joints, every=every, size=size, **scene_options)
    write_gif(images, out, duration_ms=1000.0 * every / fps, loop=loop)
    return out


def write_gif(images: Sequence[np.ndarray], path: Path, *, duration_ms: float, loop: int = 0) -> None:
    """Frames to an animated GIF with a fast octree palette per frame (8x faster than the default median-cut
    quantiser on 2 cores, and a quarter of the file size on skeleton renders)."""
    from PIL import Image

    frames = [Image.fromarray(np.asarray(im, dtype=np.uint8)).quantize(colors=256, method=Image.Quantize.FASTOCTREE)
              for im in images]
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:], duration=duration_ms, loop=loop,
                   optimize=False, disposal=1)


def render_mp4(
    joints: Motion,
    path: str | Path,
    *,
    fps: float = 20.0,
    every: int = 1,
    size: tuple[int, int] = (640, 480),
    quality: float = 7.0,
    **scene_options: Any,
) -> Path:
    """Render frames 0, every, ... to an H.264 MP4 (yuv420p, readable by imageio/ffmpeg and browsers).

    The video plays at ``fps / every`` frames per second, so the motion keeps its real
    speed. Odd sizes are rounded up to even (H.264 needs even dimensions). ``quality`` is
    imageio-ffmpeg's 0..10 scale.
    """
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    out = _prepare(path)
    # H.264 at this size softens edges itself; supersampling cost a 10-s, 640x480 export 10.6 s instead of 6.9 s
    scene_options = {"anti_aliasing": None, **scene_options}
    width, height = (int(size[0]) + int(size[0]) % 2, int(size[1]) + int(size[1]) % 2)
    with _scene(joints, size=(width, height), options=scene_options) as scene:
        writer = imageio_v2.get_writer(
            out,
            format="FFMPEG",
            mode="I",
            fps=fps / every,
            codec="libx264",
            quality=quality,
            pixelformat="yuv420p",
            macro_block_size=2,
            ffmpeg_log_level="error",
            # x264's "veryfast" preset: the same file size here, half the time of its default on 2 loaded cores
            # (18.1 s -> 8.1 s for a 9.8-s motion at 640x480)
            ffmpeg_params=["-preset", "veryfast"],
        )
        try:
            for k in _frame_indices(scene.n_frames, every=every, frames=None):
                scene.set_frame(k)
                writer.append_data(scene.screenshot())
        finally:
            writer.close()
    return out


def render_file(joints: Motion, path: str | Path, *, frame: int | None = None, **options: Any) -> Path:
    """Render to ``path`` in the format its extension names: .png (one frame), .gif or .mp4.

    ``frame`` picks the PNG's frame (default 0) and is an error for videos. Other keyword
    options go to ``render_png`` / ``render_gif`` / ``render_mp4``.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in SUPPORTED_EXTENSIONS:
        raise ValueError(
            f"cannot render to {str(path)!r}: unsupported extension {suffix or '(none)'!r}; "
            f"use one of {', '.join(SUPPORTED_EXTENSIONS)}"
        )
    if suffix == ".png":
        return render_png(joints, path, frame=0 if frame is None else frame, **options)
    if frame is not None:
        raise ValueError(f"frame={frame} applies to .png only; {suffix} renders every frame")
    if suffix == ".gif":
        return render_gif(joints, path, **options)
    return render_mp4(joints, path, **options)


def render_together(motions: Mapping[str, np.ndarray], path: str | Path, **options: Any) -> Path:
    """:func:`render_file` of several motions in one shared space (e.g. two people), not side by side."""
    return render_file(dict(motions), path, offsets={role: (0.0, 0.0, 0.0) for role in motions}, **options)
