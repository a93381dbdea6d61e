"""Ruled and graph paper (vision.ruling): rules told from a '#' drawn on them, on drawn maps
whose answer is known, and on real-like photos that the reader misread before."""

import math

import cv2
import numpy as np
import pytest

from kinegym.agents.train_cells import grid_is_right
from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision import board_reader
from kinegym.vision.board_reader import BoardReader
from kinegym.vision.errors import NoBoardError
from kinegym.vision.grid_choice import HUE_KINDS
from kinegym.vision.hand_grid import Track, find_hash_grid
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


def _red_hash(d: np.ndarray, colour: np.ndarray, xs: tuple[int, int], ys: tuple[int, int], v: float) -> None:
    """Draw a red '#' of darkness ``v`` (3 px lines at columns ``xs``, rows ``ys``, arms of 88 px) in place."""
    red = RED / np.linalg.norm(RED)
    m = np.zeros(d.shape, np.uint8)
    for x in xs:
        cv2.line(m, (x, 110), (x, 380), 1, 3)
    for y in ys:
        cv2.line(m, (110, y), (380, y), 1, 3)
    d[m > 0] = v
    colour[m > 0] = v * red


def test_a_pale_hash_of_another_colour_on_graph_paper_is_found_in_its_colour_alone() -> None:
    """A red '#' between blue rules, paler than the heavier rules and less than 1.6x the rules'
    darkness: the search in the ink darker than the rules misses it and the rules win; the search
    asked for ``other_colour`` leaves the rules' colour out and finds it. On paper without rules
    that search has nothing to leave out and finds nothing."""
    d, colour = graph_paper(size=480, step=12, heavy=48)
    _red_hash(d, colour, (198, 294), (210, 294), 0.4)
    truth = np.array([[198, 210], [198, 294], [294, 210], [294, 294]], np.float64)  # [col, row] order
    rules_won = find_hash_grid(d, (3,), colour, share=0.22)
    assert np.abs(rules_won.crossings.reshape(-1, 2) - truth).max() > 20  # the rules' '#', not the drawn one
    grid = find_hash_grid(d, (3,), colour, share=0.22, other_colour=True)
    assert grid.n == 3 and np.abs(grid.crossings.reshape(-1, 2) - truth).max() <= 3
    assert grid.rules is not None and grid.rule_hue is not None
    rulings: dict[tuple[float, bool], list[Ruling]] = {}  # the reader's memo: the level's search records its rulings,
    find_hash_grid(d, (3,), colour, share=0.22, rulings=rulings)  # and the search in another colour starts from them
    assert list(rulings) == [(0.22, False)] and rulings[(0.22, False)]
    again = find_hash_grid(d, (3,), colour, share=0.22, other_colour=True, rulings=rulings)
    np.testing.assert_array_equal(again.crossings, grid.crossings)
    assert again.score == grid.score and (again.rules == grid.rules).all()
    assert float(grid.rule_hue @ (BLUE / np.linalg.norm(BLUE))) > 0.99  # the rules' colour, to clear from the cells
    blank, hue = np.zeros_like(d), np.zeros_like(colour)
    _red_hash(blank, hue, (198, 294), (210, 294), 0.4)
    assert np.abs(find_hash_grid(blank, (3,), hue, share=0.22).crossings.reshape(-1, 2) - truth).max() <= 3
    with pytest.raises(NoBoardError, match="no ruled paper whose rules have a colour of their own"):
        find_hash_grid(blank, (3,), hue, share=0.22, other_colour=True)
    none: dict[tuple[float, bool], list[Ruling]] = {}
    find_hash_grid(blank, (3,), hue, share=0.22, rulings=none)
    with pytest.raises(NoBoardError, match="no ruled paper whose rules have a colour of their own"):
        find_hash_grid(blank, (3,), hue, share=0.22, other_colour=True, rulings=none)


def test_a_teal_hash_on_blue_graph_paper_is_read_by_the_hue_kind(monkeypatch: pytest.MonkeyPatch) -> None:
    """Real-like photo 40,133: a teal '#' on blue graph paper, no darker than its heavier rules.
    Every kind before the hue kinds takes rules for its lines; "hash 22% hue", made because those
    saw ruled paper and none was sure, reads the board right, cell for cell. Without the hue kinds
    the board is misread."""
    sc = real_like_scene(40_133)
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(sc.image, trace)
    made = dict(trace["hypotheses"])  # type: ignore[arg-type]
    assert max(made, key=made.get) in HUE_KINDS  # type: ignore[arg-type]
    assert grid_is_right(reading.homography, sc.centres_px.reshape(-1, 2), 3)
    assert (reading.cells == sc.cells).all()
    monkeypatch.setattr(board_reader, "HUE_KINDS", ())
    assert not (BoardReader(size=3).read(sc.image).cells == sc.cells).all()
