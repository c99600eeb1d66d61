"""Fast 2D drawing of skeleton scenes for video exports (GIF, MP4): numpy projection + Pillow drawing, no VTK.

The studio's pyvista scene (``viz.scene``) is a real 3D renderer: right for the interactive viewer, but a frame
costs tens of milliseconds, so a 10-s export took 7 s (GIF, 320x240) and 13 s (MP4). This module draws the same
picture in 2D, with the same camera (``viz.camera``: 3/4 front view, 18 degrees up, 30-degree view angle, following
the pelvis), the same sky gradient, checkerboard floor and root path, and the same colours (``viz.colors``: role
palette, left limbs lighter, right limbs darker):

- every joint of every frame is projected at once (numpy);
- the floor is one top-down texture (tiles and the root path, drawn once) mapped into each frame by a perspective
  transform: the floor is a plane, so its picture is a homography of the texture (one Pillow call a frame);
- bones are thick lines and joints discs, outlined and lit from the upper left, painted far to near, drawn at
  twice the size inside the skeleton's box and reduced (anti-aliased edges at a fraction of the cost of the frame);
- the title is wrapped (at most two lines, the font shrinking to fit) and never truncated; it is drawn once.

A 640x480 frame costs a few milliseconds, so the encoder, not the drawing, sets the export's time.
"""
from __future__ import annotations

import functools
import unicodedata
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from engine.skeleton import JOINT_NAMES, PARENTS
from viz.camera import UP, facing_azimuth, fit_points, view_direction
from viz.colors import ROLE_PALETTE, ColorLike, color_to_rgb, default_joint_colors, mix
from viz.layout import place_roles

N_JOINTS = len(JOINT_NAMES)
HEAD = JOINT_NAMES.index("head")
PELVIS = JOINT_NAMES.index("pelvis")
BONE_PARENTS = np.array([p for p in PARENTS if p >= 0])
BONE_CHILDREN = np.array([c for c, p in enumerate(PARENTS) if p >= 0])
_PARENT_LIST, _CHILD_LIST = BONE_PARENTS.tolist(), BONE_CHILDREN.tolist()

SKY_TOP = (207, 220, 236)  # the pyvista scene's background: "#cfdcec" at the top fading to white at the bottom
SKY_BOTTOM = (255, 255, 255)
# viz.colors.FLOOR_COLORS as the pyvista scene shows them under its light (sampled from its renders)
FLOOR_SHADED = ((206, 203, 192), (183, 182, 172))
TEXT_COLOR = (28, 30, 36)
VIEW_ANGLE = 30.0
NEAR = 0.05  # metres: parts closer to the camera than this are not drawn
SUPERSAMPLE = 2
_FLOOR_Y = 0.0
_PATH_LIFT = 0.006
TITLE_SIZES = tuple(range(20, 10, -1))  # font sizes (px at 480 rows) tried for the title, largest first


def as_motion_dict(motions: np.ndarray | Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One motion (T, 22, 3) (role "motion") or a mapping role -> motion, validated as float64."""
    items = motions.items() if isinstance(motions, Mapping) else [("motion", motions)]
    out = {}
    for role, m in items:
        arr = np.asarray(m, dtype=np.float64)
        if arr.shape == (N_JOINTS, 3):
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[1:] != (N_JOINTS, 3) or len(arr) < 1:
            raise ValueError(f"motion {role!r} must have shape (T, {N_JOINTS}, 3), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"motion {role!r} contains NaN or inf")
        out[str(role)] = arr
    if not out:
        raise ValueError("no motions given")
    return out


# ---------------------------------------------------------------------------------------------- text
def font(size: int) -> ImageFont.FreeTypeFont:
    """Pillow's bundled scalable font (no system font needed)."""
    return ImageFont.load_default(size=max(6, int(size)))


#: what a character the bundled font has no glyph for is drawn as (others lose their accents, else become "?")
STAND_INS = {"→": "->", "←": "<-", "↔": "<->", "×": "x", "—": "-", "–": "-", "✓": "ok", "✗": "x", "’": "'", "‘": "'",
             "“": '"', "”": '"', "²": "2", "³": "3"}


@functools.lru_cache(maxsize=1)
def _glyphs() -> tuple[ImageFont.FreeTypeFont, bytes]:
    """The bundled font, and the empty box it draws for a character it has no glyph for (U+E000 has none)."""
    fnt = font(20)
    return fnt, bytes(fnt.getmask("\ue000"))


@functools.lru_cache(maxsize=4096)
def _has_glyph(ch: str) -> bool:
    fnt, box = _glyphs()
    return ch.isspace() or bytes(fnt.getmask(ch)) != box


def drawable(text: str) -> str:
    """``text`` as the bundled font can draw it: a character it has no glyph for (it drew an empty box: the arrow
    of a compose title, the ← of a transfer title, an accent) becomes its stand-in (:data:`STAND_INS`), else the
    letter without its accent, else "?"."""
    out = []
    for ch in text:
        if _has_glyph(ch):
            out.append(ch)
        elif ch in STAND_INS:
            out.append(STAND_INS[ch])
        else:
            plain = "".join(c for c in unicodedata.normalize("NFKD", ch) if _has_glyph(c) and not unicodedata.combining(c))
            out.append(plain or "?")
    return "".join(out)


def wrap_text(text: str, fnt: ImageFont.ImageFont, width: float) -> list[str]:
    """Greedy word wrap of ``text`` into lines no wider than ``width`` pixels; a word wider than a line is split
    between characters. Every character of ``text`` (but the spaces at the breaks) is kept."""
    lines: list[str] = []
    line = ""
    for word in text.split():
        candidate = f"{line} {word}" if line else word
        if fnt.getlength(candidate) <= width:
            line = candidate
            continue
        if line:
            lines.append(line)
        while fnt.getlength(word) > width and len(word) > 1:  # a word longer than a line: split it
            lo, hi = 1, len(word) - 1  # the longest head that fits (binary search; at least one character)
            while lo < hi:
                mid = (lo + hi + 1) // 2
                lo, hi = (mid, hi) if fnt.getlength(word[:mid]) <= width else (lo, mid - 1)
            lines.append(word[:lo])
            word = word[lo:]
        line = word
    if line:
        lines.append(line)
    return lines


def fit_title(text: str, *, width: float, scale: float = 1.0, max_lines: int = 2,
              sizes: Sequence[int] = TITLE_SIZES) -> tuple[ImageFont.FreeTypeFont, list[str]]:
    """The largest font (of ``sizes`` times ``scale``) at which ``text`` wraps into at most ``max_lines`` lines
    of ``width`` pixels, and those lines. A text too long even at the smallest size takes more lines at that size:
    the title is never truncated."""
    text = drawable(text)
    fnt, lines = font(1), [text]
    for size in sizes:
        fnt = font(round(size * scale))
        lines = wrap_text(text, fnt, width)
        if len(lines) <= max_lines:
            break
    return fnt, lines


def _text_box(lines: Sequence[str], fnt: ImageFont.FreeTypeFont, *, pad: int, line_gap: int) -> Image.Image:
    """An RGBA picture of ``lines`` in dark text on a translucent white box."""
    ascent, descent = fnt.getmetrics()
    line_h = ascent + descent
    w = int(np.ceil(max(fnt.getlength(s) for s in lines))) + 2 * pad
    h = len(lines) * line_h + (len(lines) - 1) * line_gap + 2 * pad
    box = Image.new("RGBA", (w, h), (0, 0, 0, 0))
    draw = ImageDraw.Draw(box)
    draw.rounded_rectangle((0, 0, w - 1, h - 1), radius=max(2, pad), fill=(255, 255, 255, 185))
    for i, s in enumerate(lines):
        draw.text((pad, pad + i * (line_h + line_gap)), s, font=fnt, fill=TEXT_COLOR + (255,))
    return box


# ---------------------------------------------------------------------------------------------- camera
@dataclass(frozen=True)
class FlatCamera:
    """A perspective camera without roll (its up vector in the vertical plane), moved per frame by ``shift``."""

    position: np.ndarray  # (3,) at frame 0 before ``shift``
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    focal: float  # pixels
    size: tuple[int, int]

    def project(self, points: np.ndarray, shift: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points (T, ..., 3) with per-frame camera shifts (T, 3) -> pixel x, pixel y, depth (T, ...)."""
        w, h = self.size
        rel = points - (self.position + shift).reshape((len(shift),) + (1,) * (points.ndim - 2) + (3,))
        depth = rel @ self.forward
        safe = np.where(depth > NEAR, depth, NEAR)
        return w / 2 + self.focal * (rel @ self.right) / safe, h / 2 - self.focal * (rel @ self.up) / safe, depth

    def horizon_row(self) -> float:
        """The image row of the horizon (the floor lies below it)."""
        return self.size[1] / 2 + self.focal * self.forward[1] / max(self.up[1], 1e-9)

    def floor_coefficients(self, shift: np.ndarray, *, corner: tuple[int, int], origin: tuple[float, float],
                           ppm: float) -> tuple:
        """Pillow PERSPECTIVE coefficients mapping pixel (x, y) of the image region whose upper left is ``corner``
        (below the horizon) to the floor texture's pixel (u, v) = ppm * (world x - origin[0], world z - origin[1])."""
        w, h = self.size
        cam = self.position + shift
        # the ray through image pixel (x + col0, y + row0): d = x * a + y * b + c
        col0, row0 = corner
        a = self.right
        b = -self.up
        c = self.focal * self.forward + (col0 - w / 2) * self.right - (row0 - h / 2) * self.up
        height = cam[1]

        def numerator(axis: int, start: float) -> np.ndarray:  # ppm * ((cam - start) * d_y - height * d_axis)
            return ppm * np.array([(cam[axis] - start) * v[1] - height * v[axis] for v in (a, b, c)])

        den = np.array([a[1], b[1], c[1]])
        nu, nv = numerator(0, origin[0]), numerator(2, origin[1])
        k = den[2]
        return (nu[0] / k, nu[1] / k, nu[2] / k, nv[0] / k, nv[1] / k, nv[2] / k, den[0] / k, den[1] / k)


def camera_for(motions: Mapping[str, np.ndarray], *, size: tuple[int, int], follow: bool, azimuth: float | None,
               elevation: float) -> tuple[FlatCamera, np.ndarray]:
    """The pyvista scene's default camera (``SkeletonScene.reset_camera``) and its per-frame shifts (T, 3)."""
    n = max(len(m) for m in motions.values())
    frames = np.arange(n)
    track = np.mean([m[np.minimum(frames, len(m) - 1), PELVIS] for m in motions.values()], axis=0)
    track[:, 1] = 0.0
    first = next(iter(motions.values()))
    az = facing_azimuth(first[0]) + 30.0 if azimuth is None else float(azimuth)
    # above the floor always (the floor is drawn as seen from above)
    direction = view_direction(azimuth=az, elevation=float(np.clip(elevation, 2.0, 85.0)))
    w, h = size
    if follow:
        rel = np.concatenate([(m - track[: len(m), None]).reshape(-1, 3) for m in motions.values()])
        pose = fit_points(rel, direction=direction, view_angle=VIEW_ANGLE, aspect=w / h, margin=1.1)
        position, shifts = pose.position + track[0], track - track[0]
    else:
        pts = np.concatenate([m.reshape(-1, 3) for m in motions.values()])
        pose = fit_points(pts, direction=direction, view_angle=VIEW_ANGLE, aspect=w / h)
        position, shifts = pose.position, np.zeros((n, 3))
    back = direction / np.linalg.norm(direction)
    right = np.cross(-back, UP)
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    focal = (h / 2) / np.tan(np.radians(VIEW_ANGLE) / 2)
    return FlatCamera(position=position, right=right, up=up, forward=-back, focal=float(focal), size=(w, h)), shifts


# ---------------------------------------------------------------------------------------------- renderer
@dataclass
class _Role:
    name: str
    joints: np.ndarray  # (T, 22, 3) offsets applied
    joint_colors: np.ndarray  # (22, 3) uint8
    path_color: tuple[int, int, int]

    def __post_init__(self) -> None:
        # per joint (a bone takes its child joint's): fill, outline (darker), light (lighter), as Pillow colours
        self.fill = [_tuple(c) for c in self.joint_colors]
        self.edge = [_tuple(c) for c in mix(self.joint_colors, "black", 0.35)]
        self.light = [_tuple(c) for c in mix(self.joint_colors, "white", 0.33)]


class FlatRenderer:
    """Frames of one or more skeletons on the studio's floor, drawn in 2D.

    Args mirror ``viz.scene.SkeletonScene``: ``motions`` one (T, 22, 3) or role -> motion; ``offsets`` role -> (3,)
    (default side by side, as the scene); ``colors`` role -> base colour; ``follow`` keeps the pelvis in view;
    ``title`` (upper left, wrapped, never cut), ``frame_label`` ("frame k / T-1", upper right), ``legend`` (role
    names; default with more than one role). ``elevation`` (degrees) is kept within 2..85: the camera looks down
    on the floor.
    """

    def __init__(self, motions: np.ndarray | Mapping[str, np.ndarray], *, size: tuple[int, int] = (640, 480),
                 offsets: Mapping[str, Sequence[float]] | None = None, spacing: float = 0.6,
                 colors: Mapping[str, ColorLike] | None = None, follow: bool = True, azimuth: float | None = None,
                 elevation: float = 18.0, joint_radius: float = 0.032, bone_radius: float = 0.02,
                 floor: bool = True, path: bool = True, tile: float = 0.5, title: str | None = None,
                 frame_label: bool = False, legend: bool | None = None) -> None:
        data = as_motion_dict(motions)
        shifts, colors = place_roles(data, offsets=offsets, colors=colors, spacing=spacing)
        self.size = (int(size[0]), int(size[1]))
        if min(self.size) < 16:
            raise ValueError(f"size {self.size} is too small to draw")
        self.roles: list[_Role] = []
        for i, (role, joints) in enumerate(data.items()):
            base = colors.get(role, ROLE_PALETTE[i % len(ROLE_PALETTE)])
            path_color = tuple(int(v) for v in mix(color_to_rgb(base)[None], "black", 0.2)[0])
            self.roles.append(_Role(role, joints + shifts[role], default_joint_colors(base), path_color))
        self.n_frames = max(len(r.joints) for r in self.roles)
        motions_drawn = {r.name: r.joints for r in self.roles}
        self.camera, self._shifts = camera_for(motions_drawn, size=self.size, follow=follow, azimuth=azimuth,
                                               elevation=elevation)
        self._scale = self.size[1] / 480.0  # text and outlines scale with the picture's height
        self._joint_radii = np.full(N_JOINTS, joint_radius)
        self._joint_radii[HEAD] = max(2.6 * joint_radius, 0.07)
        self._bone_radius = bone_radius
        frames = np.arange(self.n_frames)
        stacked = np.stack([r.joints[np.minimum(frames, len(r.joints) - 1)] for r in self.roles])  # (R, T, 22, 3)
        px, py, depth = self.camera.project(stacked.transpose(1, 0, 2, 3), self._shifts)  # (T, R, 22)
        self._px, self._py, self._depth = px, py, depth
        self._background = self._sky()
        self._floor = self._floor_texture(tile=tile) if floor else None
        self._paths = [self._root_path(role) for role in self.roles] if path else []
        self._frame_label = frame_label
        self._overlays = self._static_text(title, legend if legend is not None else len(self.roles) > 1)
        self._label_font = font(round(15 * self._scale))

    # ------------------------------------------------------------------ static layers
    def _sky(self) -> Image.Image:
        w, h = self.size
        t = np.linspace(0.0, 1.0, h)[:, None]
        rows = np.round(np.asarray(SKY_TOP) * (1 - t) + np.asarray(SKY_BOTTOM) * t).astype(np.uint8)  # (h, 3)
        return Image.fromarray(np.ascontiguousarray(np.broadcast_to(rows[:, None, :], (h, w, 3))), "RGB")

    def _floor_texture(self, *, tile: float) -> dict:
        pts = np.concatenate([r.joints.reshape(-1, 3) for r in self.roles])
        margin = 0.75
        lo = np.floor((pts[:, [0, 2]].min(axis=0) - margin) / tile) * tile
        hi = np.ceil((pts[:, [0, 2]].max(axis=0) + margin) / tile) * tile
        extent = hi - lo
        ppm = float(min(96.0, 4096.0 / max(extent.max(), 1e-6)))  # texture pixels a metre
        tw, th = (int(round(e * ppm)) for e in extent)
        nx, nz = (max(1, int(round(e / tile))) for e in extent)
        ix = np.minimum((np.arange(tw) + 0.5) / ppm // tile, nx - 1).astype(int)
        iz = np.minimum((np.arange(th) + 0.5) / ppm // tile, nz - 1).astype(int)
        parity = (iz[:, None] + ix[None, :]) % 2  # (th, tw): rows are world z, columns world x
        rgba = np.empty((th, tw, 4), dtype=np.uint8)
        rgba[..., :3] = np.asarray(FLOOR_SHADED, dtype=np.uint8)[parity]
        rgba[..., 3] = 255
        texture = Image.fromarray(rgba, "RGBA")
        corners = np.array([[lo[0], _FLOOR_Y, lo[1]], [hi[0], _FLOOR_Y, lo[1]], [hi[0], _FLOOR_Y, hi[1]],
                            [lo[0], _FLOOR_Y, hi[1]]])
        return {"image": texture, "origin": (float(lo[0]), float(lo[1])), "ppm": ppm, "corners": corners}

    @staticmethod
    def _root_path(role: _Role) -> np.ndarray | None:
        """The pelvis projected on the floor (N, 3) without repeated points; None if it never moves."""
        root = role.joints[:, PELVIS].copy()
        root[:, 1] = _PATH_LIFT
        keep = np.concatenate([[True], np.linalg.norm(np.diff(root, axis=0), axis=1) > 1e-5])
        root = root[keep]
        return root if len(root) >= 2 else None

    def _static_text(self, title: str | None, legend: bool) -> list[tuple[Image.Image, tuple[int, int]]]:
        w, h = self.size
        s = self._scale
        margin, pad = max(4, round(8 * s)), max(2, round(5 * s))
        overlays = []
        if title:
            # the frame label's corner is kept free: its widest text at its font, plus a gap
            last = self.n_frames - 1
            label_w = (font(round(15 * s)).getlength(f"frame {last} / {last}") + 2 * pad + 2 * margin
                       if self._frame_label else 0)
            width = w - 2 * margin - 2 * pad - label_w
            fnt, lines = fit_title(str(title), width=width, scale=s)
            self.title_font, self.title_lines = fnt, lines
            overlays.append((_text_box(lines, fnt, pad=pad, line_gap=max(1, round(2 * s))), (margin, margin)))
        else:
            self.title_font, self.title_lines = None, []
        if legend:
            fnt = font(round(14 * s))
            ascent, descent = fnt.getmetrics()
            dot = ascent + descent
            names = [r.name for r in self.roles]
            box_w = int(max(fnt.getlength(n) for n in names) + dot + 3 * pad)
            box_h = int(len(names) * dot + (len(names) + 1) * pad)
            box = Image.new("RGBA", (box_w, box_h), (0, 0, 0, 0))
            draw = ImageDraw.Draw(box)
            draw.rounded_rectangle((0, 0, box_w - 1, box_h - 1), radius=pad, fill=(255, 255, 255, 185))
            for i, role in enumerate(self.roles):
                y = pad + i * (dot + pad)
                colour = tuple(int(v) for v in role.joint_colors[PELVIS])
                draw.ellipse((pad, y + dot * 0.15, pad + dot * 0.7, y + dot * 0.85), fill=colour + (255,))
                draw.text((2 * pad + dot * 0.7, y), role.name, font=fnt, fill=TEXT_COLOR + (255,))
            overlays.append((box, (margin, h - margin - box_h)))
        return overlays

    # ------------------------------------------------------------------ one frame
    def frame(self, k: int) -> Image.Image:
        """Frame ``k`` as an RGB image (a motion shorter than ``k`` holds its last pose)."""
        if not 0 <= k < self.n_frames:
            raise IndexError(f"frame {k} out of range 0..{self.n_frames - 1}")
        img = self._background.copy()
        if self._floor is not None:
            self._draw_floor(img, k)
        self._draw_paths(img, k)
        self._draw_skeletons(img, k)
        for overlay, xy in self._overlays:
            img.paste(overlay, xy, overlay)
        if self._frame_label:
            self._draw_frame_label(img, k)
        return img

    def frames(self, indices: Sequence[int] | None = None) -> Iterator[np.ndarray]:
        """Frames (H, W, 3) uint8 of ``indices`` (default all)."""
        for k in range(self.n_frames) if indices is None else indices:
            yield np.asarray(self.frame(int(k)))

    def _draw_floor(self, img: Image.Image, k: int) -> None:
        box = self._floor_box(k)
        if box is None:
            return
        x0, y0, x1, y1 = box
        floor = self._floor
        coeffs = self.camera.floor_coefficients(self._shifts[k], corner=(x0, y0), origin=floor["origin"],
                                                ppm=floor["ppm"])
        # nearest texels: a third of bilinear's cost; the tiles' edges are stepped as in the pyvista export
        layer = floor["image"].transform((x1 - x0, y1 - y0), Image.Transform.PERSPECTIVE, coeffs,
                                         resample=Image.Resampling.NEAREST, fillcolor=(0, 0, 0, 0))
        img.paste(layer, (x0, y0), layer)

    def _floor_box(self, k: int) -> tuple[int, int, int, int] | None:
        """The image box (x0, y0, x1, y1) holding the floor at frame ``k`` (below the horizon), None if none."""
        w, h = self.size
        cam = self.camera
        row0 = max(0, int(np.floor(cam.horizon_row())) + 2)
        if row0 >= h:
            return None
        # the floor's corners in camera space, clipped to the part in front of the camera (Sutherland-Hodgman)
        rel = self._floor["corners"] - (cam.position + self._shifts[k])
        pts = np.stack([rel @ cam.right, rel @ cam.up, rel @ cam.forward], axis=1)
        kept = []
        for i in range(4):
            p, q = pts[i], pts[(i + 1) % 4]
            if p[2] > NEAR:
                kept.append(p)
            if (p[2] > NEAR) != (q[2] > NEAR):
                t = (NEAR - p[2]) / (q[2] - p[2])
                kept.append(p + t * (q - p))
        if not kept:
            return None
        kept = np.array(kept)
        xs = w / 2 + cam.focal * kept[:, 0] / kept[:, 2]
        ys = h / 2 - cam.focal * kept[:, 1] / kept[:, 2]
        x0, x1 = max(0, int(np.floor(xs.min())) - 1), min(w, int(np.ceil(xs.max())) + 1)
        y0, y1 = max(row0, int(np.floor(ys.min())) - 1), min(h, int(np.ceil(ys.max())) + 1)
        return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None

    def _draw_paths(self, img: Image.Image, k: int) -> None:
        """Each root path as a line on the floor (the part in front of the camera)."""
        if not self._paths:
            return
        draw = ImageDraw.Draw(img)
        width = max(2, int(round(2.6 * self._scale)))
        shift = self._shifts[k : k + 1]
        for role, root in zip(self.roles, self._paths):
            if root is None:
                continue
            x, y, depth = self.camera.project(root[None], shift)
            x, y, ok = x[0].tolist(), y[0].tolist(), (depth[0] > NEAR).tolist()
            run: list[tuple[float, float]] = []
            for xi, yi, v in zip(x, y, ok):
                if v:
                    run.append((xi, yi))
                    continue
                if len(run) >= 2:
                    draw.line(run, fill=role.path_color, width=width, joint="curve")
                run = []
            if len(run) >= 2:
                draw.line(run, fill=role.path_color, width=width, joint="curve")

    def _draw_skeletons(self, img: Image.Image, k: int) -> None:
        px, py, depth = self._px[k], self._py[k], self._depth[k]  # (R, 22)
        f = self.camera.focal
        safe = np.maximum(depth, NEAR)
        joint_r = f * self._joint_radii[None] / safe
        bone_r = f * self._bone_radius / safe
        visible = depth > NEAR
        if not visible.any():
            return
        w, h = self.size
        reach = float(joint_r[visible].max()) + 3
        x0 = int(max(0, np.floor(px[visible].min() - reach)))
        y0 = int(max(0, np.floor(py[visible].min() - reach)))
        x1 = int(min(w, np.ceil(px[visible].max() + reach)))
        y1 = int(min(h, np.ceil(py[visible].max() + reach)))
        if x1 <= x0 or y1 <= y0:
            return
        ss = SUPERSAMPLE
        crop = img.crop((x0, y0, x1, y1))
        big = crop.resize(((x1 - x0) * ss, (y1 - y0) * ss), Image.Resampling.NEAREST)
        draw = ImageDraw.Draw(big)
        X, Y = ((px - x0) * ss).tolist(), ((py - y0) * ss).tolist()
        outline = max(1.0, 1.2 * self._scale) * ss
        # per bone (R, 21): width, and the offset of its lit stripe (towards the upper left, the light's side)
        width = (bone_r[:, BONE_PARENTS] + bone_r[:, BONE_CHILDREN]) * ss
        dx = px[:, BONE_CHILDREN] - px[:, BONE_PARENTS]
        dy = py[:, BONE_CHILDREN] - py[:, BONE_PARENTS]
        norm = np.maximum(np.hypot(dx, dy), 1e-9)
        nx, ny = dy / norm, -dx / norm
        flip = np.where(nx + ny > 0, -1.0, 1.0)  # the normal pointing up-left
        off_x, off_y = (nx * flip * width * 0.22).tolist(), (ny * flip * width * 0.22).tolist()
        stripe = (width > 3 * ss) & (norm > 1e-6)
        width_edge = np.round(width + 2 * outline).astype(int).tolist()
        width_fill = np.maximum(1, np.round(width)).astype(int).tolist()
        width_light = np.maximum(1, np.round(width * 0.3)).astype(int).tolist()
        stripe, width = stripe.tolist(), width.tolist()
        rad = (joint_r * ss).tolist()
        bone_depth = 0.5 * (depth[:, BONE_PARENTS] + depth[:, BONE_CHILDREN])
        bone_ok = visible[:, BONE_PARENTS] & visible[:, BONE_CHILDREN]
        items = []  # (depth, kind, role index, element); a joint is drawn just after bones of its depth
        for r in range(len(self.roles)):
            items += [(d, 0, r, b) for b, d in enumerate(bone_depth[r].tolist()) if bone_ok[r, b]]
            items += [(d - 1e-4, 1, r, j) for j, d in enumerate(depth[r].tolist()) if visible[r, j]]
        items.sort(key=lambda it: -it[0])
        for _, kind, r, e in items:
            role = self.roles[r]
            xr, yr = X[r], Y[r]
            if kind == 0:
                p, c = _PARENT_LIST[e], _CHILD_LIST[e]
                ends = [(xr[p], yr[p]), (xr[c], yr[c])]
                draw.line(ends, fill=role.edge[c], width=width_edge[r][e])
                draw.line(ends, fill=role.fill[c], width=width_fill[r][e])
                if stripe[r][e]:
                    ox, oy = off_x[r][e], off_y[r][e]
                    draw.line([(xr[p] + ox, yr[p] + oy), (xr[c] + ox, yr[c] + oy)], fill=role.light[c],
                              width=width_light[r][e])
            else:
                rr, cx, cy = rad[r][e], xr[e], yr[e]
                ro = rr + outline
                draw.ellipse((cx - ro, cy - ro, cx + ro, cy + ro), fill=role.edge[e])
                draw.ellipse((cx - rr, cy - rr, cx + rr, cy + rr), fill=role.fill[e])
                if rr > 3 * ss:
                    hr, hx, hy = rr * 0.35, cx - rr * 0.35, cy - rr * 0.35
                    draw.ellipse((hx - hr, hy - hr, hx + hr, hy + hr), fill=role.light[e])
        img.paste(big.reduce(ss), (x0, y0))

    def _draw_frame_label(self, img: Image.Image, k: int) -> None:
        w, _ = self.size
        s = self._scale
        margin, pad = max(4, round(8 * s)), max(2, round(5 * s))
        text = f"frame {k} / {self.n_frames - 1}"
        fnt = self._label_font
        tw = fnt.getlength(text)
        x = w - margin - pad - tw
        ImageDraw.Draw(img).text((x, margin + pad), text, font=fnt, fill=TEXT_COLOR)


def _tuple(rgb: np.ndarray) -> tuple[int, int, int]:
    return int(rgb[0]), int(rgb[1]), int(rgb[2])


# ---------------------------------------------------------------------------------------------- files
def frame_indices(n_frames: int, every: int) -> list[int]:
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    return list(range(0, n_frames, every))


def write_gif(renderer: FlatRenderer, path: str | Path, *, fps: float = 20.0, every: int = 1, loop: int = 0) -> Path:
    """Frames 0, every, ... as an animated GIF at real speed (each frame ``every / fps`` s).

    One palette for the whole GIF, made once from the first, middle and last frames (which hold every colour the
    drawing uses: sky, floor, skeleton, text); each frame is then mapped to it without dithering. A palette a frame
    (Pillow's default) costs more and makes the floor flicker.
    """
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    indices = frame_indices(renderer.n_frames, every)
    palette = gif_palette([renderer.frame(k) for k in sorted({indices[0], indices[len(indices) // 2], indices[-1]})])
    frames = [renderer.frame(k).quantize(palette=palette, dither=Image.Dither.NONE) for k in indices]
    # duration in ms: Pillow writes whole centiseconds; 20 fps and 10 fps are exact
    frames[0].save(out, format="GIF", save_all=True, append_images=frames[1:], duration=1000.0 * every / fps,
                   loop=loop, optimize=False, disposal=1)
    return out


def gif_palette(samples: Sequence[Image.Image]) -> Image.Image:
    """A 256-colour palette image from sample frames (stacked, median cut)."""
    w = samples[0].width
    stack = Image.new("RGB", (w, sum(s.height for s in samples)))
    y = 0
    for s in samples:
        stack.paste(s, (0, y))
        y += s.height
    return stack.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)


def write_mp4(renderer: FlatRenderer, path: str | Path, *, fps: float = 20.0, every: int = 1, quality: float = 7.0,
              preset: str = "veryfast") -> Path:
    """Frames 0, every, ... as an H.264 MP4 (yuv420p) at ``fps / every`` frames a second (real speed), encoded by
    imageio-ffmpeg's ffmpeg with x264 ``preset``. Odd sizes must be avoided by the caller (H.264 needs even sizes)."""
    import imageio.v2 as imageio_v2

    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    w, h = renderer.size
    if w % 2 or h % 2:
        raise ValueError(f"an MP4 needs an even width and height, got {w}x{h}")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = imageio_v2.get_writer(out, format="FFMPEG", mode="I", fps=fps / every, codec="libx264", quality=quality,
                                   pixelformat="yuv420p", macro_block_size=2, ffmpeg_log_level="error",
                                   ffmpeg_params=["-preset", preset])
    try:
        for k in frame_indices(renderer.n_frames, every):
            writer.append_data(np.asarray(renderer.frame(k)))
    finally:
        writer.close()
    return out
