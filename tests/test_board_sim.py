"""The simulated board and camera: ink where strokes go, erasing, seeded photos whose
homography says where the board is."""

import numpy as np
import pytest

from kinegym.envs.sim.board import PENS, BoardCanvas, Pen, field_segments, hand_o, hand_x
from kinegym.envs.sim.camera import PRESETS, Camera, CameraSpec
from kinegym.envs.sim.scenes import random_scene


def test_strokes_leave_ink_where_they_go_and_only_there() -> None:
    c = BoardCanvas(10, 10, 20)
    c.stroke([[2, 2], [8, 2]], PENS["black"])
    assert c.ink_near([[5, 2]], 0.05)[0]
    assert not c.ink_near([[5, 3]], 0.3)[0]
    img = c.image()
    r, col = np.rint(c.to_px([5, 2])).astype(int)[::-1]
    assert img[r, col].max() < 60 and img[0, 0].min() > 200


def test_ink_over_ink_darkens_and_highlighter_does_not_hide_black() -> None:
    c = BoardCanvas(4, 4, 20)
    c.stroke([[1, 1], [3, 1]], PENS["blue"])
    one = c.density.max()
    c.stroke([[1, 1], [3, 1]], PENS["blue"])
    assert c.density.max() > one
    c.stroke([[1, 2], [3, 2]], PENS["black"])
    r, col = np.rint(c.to_px([2, 2])).astype(int)[::-1]
    before = c.image()[r, col].copy()
    c.stroke([[2, 1.5], [2, 2.5]], PENS["highlighter"])
    assert c.image()[r, col].max() <= before.max() + 1


def test_erase_cleans_with_full_efficiency_and_leaves_ghosts_below() -> None:
    c = BoardCanvas(10, 10, 16)
    for s in hand_x([5, 5], 2.0, np.random.default_rng(0)):
        c.stroke(s, PENS["black"])
    ghost = c.copy()
    ghost.erase([[0, 5], [10, 5]], 4.0, efficiency=0.9)
    assert 0 < ghost.ink().max() < 0.2 * c.ink().max()
    c.erase([[0, 5], [10, 5]], 4.0, efficiency=1.0)
    assert c.ink().max() < 1e-6


def test_field_segments_are_the_thesis_field() -> None:
    segs = field_segments(5, 3.0, (0, 0))
    assert len(segs) == 8  # 4 + 4 lines, no border
    assert all(np.isclose(np.linalg.norm(b - a), 15.0) for a, b in segs)
    assert len(field_segments(5, 3.0, (0, 0), frame=True)) == 12


def test_hand_marks_are_seeded_and_sized() -> None:
    a = hand_o([0, 0], 1.5, np.random.default_rng(3))
    b = hand_o([0, 0], 1.5, np.random.default_rng(3))
    assert np.array_equal(a[0], b[0])
    assert 0.9 < np.ptp(a[0], axis=0).max() < 2.2


def test_bad_pens_and_cameras_are_named_errors() -> None:
    with pytest.raises(ValueError, match="opacity"):
        Pen(opacity=0)
    with pytest.raises(ValueError, match="tilt_deg"):
        CameraSpec(tilt_deg=(10, 5))
    with pytest.raises(ValueError, match="preset"):
        Camera("fisheye")


def test_camera_homography_puts_ink_where_the_image_is_dark() -> None:
    c = BoardCanvas(20, 20, 16)
    dots = np.array([[5, 5], [15, 6], [9, 14], [13, 13]], float)
    for d in dots:
        c.stroke(np.array([d - [0.3, 0], d + [0.3, 0]]), PENS["black"].with_(width_cm=0.6))
    for preset in ("ideal", "default", "hard"):
        photo = Camera(preset, seed=4).photograph(c)
        grey = photo.image.mean(axis=2)
        for p in photo.project(dots):
            x, y = np.rint(p).astype(int)
            assert grey[y, x] < 0.6 * np.median(grey), preset


def test_photos_replay_with_their_seed() -> None:
    a, b = random_scene(7, difficulty="hard"), random_scene(7, difficulty="hard")
    assert np.array_equal(a.photo.image, b.photo.image) and np.array_equal(a.cells, b.cells)
    assert not np.array_equal(a.photo.image, random_scene(8, difficulty="hard").photo.image)
    assert set(PRESETS) == {"ideal", "default", "hard"}
