"""Fixed-topology skeleton meshes whose points are recomputed per frame.

Joints are one merged PolyData of spheres (a template sphere translated per joint); bones
are one merged PolyData of open tubes (a unit tube template transformed per bone by a frame
built from the bone's direction and length). Topology and array identities never change, so
a scene can rewrite ``.points`` (and normals) in place for every frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyvista as pv

from engine.skeleton import PARENTS

#: (parent, child) joint indices of the 21 bones, ordered by child joint.
BONES: tuple[tuple[int, int], ...] = tuple((p, c) for c, p in enumerate(PARENTS) if p >= 0)
BONE_CHILDREN = np.array([c for _, c in BONES])
BONE_PARENTS = np.array([p for p, _ in BONES])


@dataclass(frozen=True)
class Template:
    """A unit mesh repeated once per item: its points, normals and VTK face array."""

    points: np.ndarray  # (P, 3)
    normals: np.ndarray  # (P, 3)
    faces: np.ndarray  # VTK face array of one copy: [n, i0, i1, ..., n, ...]


def sphere_template(*, resolution: int = 16) -> Template:
    """A unit sphere (radius 1, centred at the origin)."""
    sphere = pv.Sphere(radius=1.0, theta_resolution=resolution, phi_resolution=max(resolution - 2, 6))
    points = np.asarray(sphere.points, dtype=np.float64)
    normals = points / np.linalg.norm(points, axis=1, keepdims=True)
    return Template(points=points, normals=normals, faces=np.asarray(sphere.faces))


def tube_template(*, sides: int = 12) -> Template:
    """An open unit tube: radius 1 around +Z, from z=0 (ring 0) to z=1 (ring 1)."""
    angles = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    points = np.concatenate(
        [np.column_stack([ring, np.zeros(sides)]), np.column_stack([ring, np.ones(sides)])]
    )
    normals = np.concatenate([np.column_stack([ring, np.zeros(sides)])] * 2)
    idx = np.arange(sides)
    nxt = (idx + 1) % sides
    quads = np.column_stack([np.full(sides, 4), idx, nxt, nxt + sides, idx + sides])
    return Template(points=points, normals=normals, faces=quads.ravel())


def merged_polydata(template: Template, count: int) -> pv.PolyData:
    """``count`` copies of a template in one PolyData (points at the template's position)."""
    n_pts = len(template.points)
    one = template.faces
    is_count = np.zeros(len(one), dtype=bool)
    i = 0
    while i < len(one):
        is_count[i] = True
        i += 1 + int(one[i])
    copies = [np.where(is_count, one, one + k * n_pts) for k in range(count)]
    mesh = pv.PolyData(np.tile(template.points, (count, 1)), faces=np.concatenate(copies))
    mesh.point_data["Normals"] = np.tile(template.normals, (count, 1))
    mesh.point_data.active_normals_name = "Normals"
    return mesh


def sphere_points(template: Template, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Points of spheres with given centres (N, 3) and radii (N,), stacked as (N*P, 3)."""
    pts = centres[:, None, :] + radii[:, None, None] * template.points[None]
    return pts.reshape(-1, 3)


def bone_frames(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-bone orthonormal frame of one pose (22, 3): (u, v, w, length), w along the bone.

    A zero-length bone gets w = +Y. The u/v choice may jump between frames; a round tube
    looks the same either way.
    """
    start = joints[BONE_PARENTS]
    vec = joints[BONE_CHILDREN] - start
    length = np.linalg.norm(vec, axis=1)
    safe = length > 1e-9
    w = np.where(safe[:, None], vec / np.where(safe, length, 1.0)[:, None], [0.0, 1.0, 0.0])
    helper = np.where((np.abs(w[:, 2]) < 0.9)[:, None], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    u = np.cross(helper, w)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(w, u)
    return u, v, w, length


def tube_points(
    template: Template, joints: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Points and normals of the 21 bone tubes of one pose (22, 3), stacked as (21*P, 3)."""
    u, v, w, length = bone_frames(joints)
    tx, ty, tz = template.points[:, 0], template.points[:, 1], template.points[:, 2]
    start = joints[BONE_PARENTS]
    pts = (
        start[:, None, :]
        + radius * (tx[None, :, None] * u[:, None, :] + ty[None, :, None] * v[:, None, :])
        + (tz[None, :] * length[:, None])[..., None] * w[:, None, :]
    )
    nx, ny = template.normals[:, 0], template.normals[:, 1]
    nrm = nx[None, :, None] * u[:, None, :] + ny[None, :, None] * v[:, None, :]
    return pts.reshape(-1, 3), nrm.reshape(-1, 3)


def checker_floor(
    *, x_range: tuple[float, float], z_range: tuple[float, float], tile: float, height: float = 0.0
) -> tuple[pv.PolyData, np.ndarray]:
    """A horizontal checkerboard plane at ``height``; returns the mesh and each cell's parity (0/1)."""
    nx = max(1, int(round((x_range[1] - x_range[0]) / tile)))
    nz = max(1, int(round((z_range[1] - z_range[0]) / tile)))
    xs = x_range[0] + tile * np.arange(nx + 1)
    zs = z_range[0] + tile * np.arange(nz + 1)
    gx, gz = np.meshgrid(xs, zs, indexing="xy")  # (nz+1, nx+1)
    points = np.column_stack([gx.ravel(), np.full(gx.size, height), gz.ravel()])
    i, k = np.meshgrid(np.arange(nx), np.arange(nz), indexing="xy")
    p0 = (k * (nx + 1) + i).ravel()
    # counter-clockwise seen from above (+Y), so the normals point up
    quads = np.column_stack([np.full(p0.size, 4), p0, p0 + nx + 1, p0 + nx + 2, p0 + 1])
    mesh = pv.PolyData(points, faces=quads.ravel())
    mesh.point_data["Normals"] = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    mesh.point_data.active_normals_name = "Normals"
    parity = ((i + k) % 2).ravel()
    return mesh, parity


def polyline(points: np.ndarray) -> pv.PolyData:
    """An open polyline through the points (N, 3)."""
    mesh = pv.PolyData(np.asarray(points, dtype=np.float64))
    n = len(points)
    mesh.lines = np.concatenate([[n], np.arange(n)])
    return mesh
