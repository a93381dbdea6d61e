"""The board reader's second look (:mod:`kinegym.vision.zoom`): an unsure reading of a field small
in the photo is read again on a crop around it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision.board_reader import BoardReader, NoBoardError, debug_image
from kinegym.vision.image_io import read_image
from kinegym.vision.reading import BoardReading
from kinegym.vision.zoom import ZOOM_FIELD, ZOOM_MARGIN, crop_box, second_look

REAL = Path(__file__).parent / "data" / "real"


def _reading(side: float, x0: float, y0: float, p: float | None = 0.5) -> BoardReading:
    """A 3 x 3 reading whose field is a square of ``side`` px at ``(x0, y0)``, grid confidence ``p``."""
    H = np.array([[side / 3, 0.0, x0], [0.0, side / 3, y0], [0.0, 0.0, 1.0]])
    probs = np.full((3, 3, 3), 1 / 3)
    return BoardReading(np.zeros((3, 3), np.int64), np.full((3, 3), 1 / 3), probs, H, 0.5, 4, grid_confidence=p)


def test_the_crop_is_the_field_and_half_its_side_around_it() -> None:
    box = crop_box(_reading(200.0, 300.0, 250.0), (800, 1000, 3))
    m = ZOOM_MARGIN * 200
    assert box == (int(300 - m), int(250 - m), int(500 + m), int(450 + m))
    assert crop_box(_reading(200.0, 20.0, 30.0), (800, 1000, 3))[:2] == (0, 0)  # clipped to the photo
    assert crop_box(_reading(ZOOM_FIELD * 800 + 1, 10.0, 10.0), (800, 1000, 3)) is None  # a field filling the frame
    assert crop_box(_reading(30.0, 10.0, 10.0), (800, 1000, 3)) is None  # a crop under 64 px: nothing to read
    broken = _reading(200.0, 300.0, 250.0)  # a homography with no finite field
    broken.homography[2, 0] = np.nan
    assert crop_box(broken, (800, 1000, 3)) is None


def test_a_sure_reading_or_a_crop_that_reads_nothing_keeps_the_first() -> None:
    image = np.zeros((800, 1000, 3), np.uint8)
    calls: list[tuple[int, ...]] = []

    def refuse(crop: np.ndarray, trace: dict[str, object] | None) -> BoardReading:
        calls.append(crop.shape)
        raise NoBoardError("nothing in the crop")

    sure = _reading(200.0, 300.0, 250.0, p=0.95)
    assert second_look(refuse, image, sure, 0.92) is sure and not calls
    no_arbiter = _reading(200.0, 300.0, 250.0, p=None)
    assert second_look(refuse, image, no_arbiter, 0.92) is no_arbiter and not calls
    unsure = _reading(200.0, 300.0, 250.0, p=0.3)
    trace: dict[str, object] = {"hypotheses": [("hash 22%", 0.3)]}
    assert second_look(refuse, image, unsure, 0.92, trace) is unsure and calls == [(400, 400, 3)]
    assert trace["zoom"] == (200, 150, 600, 550) and trace["hypotheses"] == [("hash 22%", 0.3)]


def test_an_unsure_small_field_is_read_right_on_a_crop() -> None:
    """Real-like photo 60,090 (graph paper on a yellow table, the '#' a third of the frame): read
    whole, no grid is sure and the best reads ``.OX|OX.|...``; the crop round that field reads the
    board at 0.97, and its homography lands in the photo's px."""
    sc = real_like_scene(60_090)
    first = BoardReader(size=3, zoom=False).read(sc.image)
    assert first.text() != sc.text() and first.grid_confidence < 0.92
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(sc.image, trace)
    assert reading.text() == sc.text() and reading.grid_confidence > first.grid_confidence
    assert str(trace["kind"]).endswith(" zoomed") and trace["offset"] == tuple(float(v) for v in trace["zoom"][:2])
    assert any(k.endswith(" zoomed") for k, _ in trace["hypotheses"])  # type: ignore[union-attr]
    # each cell's centre falls in the scene's own cell
    centres = np.array([[c + 0.5, r + 0.5, 1.0] for r in range(3) for c in range(3)]) @ reading.homography.T
    centres = centres[:, :2] / centres[:, 2:]
    want = sc.centres_px.reshape(-1, 2)
    step = np.linalg.norm(sc.centres_px[1, 1] - sc.centres_px[1, 0])
    assert np.max(np.linalg.norm(centres - want, axis=1)) < 0.5 * step
    picture = debug_image(sc.image, reading, trace)
    assert picture.shape == sc.image.shape and not np.array_equal(picture, sc.image)


@pytest.mark.parametrize("name", ["kvuletic2_image5.jpeg", "kvuletic2_image13.jpeg"])
def test_the_real_photos_fill_their_frames_and_are_not_cropped(name: str) -> None:
    img = read_image(REAL / name)
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(img, trace)
    assert "zoom" not in trace
    assert reading.text() == BoardReader(size=3, zoom=False).read(img).text()
