"""`moattn bench --inversion` (engine/evaluation/bench_inversion.py) and roundtrip_error's noise_std, on an untrained
tiny model: the result's shape, the default setting's figures on top, real-data folder handling, trimming."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.evaluation.bench_inversion import (DEFAULT_SETTING, SETTINGS, InversionBenchConfig, bench_inversion,
                                               format_table, real_motions)
from engine.methods.inversion import InversionConfig, invert, roundtrip_error
from engine.paths import REAL_DATA_DIR
from tests.conftest import REAL_DATA, random_corpus_model, real_file


@pytest.fixture(scope="module")
def tiny():
    return random_corpus_model(layers=1)


def _walk(frames: int) -> np.ndarray:
    from engine.synth import Corpus

    joints = Corpus(split="test").sample(3, with_features=False).joints
    return np.concatenate([joints] * (frames // len(joints) + 1))[:frames]


def test_roundtrip_error_reports_the_inverted_noise_std(tiny):
    joints = _walk(30)
    config = InversionConfig(steps=4, refine=1)
    report = roundtrip_error(tiny, joints, config)
    assert report["noise_std"] == pytest.approx(float(invert(tiny, joints, config).noise.std()), rel=1e-6)
    assert report["noise_std"] > 0 and report["frames"] == 29


def test_defaults_point_at_the_shared_folder_and_invert_setting():
    assert InversionBenchConfig().real_data == REAL_DATA_DIR == REAL_DATA  # one constant, tests read it too
    assert InversionBenchConfig.quick().motions == 6 and InversionBenchConfig().motions == 16
    assert SETTINGS[DEFAULT_SETTING] == {"refine": InversionConfig().refine, "landing": InversionConfig().landing}
    assert InversionConfig().refine == 4 and InversionConfig().landing == 4
    assert SETTINGS["plain_ddim"] == {"refine": 0, "landing": 0}
    with pytest.raises(ValueError, match="0 or more"):
        InversionBenchConfig(motions=-1)


def test_bench_shape_with_one_corpus_motion_one_real_file_and_a_long_given_file(tiny, tmp_path):
    real = tmp_path / "real"
    real.mkdir()
    np.save(real / "a_walk.npy", _walk(40))
    np.save(real / "stats_Mean.npy", np.zeros(263, dtype=np.float32))  # not a motion: listed as skipped
    (real / "README.md").write_text("not a motion file\n")
    given = tmp_path / "long.npy"
    np.save(given, _walk(208))  # 10.4 s: cut to the model's 9.8 s
    lines = []
    result = bench_inversion(tiny, InversionBenchConfig(motions=1, steps=3, real_data=real), [given], log=lines.append)

    by = result["corpus_by_setting"]
    assert set(by) == set(SETTINGS) and by["plain_ddim"]["refine"] == 0 and by["fixed_point"]["refine"] == 4
    assert by["plain_ddim"]["landing"] == 0 and by["fixed_point"]["landing"] == 4
    corpus = result["corpus"]
    assert corpus == by[DEFAULT_SETTING] and corpus["motions"] == 1
    for key in ("mean_m", "max_m", "pose_mean_m", "noise_std"):
        assert np.isfinite(corpus[key]) and corpus[key] > 0
    assert corpus["max_m"] >= corpus["mean_m"]
    only = result["corpus_motions"][0]["by_setting"]
    assert corpus["mean_m"] == only["fixed_point"]["mean_m"] and corpus["noise_std"] == only["fixed_point"]["noise_std"]
    assert by["plain_ddim"]["noise_std"] == only["plain_ddim"]["noise_std"]

    assert [f["source"] for f in result["files"]] == ["a_walk.npy", str(given)]
    walk, long = result["files"]
    assert walk["real"] and not long["real"]
    assert walk["frames"] == 39 and walk["seconds"] == pytest.approx(2.0) and walk["trimmed_from_s"] is None
    assert long["frames"] == 195 and long["seconds"] == pytest.approx(9.8) and long["trimmed_from_s"] == pytest.approx(10.4)
    for f in result["files"]:
        assert set(f["by_setting"]) == set(SETTINGS)
        for key in ("mean_m", "max_m", "pose_mean_m", "noise_std"):
            assert f[key] == f["by_setting"][DEFAULT_SETTING][key] and np.isfinite(f[key])
    assert result["real_data"]["present"] and [s["source"] for s in result["real_data"]["skipped"]] == ["stats_Mean.npy"]
    assert result["steps"] == 3 and result["max_seconds"] == pytest.approx(9.8)
    json.dumps(result)
    assert any("skipped stats_Mean.npy" in line for line in lines)

    table = format_table(result)
    assert "corpus (1 test motions)" in table and "a_walk.npy" in table and "noise std" in table
    assert f"{corpus['noise_std']:.3f}" in table and f"{long['noise_std']:.3f}" in table
    assert "skipped: stats_Mean.npy" in table and "long.npy (10.4 s)" in table


def test_an_absent_real_folder_is_one_line_and_the_bench_goes_on(tiny, tmp_path):
    lines = []
    result = bench_inversion(tiny, InversionBenchConfig(motions=0, steps=2, real_data=tmp_path / "nowhere"),
                             log=lines.append)
    assert [line for line in lines if "absent" in line] == [
        f"real-data folder {tmp_path / 'nowhere'} is absent: inverting the corpus and given files only"]
    assert result["files"] == [] and not result["real_data"]["present"]
    assert result["corpus"]["motions"] == 0 and result["corpus"]["mean_m"] is None
    assert "is absent" in format_table(result)


def test_every_motion_file_of_the_shared_folder_is_found():
    real_file("cmu_131_01_walk.bvh")  # skips only when the shared folder is absent
    motions, info = real_motions(REAL_DATA, 196, log=lambda line: None)
    assert [m.source for m in motions] == ["cmu_131_01_walk.bvh", "humanml3d_012314_joints.npy",
                                           "humanml3d_012314_vecs.npy", "pymo_walk.bvh"]
    assert sorted(s["source"] for s in info["skipped"]) == ["humanml3d_Mean.npy", "humanml3d_Std.npy"]
    assert [len(m.joints) for m in motions] == [166, 170, 170, 178] and all(m.real for m in motions)


def test_the_pose_error_leaves_the_roots_path_out(tiny, monkeypatch):
    """``pose_mean_m``: the rebuilt motion's joints relative to its root against the input's. A rebuild that only
    walks off sideways (its root's path drifting, the pose exact) has a pose error of 0 and a mean error of the drift."""
    import engine.methods.inversion as inversion

    joints = _walk(30)
    target = inversion.features_to_joints(inversion.joints_to_features(joints))
    drift = np.linspace(0.0, 0.3, len(target))[:, None] * np.array([1.0, 0.0, 0.0])  # (T, 3): 0 -> 30 cm sideways
    monkeypatch.setattr(inversion, "reconstruct", lambda *a, **k: target + drift[:, None, :])
    report = roundtrip_error(tiny, joints, InversionConfig(steps=2, refine=0))
    assert report["pose_mean_m"] == pytest.approx(0.0, abs=1e-6)
    assert report["mean_m"] == pytest.approx(float(drift[:, 0].mean()), rel=1e-4)
