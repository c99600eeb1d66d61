"""`moattn generate --out x.gif / x.mp4 / x.png` and `moattn render IN --out x.gif / x.mp4 / x.png` write through
the studio's exporter (issue #35): one render path for a picture of a motion (viz.export, drawn by viz.flat), never
VTK; the GIF is byte for byte the studio's Export of the same joints and title, at the studio's size."""
from __future__ import annotations

import io
import sys

import imageio.v2 as imageio_v2
import numpy as np
import pytest
from PIL import Image

from app.tabs.files.exports import VIDEO_SIZE, video_bytes
from tests.conftest import walker


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


def _no_vtk(monkeypatch) -> None:
    """Importing the pyvista renderer (viz.render, viz.scene, pyvista) fails for the rest of the test."""
    for name in ("viz.render", "viz.scene", "pyvista"):
        monkeypatch.setitem(sys.modules, name, None)


def test_render_writes_the_studios_pictures(tmp_path, monkeypatch, capsys):
    from engine.cli import main
    from viz.export import write_picture

    _no_vtk(monkeypatch)
    joints = walker(14)
    motion = tmp_path / "walk.npy"
    np.save(motion, joints)

    gif, mp4, png = tmp_path / "w.gif", tmp_path / "w.mp4", tmp_path / "w.png"
    for out, extra in ((gif, []), (mp4, []), (png, ["--frame", "5"])):
        assert main(["render", str(motion), "--out", str(out), *extra]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {gif} (14 frames)" in printed and f"wrote {png} (1 frame)" in printed

    # GIF: the studio's Export of the same joints, titled with the input's name; every frame, at 20 fps
    assert gif.read_bytes() == video_bytes(joints, "gif", title="walk.npy")
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.size == VIDEO_SIZE and im.n_frames == len(joints)
        assert im.info["duration"] == 50
    # MP4: H.264 at the studio's size, every frame, 20 fps
    reader = imageio_v2.get_reader(mp4, format="FFMPEG")
    try:
        meta = reader.get_meta_data()
        frames = [np.asarray(f) for f in reader]
    finally:
        reader.close()
    assert mp4.read_bytes()[4:8] == b"ftyp" and meta["codec"] == "h264" and meta["fps"] == 20
    assert len(frames) == len(joints) and all(f.shape == (VIDEO_SIZE[1], VIDEO_SIZE[0], 3) for f in frames)
    assert not np.array_equal(frames[0], frames[-1])  # the motion moves
    # PNG: the exporter's frame 5, not frame 0
    with Image.open(io.BytesIO(png.read_bytes())) as im:
        assert im.format == "PNG" and im.size == VIDEO_SIZE
        drawn = np.asarray(im.convert("RGB"))
    expected = np.asarray(Image.open(write_picture(joints, tmp_path / "ref5.png", title="walk.npy", frame=5)))
    first = np.asarray(Image.open(write_picture(joints, tmp_path / "ref0.png", title="walk.npy")))
    assert np.array_equal(drawn, expected[..., :3]) and not np.array_equal(drawn, first[..., :3])

    # --title replaces the file name; a .bvh input is read as well
    from engine.io import load_motion, save_motion

    bvh = save_motion(joints, tmp_path / "walk.bvh")
    titled = tmp_path / "t.gif"
    assert main(["render", str(bvh), "--out", str(titled), "--title", "a person walks"]) == 0
    assert titled.read_bytes() == video_bytes(load_motion(bvh), "gif", title="a person walks")


@pytest.mark.parametrize("case,expected", [
    ("missing input", "not found"),
    ("unknown input type", "unsupported motion file type '.txt'"),
    ("unknown output type", "unsupported file type '.webm'"),
    ("no output extension", "unsupported file type '(no extension)'"),
    ("empty motion", "zero frames"),
    ("not a motion", "expected joints (T, 22, 3)"),
    ("frame out of range", "--frame 14 is outside the motion's 14 frames"),
    ("frame of a video", "--frame picks the frame of a .png"),
])
def test_render_refuses_bad_input_in_one_line(tmp_path, monkeypatch, capsys, case, expected):
    from engine.cli import main

    _no_vtk(monkeypatch)
    np.save(tmp_path / "walk.npy", walker(14))
    np.save(tmp_path / "empty.npy", np.zeros((0, 22, 3), np.float32))
    np.save(tmp_path / "flat.npy", np.zeros((14, 3), np.float32))
    (tmp_path / "walk.txt").write_text("not a motion")
    before = sorted(p.name for p in tmp_path.iterdir())
    argv = {
        "missing input": ["missing.npy", "--out", "o.gif"],
        "unknown input type": ["walk.txt", "--out", "o.gif"],
        "unknown output type": ["walk.npy", "--out", "o.webm"],
        "no output extension": ["walk.npy", "--out", "o"],
        "empty motion": ["empty.npy", "--out", "o.gif"],
        "not a motion": ["flat.npy", "--out", "o.png"],
        "frame out of range": ["walk.npy", "--out", "o.png", "--frame", "14"],
        "frame of a video": ["walk.npy", "--out", "o.gif", "--frame", "3"],
    }[case]
    argv = [str(tmp_path / a) if a.endswith((".npy", ".txt", ".gif", ".png", ".webm")) or a == "o" else a
            for a in argv]
    assert main(["render", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert err.startswith("moattn render: error: ") and expected in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
