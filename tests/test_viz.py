"""Tests of viz/: the skeleton scene (in-place updates, colours, camera) and its frames as images (for the corpus's
contact sheets; files are written by the studio's exporter, tested in test_viz_flat.py and test_cli_pictures.py).

Images are checked by statistics against a render of the same scene with the skeleton
hidden, so a blank or skeleton-less image fails. Sizes are small to keep the file fast.
"""
from __future__ import annotations

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from engine.skeleton import JOINT_NAMES, PARENTS  # noqa: E402
from tests.conftest import walker  # noqa: E402
from viz.camera import facing_azimuth  # noqa: E402
from viz.geometry import BONE_CHILDREN, BONE_PARENTS  # noqa: E402
from viz.render import render_frames  # noqa: E402
from viz.sheet import contact_sheet  # noqa: E402
from viz.layout import side_by_side_offsets  # noqa: E402
from viz.scene import SkeletonScene  # noqa: E402

SMALL = (200, 160)

# A standing pose facing +Z (left = +X), metres, feet on the floor.


def skeleton_mask(with_skeleton: np.ndarray, without: np.ndarray, *, threshold: int = 40) -> np.ndarray:
    """Pixels where the skeleton changes the image."""
    diff = np.abs(with_skeleton.astype(np.int32) - without.astype(np.int32)).sum(axis=2)
    return diff > threshold


def dilate(mask: np.ndarray, *, pixels: int) -> np.ndarray:
    """Grow a boolean mask by ``pixels`` in every direction (square neighbourhood)."""
    out = mask.copy()
    padded = np.pad(mask, pixels)
    h, w = mask.shape
    for dy in range(2 * pixels + 1):
        for dx in range(2 * pixels + 1):
            out |= padded[dy : dy + h, dx : dx + w]
    return out


def background_of(joints: np.ndarray, *, size: tuple[int, int], frame: int = 0, **options) -> np.ndarray:
    with SkeletonScene(joints, size=size, **options) as scene:
        scene.set_frame(frame)
        scene.set_skeleton_visible(False)
        return scene.screenshot()


def assert_figure_visible(image: np.ndarray, background: np.ndarray, *, upright: bool = True) -> np.ndarray:
    """The skeleton covers a plausible area, lies inside the image and (standing) is taller than wide."""
    h, w = image.shape[:2]
    mask = skeleton_mask(image, background)
    share = mask.mean()
    assert 0.005 < share < 0.5, f"skeleton covers {share:.3%} of the image"
    rows, cols = np.nonzero(mask)
    top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
    assert top > 0 and left > 0 and bottom < h - 1 and right < w - 1, "skeleton touches the image border"
    height, width = bottom - top + 1, right - left + 1
    assert height > 0.25 * h, f"skeleton only {height} px tall in a {h} px image"
    if upright:
        assert height > 1.3 * width, f"standing pose should be taller than wide, got {height}x{width} px"
    # lit, not flat: shading varies across the skeleton's pixels
    luminance = image[mask].astype(np.float64).mean(axis=1)
    assert luminance.std() > 5.0
    return mask


# ---------------------------------------------------------------------------- PNG / visibility
def test_real_frame0_shows_upright_skeleton(real_joints: np.ndarray) -> None:
    (image,) = render_frames(real_joints, frames=[0], size=(320, 240))
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    background = background_of(real_joints, size=(320, 240))
    mask = assert_figure_visible(image, background)
    # the default palette's first role is blue: the skeleton's pixels are bluish
    pixels = image[mask].astype(np.int32)
    assert (pixels[:, 2] > pixels[:, 0] + 30).mean() > 0.8


def test_synthetic_standing_pose_is_centred_and_upright() -> None:
    motion = walker(1)
    with SkeletonScene(motion, size=SMALL, follow=True) as scene:
        image = scene.screenshot()
        scene.set_skeleton_visible(False)
        background = scene.screenshot()
    mask = assert_figure_visible(image, background)
    cols = np.nonzero(mask)[1]
    assert abs(cols.mean() - SMALL[0] / 2) < SMALL[0] / 4, "body should be near the horizontal centre"


def test_floor_and_path_are_drawn() -> None:
    motion = walker(12)
    with SkeletonScene(motion, size=SMALL) as scene:
        scene.set_skeleton_visible(False)
        with_floor = scene.screenshot()
        scene.set_path_visible(False)
        without_path = scene.screenshot()
        scene.set_floor_visible(False)
        sky_only = scene.screenshot()
    floor_share = skeleton_mask(without_path, sky_only, threshold=20).mean()
    assert floor_share > 0.2, f"floor covers only {floor_share:.1%} of the image"
    assert skeleton_mask(with_floor, without_path).sum() > 20, "root path not visible"


def test_render_frames_refuses_frames_outside_the_motion() -> None:
    motion = walker(3)
    with pytest.raises(IndexError, match=r"frames \[3\] out of range 0..2"):
        render_frames(motion, frames=[0, 3], size=(64, 48))
    with pytest.raises(ValueError, match="every must be >= 1"):
        render_frames(motion, every=0, size=(64, 48))


def test_invalid_motion_shapes_raise() -> None:
    with pytest.raises(ValueError, match=r"\(T, 22, 3\)"):
        SkeletonScene(np.zeros((5, 21, 3)))
    bad = walker(2)
    bad[1, 3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        SkeletonScene(bad)


# ---------------------------------------------------------------------------- in-place updates
def test_set_frame_updates_points_in_place() -> None:
    motion = walker(6)
    with SkeletonScene(motion, size=SMALL) as scene:
        renderer = scene.plotter.renderer
        n_actors = len(renderer.actors)
        meshes = scene.meshes["motion"]
        actors = scene.actors["motion"]
        ids = {name: id(mesh) for name, mesh in meshes.items()}
        sizes = {name: (mesh.n_points, mesh.n_cells) for name, mesh in meshes.items()}
        for name in ("joints", "bones"):
            assert actors[name].mapper.dataset is meshes[name]
        before = {name: np.array(meshes[name].points) for name in ("joints", "bones")}
        first = scene.screenshot()
        scene.set_frame(5)
        after_meshes = scene.meshes["motion"]
        assert len(renderer.actors) == n_actors
        assert {name: id(mesh) for name, mesh in after_meshes.items()} == ids
        assert {name: (m.n_points, m.n_cells) for name, m in after_meshes.items()} == sizes
        for name in ("joints", "bones"):
            assert actors[name].mapper.dataset is meshes[name]
            assert not np.allclose(before[name], meshes[name].points)
        # the sphere of each joint is centred on that joint at the new frame
        centres = np.asarray(meshes["joints"].points).reshape(len(JOINT_NAMES), -1, 3).mean(axis=1)
        np.testing.assert_allclose(centres, motion[5], atol=1e-9)
        assert skeleton_mask(scene.screenshot(), first).sum() > 20, "new frame not rendered"
        scene.set_frame(0)
        np.testing.assert_array_equal(scene.screenshot(), first)
        with pytest.raises(IndexError):
            scene.set_frame(6)


def test_bone_tubes_follow_the_bones() -> None:
    motion = walker(1)
    radius = 0.02
    with SkeletonScene(motion, size=SMALL, bone_radius=radius) as scene:
        pts = np.asarray(scene.meshes["motion"]["bones"].points).reshape(len(BONE_CHILDREN), -1, 3)
    pose = motion[0]
    assert list(BONE_PARENTS) == [PARENTS[c] for c in BONE_CHILDREN]
    for b, (p, c) in enumerate(zip(BONE_PARENTS, BONE_CHILDREN)):
        axis = pose[c] - pose[p]
        length = np.linalg.norm(axis)
        rel = pts[b] - pose[p]
        along = rel @ axis / length
        radial = np.linalg.norm(rel - np.outer(along, axis / length), axis=1)
        np.testing.assert_allclose(radial, radius, atol=1e-9)
        assert along.min() == pytest.approx(0.0, abs=1e-9) and along.max() == pytest.approx(length)


def test_follow_keeps_pelvis_in_focus() -> None:
    motion = walker(10, speed=0.2)
    with SkeletonScene(motion, size=SMALL, follow=True) as scene:
        cam = scene.plotter.camera
        focal0 = np.asarray(cam.focal_point)
        offset0 = np.asarray(cam.position) - focal0
        scene.set_frame(9)
        focal = np.asarray(cam.focal_point)
        np.testing.assert_allclose(focal[[0, 2]], motion[9, 0, [0, 2]], atol=0.2)
        np.testing.assert_allclose(focal - focal0, motion[9, 0] - motion[0, 0], atol=1e-9)
        np.testing.assert_allclose(np.asarray(cam.position) - focal, offset0, atol=1e-9)
        image = scene.screenshot()
        scene.set_skeleton_visible(False)
        assert_figure_visible(image, scene.screenshot())
        scene.set_frame(0)
        np.testing.assert_allclose(np.asarray(cam.focal_point), focal0, atol=1e-12)
    with SkeletonScene(motion, size=SMALL, follow=False) as scene:
        focal_before = np.asarray(scene.plotter.camera.focal_point)
        scene.set_frame(9)
        np.testing.assert_array_equal(np.asarray(scene.plotter.camera.focal_point), focal_before)


def test_default_view_is_three_quarter_front() -> None:
    motion = walker(1)
    with SkeletonScene(motion, size=SMALL) as scene:
        cam = scene.plotter.camera
        to_camera = np.asarray(cam.position) - np.asarray(cam.focal_point)
    heading = np.radians(facing_azimuth(motion[0]))
    facing = np.array([np.sin(heading), 0.0, np.cos(heading)])
    horizontal = to_camera * [1, 0, 1] / np.linalg.norm(to_camera * [1, 0, 1])
    angle = np.degrees(np.arccos(horizontal @ facing))
    assert 15 < angle < 60, f"camera should look at the front at 3/4, got {angle:.0f} deg off the facing"
    assert to_camera[1] > 0, "camera should look down a little"


# ---------------------------------------------------------------------------- colours
def test_colouring_changes_skeleton_pixels() -> None:
    motion = walker(4)
    with SkeletonScene(motion, size=SMALL) as scene:
        default = scene.screenshot()
        scene.set_skeleton_visible(False)
        mask = skeleton_mask(default, scene.screenshot())
        scene.set_skeleton_visible(True)

        scene.set_color("red")
        red = scene.screenshot()[mask].astype(np.int32)
        assert (red[:, 0] > red[:, 2] + 40).mean() > 0.7

        values = np.zeros(len(JOINT_NAMES))
        values[JOINT_NAMES.index("head")] = 1.0
        scene.set_joint_values(values, cmap="viridis")
        by_value = scene.screenshot()
        assert np.abs(by_value.astype(int) - default.astype(int))[mask].mean() > 20

        per_frame = np.zeros((len(motion), 3))
        per_frame[2] = (0.0, 1.0, 0.0)
        scene.set_frame_colors(per_frame)
        black = scene.screenshot()[mask].astype(np.int32)
        scene.set_frame(2)
        green = scene.screenshot().astype(np.int32)
        assert np.median(black.sum(axis=1)) < np.median(green[mask].sum(axis=1))

        scene.reset_colors()
        scene.set_frame(0)
        np.testing.assert_array_equal(scene.screenshot(), default)
        with pytest.raises(ValueError):
            scene.set_joint_colors(np.zeros((21, 3)))
        with pytest.raises(ValueError):
            scene.set_frame_colors(np.zeros((len(motion) + 1, 3)))


# ---------------------------------------------------------------------------- several skeletons
def test_side_by_side_roles_never_overlap_and_colour_separately() -> None:
    a, b = walker(8), walker(5, speed=-0.05)
    motions = {"leader": a, "follower": b}
    offsets = side_by_side_offsets(motions, spacing=0.5)
    with SkeletonScene(motions, size=(240, 160), spacing=0.5) as scene:
        assert scene.roles == ("leader", "follower") and scene.n_frames == 8
        lead, follow = scene.joints(role="leader"), scene.joints(role="follower")
        np.testing.assert_allclose(lead - a, np.broadcast_to(offsets["leader"], a.shape))
        for k in range(8):
            gap = follow[min(k, 4), :, 0].min() - lead[k, :, 0].max()
            assert gap >= 0.5 - 1e-9
        scene.set_frame(7)  # the shorter motion holds its last pose
        centres = np.asarray(scene.meshes["follower"]["joints"].points).reshape(22, -1, 3).mean(axis=1)
        np.testing.assert_allclose(centres, follow[4], atol=1e-9)
        before = scene.screenshot()
        scene.set_skeleton_visible(False, role="follower")
        follower_mask = skeleton_mask(before, scene.screenshot())
        scene.set_skeleton_visible(True, role="follower")
        assert follower_mask.sum() > 20
        scene.set_color("black", role="follower")
        changed = skeleton_mask(scene.screenshot(), before)
        assert changed.sum() > 0.5 * follower_mask.sum()
        near_follower = dilate(follower_mask, pixels=2)
        assert not (changed & ~near_follower).any(), "recolouring the follower changed other pixels"
    with pytest.raises(KeyError):
        SkeletonScene(motions, size=SMALL).set_color("red", role="nobody")
    shared = {"a": a, "b": a}
    with SkeletonScene(shared, size=SMALL, offsets={"a": (0, 0, 0), "b": (1, 0, 0)}) as scene:
        np.testing.assert_allclose(scene.joints(role="b") - scene.joints(role="a"), np.broadcast_to([1, 0, 0], a.shape))


# ---------------------------------------------------------------------------- contact sheets
def test_render_frames_and_contact_sheet() -> None:
    motion = walker(10)
    images = render_frames(motion, every=3, size=(64, 80), follow=True)
    assert len(images) == 4 and all(img.shape == (80, 64, 3) for img in images)
    sheet = contact_sheet(images, cols=3, labels=["0", "3", "6", "a long label that will not fit"], pad=4)
    label_h = 14 + 4
    assert sheet.shape == (2 * (80 + label_h) + 3 * 4, 3 * 64 + 4 * 4, 3)
    strip = sheet[4 + 80 : 4 + 80 + label_h, 4 : 4 + 64]
    assert (strip.sum(axis=2) < 400).sum() > 5, "label text not drawn"
    plain = contact_sheet(images[:2], cols=5)
    assert plain.shape == (80 + 2 * 6, 2 * 64 + 3 * 6, 3)
    with pytest.raises(ValueError):
        contact_sheet(images, cols=2, labels=["only one"])


def test_follow_frames_all_roles_and_can_be_toggled() -> None:
    motions = {"a": walker(6, speed=0.1), "b": walker(6, speed=0.1)}
    with SkeletonScene(motions, size=(240, 160), follow=True, offsets={"a": (-1, 0, 0), "b": (1, 0, 0)}) as scene:
        image = scene.screenshot()
        scene.set_skeleton_visible(False)
        mask = skeleton_mask(image, scene.screenshot())
        scene.set_skeleton_visible(True)
        cols = np.nonzero(mask)[1]
        assert cols.min() > 0 and cols.max() < 239, "both skeletons should be in view"
        assert mask[:, :120].sum() > 20 and mask[:, 120:].sum() > 20
        scene.follow = False
        focal = np.asarray(scene.plotter.camera.focal_point)
        scene.set_frame(5)
        np.testing.assert_array_equal(np.asarray(scene.plotter.camera.focal_point), focal)
        scene.follow = True  # re-enabling does not jump: only later motion moves the camera
        np.testing.assert_array_equal(np.asarray(scene.plotter.camera.focal_point), focal)
        scene.set_frame(3)
        np.testing.assert_allclose(np.asarray(scene.plotter.camera.focal_point) - focal, [0, 0, -0.2], atol=1e-9)
