"""NPY motion files and the load_motion / save_motion entry points."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

from engine.io import MotionIOError, load_motion, load_npy, save_motion, save_npy
from engine.representation import features_to_joints


def _save(tmp_path, name, array, **kwargs):
    path = tmp_path / name
    np.save(path, array, **kwargs)
    return path


def test_kind_is_told_by_shape(tmp_path, real_joints, real_vecs):
    kind, joints = load_npy(_save(tmp_path, "j.npy", real_joints))
    assert kind == "joints" and joints.shape == real_joints.shape and joints.dtype == np.float32
    kind, vecs = load_npy(_save(tmp_path, "v.npy", real_vecs.astype(np.float64)))
    assert kind == "vecs" and vecs.dtype == np.float32 and np.allclose(vecs, real_vecs)
    kind, flat = load_npy(_save(tmp_path, "flat.npy", real_joints.reshape(len(real_joints), 66)))
    assert kind == "joints" and np.array_equal(flat, real_joints)


def test_pickles_and_object_arrays_are_refused(tmp_path):
    path = tmp_path / "evil.npy"
    path.write_bytes(pickle.dumps({"joints": [1, 2, 3]}))
    with pytest.raises(MotionIOError, match="pickled data"):
        load_npy(path)
    objects = np.empty((4, 263), dtype=object)
    objects[:] = 0.0
    with pytest.raises(MotionIOError, match="object array"):
        load_npy(_save(tmp_path, "objects.npy", objects, allow_pickle=True))
    archive = tmp_path / "a.npz"
    np.savez(archive, joints=np.zeros((3, 22, 3)))
    with pytest.raises(MotionIOError, match="npz archive"):
        load_npy(archive)
    text = tmp_path / "text.npy"
    text.write_text("0 1 2")
    with pytest.raises(MotionIOError, match="not a .npy file"):
        load_npy(text)


@pytest.mark.parametrize(
    "array,message",
    [
        (np.zeros((10, 21, 3), np.float32), "21 joints per frame, but the skeleton has 22"),
        (np.zeros((22, 3), np.float32), "a single pose without a time axis"),
        (np.zeros((2, 10, 22, 3), np.float32), "a batch of 2 motions"),
        (np.zeros((10, 251), np.float32), "KIT-ML"),
        (np.zeros((10, 5), np.float32), "expected joints (T, 22, 3) or HumanML3D features (T, 263)"),
        (np.zeros((10, 263), np.int64), "dtype int64; expected floating point"),
        (np.zeros((0, 22, 3), np.float32), "zero frames"),
        (np.full((4, 263), np.nan, np.float32), "NaN or infinite values (first at frame 0)"),
    ],
)
def test_bad_arrays_are_refused_with_clear_messages(tmp_path, array, message):
    with pytest.raises(MotionIOError) as info:
        load_npy(_save(tmp_path, "bad.npy", array))
    assert message in str(info.value)
    assert "bad.npy" in str(info.value)


def test_size_limit_and_truncation(tmp_path, real_joints):
    path = _save(tmp_path, "j.npy", real_joints)
    with pytest.raises(MotionIOError, match="larger than the limit"):
        load_npy(path, max_bytes=1000)
    truncated = tmp_path / "cut.npy"
    truncated.write_bytes(path.read_bytes()[:500])
    with pytest.raises(MotionIOError, match="truncated or corrupt"):
        load_npy(truncated)


def test_save_npy_checks_and_writes_exact_path(tmp_path, real_vecs):
    path = save_npy(tmp_path / "motion.data", real_vecs, kind="vecs")
    assert path.name == "motion.data" and path.exists()
    with pytest.raises(MotionIOError, match="expected joints"):
        save_npy(tmp_path / "x.npy", real_vecs, kind="joints")


def test_load_motion_dispatches_on_extension(tmp_path, real_joints, real_vecs):
    joints = load_motion(_save(tmp_path, "j.npy", real_joints))
    assert np.array_equal(joints, real_joints)
    from_vecs = load_motion(_save(tmp_path, "v.npy", real_vecs))
    assert from_vecs.dtype == np.float32 and np.abs(from_vecs - features_to_joints(real_vecs)).max() < 1e-6
    assert np.abs(from_vecs - real_joints).max() < 1e-4
    with pytest.raises(MotionIOError, match="unsupported motion file type '.txt'"):
        load_motion(tmp_path / "x.txt")


def test_save_motion_joints_vecs_and_bvh(tmp_path, real_joints):
    joints_path = save_motion(real_joints, tmp_path / "out.npy")
    assert load_npy(joints_path)[0] == "joints"
    vecs_path = save_motion(real_joints, tmp_path / "out_vecs.npy", to="vecs")
    kind, vecs = load_npy(vecs_path)
    assert kind == "vecs" and vecs.shape == (len(real_joints) - 1, 263)
    assert np.abs(load_motion(vecs_path) - real_joints[:-1]).max() < 1e-3
    with pytest.raises(MotionIOError, match="only for .npy"):
        save_motion(real_joints, tmp_path / "out.bvh", to="vecs")
    with pytest.raises(MotionIOError, match="takes joints"):
        save_motion(np.zeros((5, 263), np.float32), tmp_path / "x.npy")
