"""Contact sheets: tile images in a grid with optional text labels (pillow)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont


def contact_sheet(
    images: Sequence[np.ndarray],
    *,
    cols: int,
    labels: Sequence[str] | None = None,
    pad: int = 6,
    font_size: int = 14,
    background: tuple[int, int, int] = (255, 255, 255),
    label_color: tuple[int, int, int] = (30, 30, 30),
) -> np.ndarray:
    """Tile images (H, W, 3 or 4, uint8) row by row into one RGB image (uint8).

    Cells take the largest image's size; smaller images are centred. With ``labels`` (one
    per image) each cell gets its text centred below the image, shortened with "…" when it
    does not fit. ``cols`` larger than the number of images gives a single row.
    """
    if not images:
        raise ValueError("no images to tile")
    if cols < 1:
        raise ValueError(f"cols must be >= 1, got {cols}")
    if labels is not None and len(labels) != len(images):
        raise ValueError(f"{len(labels)} labels for {len(images)} images")
    tiles = [_as_rgb_image(img) for img in images]
    cell_w = max(t.width for t in tiles)
    cell_h = max(t.height for t in tiles)
    font = ImageFont.load_default(size=font_size)
    label_h = font_size + pad if labels is not None else 0
    cols = min(cols, len(tiles))
    rows = -(-len(tiles) // cols)
    sheet = Image.new(
        "RGB",
        (cols * cell_w + (cols + 1) * pad, rows * (cell_h + label_h) + (rows + 1) * pad),
        background,
    )
    draw = ImageDraw.Draw(sheet)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, cols)
        x0 = pad + c * (cell_w + pad)
        y0 = pad + r * (cell_h + label_h + pad)
        sheet.paste(tile, (x0 + (cell_w - tile.width) // 2, y0 + (cell_h - tile.height) // 2))
        if labels is not None:
            text = _fit_text(draw, str(labels[i]), font=font, width=cell_w)
            text_w = draw.textlength(text, font=font)
            draw.text((x0 + (cell_w - text_w) / 2, y0 + cell_h + pad // 2), text, fill=label_color, font=font)
    return np.asarray(sheet)


def _as_rgb_image(image: np.ndarray) -> Image.Image:
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or arr.dtype != np.uint8:
        raise ValueError(f"images must be uint8 (H, W, 3|4), got {arr.dtype} {arr.shape}")
    return Image.fromarray(np.ascontiguousarray(arr[..., :3]), mode="RGB")


def _fit_text(draw: ImageDraw.ImageDraw, text: str, *, font: ImageFont.ImageFont, width: int) -> str:
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "…", font=font) > width:
        text = text[:-1]
    return text + "…"


def pyvista_gallery(items: Sequence[tuple[str, np.ndarray]], *, poses: int) -> Image.Image:
    """The corpus gallery drawn by the pyvista scene (``moattn corpus --gallery --renderer pyvista``): ``poses``
    evenly spaced poses of each (label, joints (T, 22, 3)) item, one row each (about a third of a second a pose)."""
    from viz.render import render_frames

    images, labels = [], []
    for label, joints in items:
        idx = np.linspace(0, len(joints) - 1, poses).round().astype(int).tolist()
        images += render_frames(joints.astype(np.float64), frames=idx, size=(120, 170))
        labels += [f"{label} @{k}" if n == 0 else f"@{k}" for n, k in enumerate(idx)]
    return Image.fromarray(contact_sheet(images, cols=poses, labels=labels, font_size=10))
