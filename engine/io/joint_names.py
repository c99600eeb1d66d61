"""Map the joint names of common BVH skeletons onto the 22 HumanML3D joints.

Names are normalised before matching: a namespace ("mixamorig:", "rig|") and prefixes such as
"Bip01 ", "Character1_", "mixamorig" are dropped, the name is split into words (camel case,
"_", " ", "-", "."), a leading or trailing side word ("Left", "L", "left_", "_l") gives the
side, and the remaining words, lower-cased and joined, are the *part* ("LeftUpLeg" ->
(left, "upleg"), "Bip01 L Thigh" -> (left, "thigh"), "left_collar" -> (left, "collar"),
"lfemur" -> (left, "femur")). Each of our joints has an ordered list of parts it accepts; the
first part present wins. Joints whose rest offset is zero (CMU's ``LHipJoint``, ``LeftCollar``
and ``lowerneck``, the zero-length branch joints of our own export) are never matched: they
sit on their parent and carry no position of their own.

The ambiguous "LeftShoulder" (a collar bone in Mixamo and CMU/cgspeed files, the shoulder
joint in SMPL and 3dsMax-CMU files) is resolved by order: the shoulder joint prefers "arm"
names, and only when none exists does it take "shoulder"; the collar takes what is left.

The spine joints are matched here only under SMPL names (spine1/2/3); other skeletons' torso
joints are placed by :mod:`engine.io.joint_fill` from the hierarchy between pelvis and neck.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from engine.io.bvh_parse import BVHData
from engine.skeleton import JOINT_INDEX

_PREFIX_RE = re.compile(r"^(?:bip0*1|character\d*|mixamorig\d*)(?:[\s_\-.]+|(?=[A-Z]))", re.IGNORECASE)
_WORD_RE = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")
_SIDE_WORDS = {"l": "left", "left": "left", "r": "right", "right": "right"}

# Parts accepted for each of our joints, best first. Sided joints use the same list per side.
PART_ALIASES: dict[str, tuple[str, ...]] = {
    "pelvis": ("pelvis", "hips", "hip"),
    "hip": ("hip", "upleg", "thigh", "upperleg", "femur"),
    "knee": ("knee", "leg", "calf", "lowerleg", "shin", "tibia"),
    "ankle": ("ankle", "foot"),
    "foot": ("toe", "toebase", "toes", "toe0", "ball", "foot"),
    "shoulder": ("arm", "uparm", "upperarm", "humerus", "shoulder"),
    "collar": ("collar", "clavicle", "shoulder"),
    "elbow": ("elbow", "forearm", "lowerarm", "radius"),
    "wrist": ("wrist", "hand"),
    "neck": ("neck", "neck1", "lowerneck", "upperneck"),
    "head": ("head",),
    "spine1": ("spine1",),
    "spine2": ("spine2",),
    "spine3": ("spine3",),
}
# Joints that must be found by name; everything else can be derived from them.
ESSENTIAL: tuple[str, ...] = (
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "head",
)
# Resolution order: parents of a chain before their children, shoulders before collars.
_ORDER: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_foot", "right_foot", "left_shoulder", "right_shoulder", "left_collar", "right_collar",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "head", "neck",
)
# chain predecessor: a match must be a descendant of it (or, for collars, an ancestor of it)
_BELOW = {
    "knee": "hip", "ankle": "knee", "foot": "ankle", "elbow": "shoulder", "wrist": "elbow",
}
_ALL_PARTS = frozenset(p for parts in PART_ALIASES.values() for p in parts)


@dataclass(frozen=True)
class NameKey:
    """A normalised joint name: side ("left", "right" or None) and part ("upleg")."""

    side: str | None
    part: str


def normalize_name(name: str) -> NameKey:
    """Split a BVH joint name into side and part (see the module docstring)."""
    base = re.split(r"[:|]", name)[-1].strip()
    base = _PREFIX_RE.sub("", base)
    words = [w.lower() for w in _WORD_RE.findall(base)]
    side = None
    if len(words) > 1 and words[0] in _SIDE_WORDS:
        side, words = _SIDE_WORDS[words[0]], words[1:]
    elif len(words) > 1 and words[-1] in _SIDE_WORDS:
        side, words = _SIDE_WORDS[words[-1]], words[:-1]
    part = "".join(words)
    if side is None and len(words) == 1 and part[:1] in ("l", "r"):
        # glued lower-case side letters of CMU/ASF names: "lfemur", "rhumerus"
        for prefix, which in (("left", "left"), ("right", "right"), ("l", "left"), ("r", "right")):
            rest = part[len(prefix):]
            if part.startswith(prefix) and rest in _ALL_PARTS:
                side, part = which, rest
                break
    return NameKey(side, part)


def _split(our_name: str) -> tuple[str | None, str]:
    for side in ("left", "right"):
        if our_name.startswith(side + "_"):
            return side, our_name[len(side) + 1:]
    return None, our_name


def _is_descendant(data: BVHData, joint: int, ancestor: int) -> bool:
    parent = data.parents[joint]
    while parent >= 0:
        if parent == ancestor:
            return True
        parent = data.parents[parent]
    return False


def zero_offset_joints(data: BVHData) -> np.ndarray:
    """Boolean per BVH joint: its rest offset is (numerically) zero, so it adds no position."""
    norms = np.linalg.norm(data.offsets, axis=-1)
    scale = max(float(norms.max()), 1e-12)
    zero = norms <= 1e-4 * scale
    zero[[p < 0 for p in data.parents]] = False  # the root's offset is its placement, not a bone
    return zero


def match_joint_names(data: BVHData) -> dict[str, int]:
    """Our joint name -> BVH joint index, for every joint that can be matched by name."""
    keys = [normalize_name(n) for n in data.names]
    zero = zero_offset_joints(data)
    usable = [not data.end_site[j] and not zero[j] for j in range(data.num_joints)]
    found: dict[str, int] = {}
    used: set[int] = set()

    def pick(our_name: str, parts: tuple[str, ...]) -> int | None:
        side, kind = _split(our_name)
        for part in parts:
            for j, key in enumerate(keys):
                if not usable[j] or j in used or key.side != side or key.part != part:
                    continue
                if kind in _BELOW:
                    prev = found.get(our_name.replace(kind, _BELOW[kind]))
                    if prev is not None and not _is_descendant(data, j, prev):
                        continue
                if kind == "collar":
                    shoulder = found.get(our_name.replace("collar", "shoulder"))
                    if shoulder is not None and not _is_descendant(data, shoulder, j):
                        continue
                return j
        return None

    for our_name in _ORDER:
        _, kind = _split(our_name)
        j = pick(our_name, PART_ALIASES[kind])
        if j is not None:
            found[our_name] = j
            used.add(j)
    # SMPL-named spines: only when all three are there, so that Mixamo's Spine/Spine1/Spine2
    # (which mean spine1/2/3) are not half-matched.
    spines = {name: pick(name, PART_ALIASES[name]) for name in ("spine1", "spine2", "spine3")}
    if all(j is not None for j in spines.values()):
        found.update(spines)  # type: ignore[arg-type]
    assert all(name in JOINT_INDEX for name in found)
    return found


def missing_essentials(found: dict[str, int]) -> list[str]:
    """Names of the essential joints that were not found, in skeleton order."""
    return [name for name in ESSENTIAL if name not in found]
