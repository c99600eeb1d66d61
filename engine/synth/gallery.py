"""Contact sheets of the corpus: a strip of poses per action and per style.

A small built-in orthographic line renderer (PIL) draws the strips, so the gallery never depends on a GPU or an
OpenGL context; a caller may pass another renderer (``moattn corpus --renderer pyvista`` passes
``viz.sheet.pyvista_gallery``), and the engine itself imports nothing from viz/.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from engine.skeleton import PARENTS

_LEFT = {1, 4, 7, 10, 13, 16, 18, 20}
_RIGHT = {2, 5, 8, 11, 14, 17, 19, 21}


def _project(points: np.ndarray, view: str) -> np.ndarray:
    """World (…, 3) -> image plane (…, 2) (x right, y up) for a camera looking at the body."""
    if view == "side":  # camera on the body's right, looking toward +X: forward (+Z) is to the right
        return np.stack([points[..., 2], points[..., 1]], -1)
    if view == "front":  # camera in front, looking toward -Z: the body's left (+X) is on the image right
        return np.stack([points[..., 0], points[..., 1]], -1)
    # oblique: 35° around Y from the side view, a little from above
    a = np.deg2rad(35.0)
    x = points[..., 2] * np.cos(a) + points[..., 0] * np.sin(a)
    depth = -points[..., 2] * np.sin(a) + points[..., 0] * np.cos(a)
    depth = depth - depth[..., :1]  # relative to the pelvis: each pose keeps its own floor line
    y = points[..., 1] * 0.97 + depth * 0.12
    return np.stack([x, y], -1)


def strip(joints: np.ndarray, *, poses: int = 8, view: str = "oblique", width: int = 900, height: int = 190,
          label: str = "", travel: bool = True, frames: list[int] | None = None) -> Image.Image:
    """One row: ``poses`` poses sampled over the motion, drawn side by side (left to right).

    With ``travel`` the poses keep their real displacement (scaled to fit); otherwise each pose
    is centred in its own cell.
    """
    T = joints.shape[0]
    idx = frames if frames is not None else np.linspace(0, T - 1, poses).round().astype(int).tolist()
    img = Image.new("RGB", (width, height), (250, 250, 247))
    draw = ImageDraw.Draw(img)
    pts = _project(joints[idx], view)
    label_h = 16
    scale = (height - label_h - 14) / 2.1
    cell = (width - 20) / len(idx)
    base_y = height - 8
    for i, f in enumerate(idx):
        p = pts[i].copy()
        cx = 10 + cell * (i + 0.5)
        p[:, 0] = (p[:, 0] - p[0, 0]) * scale + cx
        p[:, 1] = base_y - p[:, 1] * scale
        draw.line([(cx - cell * 0.45, base_y), (cx + cell * 0.45, base_y)], fill=(200, 200, 195), width=1)
        for j in range(1, 22):
            a, b = p[PARENTS[j]], p[j]
            col = (40, 90, 200) if j in _LEFT else (210, 70, 50) if j in _RIGHT else (60, 60, 60)
            draw.line([tuple(a), tuple(b)], fill=col, width=3)
        hx, hy = p[15]
        draw.ellipse([hx - 6, hy - 9, hx + 6, hy + 3], outline=(60, 60, 60), width=2)
        draw.text((cx - 8, height - label_h - 2 - scale * 2.0 + 4), str(f), fill=(150, 150, 150))
    if label:
        draw.text((6, 3), label, fill=(20, 20, 20), font=ImageFont.load_default())
    return img


def sheet(rows: list[Image.Image]) -> Image.Image:
    w = max(r.width for r in rows)
    h = sum(r.height for r in rows)
    out = Image.new("RGB", (w, h), (255, 255, 255))
    y = 0
    for r in rows:
        out.paste(r, (0, y))
        y += r.height
    return out


def save_strips(path: str | Path, items: list[tuple[str, np.ndarray]], **kw) -> Path:
    rows = [strip(j, label=name, **kw) for name, j in items]
    img = sheet(rows)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path)
    return path


# ------------------------------------------------------------------------ the corpus gallery
def gallery_programs():
    """(label, program) pairs: one row per action, then one per style (walking and one more action)."""
    from engine.synth.program import Program, Segment

    def one(action, style="none", **kw):
        frames = kw.pop("frames", 80)
        return Program(segments=(Segment(action=action, frames=frames, **kw),), style=style, seed=1)

    rows = [
        ("stand", one("stand", frames=40)),
        ("walk forward", one("walk", direction="forward", frames=90)),
        ("run", one("run", direction="forward")),
        ("jog", one("jog", direction="forward")),
        ("walk backward", one("walk_backward", direction="backward")),
        ("side-step left", one("side_step", direction="left")),
        ("walk in a circle", one("walk", direction="circle_left", frames=130)),
        ("turn around", one("turn", turn=3.14159, direction="around", frames=44)),
        ("jump twice", one("jump", count=2, frames=44)),
        ("jump high", one("jump", count=1, intensity=1.6, intensity_word="high", frames=30)),
        ("jump forward twice", one("jump_forward", count=2, frames=50)),
        ("hop on the left leg x3", one("hop", count=3, side="left", frames=50)),
        ("jumping jacks x2", one("jumping_jacks", count=2, frames=50)),
        ("squat", one("squat", count=1, frames=40)),
        ("kick right", one("kick", count=1, side="right", frames=34)),
        ("punch left x2", one("punch", count=2, side="left", frames=36)),
        ("wave right x3", one("wave", count=3, side="right", frames=56)),
        ("clap x3", one("clap", count=3, frames=46)),
        ("raise both arms", one("raise_arms", count=1, side="both", frames=50)),
        ("raise the left arm", one("raise_arms", count=1, side="left", frames=50)),
        ("bow", one("bow", count=1, frames=44)),
        ("dance", one("dance", frames=80)),
        ("walk, then jump twice", Program(segments=(Segment("walk", 50, direction="forward"),
                                                    Segment("jump", 44, count=2)), seed=1)),
        ("walk while waving the right hand", Program(segments=(Segment("walk", 80, direction="forward",
                                                                       overlay=Segment("wave", 80, count=3, side="right")),),
                                                      seed=1)),
    ]
    for style in ("zombie", "chicken", "hands_up", "crouched", "old", "happy", "sad", "robot", "drunk", "gorilla",
                  "proud"):
        rows.append((f"walk, {style}", one("walk", style=style, direction="forward", frames=90)))
    extra = {"zombie": ("jump", {"count": 1, "frames": 30}), "chicken": ("stand", {"frames": 40}),
             "hands_up": ("jump", {"count": 2, "frames": 44}), "crouched": ("side_step", {"direction": "left"}),
             "old": ("squat", {"count": 1, "frames": 44}), "happy": ("jump", {"count": 2, "frames": 44}),
             "sad": ("stand", {"frames": 40}), "robot": ("wave", {"count": 2, "side": "right", "frames": 44}),
             "drunk": ("run", {"direction": "forward"}), "gorilla": ("jump", {"count": 1, "frames": 30}),
             "proud": ("kick", {"count": 1, "side": "left", "frames": 34})}
    for style, (action, kw) in extra.items():
        rows.append((f"{action}, {style}", one(action, style=style, **kw)))
    return rows


def gallery_joints() -> list[tuple[str, np.ndarray]]:
    """(label, canonical joints (T, 22, 3)) of every gallery program, in sheet order."""
    from engine.synth.compose import synthesize
    from engine.synth.corpus import to_canonical

    return [(label, to_canonical(synthesize(program).joints)[0]) for label, program in gallery_programs()]


def render_gallery(path: str | Path, *, poses: int = 10, view: str = "oblique", draw=None) -> Path:
    """Write the contact sheet (one strip per action and per style) to ``path``.

    The fast built-in line drawing by default (poses side by side with real displacement); ``draw`` (the
    command line passes viz.sheet.pyvista_gallery for ``--renderer pyvista``) turns ``gallery_joints()`` and
    ``poses`` into the sheet instead: the engine itself draws with nothing from viz/.
    """
    items = gallery_joints()
    if draw is not None:
        img = draw(items, poses=poses)
    else:
        img = sheet([strip(j, poses=poses, view=view, label=label, width=1100, height=170) for label, j in items])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path)
    return path
