"""`moattn generate --out x.gif / x.mp4 / x.png` writes through the studio's exporter (issue #35): one render path
for a picture of a motion (viz.export, drawn by viz.flat), never VTK; the GIF is byte for byte the studio's Export
of the same joints and title, at the studio's size."""
from __future__ import annotations

import io

import numpy as np
from PIL import Image

from app.tabs.files.exports import VIDEO_SIZE, video_bytes


def test_generate_writes_its_pictures_with_the_studios_exporter(tmp_path, tiny_model_dir, monkeypatch):
    import viz.render
    from engine.cli import main

    def no_vtk(*_, **__):
        raise AssertionError("moattn generate rendered through viz.render (VTK), not the studio's exporter")

    monkeypatch.setattr(viz.render, "render_file", no_vtk)
    outs = [tmp_path / "m.npy", tmp_path / "m.gif", tmp_path / "m.png", tmp_path / "m.mp4"]
    prompt = "a person walks forward"
    argv = ["generate", prompt, "--model", str(tiny_model_dir), "--steps", "2", "--seconds", "2", "--no-library"]
    assert main([*argv, *(a for out in outs for a in ("--out", str(out)))]) == 0
    joints = np.load(outs[0])
    assert outs[1].read_bytes() == video_bytes(joints, "gif", title=prompt)
    gif = Image.open(outs[1])
    assert gif.size == VIDEO_SIZE and gif.n_frames == len(joints)
    png = Image.open(io.BytesIO(outs[2].read_bytes()))
    assert png.format == "PNG" and png.size == VIDEO_SIZE
    assert outs[3].read_bytes()[4:8] == b"ftyp"
