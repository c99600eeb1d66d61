"""`moattn bench --exports` times the studio's own export path for every format it names."""
from __future__ import annotations

import math

import pytest

from app.bench_exports import bench_exports, format_table


def test_exports_are_timed_through_the_studio_path(tiny_model_dir):
    from engine.checkpoint import load_model

    result = bench_exports(load_model(tiny_model_dir), formats=("bvh", "glb", "gif"), steps=2)
    assert [r["format"] for r in result["rows"]] == ["bvh", "glb", "gif"]
    assert all(math.isfinite(r["seconds"]) and r["seconds"] > 0 and r["kb"] > 1 for r in result["rows"])
    gif = result["rows"][2]
    assert gif["target_s"] == 5.0 and gif["meets_target"] == (gif["seconds"] <= 5.0)
    assert "gif" in format_table(result)
    with pytest.raises(ValueError, match="no export 'png'"):
        bench_exports(load_model(tiny_model_dir), formats=("png",), steps=1)
