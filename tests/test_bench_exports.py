"""`moattn bench --exports` times the studio's own export path for every format it names, beside a busy process."""
from __future__ import annotations

import math

import pytest

from app.bench.exports import bench_exports, busy_processes, format_table


def test_exports_are_timed_through_the_studio_path_beside_a_busy_process(tiny_model_dir):
    from engine.checkpoint import load_model

    result = bench_exports(load_model(tiny_model_dir), formats=("bvh", "glb", "gif"), steps=2, busy=1)
    assert [r["format"] for r in result["rows"]] == ["bvh", "glb", "gif"]
    assert all(math.isfinite(r["seconds"]) and r["seconds"] > 0 and r["kb"] > 1 for r in result["rows"])
    assert all(0 < r["cpu_s"] < 10 * r["seconds"] + 1 for r in result["rows"])
    gif = result["rows"][2]
    assert gif["target_s"] == 5.0 and gif["meets_target"] == (gif["seconds"] <= 5.0)
    # what a user gets: at least 640x480, every frame of the motion, played at its own speed
    assert gif["width"] >= 640 and gif["height"] >= 480
    assert gif["frames"] <= result["frames"] and gif["play_s"] == pytest.approx(result["motion_seconds"], abs=0.01)
    table = format_table(result)
    assert "gif" in table and "640x480" in table and "beside 1 busy process" in table
    with pytest.raises(ValueError, match="no export 'png'"):
        bench_exports(load_model(tiny_model_dir), formats=("png",), steps=1)


def test_busy_processes_spin_during_the_block_and_stop_after():
    with busy_processes(2) as procs:
        assert len(procs) == 2 and all(p.poll() is None for p in procs)
    assert all(p.returncode is not None for p in procs)
    with busy_processes(0) as procs:
        assert procs == []
