"""Small rotation toolkit (numpy): quaternions (w, x, y, z), rotation matrices, 6D, Euler.

Quaternions follow the HumanML3D convention (scalar first) so that the representation code
reads like its definition. Everything broadcasts over leading dimensions.
"""
from __future__ import annotations

import numpy as np

_EPS = 1e-9


def components(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """View of ``x`` with its component axis (0 or -1) first, so ``a, b, c = components(v, axis)``
    unpacks it."""
    if axis == 0:
        return x
    n = np.ndim(x)
    return x.transpose((n - 1, *range(n - 1)))  # much cheaper than np.moveaxis


def expand(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """``x`` with a length-1 component axis (0 or -1) to broadcast against vectors."""
    return x[None] if axis == 0 else x[..., None]


def new_vectors(first: np.ndarray, n: int, axis: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """An empty array of ``n``-component vectors shaped like the component ``first`` (component
    axis 0 or -1), and its component-first view with ``first`` already written."""
    shape = np.shape(first)
    out = np.empty((n, *shape) if axis == 0 else (*shape, n), dtype=np.result_type(first, 1.0))
    parts = components(out, axis)
    parts[0] = first
    return out, parts


# Every function below takes ``axis``: where the components are, 0 (first) or -1 (last, the
# default). Component-first arrays keep each component contiguous, which is several times
# faster on (T, J) batches; reductions over a last axis of 3 or 4 are slow in numpy, so dot
# products are written out per component (first) or use einsum (last).
def dot(a: np.ndarray, b: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Dot product over the component axis: (..., n) -> (...)."""
    if axis != 0:
        return np.einsum("...i,...i->...", a, b)
    out = a[0] * b[0]
    for k in range(1, len(a)):
        out = out + a[k] * b[k]
    return out


def qnormalize(q: np.ndarray, *, axis: int = -1) -> np.ndarray:
    return q / expand(np.maximum(np.sqrt(dot(q, q, axis=axis)), _EPS), axis)


def cross(a: np.ndarray, b: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Cross product over the component axis (..., 3); faster than np.cross on small arrays."""
    ax, ay, az = components(a, axis)
    bx, by, bz = components(b, axis)
    out, o = new_vectors(ay * bz - az * by, 3, axis)
    o[1] = az * bx - ax * bz
    o[2] = ax * by - ay * bx
    return out


def qmul(a: np.ndarray, b: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Hamilton product a*b; shapes (..., 4)."""
    aw, ax, ay, az = components(a, axis)
    bw, bx, by, bz = components(b, axis)
    out, o = new_vectors(aw * bw - ax * bx - ay * by - az * bz, 4, axis)
    o[1] = aw * bx + ax * bw + ay * bz - az * by
    o[2] = aw * by - ax * bz + ay * bw + az * bx
    o[3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def qinv(q: np.ndarray, *, axis: int = -1) -> np.ndarray:
    out = q.copy()
    components(out, axis)[1:] *= -1.0
    return out


def qrot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    qvec = q[..., 1:]
    uv = cross(qvec, v)
    uuv = cross(qvec, uv)
    return v + 2.0 * (q[..., :1] * uv + uuv)


def qbetween(v0: np.ndarray, v1: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """The shortest-arc rotation taking direction v0 to direction v1 (..., 3) -> (..., 4).

    Opposite directions have no unique shortest arc; they get a half turn about an axis
    perpendicular to v0 (e.g. an arm raised straight up against a rest direction pointing down),
    never a zero quaternion.
    """
    norms = np.sqrt(dot(v0, v0, axis=axis) * dot(v1, v1, axis=axis))
    w = norms + dot(v0, v1, axis=axis)
    q, parts = new_vectors(w, 4, axis)
    parts[1:] = components(cross(v0, v1, axis=axis), axis)
    opposite = w <= 1e-9 * np.maximum(norms, _EPS)
    if np.any(opposite):
        shape = np.broadcast_shapes(np.shape(v0), np.shape(v1))
        x, y, z = components(np.broadcast_to(v0, shape), axis)
        about_x = np.abs(x) <= np.abs(y)  # cross v0 with the basis axis it is least aligned with
        perpendicular = (np.where(about_x, 0.0, -z), np.where(about_x, z, 0.0), np.where(about_x, -y, x))
        parts[0] = np.where(opposite, 0.0, parts[0])
        for k in range(3):
            parts[k + 1] = np.where(opposite, perpendicular[k], parts[k + 1])
    return qnormalize(q, axis=axis)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(..., 4) -> (..., 3, 3)."""
    w, x, y, z = components(qnormalize(q))
    out = np.empty(q.shape[:-1] + (3, 3), dtype=np.result_type(q, 1.0))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - w * z)
    out[..., 0, 2] = 2 * (x * z + w * y)
    out[..., 1, 0] = 2 * (x * y + w * z)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - w * x)
    out[..., 2, 0] = 2 * (x * z - w * y)
    out[..., 2, 1] = 2 * (y * z + w * x)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 4), numerically stable branch selection, w >= 0."""
    m = np.asarray(m, dtype=np.float64)
    shape = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack(
        [
            1 + tr,
            1 + m[:, 0, 0] - m[:, 1, 1] - m[:, 2, 2],
            1 - m[:, 0, 0] + m[:, 1, 1] - m[:, 2, 2],
            1 - m[:, 0, 0] - m[:, 1, 1] + m[:, 2, 2],
        ],
        axis=-1,
    )
    best = cand.argmax(-1)
    q = np.empty((m.shape[0], 4))
    for b in range(4):
        sel = best == b
        if not sel.any():
            continue
        ms = m[sel]
        s = np.sqrt(np.maximum(cand[sel, b], _EPS)) * 2.0  # = 4 * component b
        if b == 0:
            q[sel] = np.stack([s / 4, (ms[:, 2, 1] - ms[:, 1, 2]) / s, (ms[:, 0, 2] - ms[:, 2, 0]) / s,
                               (ms[:, 1, 0] - ms[:, 0, 1]) / s], -1)
        elif b == 1:
            q[sel] = np.stack([(ms[:, 2, 1] - ms[:, 1, 2]) / s, s / 4, (ms[:, 0, 1] + ms[:, 1, 0]) / s,
                               (ms[:, 0, 2] + ms[:, 2, 0]) / s], -1)
        elif b == 2:
            q[sel] = np.stack([(ms[:, 0, 2] - ms[:, 2, 0]) / s, (ms[:, 0, 1] + ms[:, 1, 0]) / s, s / 4,
                               (ms[:, 1, 2] + ms[:, 2, 1]) / s], -1)
        else:
            q[sel] = np.stack([(ms[:, 1, 0] - ms[:, 0, 1]) / s, (ms[:, 0, 2] + ms[:, 2, 0]) / s,
                               (ms[:, 1, 2] + ms[:, 2, 1]) / s, s / 4], -1)
    q = np.where(q[:, :1] < 0, -q, q)
    return qnormalize(q).reshape(*shape, 4)


def axis_angle_to_matrix(axis_angle: np.ndarray) -> np.ndarray:
    """Rodrigues: (..., 3) rotation vectors -> (..., 3, 3)."""
    aa = np.asarray(axis_angle, dtype=np.float64)
    angle = np.linalg.norm(aa, axis=-1, keepdims=True)
    axis = aa / np.maximum(angle, _EPS)
    x, y, z = np.moveaxis(axis, -1, 0)
    c, s = np.cos(angle[..., 0]), np.sin(angle[..., 0])
    C = 1 - c
    return np.stack(
        [
            np.stack([c + x * x * C, x * y * C - z * s, x * z * C + y * s], -1),
            np.stack([y * x * C + z * s, c + y * y * C, y * z * C - x * s], -1),
            np.stack([z * x * C - y * s, z * y * C + x * s, c + z * z * C], -1),
        ],
        axis=-2,
    )


def axis_rotation(axis: str, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices about a principal axis 'x', 'y' or 'z' by angles (radians), (...,) -> (..., 3, 3)."""
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, i = np.zeros_like(angle), np.ones_like(angle)
    rows = {
        "x": [[i, o, o], [o, c, -s], [o, s, c]],
        "y": [[c, o, s], [o, i, o], [-s, o, c]],
        "z": [[c, -s, o], [s, c, o], [o, o, i]],
    }[axis.lower()]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def euler_to_matrix(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """BVH-style intrinsic Euler angles in degrees, applied in the channel order given.

    ``order`` is e.g. "ZYX": the rotation is Rz @ Ry @ Rx (the first channel is outermost),
    which is how BVH channels compose. angles_deg (..., 3) in that same order.
    """
    rad = np.deg2rad(np.asarray(angles_deg, dtype=np.float64))
    out = axis_rotation(order[0], rad[..., 0])
    for k in (1, 2):
        out = out @ axis_rotation(order[k], rad[..., k])
    return out


def matrix_to_euler(m: np.ndarray, order: str) -> np.ndarray:
    """Inverse of :func:`euler_to_matrix` for the six Tait-Bryan orders; degrees (..., 3)."""
    order = order.upper()
    i, j, k = ("XYZ".index(c) for c in order)
    if len(set(order)) != 3:
        raise ValueError(f"unsupported Euler order {order!r}")
    # sign of the permutation (i, j, k) of (0, 1, 2)
    sign = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    m = np.asarray(m, dtype=np.float64)
    b = np.clip(sign * m[..., i, k], -1.0, 1.0)
    second = np.arcsin(b)
    first = np.arctan2(-sign * m[..., j, k], m[..., k, k])
    third = np.arctan2(-sign * m[..., i, j], m[..., i, i])
    # gimbal lock: put everything in the first angle
    lock = np.abs(b) > 1 - 1e-9
    if np.any(lock):
        third = np.where(lock, 0.0, third)
        first = np.where(lock, np.arctan2(sign * m[..., k, j], m[..., j, j]), first)
    return np.rad2deg(np.stack([first, second, third], axis=-1))


def kabsch(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Best rotation R with R @ src_i ~ dst_i. src (..., N, 3), dst (..., N, 3) -> (..., 3, 3)."""
    h = np.swapaxes(src, -1, -2) @ dst  # (..., 3, 3) = sum_i src_i dst_i^T
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.swapaxes(vt, -1, -2) @ np.swapaxes(u, -1, -2)))
    diag = np.ones(h.shape[:-1])
    diag[..., -1] = d
    return np.swapaxes(vt, -1, -2) @ (diag[..., None] * np.swapaxes(u, -1, -2))
