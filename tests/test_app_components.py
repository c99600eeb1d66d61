"""App components without a server: state, import parsing, viewer frames."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from app.state import StudioState
from app.views.files import MAX_UPLOAD_BYTES, import_bytes
from app.views.viewer import SkeletonViewer


def test_state_validates_motion():
    state = StudioState()
    with pytest.raises(ValueError, match="shape"):
        state.show_motion(np.zeros((10, 21, 3)), title="bad")
    state.show_motion(np.zeros((10, 22, 3)), title="zeros")
    assert state.n_frames == 10 and state.frame == 0 and "10 frames" in state.message


def test_import_bytes_parses_npy_and_refuses_bad_files(real_joints):
    buf = io.BytesIO()
    np.save(buf, real_joints)
    joints = import_bytes(buf.getvalue(), "walk.npy")
    assert joints.shape == real_joints.shape
    with pytest.raises(ValueError, match="empty"):
        import_bytes(b"", "x.npy")
    with pytest.raises(ValueError, match="only .bvh and .npy"):
        import_bytes(b"abc", "x.txt")
    with pytest.raises(ValueError, match="limited"):
        import_bytes(b"0" * (MAX_UPLOAD_BYTES + 1), "big.bvh")
    pickled = io.BytesIO()
    np.save(pickled, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError):
        import_bytes(pickled.getvalue(), "evil.npy")
    with pytest.raises(ValueError):
        import_bytes(b"HIERARCHY\nROOT Hips\n{\n", "broken.bvh")


def test_viewer_draws_the_skeleton_and_follows_the_playhead(real_joints):
    state = StudioState()
    state.show_motion(real_joints, title="sample")
    viewer = SkeletonViewer(state=state)
    first = np.asarray(Image.open(io.BytesIO(viewer._image.object)).convert("RGB"))
    state.frame = 100
    later = np.asarray(Image.open(io.BytesIO(viewer._image.object)).convert("RGB"))
    assert first.shape == (480, 640, 3)
    # the skeleton is drawn in blue tones: many strongly blue pixels
    blue = (first[..., 2].astype(int) - first[..., 0].astype(int) > 60).sum()
    assert blue > 500
    assert np.abs(first.astype(int) - later.astype(int)).sum() > 0
    assert viewer._player.end == len(real_joints) - 1
