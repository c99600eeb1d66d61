"""Where several skeletons stand in one picture, and which colours they take: shared by the 3-D scene
(viz.scene) and the flat export drawing (viz.flat). numpy only."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np


def side_by_side_offsets(motions: Mapping[str, np.ndarray], *, spacing: float) -> dict[str, np.ndarray]:
    """X offsets that keep skeletons apart: at every frame, each one is at least ``spacing``
    metres to the +X side of the previous one (a motion past its end holds its last pose).

    Paths may cross (at different times); bodies never overlap. The group is centred on the
    mean X centre of the original motions; a single motion gets no offset.
    """
    roles = list(motions)
    if len(roles) == 1:
        return {roles[0]: np.zeros(3)}
    n = max(m.shape[0] for m in motions.values())
    frame = np.arange(n)
    low = {r: m[np.minimum(frame, len(m) - 1), :, 0].min(axis=1) for r, m in motions.items()}
    high = {r: m[np.minimum(frame, len(m) - 1), :, 0].max(axis=1) for r, m in motions.items()}
    shift = {roles[0]: 0.0}
    for prev, cur in zip(roles, roles[1:]):
        shift[cur] = shift[prev] + float(np.max(high[prev] - low[cur])) + spacing
    lows = [float(low[r].min()) + shift[r] for r in roles]
    highs = [float(high[r].max()) + shift[r] for r in roles]
    group_centre = 0.5 * (min(lows) + max(highs))
    centre = float(np.mean([0.5 * (m[..., 0].min() + m[..., 0].max()) for m in motions.values()]))
    return {r: np.array([shift[r] - group_centre + centre, 0.0, 0.0]) for r in roles}


def place_roles(motions: Mapping[str, np.ndarray], *, offsets: Mapping[str, Sequence[float]] | None,
                colors: Mapping | None, spacing: float) -> tuple[dict[str, np.ndarray], dict]:
    """(offset (3,) per role, the given colours) for ``motions`` by role: ``offsets`` as given (every role needs one),
    or :func:`side_by_side_offsets`; colours only for roles that exist."""
    if offsets is None:
        shifts = side_by_side_offsets(motions, spacing=spacing)
    else:
        missing = set(motions) - set(offsets)
        if missing:
            raise ValueError(f"offsets missing for roles {sorted(missing)}")
        shifts = {r: np.asarray(offsets[r], dtype=np.float64).reshape(3) for r in motions}
    colors = dict(colors or {})
    unknown = set(colors) - set(motions)
    if unknown:
        raise ValueError(f"colours given for unknown roles {sorted(unknown)}")
    return shifts, colors
