"""The studio's GIF/MP4 exports (viz.flat, app.tabs.files.exports): at least 640x480, the full title, every frame
at real speed; and the 2D drawing keeps the pyvista scene's camera."""
from __future__ import annotations

import io
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from PIL import Image

from app.session.items import MotionItem
from app.tabs.files.exports import VIDEO_SIZE, export_bytes
from engine.skeleton import JOINT_NAMES
from tests.conftest import walker
from viz.flat import FLOOR_SHADED, TEXT_COLOR, FlatRenderer, fit_title, font, wrap_text, write_gif, write_mp4

LONG_TITLE = ("a person walks forward slowly, stops to look around, then turns left and runs in a wide circle "
              "before jumping twice and waving with both hands · seed 12345")

# a standing pose facing +Z (left = +X), metres, feet on the floor


def dark(image: np.ndarray) -> np.ndarray:
    """Pixels about the text colour (nothing else in the picture is that dark)."""
    return np.abs(image[..., :3].astype(int) - np.array(TEXT_COLOR)).sum(axis=-1) < 90


# ---------------------------------------------------------------------------------------------- exports
def test_gif_export_is_640x480_with_every_frame_at_real_speed():
    motion = walker(40)
    data = export_bytes(MotionItem(name=LONG_TITLE, joints=motion, source="imported"), "gif")
    assert VIDEO_SIZE[0] >= 640 and VIDEO_SIZE[1] >= 480
    with Image.open(io.BytesIO(data)) as gif:
        assert gif.size == VIDEO_SIZE
        assert gif.n_frames == len(motion)
        durations = []
        for k in range(gif.n_frames):
            gif.seek(k)
            durations.append(gif.info["duration"])
    assert durations == [50] * len(motion)  # 20 fps: 40 frames play 2.0 s, the motion's own length
    frames = iio.imread(data, index=None, extension=".gif")[..., :3]
    assert np.abs(frames[-1].astype(int) - frames[0].astype(int)).sum(axis=-1).astype(bool).mean() > 0.01


def test_mp4_export_is_640x480_20fps_with_every_frame():
    motion = walker(30)
    data = export_bytes(MotionItem(name=LONG_TITLE, joints=motion, source="imported"), "mp4")
    meta = iio.immeta(data, extension=".mp4", plugin="FFMPEG")
    frames = list(iio.imiter(data, extension=".mp4", plugin="FFMPEG"))
    assert frames[0].shape == (VIDEO_SIZE[1], VIDEO_SIZE[0], 3)
    assert len(frames) == len(motion)
    assert abs(meta["fps"] - 20.0) < 1e-6 and abs(meta["duration"] - len(motion) / 20.0) < 0.06


def test_exported_frames_carry_the_whole_title_on_two_lines():
    """The GIF's first frame holds the long title as two lines of dark text inside the frame, the second line as
    long as the wrapped text says (nothing cut, no ellipsis)."""
    data = export_bytes(MotionItem(name=LONG_TITLE, joints=walker(3), source="imported"), "gif")
    frame = iio.imread(data, index=0, extension=".gif")[..., :3]
    renderer = FlatRenderer(walker(3), size=VIDEO_SIZE, title=LONG_TITLE, frame_label=True)
    lines, fnt = renderer.title_lines, renderer.title_font
    assert len(lines) == 2 and " ".join(lines) == LONG_TITLE and "…" not in "".join(lines)
    assert fnt.size >= 11
    (box, (x0, _)), = renderer._overlays
    title_right = x0 + box.width  # the frame counter is right of the title's box
    assert title_right <= VIDEO_SIZE[0]
    rows = dark(frame[:, :title_right]).any(axis=1)
    bands = np.flatnonzero(np.diff(np.concatenate([[0], rows.astype(int), [0]])) == 1)
    assert len(bands) >= 2 and bands[1] < 80, f"expected two text lines at the top, got bands at {bands}"
    # the second line's text ends where its full width says (+- 3 px), within the frame
    line_h = sum(fnt.getmetrics())
    top = bands[1]
    band = dark(frame[top : top + line_h, :title_right])
    right = np.flatnonzero(band.any(axis=0)).max()
    left = np.flatnonzero(band.any(axis=0)).min()
    assert abs((right - left + 1) - fnt.getlength(lines[1])) <= 3


def test_long_titles_shrink_then_wrap_and_are_never_cut():
    width = 460
    fnt, lines = fit_title("a person walks · seed 0", width=width)
    assert lines == ["a person walks · seed 0"] and fnt.size == 20
    fnt, lines = fit_title(LONG_TITLE, width=width)
    assert len(lines) == 2 and " ".join(lines) == LONG_TITLE
    assert all(fnt.getlength(s) <= width for s in lines)
    huge = " ".join([LONG_TITLE] * 4) + " " + "x" * 200  # past two lines even at the smallest size, and a long word
    fnt, lines = fit_title(huge, width=width)
    assert len(lines) > 2 and "".join(lines).replace(" ", "") == huge.replace(" ", "")
    assert all(fnt.getlength(s) <= width for s in lines)
    assert wrap_text("", font(12), 100) == []


def test_title_and_frame_counter_do_not_overlap():
    renderer = FlatRenderer(walker(5), size=VIDEO_SIZE, title=LONG_TITLE * 2, frame_label=True)
    (box, (x, y)), = renderer._overlays
    with_label = np.asarray(renderer.frame(4))
    counter = dark(with_label[: y + box.height, x + box.width + 1 :])
    assert counter.any(), "the frame counter sits right of the title box"
    assert x + box.width <= VIDEO_SIZE[0]


def test_duet_video_has_both_people_and_a_legend():
    a = walker(12)
    b = a.copy()
    b[..., 0] += 0.9
    renderer = FlatRenderer({"person a": a, "person b": b}, size=VIDEO_SIZE,
                            offsets={"person a": (0, 0, 0), "person b": (0, 0, 0)}, title="two people")
    image = np.asarray(renderer.frame(6)).astype(int)
    blue, orange = np.array([58, 111, 216]), np.array([232, 119, 46])  # the role palette's first two colours
    for colour in (blue, orange):
        assert (np.abs(image - colour).sum(axis=-1) < 40).sum() > 200
    assert len(renderer._overlays) == 2  # title and legend


def test_gif_uses_one_palette_so_the_floor_keeps_its_colours(tmp_path: Path):
    path = write_gif(FlatRenderer(walker(20), size=(320, 240)), tmp_path / "w.gif")
    frames = iio.imread(path, index=None)[..., :3].reshape(20, -1, 3)
    for tile in FLOOR_SHADED:
        present = [(np.abs(f.astype(int) - tile).sum(axis=-1) == 0).mean() for f in frames]
        assert min(present) > 0.02, "both floor colours exactly, in every frame"


def test_mp4_needs_even_sizes_and_every_keeps_real_speed(tmp_path: Path):
    with pytest.raises(ValueError, match="even"):
        write_mp4(FlatRenderer(walker(4), size=(121, 96)), tmp_path / "odd.mp4")
    path = write_gif(FlatRenderer(walker(12), size=(96, 80)), tmp_path / "w.gif", every=4)
    assert iio.imread(path, index=None).shape[0] == 3 and iio.immeta(path)["duration"] == 200


def test_still_camera_and_no_floor_render():
    still = FlatRenderer(walker(10, speed=0.3), size=(200, 160), follow=False)
    bare = FlatRenderer(walker(10, speed=0.3), size=(200, 160), follow=False, floor=False, path=False)
    a, b = np.asarray(still.frame(9)), np.asarray(bare.frame(9))
    floor = [(np.abs(a.astype(int) - tile).sum(axis=-1) < 6).mean() for tile in FLOOR_SHADED]
    assert min(floor) > 0.05 and (np.abs(b.astype(int) - FLOOR_SHADED[0]).sum(axis=-1) < 6).mean() < 0.01
    with pytest.raises(IndexError):
        still.frame(10)
    with pytest.raises(ValueError, match="shape"):
        FlatRenderer(np.zeros((4, 21, 3)))


# ---------------------------------------------------------------------------------------------- same camera
def test_flat_drawing_keeps_the_pyvista_scenes_camera():
    """The skeleton lands where the studio's 3D scene puts it: the centre of its pixels within a few pixels."""
    pytest.importorskip("pyvista")
    from viz.scene import SkeletonScene

    motion = walker(8)
    size = (240, 180)
    with SkeletonScene(motion, size=size, follow=True, anti_aliasing=None) as scene:
        scene.set_frame(7)
        with_body = scene.screenshot()
        scene.set_skeleton_visible(False)
        scene.set_path_visible(False)
        without = scene.screenshot()
    flat = FlatRenderer(motion, size=size, follow=True, path=False)
    flat_img = np.asarray(flat.frame(7))
    bare = np.asarray(FlatRenderer(motion, size=size, follow=True, path=False)._background)
    # the skeleton's colour: blue-ish pixels (blue well above red)
    def body(img: np.ndarray) -> np.ndarray:
        return (img[..., 2].astype(int) - img[..., 0]) > 60

    pv_mask = body(with_body) & (np.abs(with_body.astype(int) - without).sum(axis=-1) > 30)
    flat_mask = body(flat_img) & ~body(bare)
    assert pv_mask.sum() > 100 and flat_mask.sum() > 100
    centre = lambda m: np.array(np.nonzero(m)).mean(axis=1)  # noqa: E731
    assert np.abs(centre(pv_mask) - centre(flat_mask)).max() < 4
    rows = lambda m: np.flatnonzero(m.any(axis=1))  # noqa: E731
    assert abs(rows(pv_mask)[0] - rows(flat_mask)[0]) <= 4 and abs(rows(pv_mask)[-1] - rows(flat_mask)[-1]) <= 4


def test_titles_draw_no_empty_boxes():
    """The bundled font has no arrow, no ×, no dash and no accented letters: a compose title (A → B), a transfer
    title (LEADER ← FOLLOWER) or a typed "café" drew empty boxes. Such characters get a stand-in, or lose their
    accent, and every character of the fitted title has a glyph."""
    from viz.flat import STAND_INS, drawable

    missing = "\ue000"  # no glyph in any font: its mask is the box
    box = bytes(font(20).getmask(missing))
    for title in ("a man walks forward → he jumps", "walk ← run", "café, jumps ×2 — ok ✓"):
        assert any(bytes(font(20).getmask(ch)) == box for ch in title if not ch.isspace())  # the problem is real
        _, lines = fit_title(title, width=460)
        drawn = " ".join(lines)
        assert all(bytes(font(20).getmask(ch)) != box for ch in drawn if not ch.isspace()), drawn
    assert fit_title("a man walks forward → he jumps", width=460)[1] == ["a man walks forward -> he jumps"]
    assert drawable("café") == "cafe" and drawable("漢") == "?" and STAND_INS["←"] == "<-"
    assert drawable("a person walks · seed 0") == "a person walks · seed 0"  # what the font has is kept
