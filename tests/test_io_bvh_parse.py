"""The strict BVH parser: valid files, forward kinematics, and a dozen malformed files."""
from __future__ import annotations

import numpy as np
import pytest

from engine.io.bvh import BVHError, read_bvh
from engine.io.bvh_parse import parse_bvh
from engine.rotations import euler_to_matrix

VALID = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Spine
  {
    OFFSET 0 1 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.05
0 1 0 0 0 0 0 0 0
0 1 0 90 0 0 0 0 0
"""
# line numbers in VALID: 16 = MOTION, 17 = "Frames: 2", 18 = "Frame Time", 19/20 = the two frames


def _write(tmp_path, text: str, name: str = "bad.bvh"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_valid_file_parses_and_fk_is_right(tmp_path):
    data = read_bvh(_write(tmp_path, VALID, "ok.bvh"))
    assert data.names == ("Hips", "Spine", "Spine/End Site")
    assert data.parents == (-1, 0, 1)
    assert data.end_site == (False, False, True)
    assert data.channels[1] == ("Zrotation", "Yrotation", "Xrotation")
    assert data.num_frames == 2 and data.frame_time == 0.05 and data.motion.shape == (2, 9)
    pos = data.world_positions()
    assert np.allclose(pos[0], [[0, 1, 0], [0, 2, 0], [0, 3, 0]])
    # root turned 90 degrees about Z: the spine points along -X
    assert np.allclose(pos[1], [[0, 1, 0], [-1, 1, 0], [-2, 1, 0]], atol=1e-12)


def test_any_channel_order_and_subset(tmp_path):
    text = """HIERARCHY
ROOT Bip01 Pelvis {
  OFFSET 1 2 3
  CHANNELS 2 Yposition Xrotation
  JOINT Bip01 L Thigh {
    OFFSET 0.1 -0.1 0
    CHANNELS 4 Xrotation Zposition Yrotation Zrotation
    End Site {
      OFFSET 0 -0.5 0
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.01
5 30 10 0.7 -20 45
"""
    data = parse_bvh(text)
    assert data.names[:2] == ("Bip01 Pelvis", "Bip01 L Thigh")
    pos = data.world_positions()[0]
    root_rot = euler_to_matrix(np.array([30.0, 0.0, 0.0]), "XYZ")  # the root's only rotation: X
    thigh_rot = euler_to_matrix(np.array([10.0, -20.0, 45.0]), "XYZ")  # X, Y, Z in file order
    root = np.array([1.0, 5.0, 3.0])  # X and Z from OFFSET, Y from its channel
    thigh = root + root_rot @ np.array([0.1, -0.1, 0.7])  # Z offset replaced by the Zposition channel
    site = thigh + root_rot @ thigh_rot @ np.array([0, -0.5, 0])
    assert np.allclose(pos, [root, thigh, site])


def test_real_files_parse():
    from tests.conftest import real_file

    cmu = read_bvh(real_file("cmu_131_01_walk.bvh"))
    assert cmu.num_frames == 995 and cmu.num_channels == 96 and cmu.channels[0][:3] == (
        "Xposition", "Yposition", "Zposition")
    assert cmu.channels[cmu.index("LeftShoulder")] == ("Zrotation", "Xrotation", "Yrotation")
    pymo = read_bvh(real_file("pymo_walk.bvh"))
    assert pymo.num_frames == 1064 and pymo.num_channels == 72
    assert np.allclose(pymo.offsets[0], [11.2666, 35.4190, -54.3259])


def _replace(old: str, new: str, count: int = 1) -> str:
    assert old in VALID
    return VALID.replace(old, new, count)


MALFORMED = [
    ("missing MOTION", VALID.split("MOTION")[0], "missing MOTION"),
    ("too few values", _replace("0 1 0 90 0 0 0 0 0", "0 1 0 90 0 0 0 0"), "line 20: wrong number of values on frame 2: 8 values, expected 9"),
    ("too many values", _replace("0 1 0 0 0 0 0 0 0", "0 1 0 0 0 0 0 0 0 0"), "line 19: wrong number of values on frame 1"),
    ("non-numeric", _replace("0 1 0 90", "0 1 abc 90"), "line 20: non-numeric value 'abc'"),
    ("NaN", _replace("0 1 0 90", "0 1 nan 90"), "line 20: NaN or infinite value on frame 2"),
    ("missing brace", _replace("    }\n  }\n}\n", "    }\n  }\n"), "unbalanced braces"),
    ("extra brace", _replace("}\nMOTION", "}\n}\nMOTION"), "line 16: unbalanced braces"),
    ("zero frames", _replace("Frames: 2", "Frames: 0"), "line 17: the file declares 0 frames"),
    ("unknown channel", _replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Wrotation Xrotation"),
     "line 9: unknown channel name 'Wrotation'"),
    ("channel count", _replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Yrotation"),
     "declares 3 channels but lists 2"),
    ("duplicate channel", _replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Zrotation Xrotation"),
     "channel Zrotation appears twice"),
    ("no HIERARCHY", _replace("HIERARCHY\n", ""), "line 1: expected HIERARCHY"),
    ("bad frame time", _replace("Frame Time: 0.05", "Frame Time: 0"), "line 18: Frame Time must be positive"),
    ("missing frame time", _replace("Frame Time: 0.05\n", ""), "expected 'Frame Time: <seconds>'"),
    ("frame count text", _replace("Frames: 2", "Frames: two"), "frame count is not an integer: 'two'"),
    ("fewer frames", _replace("0 1 0 90 0 0 0 0 0\n", ""), "ends after 1 of the 2 frames"),
    ("more frames", VALID + "0 1 0 0 0 0 0 0 0\n", "line 21: more frame lines than the 2 declared"),
    ("short OFFSET", _replace("OFFSET 0 1 0", "OFFSET 0 1"), "line 8: OFFSET of joint 'Spine' has 2 values, expected 3"),
    ("non-numeric OFFSET", _replace("OFFSET 0 1 0", "OFFSET 0 x 0"), "line 8: non-numeric value 'x' in OFFSET"),
    ("missing OFFSET", _replace("    OFFSET 0 1 0\n", "", 1), "joint 'Spine' has no OFFSET"),
    ("duplicate name", _replace("JOINT Spine", "JOINT Hips"), "line 6: duplicate joint name 'Hips' (first defined on line 2)"),
    ("unknown keyword", _replace("  OFFSET 0 0 0\n", "  OFFSET 0 0 0\n  SCALE 2\n"), "line 5: unexpected line in joint 'Hips'"),
    ("channels in End Site", _replace("      OFFSET 0 1 0\n", "      OFFSET 0 1 0\n      CHANNELS 1 Xrotation\n"),
     "an End Site cannot have CHANNELS"),
    ("no channels at all", VALID.replace("  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n", "")
     .replace("    CHANNELS 3 Zrotation Yrotation Xrotation\n", ""), "declares no channels"),
    ("second ROOT", _replace("MOTION", "ROOT Other\n{\n OFFSET 0 0 0\n}\nMOTION"), "a second ROOT"),
    ("empty file", "", "expected HIERARCHY"),
]


@pytest.mark.parametrize("label,text,expected", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_files_are_refused_with_a_clear_message(tmp_path, label, text, expected):
    path = _write(tmp_path, text)
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    message = str(info.value)
    assert expected in message, message
    assert message.startswith("bad.bvh: ")  # names the file
    assert isinstance(info.value, ValueError)


def test_file_size_limit(tmp_path):
    path = _write(tmp_path, VALID)
    with pytest.raises(BVHError, match="larger than the limit"):
        read_bvh(path, max_bytes=100)
    with pytest.raises(BVHError, match="not found"):
        read_bvh(tmp_path / "absent.bvh")


def test_tabs_crlf_and_trailing_brace_headers():
    text = VALID.replace("ROOT Hips\n{", "ROOT\tHips {").replace("End Site\n    {", "End Site{").replace("\n", "\r\n")
    data = parse_bvh(text)
    assert data.names[0] == "Hips" and data.num_frames == 2
