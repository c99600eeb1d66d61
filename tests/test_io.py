"""Motion import/export: the two real BVH files, BVH export round trips, name mapping, units."""
from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import real_file
from engine.io import import_bvh, load_bvh, load_motion, save_bvh, save_motion
from engine.io.bvh import BVHError, parse_bvh, read_bvh
from engine.io.bvh_export import EXPORT_JOINTS, format_bvh
from engine.io.joint_names import normalize_name
from engine.io.retarget import canonical_placement, detect_unit, resample, up_axis_rotation
from engine.representation import canonicalize, facing_direction
from engine.rotations import axis_angle_to_matrix, matrix_to_euler
from engine.skeleton import BONE_LENGTHS, JOINT_INDEX, JOINT_NAMES, PARENTS, Skeleton, measure_bone_lengths

FEET = [JOINT_INDEX[n] for n in ("left_ankle", "right_ankle", "left_foot", "right_foot")]


def _facing_degrees(joints: np.ndarray) -> np.ndarray:
    forward = facing_direction(joints.astype(np.float64))
    return np.degrees(np.unwrap(np.arctan2(forward[:, 0], forward[:, 2])))


def _synthetic_motion(frames: int = 60, seed: int = 0) -> np.ndarray:
    """A wild but valid motion of the default skeleton (random local rotations, moving root)."""
    rng = np.random.default_rng(seed)
    local = axis_angle_to_matrix(rng.normal(0.0, 0.4, (frames, 22, 3)))
    root = np.stack([np.linspace(0, 2, frames), np.full(frames, 0.95), np.linspace(0, 1, frames)], axis=1)
    return Skeleton.default().forward(local, root)


def _plain_bvh(
    joints: np.ndarray,
    *,
    names: tuple[str, ...],
    scale: float = 1.0,
    fps: float = 20.0,
    turn: np.ndarray | None = None,
) -> str:
    """A 22-joint BVH of a motion of the default skeleton (one joint per HumanML3D joint).

    ``turn`` rotates the whole body (root rotation and position), e.g. into a Z-up file.
    """
    skeleton = Skeleton.default()
    local, root = skeleton.inverse(joints)
    if turn is not None:
        local[:, 0] = turn @ local[:, 0]
        root = root @ turn.T
    angles = matrix_to_euler(local, "ZXY")
    lines = ["HIERARCHY"]
    order: list[int] = []  # joints in file (depth-first) order, for the motion columns

    def write(j: int, depth: int) -> None:
        order.append(j)
        pad = "  " * depth
        off = skeleton.offsets[j] * scale
        lines.append(f"{pad}{'ROOT' if j == 0 else 'JOINT'} {names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        pos = "Xposition Yposition Zposition " if j == 0 else ""
        lines.append(f"{pad}  CHANNELS {6 if j == 0 else 3} {pos}Zrotation Xrotation Yrotation")
        kids = [c for c, p in enumerate(PARENTS) if p == j]
        for c in kids:
            write(c, depth + 1)
        if not kids:
            lines.append(f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 {0.05 * scale:.6f} 0\n{pad}  }}")
        lines.append(f"{pad}}}")

    write(0, 0)
    lines += ["MOTION", f"Frames: {len(joints)}", f"Frame Time: {1 / fps:.6f}"]
    for t in range(len(joints)):
        values = np.concatenate([root[t] * scale, angles[t, order].reshape(-1)])
        lines.append(" ".join(f"{v:.6f}" for v in values))
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- real files
@pytest.fixture(scope="module")
def cmu():
    return import_bvh(real_file("cmu_131_01_walk.bvh"))


@pytest.fixture(scope="module")
def pymo():
    return import_bvh(real_file("pymo_walk.bvh"))


@pytest.mark.parametrize("which", ["cmu", "pymo"])
def test_real_bvh_gives_a_plausible_body(which, request):
    imported = request.getfixturevalue(which)
    joints = imported.joints.astype(np.float64)
    assert imported.joints.dtype == np.float32 and joints.shape[1:] == (22, 3)
    assert imported.fps == 20.0 and imported.source_fps == 120.0
    # 20 fps frame count = duration x 20 (+1 for the first frame)
    file_duration = (imported.source_frames - 1) / imported.source_fps
    assert len(joints) == int(np.floor(file_duration * 20 + 1e-6)) + 1
    assert 1.5 <= imported.height <= 2.0
    assert 1.4 <= joints[:, JOINT_INDEX["head"], 1].max() <= 2.0
    # retargeted: our bone lengths, constant over time
    lengths = measure_bone_lengths(joints)
    assert np.allclose(lengths[:, 1:], [BONE_LENGTHS[j] for j in range(1, 22)], atol=1e-5)
    # feet on the floor: the lowest foot point of a typical frame within 3 cm of y=0, little penetration
    lowest = joints[:, FEET, 1].min(axis=1)
    assert abs(np.median(lowest)) < 0.03
    assert lowest.min() > -0.05
    # canonical start: root at the XZ origin, facing +Z
    assert np.allclose(joints[0, 0, [0, 2]], 0.0, atol=1e-5)
    assert abs(_facing_degrees(joints)[0]) < 1.0
    # upright: head above pelvis above the ankles in every frame, torso mostly vertical
    assert np.all(joints[:, JOINT_INDEX["head"], 1] > joints[:, 0, 1])
    assert np.all(joints[:, 0, 1] > joints[:, [7, 8], 1].max(axis=1))
    spine = joints[:, JOINT_INDEX["neck"]] - joints[:, 0]
    assert np.median(spine[:, 1] / np.linalg.norm(spine, axis=1)) > 0.9
    # the mapping is reported for every joint
    assert set(imported.mapping) == set(JOINT_NAMES)


def test_cmu_file_is_in_metres_and_walks_forward(cmu):
    assert cmu.unit == "m" and cmu.scale == 1.0 and cmu.up_axis == "+Y"
    assert cmu.mapping["left_hip"] == "LeftHip" and cmu.mapping["left_shoulder"] == "LeftShoulder"
    assert cmu.mapping["left_collar"].startswith("derived")  # CMU's LeftCollar has zero length
    joints = cmu.joints.astype(np.float64)
    assert len(joints) == 166
    shift = joints[-1, 0] - joints[0, 0]
    assert shift[2] > 2.0 and abs(shift[0]) < 0.5 * shift[2]  # start, walk forward (+Z), stop
    # the Michael-Jackson move: a turn to the left and a deep dip around 3 s
    assert joints[:, 0, 1].min() < 0.6 and _facing_degrees(joints).max() > 80


def test_pymo_file_is_in_inches_and_walks_a_loop(pymo):
    assert pymo.unit == "in" and abs(pymo.scale - 0.0254) < 1e-12
    assert pymo.mapping["left_hip"] == "LeftUpLeg" and pymo.mapping["left_shoulder"] == "LeftArm"
    for name in ("neck", "spine1", "spine2", "spine3", "left_collar"):  # one Spine joint, no Neck
        assert pymo.mapping[name].startswith("derived")
    joints = pymo.joints.astype(np.float64)
    assert len(joints) == 178
    early = joints[30, 0] - joints[0, 0]  # first 1.5 s: forward along +Z
    assert early[2] > 1.0 and abs(early[0]) < 0.5 * early[2]
    facing = _facing_degrees(joints)
    assert facing.max() - facing.min() > 180  # it turns around and walks back
    assert np.linalg.norm(joints[-1, 0, [0, 2]]) < 1.0


def test_pymo_root_path_is_the_files_own_root_channels_in_metres(pymo):
    """Issue #32: PyMO's inversion round trip (274 cm) is an outlier; the import is not the cause. The root path is
    the file's own Hips position channels, inches -> metres, every 6th frame (120 -> 20 fps), only turned about Y
    and shifted by the canonical placement; the walk is a brisk one at a normal cadence, with feet on the floor."""
    path = real_file("pymo_walk.bvh")
    data = read_bvh(path)
    assert data.names[0] == "Hips" and data.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    assert abs(data.fps - 120.0) < 0.01
    raw = data.motion[::6, :3] * 0.0254  # the file's root channels in metres at 20 fps
    imported = import_bvh(path, retarget=False)
    assert imported.up_axis == "+Y" and imported.mapping["pelvis"] == "Hips"
    root = imported.joints[:, 0].astype(np.float64)
    assert len(root) == len(raw) == 178

    def floor_distances(p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p[:, None, [0, 2]] - p[None, :, [0, 2]], axis=-1)

    assert np.allclose(floor_distances(root), floor_distances(raw), atol=1e-4)  # same path up to a turn about Y
    assert np.allclose(root[:, 1] - root[0, 1], raw[:, 1] - raw[0, 1], atol=1e-4)  # same height changes
    # the retargeted motion (what the model sees) keeps that path: our legs are about as long as the file's
    for joints in (root, pymo.joints[:, 0].astype(np.float64)):
        speed = np.linalg.norm(np.diff(joints[:, [0, 2]], axis=0), axis=1).sum() / pymo.duration
        assert 1.5 < speed < 1.9  # 15 m in 8.9 s: a brisk walk, 1.7 m/s
    # ~2 steps a second (a walk at 120 fps, not a walk at 60 fps played twice as fast): stance onsets of each ankle
    joints = pymo.joints.astype(np.float64)
    for side in ("left", "right"):
        ankle = joints[:, JOINT_INDEX[f"{side}_ankle"], :]
        still = np.linalg.norm(np.diff(ankle[:, [0, 2]], axis=0), axis=1) * pymo.fps < 0.5
        strides = np.count_nonzero(still[1:] & ~still[:-1]) / pymo.duration
        assert 0.8 < strides < 1.4
    # feet on the floor, pelvis at a standing adult's hip height, head joint at ~1.45 m
    assert abs(np.median(joints[:, FEET, 1].min(axis=1))) < 0.03
    assert 0.75 < np.median(joints[:, 0, 1]) < 0.95
    assert 1.35 < np.median(joints[:, JOINT_INDEX["head"], 1]) < 1.6


def test_raw_import_keeps_the_files_bodies():
    cmu_raw = import_bvh(real_file("cmu_131_01_walk.bvh"), retarget=False)
    pymo_raw = import_bvh(real_file("pymo_walk.bvh"), retarget=False)
    for imported in (cmu_raw, pymo_raw):
        assert 1.2 <= imported.height <= 2.1  # head joint of a standing adult after unit scaling
        lengths = measure_bone_lengths(imported.joints.astype(np.float64))
        assert lengths[:, JOINT_INDEX["left_knee"]].std() < 1e-3  # rigid bones in the file
    # CMU thigh (LeftHip -> LeftKnee) is 0.41 m in the file
    knee = measure_bone_lengths(cmu_raw.joints.astype(np.float64))[:, JOINT_INDEX["left_knee"]]
    assert abs(np.median(knee) - 0.4115) < 2e-3


def test_load_bvh_and_load_motion_agree():
    path = real_file("pymo_walk.bvh")
    joints = load_bvh(path)
    assert np.array_equal(joints, load_motion(path))
    assert len(load_bvh(path, fps=30)) == int(np.floor(1063 / 120 * 30 + 1e-6)) + 1


# --------------------------------------------------------------------------- export / re-import
def test_export_reimports_the_real_sample(real_joints, tmp_path):
    path = save_bvh(real_joints, tmp_path / "real.bvh")
    raw = import_bvh(path, retarget=False, canonical=False)
    assert raw.unit == "m" and raw.source_fps == 20.0 and raw.joints.shape == real_joints.shape
    assert np.linalg.norm(raw.joints - real_joints, axis=-1).max() < 1e-3
    assert all(not how.startswith("derived") for how in raw.mapping.values())
    # the default import (our bone lengths, canonical placement) stays within 2 cm
    default = load_bvh(path)
    assert np.linalg.norm(default - real_joints, axis=-1).max() < 0.02


def test_export_reimports_a_synthetic_motion(tmp_path):
    motion = _synthetic_motion()
    path = save_bvh(motion, tmp_path / "synthetic.bvh", fps=20)
    raw = import_bvh(path, retarget=False, canonical=False)
    assert np.linalg.norm(raw.joints - motion, axis=-1).max() < 1e-3
    default = load_bvh(path)  # same skeleton, so retargeting changes nothing
    assert np.linalg.norm(default - canonical_placement(motion, fps=20), axis=-1).max() < 1e-3


def test_export_handles_non_rigid_and_degenerate_input(tmp_path):
    motion = _synthetic_motion(frames=20, seed=3)
    noisy = motion + np.random.default_rng(1).normal(0, 0.01, motion.shape)  # bones change length
    raw = import_bvh(save_bvh(noisy, tmp_path / "noisy.bvh"), retarget=False, canonical=False)
    lengths = measure_bone_lengths(noisy)
    deviation = np.abs(lengths - np.median(lengths, axis=0)).sum(axis=1).max()  # worst accumulated change
    assert np.linalg.norm(raw.joints - noisy, axis=-1).max() <= deviation + 1e-3
    # a bone pointing exactly against its rest direction (forearm folded back onto the upper arm)
    folded = motion.copy()
    elbow, wrist, shoulder = (JOINT_INDEX[n] for n in ("left_elbow", "left_wrist", "left_shoulder"))
    back = folded[:, shoulder] - folded[:, elbow]
    folded[:, wrist] = folded[:, elbow] + back / np.linalg.norm(back, axis=1, keepdims=True) * BONE_LENGTHS[wrist]
    raw = import_bvh(save_bvh(folded, tmp_path / "folded.bvh"), retarget=False, canonical=False)
    assert np.linalg.norm(raw.joints - folded, axis=-1).max() < 1e-3


def test_exported_file_structure(real_joints):
    text = format_bvh(real_joints[:5], fps=20)
    data = parse_bvh(text)
    names = [n for n, e in zip(data.names, data.end_site) if not e]
    assert names == [e[0] for e in EXPORT_JOINTS]
    assert data.frame_time == pytest.approx(0.05) and data.num_frames == 5
    assert data.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
    for name in ("LHipJoint", "RHipJoint", "LowerBack", "LowerNeck", "LCollarJoint", "RCollarJoint"):
        assert np.allclose(data.offsets[data.index(name)], 0.0)
    # rest bone lengths are the motion's own (median over frames)
    upleg = data.offsets[data.index("LeftLeg")]
    assert np.linalg.norm(upleg) == pytest.approx(np.median(measure_bone_lengths(real_joints)[:, 4]), abs=1e-5)


def test_save_motion_bvh_round_trip(real_joints, tmp_path):
    path = save_motion(real_joints, tmp_path / "m.bvh")
    assert np.linalg.norm(load_motion(path) - real_joints, axis=-1).max() < 0.02


# --------------------------------------------------------------------------- other skeletons
SMPL_NAMES = JOINT_NAMES
SMPL_STYLE_NAMES = (
    "Pelvis", "L_Hip", "R_Hip", "Spine1", "L_Knee", "R_Knee", "Spine2", "L_Ankle", "R_Ankle", "Spine3",
    "L_Foot", "R_Foot", "Neck", "L_Collar", "R_Collar", "Head", "L_Shoulder", "R_Shoulder", "L_Elbow",
    "R_Elbow", "L_Wrist", "R_Wrist",
)


@pytest.mark.parametrize("names", [SMPL_NAMES, SMPL_STYLE_NAMES], ids=["smpl", "smpl-caps"])
def test_smpl_named_skeleton_maps_one_to_one(names):
    motion = _synthetic_motion(frames=12)
    data = parse_bvh(_plain_bvh(motion, names=names))
    imported_raw = import_bvh_from_text(_plain_bvh(motion, names=names))
    assert all(imported_raw.mapping[ours] == theirs for ours, theirs in zip(JOINT_NAMES, names))
    assert np.linalg.norm(imported_raw.joints - motion, axis=-1).max() < 1e-3
    assert data.num_joints == 22 + 5  # End Sites at the five leaves


def import_bvh_from_text(text: str, **options):
    from engine.io.bvh_import import import_bvh_data

    options = {"retarget": False, "canonical": False, **options}
    return import_bvh_data(parse_bvh(text), **options)


@pytest.mark.parametrize("unit,scale", [("cm", 100.0), ("in", 1 / 0.0254), ("mm", 1000.0), ("m", 1.0)])
def test_units_are_detected(unit, scale):
    motion = _synthetic_motion(frames=8)
    imported = import_bvh_from_text(_plain_bvh(motion, names=SMPL_NAMES, scale=scale))
    assert imported.unit == unit
    assert np.linalg.norm(imported.joints - motion, axis=-1).max() < 1e-3


def test_z_up_file_is_turned_upright():
    motion = _synthetic_motion(frames=8)
    y_up_to_z_up = up_axis_rotation("+Z").T
    imported = import_bvh_from_text(_plain_bvh(motion, names=SMPL_NAMES, turn=y_up_to_z_up))
    assert imported.up_axis == "+Z"
    assert np.linalg.norm(imported.joints - motion, axis=-1).max() < 1e-3


def test_mixamo_prefixed_names_read_back(real_joints):
    renamed = format_bvh(real_joints[:10])
    for name in sorted((e[0] for e in EXPORT_JOINTS), key=len, reverse=True):
        renamed = renamed.replace(f"JOINT {name}\n", f"JOINT mixamorig:{name}\n")
    renamed = renamed.replace("ROOT Hips\n", "ROOT mixamorig:Hips\n")
    imported = import_bvh_from_text(renamed)
    assert imported.mapping["left_elbow"] == "mixamorig:LeftForeArm"
    assert np.linalg.norm(imported.joints - real_joints[:10], axis=-1).max() < 1e-3


def test_missing_essential_joints_are_listed():
    text = (
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition Zposition\n"
        " JOINT LeftUpLeg\n {\n  OFFSET 0.1 -0.1 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "  End Site\n  {\n   OFFSET 0 -0.4 0\n  }\n }\n JOINT Head\n {\n  OFFSET 0 0.6 0\n"
        "  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 0.1 0\n  }\n }\n}\n"
        "MOTION\nFrames: 1\nFrame Time: 0.05\n0 1 0 0 0 0 0 0 0\n"
    )
    with pytest.raises(BVHError) as info:
        import_bvh_from_text(text)
    message = str(info.value)
    for name in ("right_hip", "left_knee", "right_knee", "left_ankle", "left_shoulder", "left_elbow", "right_wrist"):
        assert name in message
    assert "left_hip," not in message.split("Essential")[0] and "LeftUpLeg" in message  # lists the file's joints


@pytest.mark.parametrize(
    "name,side,part",
    [
        ("LeftUpLeg", "left", "upleg"), ("mixamorig:LeftArm", "left", "arm"), ("Bip01 L Thigh", "left", "thigh"),
        ("Character1_RightForeArm", "right", "forearm"), ("L_Hip", "left", "hip"), ("left_collar", "left", "collar"),
        ("LHipJoint", "left", "hipjoint"), ("lfemur", "left", "femur"), ("lowerback", None, "lowerback"),
        ("Spine1", None, "spine1"), ("hand_r", "right", "hand"), ("RThumb", "right", "thumb"), ("Hips", None, "hips"),
    ],
)
def test_name_normalisation(name, side, part):
    key = normalize_name(name)
    assert (key.side, key.part) == (side, part)


def test_unit_detection_and_resampling_helpers():
    assert detect_unit(1.55) == ("m", 1.0)
    assert detect_unit(155.0)[0] == "cm"
    assert detect_unit(61.0)[0] == "in"
    series = np.arange(13, dtype=np.float64)[:, None]  # 0.1 s at 120 fps
    out = resample(series, 120.0, 20.0)
    assert np.allclose(out[:, 0], [0, 6, 12])
    assert np.allclose(resample(series, 120.0, 50.0)[:, 0], np.arange(6) * 2.4)


def test_canonical_placement_matches_canonicalize_on_floored_data(real_joints):
    placed = canonical_placement(real_joints, fps=20)
    assert np.abs(placed - canonicalize(real_joints)).max() < 1e-6


def _rest_bvh(tree: list, frames: int = 2) -> str:
    """A BVH in its rest pose from nested (name, offset, children) tuples; every joint has 3 rotations."""
    lines, count = ["HIERARCHY"], [0]

    def write(node, depth):
        name, offset, children = node
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {name}\n{pad}{{")
        lines.append(f"{pad}  OFFSET {offset[0]} {offset[1]} {offset[2]}")
        extra = "Xposition Yposition Zposition " if depth == 0 else ""
        lines.append(f"{pad}  CHANNELS {6 if depth == 0 else 3} {extra}Zrotation Xrotation Yrotation")
        count[0] += 6 if depth == 0 else 3
        for child in children:
            write(child, depth + 1)
        if not children:
            lines.append(f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 1 0\n{pad}  }}")
        lines.append(f"{pad}}}")

    write(tree, 0)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    row = ["0", "37", "0"] + ["0"] * (count[0] - 3)
    lines += [" ".join(row)] * frames
    return "\n".join(lines) + "\n"


def _leg(side: str, sign: int, names: tuple[str, ...], hip_joint: str | None) -> tuple:
    upleg, leg, foot, toe = (side + n for n in names)
    chain = (upleg, (sign * 3.4, -3.0, 0), [(leg, (0, -16.5, 0), [(foot, (0, -15.5, 0), [(toe, (0, -1.5, 5.4), [])])])])
    return (hip_joint, (0, 0, 0), [chain]) if hip_joint else chain


def _arm(side: str, sign: int, collar: str, collar_offset, names: tuple[str, ...]) -> tuple:
    arm, fore, hand = (side + n for n in names)
    return (side + collar, collar_offset(sign), [(arm, (sign * 5.0, 0.5, 0), [(fore, (sign * 10.7, 0, 0), [(hand, (sign * 8.5, 0, 0), [])])])])


def test_cgspeed_cmu_names_map_structurally():
    """CMU as converted by cgspeed: zero-length LHipJoint/LowerBack/Neck/LeftShoulder, inches-like units."""
    leg_names = ("UpLeg", "Leg", "Foot", "ToeBase")
    arm_names = ("Arm", "ForeArm", "Hand")
    tree = ("Hips", (0, 0, 0), [
        _leg("Left", 1, leg_names, "LHipJoint"), _leg("Right", -1, leg_names, "RHipJoint"),
        ("LowerBack", (0, 0, 0), [("Spine", (0, 8.0, 0), [("Spine1", (0, 8.0, 0), [
            ("Neck", (0, 0, 0), [("Neck1", (0, 3.5, 0), [("Head", (0, 3.5, 0), [])])]),
            _arm("Left", 1, "Shoulder", lambda s: (0, 0, 0), arm_names),
            _arm("Right", -1, "Shoulder", lambda s: (0, 0, 0), arm_names),
        ])])]),
    ])
    imported = import_bvh_from_text(_rest_bvh(tree))
    mapping = imported.mapping
    assert imported.unit == "in" and imported.source_fps == 30.0
    assert mapping["neck"] == "Neck1" and mapping["left_shoulder"] == "LeftArm"
    assert mapping["left_hip"] == "LeftUpLeg" and mapping["left_foot"] == "LeftToeBase"
    assert mapping["left_collar"].startswith("derived") and mapping["spine3"].startswith("derived")
    assert "Spine -> Spine1" in mapping["spine2"]


def test_mixamo_names_map_spine_and_collars():
    leg_names = ("UpLeg", "Leg", "Foot", "ToeBase")
    arm_names = ("Arm", "ForeArm", "Hand")
    tree = ("mixamorig:Hips", (0, 0, 0), [
        _leg("mixamorig:Left", 1, leg_names, None), _leg("mixamorig:Right", -1, leg_names, None),
        ("mixamorig:Spine", (0, 4.0, 0), [("mixamorig:Spine1", (0, 4.5, 0), [("mixamorig:Spine2", (0, 5.0, 0), [
            ("mixamorig:Neck", (0, 6.0, 0), [("mixamorig:Head", (0, 4.0, 0), [])]),
            _arm("mixamorig:Left", 1, "Shoulder", lambda s: (s * 2.5, 4.0, 0), arm_names),
            _arm("mixamorig:Right", -1, "Shoulder", lambda s: (s * 2.5, 4.0, 0), arm_names),
        ])])]),
    ])
    mapping = import_bvh_from_text(_rest_bvh(tree)).mapping
    assert [mapping[f"spine{i}"].split(" ")[0] for i in (1, 2, 3)] == [
        "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2"]
    assert mapping["left_collar"] == "mixamorig:LeftShoulder"
    assert mapping["right_shoulder"] == "mixamorig:RightArm"
    assert mapping["right_ankle"] == "mixamorig:RightFoot"
