"""Check report, HumanML3D export, gallery and two-person interactions."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.representation import joints_to_features
from engine.synth.check import check_corpus


def test_check_report_meets_limits():
    report = check_corpus(200, split="train", seed=3)
    assert report["ok"], report["failures"]
    assert report["foot_slide_cm"] < 1.0 and report["penetration_cm"] <= 1.0
    assert report["bone_length_std_cm"] < 0.01 and report["nan_count"] == 0
    assert report["max_joint_speed_ms"] < 12.0
    assert report["transitions_checked"] > 20 and report["transition_accel_ratio"] < 1.25
    assert report["samples_per_s"] > 0


def test_export_folder_layout(tmp_path):
    from engine.synth.export import export_corpus

    out = export_corpus(tmp_path / "hml", n=5, seed=2, split="test")
    names = (out / "test.txt").read_text().split()
    assert len(names) == 5 and (out / "all.txt").exists()
    mean, std = np.load(out / "Mean.npy"), np.load(out / "Std.npy")
    assert mean.shape == (263,) and std.shape == (263,) and (std > 0).all()
    for name in names:
        feats = np.load(out / "new_joint_vecs" / f"{name}.npy")
        joints = np.load(out / "new_joints" / f"{name}.npy")
        assert feats.shape == (joints.shape[0] - 1, 263)
        np.testing.assert_allclose(feats, joints_to_features(joints), atol=1e-5)
        lines = (out / "texts" / f"{name}.txt").read_text().strip().splitlines()
        assert len(lines) >= 3
        for line in lines:
            text, toks, start, end = line.split("#")
            assert text and float(start) == 0.0 and float(end) == 0.0
            assert all("/" in t for t in toks.split())
        label = json.loads((out / "labels" / f"{name}.json").read_text())
        assert label["frames"] == joints.shape[0] and "program" in label
    from engine.io.humanml3d import HumanML3DFolder

    sample = HumanML3DFolder(out).read_sample(names[0])  # the exported folder reads back as HumanML3D
    np.testing.assert_allclose(sample.features, np.load(out / "new_joint_vecs" / f"{names[0]}.npy"))
    assert sample.features.shape[-1] == 263 and sample.captions


def test_gallery_renders(tmp_path):
    from PIL import Image

    from engine.synth.gallery import render_gallery

    path = render_gallery(tmp_path / "g.png", poses=4)
    img = np.asarray(Image.open(path))
    assert img.shape[0] > 1000 and img.std() > 5


@pytest.mark.parametrize("interaction", ["handshake", "high_five", "hug", "push", "sparring", "dance_together",
                                         "side_by_side", "following"])
def test_duets(interaction):
    from engine.synth.duet import make_duet

    d = make_duet(interaction, np.random.default_rng(4))
    assert d.joints_a.shape == d.joints_b.shape and d.joints_a.shape[1:] == (22, 3)
    assert np.isfinite(d.joints_a).all() and np.isfinite(d.joints_b).all()
    assert len(d.captions) >= 3
    for c in d.labels["contacts"]:
        f = np.arange(c["start"], c["end"])
        assert len(f) >= 2
        if c["kind"] == "right_hands":
            gap = np.linalg.norm(d.joints_a[f, 21] - d.joints_b[f, 21], axis=-1)
            assert gap.max() < 0.06
    if interaction in ("handshake", "hug", "push"):
        assert d.labels["contacts"]
    if interaction == "side_by_side":
        off = d.labels["placement"]["offset_xz"]
        assert abs(off[1]) < 0.05 and 0.5 < abs(off[0]) < 0.85


def test_duet_corpus_deterministic():
    from engine.synth.duet import DuetCorpus

    a, b = DuetCorpus("train").sample(3), DuetCorpus("train").sample(3)
    assert a.interaction == b.interaction and np.array_equal(a.joints_a, b.joints_a)
