"""``SkeletonScene``: a pyvista scene of one or more skeletons, built once, updated in place.

Each skeleton (a *role*: "motion", "leader", "follower", "reference", "edited", ...) is two
meshes with fixed topology: 22 joint spheres merged into one PolyData and 21 bone tubes
merged into another. ``set_frame(k)`` rewrites their points, normals and colours in place;
no actor or mesh is created after construction. A checkerboard floor at y=0 covers the
motions' extent and each root path (the pelvis projected on the floor) is drawn as a line.

The underlying ``pv.Plotter`` is ``scene.plotter`` (off-screen by default), so an app can
embed it (e.g. Panel's VTK pane) and tests can take screenshots.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyvista as pv

from engine.skeleton import JOINT_NAMES
from viz.camera import facing_azimuth, fit_points, view_direction
from viz.colors import (
    FLOOR_COLORS,
    ROLE_PALETTE,
    ColorLike,
    color_to_rgb,
    default_joint_colors,
    mix,
    rgb_array,
    values_to_rgb,
)
from viz.geometry import (
    BONE_CHILDREN,
    checker_floor,
    merged_polydata,
    polyline,
    sphere_points,
    sphere_template,
    tube_points,
    tube_template,
)
from viz.layout import place_roles

N_JOINTS = len(JOINT_NAMES)
HEAD = JOINT_NAMES.index("head")
PELVIS = JOINT_NAMES.index("pelvis")
DEFAULT_ROLE = "motion"
_PATH_LIFT = 0.006  # root path sits just above the floor to avoid z-fighting
_FLOOR_HEIGHT = -0.002


def as_motion(joints: object, *, name: str = "joints") -> np.ndarray:
    """Validate and copy one motion as float64 (T, 22, 3); a single pose (22, 3) becomes T=1."""
    arr = np.asarray(joints, dtype=np.float64)
    if arr.shape == (N_JOINTS, 3):
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (N_JOINTS, 3) or arr.shape[0] < 1:
        raise ValueError(f"{name} must have shape (T, {N_JOINTS}, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr.copy()


def as_motions(motions: object) -> dict[str, np.ndarray]:
    """One array (role ``"motion"``) or a mapping role -> array, validated."""
    if isinstance(motions, Mapping):
        if not motions:
            raise ValueError("no motions given")
        return {str(role): as_motion(m, name=f"motion {role!r}") for role, m in motions.items()}
    return {DEFAULT_ROLE: as_motion(motions)}


@dataclass
class _Skeleton:
    """One role's data, meshes and colours."""

    role: str
    joints: np.ndarray  # (T, 22, 3), offset applied
    base_colors: np.ndarray  # (22, 3) uint8
    joint_mesh: pv.PolyData
    bone_mesh: pv.PolyData
    path_mesh: pv.PolyData | None
    actors: dict[str, pv.Actor] = field(default_factory=dict)
    colors: np.ndarray | None = None  # (22, 3) static colours
    frame_colors: np.ndarray | None = None  # (T, 22, 3) per-frame colours

    @property
    def n_frames(self) -> int:
        return self.joints.shape[0]


class SkeletonScene:
    """A pyvista scene of skeletons (bones as tubes, joints as spheres) on a floor, built once.

    Args:
        motions: joints (T, 22, 3) of one motion, or a mapping role -> joints for several
            skeletons (e.g. ``{"leader": a, "follower": b, "out": c}``); motions may differ in
            length (a short one holds its last pose).
        offsets: role -> (3,) translation added to that motion. Default: side by side along X
            without overlap (pass zeros to put two people in one shared space).
        spacing: gap in metres between side-by-side motions when ``offsets`` is None.
        colors: role -> base colour; default from ``ROLE_PALETTE`` in role order.
        size: window size in pixels (width, height).
        follow: keep the camera on the pelvis (mean pelvis of all roles) as frames change.
        azimuth: camera heading in degrees (from +Z towards +X); None = a 3/4 front view of
            the first motion's initial facing.
        elevation: camera height angle in degrees above the horizon.
        joint_radius: sphere radius in metres (the head gets a larger sphere).
        bone_radius: tube radius in metres.
        floor: draw the checkerboard floor.
        path: draw each root path on the floor.
        tile: checkerboard tile size in metres.
        title: text in the upper left corner (e.g. the prompt).
        frame_label: show "frame k / T-1" in the upper right corner.
        legend: show role names and colours; default when there is more than one role.
        anti_aliasing: pyvista anti-aliasing ("msaa", "ssaa", "fxaa") or None; off-screen
            EGL/OSMesa builds of VTK replace "fxaa" by the slower "ssaa".
        off_screen: render off screen (no window); keep True for tests, files and servers.
    """

    def __init__(
        self,
        motions: np.ndarray | Mapping[str, np.ndarray],
        *,
        offsets: Mapping[str, Sequence[float]] | None = None,
        spacing: float = 0.6,
        colors: Mapping[str, ColorLike] | None = None,
        size: tuple[int, int] = (640, 480),
        follow: bool = False,
        azimuth: float | None = None,
        elevation: float = 18.0,
        joint_radius: float = 0.032,
        bone_radius: float = 0.02,
        floor: bool = True,
        path: bool = True,
        tile: float = 0.5,
        title: str | None = None,
        frame_label: bool = False,
        legend: bool | None = None,
        anti_aliasing: str | None = "ssaa",
        off_screen: bool = True,
    ) -> None:
        data = as_motions(motions)
        shifts, colors = place_roles(data, offsets=offsets, colors=colors, spacing=spacing)

        self._follow_enabled = bool(follow)
        self.elevation = float(np.clip(elevation, -85.0, 85.0))
        self._sphere = sphere_template()
        self._tube = tube_template()
        self._joint_radii = np.full(N_JOINTS, joint_radius)
        self._joint_radii[HEAD] = max(2.6 * joint_radius, 0.07)
        self._bone_radius = bone_radius
        self._frame = 0
        self._followed_root = np.zeros(3)
        self.guide_names: list[str] = []  # actors a caller added beside the skeletons (drawn target paths)

        self.plotter = pv.Plotter(off_screen=off_screen, window_size=list(size))
        self.plotter.set_background("white", top="#cfdcec")
        if anti_aliasing:
            self.plotter.enable_anti_aliasing(anti_aliasing)

        self._skeletons: dict[str, _Skeleton] = {}
        for i, (role, joints) in enumerate(data.items()):
            base = colors.get(role, ROLE_PALETTE[i % len(ROLE_PALETTE)])
            self._skeletons[role] = self._build_skeleton(
                role, joints + shifts[role], base=base, with_path=path
            )
        all_joints = np.concatenate([s.joints.reshape(-1, 3) for s in self._skeletons.values()])
        self._track = self._root_track()

        self.floor_mesh: pv.PolyData | None = None
        self.floor_actor: pv.Actor | None = None
        if floor:
            self._build_floor(all_joints, tile=tile)

        self._title_actor = self.plotter.add_text(title, position="upper_left", font_size=11) if title else None
        self._frame_actor = (
            self.plotter.add_text(" ", position="upper_right", font_size=10) if frame_label else None
        )
        if legend if legend is not None else len(self._skeletons) > 1:
            entries = [
                {"label": role, "color": color_to_rgb(s.base_colors[PELVIS]) / 255.0}
                for role, s in self._skeletons.items()
            ]
            # large enough to read on the 720-px compare picture (the text scales with the box)
            self.plotter.add_legend(entries, bcolor="white", size=(0.3, 0.075 * len(entries)), face="circle")

        first = next(iter(self._skeletons.values()))
        self.azimuth = facing_azimuth(first.joints[0]) + 30.0 if azimuth is None else float(azimuth)
        self.set_frame(0)
        self.reset_camera()

    # ------------------------------------------------------------------ construction
    def _build_skeleton(self, role: str, joints: np.ndarray, *, base: ColorLike, with_path: bool) -> _Skeleton:
        joint_mesh = merged_polydata(self._sphere, N_JOINTS)
        bone_mesh = merged_polydata(self._tube, len(BONE_CHILDREN))
        joint_mesh.point_data["rgb"] = np.zeros((joint_mesh.n_points, 3), dtype=np.uint8)
        bone_mesh.point_data["rgb"] = np.zeros((bone_mesh.n_points, 3), dtype=np.uint8)
        base_colors = default_joint_colors(base)
        style = dict(scalars="rgb", rgb=True, ambient=0.25, diffuse=0.8, specular=0.25, specular_power=20.0)
        skel = _Skeleton(
            role=role,
            joints=joints,
            base_colors=base_colors,
            joint_mesh=joint_mesh,
            bone_mesh=bone_mesh,
            path_mesh=None,
        )
        skel.actors["bones"] = self.plotter.add_mesh(bone_mesh, name=f"{role}/bones", **style)
        skel.actors["joints"] = self.plotter.add_mesh(joint_mesh, name=f"{role}/joints", **style)
        root = _root_path(joints) if with_path else None
        if root is not None:
            skel.path_mesh = polyline(root).tube(radius=0.008, n_sides=8)
            path_color = mix(color_to_rgb(base)[None], "black", 0.2)[0] / 255.0
            skel.actors["path"] = self.plotter.add_mesh(
                skel.path_mesh, name=f"{role}/path", color=path_color, ambient=0.4, diffuse=0.6
            )
        return skel

    def _build_floor(self, points: np.ndarray, *, tile: float) -> None:
        margin = 0.75
        lo = np.floor((points[:, [0, 2]].min(axis=0) - margin) / tile) * tile
        hi = np.ceil((points[:, [0, 2]].max(axis=0) + margin) / tile) * tile
        mesh, parity = checker_floor(
            x_range=(lo[0], hi[0]), z_range=(lo[1], hi[1]), tile=tile, height=_FLOOR_HEIGHT
        )
        mesh.cell_data["rgb"] = np.array(FLOOR_COLORS, dtype=np.uint8)[parity]
        self.floor_mesh = mesh
        self.floor_actor = self.plotter.add_mesh(
            mesh, name="floor", scalars="rgb", rgb=True, ambient=0.35, diffuse=0.7, specular=0.0
        )

    # ------------------------------------------------------------------ properties
    @property
    def roles(self) -> tuple[str, ...]:
        """Role names in the order given."""
        return tuple(self._skeletons)

    @property
    def n_frames(self) -> int:
        """Number of frames of the longest motion."""
        return max(s.n_frames for s in self._skeletons.values())

    @property
    def frame(self) -> int:
        """The frame currently shown."""
        return self._frame

    @property
    def follow(self) -> bool:
        """Whether the camera translates with the pelvis as frames change (settable)."""
        return self._follow_enabled

    @follow.setter
    def follow(self, value: bool) -> None:
        self._follow_enabled = bool(value)
        self._followed_root = self._current_root_xz()

    @property
    def meshes(self) -> dict[str, dict[str, pv.PolyData]]:
        """role -> {"joints", "bones"[, "path"]} meshes (the objects the actors draw)."""
        out: dict[str, dict[str, pv.PolyData]] = {}
        for role, s in self._skeletons.items():
            out[role] = {"joints": s.joint_mesh, "bones": s.bone_mesh}
            if s.path_mesh is not None:
                out[role]["path"] = s.path_mesh
        return out

    @property
    def actors(self) -> dict[str, dict[str, pv.Actor]]:
        """role -> {"joints", "bones"[, "path"]} actors."""
        return {role: dict(s.actors) for role, s in self._skeletons.items()}

    def joints(self, *, role: str | None = None) -> np.ndarray:
        """The motion (T, 22, 3) of a role as drawn (offset applied); default the first role."""
        return self._select(role)[0].joints

    # ------------------------------------------------------------------ frames
    def set_frame(self, frame: int) -> None:
        """Show frame ``frame``: rewrite mesh points, normals and colours in place.

        A motion shorter than ``frame`` holds its last pose. With ``follow`` the camera
        translates with the pelvis. Nothing is rendered; call ``render()`` or ``screenshot()``.
        """
        k = int(frame)
        if not 0 <= k < self.n_frames:
            raise IndexError(f"frame {k} out of range 0..{self.n_frames - 1}")
        self._frame = k
        for skel in self._skeletons.values():
            pose = skel.joints[min(k, skel.n_frames - 1)]
            _write(skel.joint_mesh, points=sphere_points(self._sphere, pose, self._joint_radii))
            pts, normals = tube_points(self._tube, pose, self._bone_radius)
            _write(skel.bone_mesh, points=pts, normals=normals)
            self._apply_colors(skel)
        if self._frame_actor is not None:
            self._frame_actor.SetText(3, f"frame {k} / {self.n_frames - 1}")
        if self.follow:
            self._follow()

    def set_title(self, text: str) -> None:
        """Set (or add) the text in the upper left corner."""
        if self._title_actor is None:
            self._title_actor = self.plotter.add_text(text, position="upper_left", font_size=11)
        else:
            self._title_actor.SetText(2, text)

    def render(self) -> None:
        """Render the current state (needed before reading pixels of an embedded window)."""
        self.plotter.render()

    def screenshot(self) -> np.ndarray:
        """Render and return the image as uint8 (height, width, 3)."""
        self.plotter.render()  # pyvista only renders on its own before the first screenshot
        return np.asarray(self.plotter.screenshot(return_img=True))[..., :3].copy()

    # ------------------------------------------------------------------ camera
    def reset_camera(self) -> None:
        """Default 3/4 front view that frames the body.

        Without ``follow`` the whole motion (all frames, all roles) is framed; with ``follow``
        everything the body does relative to its pelvis is framed, centred on the current pelvis.
        """
        direction = view_direction(azimuth=self.azimuth, elevation=self.elevation)
        width, height = self.plotter.window_size
        if self.follow:
            track = self._track
            rel = np.concatenate(
                [(s.joints - track[: s.n_frames, None]).reshape(-1, 3) for s in self._skeletons.values()]
            )
            pose = fit_points(rel, direction=direction, aspect=width / height, margin=1.1)
            shift = track[self._frame]
            position, focal = pose.position + shift, pose.focal_point + shift
        else:
            pts = np.concatenate([s.joints.reshape(-1, 3) for s in self._skeletons.values()])
            pose = fit_points(pts, direction=direction, aspect=width / height)
            position, focal = pose.position, pose.focal_point
        self._followed_root = self._current_root_xz()
        camera = self.plotter.camera
        camera.view_angle = 30.0
        camera.focal_point = tuple(focal)
        camera.position = tuple(position)
        camera.up = (0.0, 1.0, 0.0)
        self.plotter.renderer.reset_camera_clipping_range()

    def _follow(self) -> None:
        """Translate the camera (position and focal point) by the pelvis' XZ motion since the last frame."""
        target = self._current_root_xz()
        delta = target - self._followed_root
        self._followed_root = target
        if not np.any(delta):
            return
        camera = self.plotter.camera
        camera.focal_point = tuple(np.asarray(camera.focal_point) + delta)
        camera.position = tuple(np.asarray(camera.position) + delta)
        self.plotter.renderer.reset_camera_clipping_range()

    def _root_track(self) -> np.ndarray:
        """Per frame (n_frames, 3): the mean pelvis XZ of all roles (y = 0); what ``follow`` tracks."""
        frames = np.arange(self.n_frames)
        roots = [s.joints[np.minimum(frames, s.n_frames - 1), PELVIS] for s in self._skeletons.values()]
        track = np.mean(roots, axis=0)
        track[:, 1] = 0.0
        return track

    def _current_root_xz(self) -> np.ndarray:
        return self._track[self._frame]

    # ------------------------------------------------------------------ colours
    def set_color(self, color: ColorLike, *, role: str | None = None) -> None:
        """One colour for a whole skeleton (all roles when ``role`` is None)."""
        rgb = color_to_rgb(color)
        for skel in self._select(role):
            skel.colors = np.repeat(rgb[None], N_JOINTS, axis=0)
            skel.frame_colors = None
            self._apply_colors(skel)

    def set_joint_colors(self, colors: np.ndarray, *, role: str | None = None) -> None:
        """Per-joint colours (22, 3) (floats 0..1 or uint8); bones take their child joint's colour."""
        rgb = rgb_array(colors)
        if rgb.shape != (N_JOINTS, 3):
            raise ValueError(f"joint colours must have shape ({N_JOINTS}, 3), got {rgb.shape}")
        for skel in self._select(role):
            skel.colors = rgb.copy()
            skel.frame_colors = None
            self._apply_colors(skel)

    def set_frame_colors(self, colors: np.ndarray, *, role: str | None = None) -> None:
        """Per-frame colours: (T, 3) for the whole skeleton or (T, 22, 3) per joint, applied by ``set_frame``."""
        rgb = rgb_array(colors)
        for skel in self._select(role):
            t = skel.n_frames
            if rgb.shape == (t, 3):
                per_frame = np.repeat(rgb[:, None], N_JOINTS, axis=1)
            elif rgb.shape == (t, N_JOINTS, 3):
                per_frame = rgb.copy()
            else:
                raise ValueError(
                    f"frame colours for {skel.role!r} must have shape ({t}, 3) or ({t}, {N_JOINTS}, 3), got {rgb.shape}"
                )
            skel.frame_colors = per_frame
            self._apply_colors(skel)

    def set_joint_values(
        self,
        values: np.ndarray,
        *,
        role: str | None = None,
        cmap: str = "viridis",
        clim: tuple[float, float] | None = None,
    ) -> None:
        """Colour joints by scalars through a colormap: (22,) static or (T, 22) per frame."""
        vals = np.asarray(values, dtype=np.float64)
        if vals.ndim == 1:
            if vals.shape != (N_JOINTS,):
                raise ValueError(f"joint values must have shape ({N_JOINTS},) or (T, {N_JOINTS}), got {vals.shape}")
            self.set_joint_colors(values_to_rgb(vals, cmap=cmap, clim=clim), role=role)
        elif vals.ndim == 2 and vals.shape[1] == N_JOINTS:
            self.set_frame_colors(values_to_rgb(vals, cmap=cmap, clim=clim), role=role)
        else:
            raise ValueError(f"joint values must have shape ({N_JOINTS},) or (T, {N_JOINTS}), got {vals.shape}")

    def set_frame_values(
        self,
        values: np.ndarray,
        *,
        role: str | None = None,
        cmap: str = "viridis",
        clim: tuple[float, float] | None = None,
    ) -> None:
        """Colour the whole skeleton per frame by one scalar per frame (T,) (e.g. a word's attention)."""
        vals = np.asarray(values, dtype=np.float64)
        if vals.ndim != 1:
            raise ValueError(f"frame values must have shape (T,), got {vals.shape}")
        self.set_frame_colors(values_to_rgb(vals, cmap=cmap, clim=clim), role=role)

    def reset_colors(self, *, role: str | None = None) -> None:
        """Back to the role's default colours."""
        for skel in self._select(role):
            skel.colors = None
            skel.frame_colors = None
            self._apply_colors(skel)

    def _apply_colors(self, skel: _Skeleton) -> None:
        if skel.frame_colors is not None:
            rgb = skel.frame_colors[min(self._frame, skel.n_frames - 1)]
        elif skel.colors is not None:
            rgb = skel.colors
        else:
            rgb = skel.base_colors
        _write_rgb(skel.joint_mesh, np.repeat(rgb, len(self._sphere.points), axis=0))
        _write_rgb(skel.bone_mesh, np.repeat(rgb[BONE_CHILDREN], len(self._tube.points), axis=0))

    # ------------------------------------------------------------------ visibility
    def set_skeleton_visible(self, visible: bool, *, role: str | None = None) -> None:
        """Show or hide bones and joints of a role (all roles when None)."""
        for skel in self._select(role):
            skel.actors["bones"].visibility = bool(visible)
            skel.actors["joints"].visibility = bool(visible)

    def set_path_visible(self, visible: bool, *, role: str | None = None) -> None:
        """Show or hide the root path of a role (all roles when None)."""
        for skel in self._select(role):
            if "path" in skel.actors:
                skel.actors["path"].visibility = bool(visible)

    def set_floor_visible(self, visible: bool) -> None:
        """Show or hide the floor."""
        if self.floor_actor is not None:
            self.floor_actor.visibility = bool(visible)

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Release the render window."""
        self.plotter.close()

    def __enter__(self) -> SkeletonScene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _select(self, role: str | None) -> list[_Skeleton]:
        if role is None:
            return list(self._skeletons.values())
        if role not in self._skeletons:
            raise KeyError(f"unknown role {role!r}; roles: {list(self._skeletons)}")
        return [self._skeletons[role]]


def _root_path(joints: np.ndarray) -> np.ndarray | None:
    """The pelvis projected just above the floor, without repeated points; None if it never moves."""
    root = joints[:, PELVIS].copy()
    root[:, 1] = _PATH_LIFT
    # drop repeated points (standing still): the tube filter needs distinct neighbours
    keep = np.concatenate([[True], np.linalg.norm(np.diff(root, axis=0), axis=1) > 1e-5])
    root = root[keep]
    return root if len(root) >= 2 else None


def _write(mesh: pv.PolyData, *, points: np.ndarray, normals: np.ndarray | None = None) -> None:
    """Overwrite a mesh's points (and normals) in place and mark them modified."""
    mesh.points[:] = points
    mesh.GetPoints().Modified()
    if normals is not None:
        mesh.point_data["Normals"][:] = normals
        mesh.GetPointData().GetNormals().Modified()
    mesh.Modified()


def _write_rgb(mesh: pv.PolyData, rgb: np.ndarray) -> None:
    """Overwrite a mesh's point colours in place and mark them modified."""
    mesh.point_data["rgb"][:] = rgb
    mesh.GetPointData().GetArray("rgb").Modified()
    mesh.Modified()
