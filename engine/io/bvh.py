"""BVH import and export in one place (the parts live in their own modules).

- :func:`read_bvh` / :func:`parse_bvh` -> :class:`BVHData` (strict parser, FK for all joints)
- :func:`import_bvh` -> :class:`BVHImport` (22 joints + unit, fps, mapping, ...),
  :func:`load_bvh` -> joints (T, 22, 3) float32
- :func:`save_bvh` / :func:`format_bvh`: joints -> BVH that re-imports to the same joints
"""
from __future__ import annotations

from engine.io.bvh_export import format_bvh, save_bvh
from engine.io.bvh_import import BVHImport, import_bvh, import_bvh_data, load_bvh
from engine.io.bvh_parse import BVHData, parse_bvh, read_bvh
from engine.io.errors import BVHError

__all__ = [
    "BVHData", "BVHError", "BVHImport", "format_bvh", "import_bvh", "import_bvh_data", "load_bvh",
    "parse_bvh", "read_bvh", "save_bvh",
]
