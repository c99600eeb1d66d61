"""`moattn generate --out x.gif / x.mp4 / x.png`, `moattn render IN --out x.gif / x.mp4 / x.png` and the `--render`
pictures of `edit`, `compose`, `transfer`, `control` and `duet` write through the studio's exporter (issue #35): one
render path for a picture of a motion (viz.export, drawn by viz.flat), never VTK; the GIF is byte for byte the
studio's Export of the same joints and title, at the studio's size."""
from __future__ import annotations

import io
import json
import sys
from types import SimpleNamespace

import imageio.v2 as imageio_v2
import numpy as np
import pytest
from PIL import Image

from app.tabs.files.exports import VIDEO_SIZE, video_bytes
from tests.conftest import walker
from viz.export import write_picture as _exporter  # the real one, never the spy


def test_generate_writes_its_pictures_with_the_studios_exporter(tmp_path, tiny_model_dir, monkeypatch):
    from engine.cli import main

    _no_vtk(monkeypatch)
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


# ------------------------------------------------------------------- --render of edit, compose, transfer, control, duet
def _spy_on_the_exporter(monkeypatch) -> list[dict]:
    """Every call of viz.export.write_picture (which still writes): the motions, path and options it was given.
    The tests' own pictures are drawn by ``_exporter`` (the function itself), so only the command's calls count."""
    import viz.export

    calls, real = [], viz.export.write_picture

    def spy(motions, path, **options):
        calls.append({"motions": motions, "path": path, **options})
        return real(motions, path, **options)

    monkeypatch.setattr(viz.export, "write_picture", spy)
    return calls


def _gif_of_the_studio(path, n_frames: int) -> None:
    with Image.open(path) as im:
        assert im.format == "GIF" and im.size == VIDEO_SIZE and im.n_frames == n_frames
        assert im.info["duration"] == 50  # 20 fps: the motion's real speed


def _is_the_exporters_picture(call: dict, tmp_path) -> None:
    """The file the command wrote is byte for byte write_picture's picture of the same motions and title."""
    written = call["path"]
    again = tmp_path / f"again{written.suffix}"
    options = {k: v for k, v in call.items() if k not in ("motions", "path")}
    assert written.read_bytes() == _exporter(call["motions"], again, **options).read_bytes()


def test_edit_render_is_the_studios_before_after_picture(tmp_path, tiny_model_dir, monkeypatch, capsys):
    from engine.cli import main

    _no_vtk(monkeypatch)
    calls = _spy_on_the_exporter(monkeypatch)
    out, gif = tmp_path / "edited.npy", tmp_path / "edit.gif"
    assert main(["edit", "emphasize", "a person jumps", "--word", "jumps", "--weight", "0.5", "--steps", "2",
                 "--seconds", "1", "--seed", "3", "--model", str(tiny_model_dir), "--out", str(out),
                 "--render", str(gif), "--no-library"]) == 0
    assert json.loads(capsys.readouterr().out)["render"] == str(gif)
    (call,) = calls
    assert call["path"] == gif and call["title"] == "emphasize: a person jumps" and call.get("offsets") is None
    before, after = call["motions"]  # before and after, side by side (the exporter's default layout)
    assert before.startswith("before (") and after.startswith("after (")
    edited = np.load(out)
    np.testing.assert_allclose(call["motions"][after], edited, atol=1e-6)  # the edited motion it wrote
    _gif_of_the_studio(gif, len(edited))
    _is_the_exporters_picture(call, tmp_path)
    # two people side by side, not the edited motion alone
    alone = _exporter(edited, tmp_path / "alone.gif", title=call["title"])
    assert gif.read_bytes() != alone.read_bytes()
    # an edit of a motion file is titled with the file's name (it once failed here, after writing --out)
    calls.clear()
    np.save(tmp_path / "walk.npy", walker(30))
    png = tmp_path / "example.png"
    assert main(["edit", "example", str(tmp_path / "walk.npy"), "--steps", "2", "--model", str(tiny_model_dir),
                 "--out", str(tmp_path / "example.npy"), "--render", str(png), "--no-library"]) == 0
    capsys.readouterr()
    (call,) = calls
    assert call["path"] == png and call["title"] == "example: walk.npy"
    with Image.open(png) as im:
        assert im.format == "PNG" and im.size == VIDEO_SIZE
    _is_the_exporters_picture(call, tmp_path)


def test_duet_render_is_the_studios_duet_export(tmp_path, tiny_model_dir, tiny_duet_dir, monkeypatch, capsys):
    from app.tabs.files.exports import export_duet_bytes
    from engine.cli import main
    from engine.methods.duet import by_person

    _no_vtk(monkeypatch)
    out, gif = tmp_path / "duet.npy", tmp_path / "duet.gif"
    models = ["--model", str(tiny_model_dir), "--duet-model", str(tiny_duet_dir), "--no-library"]
    assert main(["duet", "two people hug", "--out", str(out), "--seconds", "2", "--steps", "3", "--render", str(gif),
                 *models]) == 0
    assert json.loads(capsys.readouterr().out)["render"] == str(gif)
    joints = np.load(out)
    assert joints.shape == (2, 40, 22, 3)
    _gif_of_the_studio(gif, 40)
    # the studio's Duet export of the same two people (one shared space), titled with the prompt
    assert gif.read_bytes() == export_duet_bytes(SimpleNamespace(joints=joints), "gif", title="two people hug")
    # both bodies are drawn: not person a alone, nor person b alone, nor the two side by side
    people = by_person(joints)
    for other in (joints[0], joints[1], people):
        assert gif.read_bytes() != _exporter(other, tmp_path / "other.gif", title="two people hug").read_bytes()
    # a completion (no prompt) as a PNG: frame 0, titled as the duet is kept ("completed duet")
    more, png = tmp_path / "more.npy", tmp_path / "more.png"
    assert main(["duet", "--prefix", str(out), "--prefix-seconds", "0.5", "--seconds", "1", "--steps", "3",
                 "--out", str(more), "--render", str(png), *models]) == 0
    capsys.readouterr()
    completed = by_person(np.load(more))
    expected = _exporter(completed, tmp_path / "ref.png", title="completed duet",
                         offsets={role: (0.0, 0.0, 0.0) for role in completed})
    with Image.open(png) as im:
        assert im.format == "PNG" and im.size == VIDEO_SIZE
    assert png.read_bytes() == expected.read_bytes()


def test_compose_transfer_and_control_render_with_the_studios_exporter(tmp_path, tiny_model_dir, monkeypatch,
                                                                        capsys):
    from engine.cli import main

    _no_vtk(monkeypatch)
    calls = _spy_on_the_exporter(monkeypatch)
    model = ["--model", str(tiny_model_dir), "--steps", "2", "--no-library"]

    long, gif = tmp_path / "long.npy", tmp_path / "long.gif"
    assert main(["compose", "a person walks:2", "a person jumps:2", "--out", str(long), "--render", str(gif),
                 *model]) == 0
    assert json.loads(capsys.readouterr().out)["render"] == str(gif)
    (call,) = calls
    calls.clear()
    assert call["path"] == gif and call["title"] == "a person walks → a person jumps"
    np.testing.assert_allclose(call["motions"], np.load(long), atol=1e-6)
    _gif_of_the_studio(gif, len(np.load(long)))
    _is_the_exporters_picture(call, tmp_path)

    moved, gif = tmp_path / "moved.npy", tmp_path / "moved.gif"
    assert main(["transfer", "--leader", "a person walks", "--follower", "a person jumps", "--seconds", "1",
                 "--out", str(moved), "--render", str(gif), *model]) == 0
    report = json.loads(capsys.readouterr().out)
    (call,) = calls
    calls.clear()
    assert call["path"] == gif and call["title"] == f"{report['leader']} ← {report['followers'][0]}"
    assert "a person walks" in call["title"] and "a person jumps" in call["title"]
    assert list(call["motions"]) == ["leader", "follower 1", "out 1"]  # side by side, as before
    np.testing.assert_allclose(call["motions"]["out 1"], np.load(moved), atol=1e-6)
    _gif_of_the_studio(gif, 20)
    _is_the_exporters_picture(call, tmp_path)

    root = tmp_path / "root.json"
    root.write_text(json.dumps({"points": [[0, 0], [0, 1], [0.5, 1.5]]}))
    followed, png = tmp_path / "c.npy", tmp_path / "c.png"
    assert main(["control", "--prompt", "a person walks", "--root", str(root), "--inpaint", "--seconds", "2",
                 "--out", str(followed), "--render", str(png), *model]) == 0
    capsys.readouterr()
    (call,) = calls
    calls.clear()
    assert call["path"] == png and call["title"] == "a person walks · inpainting (root)"
    np.testing.assert_allclose(call["motions"], np.load(followed), atol=1e-5)
    with Image.open(png) as im:
        assert im.format == "PNG" and im.size == VIDEO_SIZE
    _is_the_exporters_picture(call, tmp_path)
