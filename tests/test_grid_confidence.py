"""The reading's grid confidence: the grid arbiter's probability that the grid it chose, and the
board read on it, are right - carried by :class:`~kinegym.vision.reading.BoardReading` and said
by ``kinegym read-board``, so that a user learns when not to trust a reading."""

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from kinegym.cli import main
from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision.board_reader import BoardReader, VisionError, debug_image
from kinegym.vision.image_io import read_image
from kinegym.vision.reading import UNSURE_GRID

REAL = Path(__file__).parent / "data" / "real"
LABELS: dict[str, str] = json.loads((REAL / "labels.json").read_text())["boards"]
#: A real-like photo whose faint '#' lies in a hard shadow beside a striped reflection: the reader
#: takes the stripes for a grid and reads a board that is not there (seed 30,024, an empty board).
STRIPES = 30_024


def test_a_reading_carries_the_arbiter_s_probability_of_its_grid() -> None:
    img = read_image(REAL / "kvuletic2_image4.jpeg")
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(img, trace)
    tried = trace["hypotheses"]
    assert isinstance(tried, list) and tried
    assert reading.grid_confidence == max(p for _, p in tried)  # the chosen one: the most probable made
    assert UNSURE_GRID < reading.grid_confidence <= 1.0 and not reading.unsure
    first = BoardReader(size=3, arbiter=None).read(img)  # the first grid found, judged by no one
    assert first.grid_confidence is None and not first.unsure
    assert first.text() == reading.text() == "XO.|.X.|..."


def test_a_wrong_grid_is_read_as_unsure() -> None:
    scene = real_like_scene(STRIPES)
    reading = BoardReader(size=3).read(scene.image)
    assert reading.text() != scene.text()  # if this photo ever reads right, pick another wrong one
    assert reading.unsure and reading.grid_confidence is not None and reading.grid_confidence < UNSURE_GRID


def test_read_board_says_an_unsure_grid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    photo = tmp_path / "stripes.png"  # PNG: the pixels the reader sees in memory above
    cv2.imwrite(str(photo), real_like_scene(STRIPES).image[..., ::-1])
    assert main(["read-board", str(photo), "--size", "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["unsure"] is True and out["grid_confidence"] < UNSURE_GRID
    tried = out["grids_tried"]  # each grid hypothesis made, and the one read: the most probable
    assert tried and out["grid_kind"] == max(tried, key=lambda t: t["p"])["kind"]
    assert out["grid_confidence"] == pytest.approx(max(t["p"] for t in tried))
    assert main(["read-board", str(photo), "--size", "3"]) == 0
    text = capsys.readouterr().out
    assert "unsure grid" in text and "grid confidence 0.0" in text
    assert f"({out['grid_kind']}, {len(tried)} grid{'s' * (len(tried) != 1)} tried)" in text
    assert main(["read-board", str(REAL / "kvuletic2_image4.jpeg"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["unsure"] is False and out["grid_confidence"] > UNSURE_GRID and out["board"] == "XO.|.X.|..."


def _red_banner(picture: np.ndarray) -> int:
    """Pixels of the debug picture's top-left banner drawn in its red (220, 0, 0)."""
    top = picture[:28, :260].astype(int)
    return int(((top[..., 0] > 180) & (top[..., 1] < 60) & (top[..., 2] < 60)).sum())


def test_the_debug_picture_says_the_grid_s_confidence() -> None:
    scene = real_like_scene(STRIPES)
    trace: dict[str, object] = {}
    unsure = debug_image(scene.image, BoardReader(size=3).read(scene.image, trace), trace)
    assert _red_banner(unsure) > 40 and _red_banner(scene.image) < 5  # "unsure grid 0.00" in red
    img = read_image(REAL / "kvuletic2_image4.jpeg")
    trace = {}
    sure = debug_image(img, BoardReader(size=3).read(img, trace), trace)
    assert _red_banner(sure) < 5 and not np.array_equal(sure[:28, :260], img[:28, :260])  # in green


def test_a_lower_accept_level_makes_fewer_grid_hypotheses(capsys: pytest.CaptureFixture[str]) -> None:
    """``accept`` trades reading right for speed: 0 takes the first grid found, 1 makes every
    hypothesis, the default stops at the shipped arbiter's level. Real photo 4's first '#' is 0.78
    probable, under the shipped 0.94: by default all three hypotheses are made; photo 1's first is
    0.95: by default it alone is made."""
    def made(name: str, accept: float | None) -> list[tuple[str, float]]:
        trace: dict[str, object] = {}
        reading = BoardReader(size=3, accept=accept).read(read_image(REAL / name), trace)
        assert reading.text() == LABELS[name]  # both read right at every level
        return trace["hypotheses"]  # type: ignore[return-value]

    four, one = "kvuletic2_image4.jpeg", "kvuletic2_image1.jpeg"
    every = {name: [(h.kind, h.p) for h in BoardReader(size=3).hypotheses(read_image(REAL / name))]
             for name in (four, one)}
    assert [len(v) for v in every.values()] == [3, 3]
    assert made(four, None) == made(four, 1.0) == every[four]
    assert made(four, 0.75) == made(four, 0.0) == every[four][:1]
    assert made(one, None) == every[one][:1] and made(one, 1.0) == every[one]
    for bad in (-0.1, 1.5, float("nan"), "0.5"):
        with pytest.raises(VisionError, match=r"accept=.*expected a probability in \[0, 1\]"):
            BoardReader(size=3, accept=bad)  # type: ignore[arg-type]
    assert main(["read-board", str(REAL / "kvuletic2_image4.jpeg"), "--accept", "0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["grids_tried"]) == 1 and out["board"] == LABELS["kvuletic2_image4.jpeg"]
    assert main(["read-board", str(REAL / "kvuletic2_image4.jpeg"), "--accept", "2"]) == 2
    assert "--accept '2': expected a probability in 0..1" in capsys.readouterr().err
