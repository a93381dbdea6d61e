"""Ruled and graph paper (vision.ruling): rules told from a '#' drawn on them, on drawn maps
whose answer is known, and on real-like photos that the reader misread before."""

import math

import numpy as np
import pytest

from kinegym.agents.train_cells import grid_is_right
from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision.board_reader import BoardReader
from kinegym.vision.hand_grid import Track
from kinegym.vision.ruling import Ruling, clear_rules, is_ruled, rules_mask

BLUE = np.array([0.75, 0.45, 0.1], np.float32)  # RGB darkness of blue ink: mostly red and green
RED = np.array([0.1, 0.7, 0.7], np.float32)


def graph_paper(size: int = 240, step: int = 10, heavy: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """A darkness map and its RGB darkness: blue vertical and horizontal rules 3 px wide every
    ``step`` px over the middle of the image (the paper), every ``heavy``-th px twice as dark
    and 4 px wide."""
    d = np.zeros((size, size), np.float32)
    lo, hi = size // 8, size - size // 8
    for x in range(lo, hi + 1, step):
        w, v = (4, 0.6) if (x - lo) % heavy == 0 else (3, 0.3)
        d[lo:hi + 1, x:x + w] = v
        d[x:x + w, lo:hi + 1] = v
    return d, d[:, :, None] * BLUE[None, None, :] / np.linalg.norm(BLUE)


def ruling(d: np.ndarray, phis: list[float], colour: np.ndarray | None = None) -> Ruling:
    """The ruling the '#' finder makes of darkness map ``d``'s ink along ``phis``."""
    return Ruling.of(rules_mask((d > 0.2).astype(np.uint8), phis, max(9, int(0.06 * max(d.shape)))), phis, d, colour)


def vertical(x: float, y0: float, y1: float) -> Track:
    return Track(np.array([[x, y] for y in np.linspace(y0, y1, 8)]), 1.0, 8)


def test_a_heavier_rule_runs_on_and_a_drawn_line_ends_on_the_paper() -> None:
    d, colour = graph_paper()
    d[80:160, 84:87] = 0.6  # a drawn line as dark as the heavier rules, between two rules
    lined = ruling(d, [math.pi / 2, 0.0])
    assert lined is not None
    assert lined.runs_on(vertical(71.5, 40, 200), math.pi / 2)  # a heavier rule, traced across the paper
    assert lined.runs_on(vertical(71.5, 90, 150), math.pi / 2)  # ... or only a piece of it
    assert not lined.runs_on(vertical(85.0, 80, 159), math.pi / 2)  # the drawn line stops on the paper
    across = ruling(d, [0.0])  # only the horizontal rules count as ruled
    assert across is not None and not across.runs_on(vertical(71.5, 40, 200), math.pi / 2)
    d[:, :] = np.where(d > 0.5, 1.4, d)  # a pen darker than the heavier rules: the piece no longer runs on as dark
    d[40:200, 70:72] = 0.6
    lined = ruling(d, [math.pi / 2, 0.0])
    assert not lined.runs_on(vertical(85.0, 80, 159), math.pi / 2)


def test_the_rules_colour_is_told_from_another_pens() -> None:
    d, colour = graph_paper()
    colour[100:140, 124:127] = RED * 0.6 / np.linalg.norm(RED)
    d[100:140, 124:127] = 0.6
    lined = ruling(d, [math.pi / 2, 0.0], colour)
    assert lined is not None and lined.hue is not None
    paints = lined.paints(d, colour)
    assert paints[65, 71] and paints[31, 100]  # a heavier rule and a rule, both in the rules' colour
    assert not paints[120, 125]  # the red pen
    assert not paints[0, 0]  # no ink at all is no rule's


def test_clear_rules_leaves_a_pen_and_clears_a_heavier_rule() -> None:
    d, colour = graph_paper()
    d[100:140, 124:127] = 0.6
    rgb = np.full(d.shape + (3,), 235, np.uint8)
    rgb -= (200 * d[:, :, None] * np.where(d[:, :, None] > 0, BLUE, 0)).astype(np.uint8)  # blue rules on white
    rgb[100:140, 124:127] = (235, 80, 80)  # a red pen stroke
    paper = ruling(d, [math.pi / 2, 0.0], colour)
    clean = d.copy()
    clear_rules(clean, d, rgb, paper.rules, paper.hue, np.zeros(d.shape, bool))
    assert clean[65, 71] == 0.0 and clean[31, 100] == 0.0  # a heavier rule, twice as dark as the rest, and a rule
    assert clean[120, 125] == pytest.approx(0.6)  # the pen stays
    clean = d.copy()
    clear_rules(clean, d, rgb, paper.rules, None, np.zeros(d.shape, bool))
    assert clean[65, 71] > 0.0  # without the rules' colour a heavier rule stays: it is as dark as a pen


def test_many_long_lines_are_a_ruling_even_when_unevenly_traced() -> None:
    side = 400.0
    xs = np.cumsum(np.random.default_rng(0).uniform(2.0, 20.0, 20))  # 20 lines, gaps from 2 to 20 px
    assert is_ruled([vertical(x, 0, 300) for x in xs], side)
    assert not is_ruled([vertical(x, 0, 300) for x in xs[:7]], side)
    assert not is_ruled([vertical(x, 0, 50) for x in xs], side)  # short strokes are no rules


@pytest.mark.parametrize("seed", [30_022, 30_041])
def test_real_like_graph_paper_misread_before(seed: int) -> None:
    """Real-like photos 30,022 (black marker on dense graph paper in perspective: its traced
    rules were too uneven to count as a ruling, and rules won the '#') and 30,041 (a blue pen
    beside heavier rules every fifth line, which passed the search in the ink darker than the
    rules and made the '#'). Both read right now, cell for cell."""
    sc = real_like_scene(seed)
    reading = BoardReader(size=3).read(sc.image)
    assert grid_is_right(reading.homography, sc.centres_px.reshape(-1, 2), 3)
    assert (reading.cells == sc.cells).all()
