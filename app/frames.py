"""Server-side frames for the in-browser player: one pyvista scene per session, JPEGs rendered in the background.

The scene is built once per set of motions (``viz.scene.SkeletonScene``) and only its points,
colours and camera change afterwards. A render thread owns the scene: after every change it
renders the frame on screen first, then the others (from there on, wrapping around), and hands
them out in small batches through ``on_frames(batch)``. The browser caches the frames and plays
them itself, so playback speed does not depend on the server.

Every batch carries a ``motion_key`` (changes when the motions change: the browser drops its
cache) and a ``version`` (changes on any re-render, e.g. camera or colours: the browser keeps
showing older frames until the new ones arrive).
"""
from __future__ import annotations

import io
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from PIL import Image

from app.model_cache import VTK_LOCK

SINGLE_SIZE = (480, 360)
COMPARE_SIZE = (720, 360)
JPEG_QUALITY = 85
BATCH_SECONDS = 0.12


@dataclass(frozen=True, eq=False)
class SceneSpec:
    """What the player shows: roles -> joints, and how to draw them."""

    motions: tuple[tuple[str, np.ndarray], ...]
    follow: bool = True
    show_path: bool = True
    frame_values: np.ndarray | None = None  # (T,) colours for the first role (e.g. a word's attention)
    role_colors: tuple[tuple[str, np.ndarray], ...] = ()  # role -> (T, 3) uint8 per-frame colours (wins over values)
    azimuth_offset: float = 0.0
    camera_serial: int = 0
    title: str = ""
    guides: tuple[tuple[str, str, np.ndarray], ...] = ()  # (role, colour, (N, 3) points): target paths drawn in 3-D
    together: bool = False  # every role in one shared space (a duet), not side by side

    @property
    def roles(self) -> tuple[str, ...]:
        return tuple(r for r, _ in self.motions)

    @property
    def n_frames(self) -> int:
        return max(len(j) for _, j in self.motions)

    @property
    def size(self) -> tuple[int, int]:
        return SINGLE_SIZE if len(self.motions) == 1 else COMPARE_SIZE

    def same_motions(self, other: "SceneSpec | None") -> bool:
        return other is not None and other.together == self.together and len(other.motions) == len(self.motions) and all(
            ra == rb and ja is jb for (ra, ja), (rb, jb) in zip(self.motions, other.motions))


@dataclass
class FrameBatch:
    motion_key: int
    version: int
    n_frames: int
    frames: dict[int, bytes] = field(default_factory=dict)
    done: bool = False  # every frame of this version is rendered


def encode_jpeg(image: np.ndarray, quality: int = JPEG_QUALITY) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="JPEG", quality=quality)
    return buf.getvalue()


class FrameRenderer:
    """Owns a session's ``SkeletonScene`` on a background thread; renders and caches frames."""

    def __init__(self, on_frames: Callable[[FrameBatch], None] | None = None):
        self.on_frames = on_frames
        self._cond = threading.Condition()
        self._spec: SceneSpec | None = None
        self._applied: SceneSpec | None = None
        self._scene = None
        self._version = 0
        self._motion_key = 0
        self._cache: dict[int, bytes] = {}
        self._priority: list[int] = []
        self._cursor = 0
        self._closed = False
        self.errors: list[str] = []
        self.render_seconds: list[float] = []
        self._thread = threading.Thread(target=self._loop, name="moattn-frames", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ API (any thread)
    def show(self, spec: SceneSpec | None, *, frame: int = 0) -> None:
        """Show ``spec`` (None: nothing); frame ``frame`` is rendered first."""
        with self._cond:
            if spec is not None and not spec.same_motions(self._spec):
                self._motion_key += 1
            self._spec = spec
            self._version += 1
            self._cache = {}
            self._priority = [] if spec is None else [int(np.clip(frame, 0, spec.n_frames - 1))]
            self._cursor = self._priority[0] if self._priority else 0
            self._cond.notify_all()

    def prioritize(self, frame: int) -> None:
        """Render ``frame`` next if it is not ready (a scrub or a pick)."""
        with self._cond:
            if self._spec is None or frame in self._cache:
                return
            frame = int(np.clip(frame, 0, self._spec.n_frames - 1))
            self._priority.insert(0, frame)
            self._cursor = frame
            self._cond.notify_all()

    def snapshot(self) -> FrameBatch:
        """Everything rendered so far for the current version (to resend to a freshly loaded page)."""
        with self._cond:
            n = 0 if self._spec is None else self._spec.n_frames
            return FrameBatch(self._motion_key, self._version, n, dict(self._cache), done=n > 0 and len(self._cache) == n)

    @property
    def version(self) -> int:
        return self._version

    @property
    def motion_key(self) -> int:
        return self._motion_key

    def frame_bytes(self, frame: int) -> bytes | None:
        with self._cond:
            return self._cache.get(frame)

    def wait_until_done(self, timeout: float = 60.0) -> bool:
        """Block until every frame of the current version is rendered (tests, export)."""
        end = time.monotonic() + timeout
        with self._cond:
            while True:
                if self._spec is None or len(self._cache) >= self._spec.n_frames:
                    return True
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5)

    # ------------------------------------------------------------------ render thread
    def _next_job(self):
        """(spec, version, frame) to render, or None to stop; waits while there is nothing to do."""
        with self._cond:
            while True:
                if self._closed:
                    return None
                spec = self._spec
                if spec is not None and len(self._cache) < spec.n_frames:
                    while self._priority and self._priority[0] in self._cache:
                        self._priority.pop(0)
                    if self._priority:
                        frame = self._priority.pop(0)
                    else:
                        n = spec.n_frames
                        frame = next(k % n for k in range(self._cursor, self._cursor + n) if k % n not in self._cache)
                    self._cursor = frame + 1
                    return spec, self._version, self._motion_key, frame
                if spec is None and self._applied is not None:
                    return None, self._version, self._motion_key, -1
                self._cond.wait()

    def _loop(self) -> None:
        pending: FrameBatch | None = None
        last_flush = time.monotonic()
        try:
            while True:
                job = self._next_job()
                if job is None:
                    break
                spec, version, motion_key, frame = job
                if spec is None:
                    self._drop_scene()
                    continue
                try:
                    t0 = time.perf_counter()
                    with VTK_LOCK:
                        self._apply(spec)
                        self._scene.set_frame(min(frame, self._scene.n_frames - 1))
                        image = self._scene.screenshot()
                    data = encode_jpeg(image)
                    self.render_seconds.append(time.perf_counter() - t0)
                    del self.render_seconds[:-200]
                except Exception as exc:  # a broken motion must not kill the thread
                    traceback.print_exc()
                    self.errors.append(str(exc))
                    with self._cond:
                        if self._version == version:
                            self._spec = None
                    continue
                with self._cond:
                    if self._version != version:
                        continue  # the spec changed while rendering: drop this frame
                    self._cache[frame] = data
                    done = len(self._cache) >= spec.n_frames
                    self._cond.notify_all()
                if pending is None or pending.version != version:
                    pending = FrameBatch(motion_key, version, spec.n_frames)
                pending.frames[frame] = data
                pending.done = done
                now = time.monotonic()
                first = len(pending.frames) == 1 and (frame == 0 or len(self._cache) == 1)
                if done or first or now - last_flush >= BATCH_SECONDS:
                    self._emit(pending)
                    pending, last_flush = None, now
        finally:
            self._drop_scene()

    def _emit(self, batch: FrameBatch) -> None:
        if self.on_frames is not None:
            try:
                self.on_frames(batch)
            except Exception:
                traceback.print_exc()

    def _drop_scene(self) -> None:
        with VTK_LOCK:
            if self._scene is not None:
                self._scene.close()
                self._scene = None
        self._applied = None

    def _apply(self, spec: SceneSpec) -> None:
        """Bring the scene to ``spec``: rebuild only if the motions changed, else update in place."""
        old = self._applied
        if old is spec:
            return
        from viz.scene import SkeletonScene

        if self._scene is None or not spec.same_motions(old):
            if self._scene is not None:
                self._scene.close()
            self._scene = SkeletonScene(dict(spec.motions), size=spec.size, follow=spec.follow,
                                        anti_aliasing="msaa", frame_label=True, title=spec.title or None,
                                        offsets=_offsets(spec))
            self._base_azimuth = self._scene.azimuth
            old = None
        scene = self._scene
        if old is None or old.show_path != spec.show_path:
            scene.set_path_visible(spec.show_path)
        if _colors_changed(old, spec):
            colored = dict(spec.role_colors)
            for i, (role, joints) in enumerate(spec.motions):
                if role in colored:
                    rgb = np.asarray(colored[role])
                    scene.set_frame_colors(rgb[np.linspace(0, len(rgb) - 1, len(joints)).round().astype(int)],
                                           role=role)
                elif i == 0 and spec.frame_values is not None:
                    values = np.asarray(spec.frame_values, dtype=np.float64)
                    n = len(joints)
                    values = np.interp(np.arange(n), np.linspace(0, n - 1, len(values)), values) if len(values) != n else values
                    hi = float(values.max()) if values.size and values.max() > 0 else 1.0
                    scene.set_frame_values(values, role=role, cmap="plasma", clim=(0.0, hi))
                else:
                    scene.reset_colors(role=role)
        if old is None or old.guides is not spec.guides or old.show_path != spec.show_path:
            _draw_guides(scene, spec)
        if old is not None and old.title != spec.title:
            scene.set_title(spec.title)
        if (old is None or old.follow != spec.follow or old.azimuth_offset != spec.azimuth_offset
                or old.camera_serial != spec.camera_serial):
            scene.follow = spec.follow
            scene.azimuth = self._base_azimuth + spec.azimuth_offset
            scene.reset_camera()
        self._applied = spec


def _draw_guides(scene, spec: SceneSpec) -> None:
    """Target paths (e.g. a drawn root path) as thin tubes beside the skeletons, shifted like their role."""
    from viz.geometry import polyline
    from viz.scene import side_by_side_offsets

    for name in scene.guide_names:
        scene.plotter.remove_actor(name, render=False)
    scene.guide_names = []
    if not spec.show_path:  # the "root path" checkbox shows or hides the target paths too
        return
    shifts = _offsets(spec) or side_by_side_offsets(dict(spec.motions), spacing=0.6)
    for k, (role, color, points) in enumerate(spec.guides):
        pts = np.asarray(points, dtype=np.float64)
        pts = pts[np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-5])]
        if role not in shifts or len(pts) < 2 or not np.isfinite(pts).all():
            continue
        name = f"guide/{k}"
        scene.plotter.add_mesh(polyline(pts + shifts[role]).tube(radius=0.012, n_sides=8), name=name, color=color,
                               ambient=0.5, diffuse=0.6, opacity=0.85)
        scene.guide_names.append(name)


def _offsets(spec: SceneSpec) -> dict[str, tuple[float, float, float]] | None:
    """Zero offsets for a shared space; None for the scene's default (side by side)."""
    return {r: (0.0, 0.0, 0.0) for r in spec.roles} if spec.together else None


def _colors_changed(old: SceneSpec | None, spec: SceneSpec) -> bool:
    if old is None or old.frame_values is not spec.frame_values:
        return True
    a, b = dict(old.role_colors), dict(spec.role_colors)
    return a.keys() != b.keys() or any(a[r] is not b[r] for r in b)
