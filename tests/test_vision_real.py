"""The board reader on real photos of hand-drawn boards (``tests/data/real``: 15 whiteboard
photos, MIT licence, labelled by eye in ``labels.json``) and on the same photos made harder:
paler pens, much larger frames, a grid cut off by the picture's edge."""

import contextlib
import json
import math
import warnings
from pathlib import Path
from types import ModuleType

import cv2
import numpy as np
import pytest

from kinegym.envs.sim.scenes_real import real_like_scene
from kinegym.vision import board_reader, ink
from kinegym.vision.board_reader import BoardReader, NoBoardError, debug_image
from kinegym.vision.grid_choice import HUE_KINDS, same_lattice
from kinegym.vision.hand_grid import HashGrid, Track
from kinegym.vision.hash_cells import (
    ALONG_CELLS,
    FLICK_CELLS,
    MAX_PERSPECTIVE,
    affine_lattice,
    erase_mask,
    perspective_ratio,
)
from kinegym.vision.image_io import read_image
from kinegym.vision.ink import NOISE_FLOOR_CAP, NOISY_SIGMA, ink_mask, ink_threshold, local_ink_threshold, noise_sigma
from kinegym.vision.polylines import resample

DATA = Path(__file__).parent / "data" / "real"
LABELS = json.loads((DATA / "labels.json").read_text())["boards"]


def matches(text: str, label: str) -> bool:
    """A reading against a label; '*' in the label: marked, either symbol."""
    return len(text) == len(label) and all(a == b or (b == "*" and a in "XO") for a, b in zip(text, label))


@pytest.mark.parametrize("name", sorted(LABELS))
def test_every_real_photo_reads_as_labelled(name: str) -> None:
    trace: dict[str, object] = {}
    reading = BoardReader(size=None).read(read_image(DATA / name), trace)
    assert matches(reading.text(), LABELS[name]), (name, reading.text(), LABELS[name])
    assert not any(k in HUE_KINDS for k, _ in trace["hypotheses"])  # type: ignore[union-attr]  # no rules: no hue kind


def test_the_size_given_or_found_reads_the_same() -> None:
    for name in ("kvuletic2_image11.jpeg", "kvuletic2_image13.jpeg"):
        img = read_image(DATA / name)
        assert BoardReader(size=3).read(img).text() == BoardReader().read(img).text()


def test_a_4000_px_photo_reads_as_its_small_copy() -> None:
    """Every photo is processed at one scale: a 4,000 px frame (here the photo enlarged, with
    its strokes 7 times as wide in px) reads like the 577 px original."""
    name = "kvuletic2_image13.jpeg"
    img = read_image(DATA / name)
    big = cv2.resize(img, (4000, 3000), interpolation=cv2.INTER_CUBIC)
    assert matches(BoardReader().read(big).text(), LABELS[name])


def test_a_pale_pen_is_ink_too(photo_conditions: ModuleType) -> None:
    """The photos washed out: at 60 % of their contrast 14 of 15 boards read, at 45 % (the
    strongest strokes about 0.11 darker than the board, as pale as ballpoint) all 15: at 60 %
    image7's three '#' hypotheses are all unsure (p 0.375, 0.407, 0.403) and the arbiter takes the
    45 % ink's, which loses the top-right X. (Until stop 65: 15 at 60 % and 13 at 45 %; stops 66-68
    14 at 45 %, the empty image12 given a false X, which the faint pen's floor below mends.)"""
    right = {c: sum(matches(BoardReader().read(photo_conditions.washed_out(read_image(DATA / name), c)).text(), label)
                    for name, label in LABELS.items()) for c in (0.6, 0.45)}
    assert right[0.6] >= len(LABELS) - 1 and right[0.45] == len(LABELS), right


@pytest.mark.parametrize("contrast", [0.35, 0.25])
def test_a_faint_pen_s_floor_lets_its_lines_in(photo_conditions: ModuleType, contrast: float,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A pen a third or a quarter as dark as the photos' own (its strongest strokes 0.06-0.09 darker than
    the board): the ink above the noise is taken down to a floor scaled to the strong ink
    (:func:`ink.ink_floor`), and 14 of 15 read (image14's pale teal loses a mark). With the plain floor
    (:data:`ink.FAINT_TOP` next to 0: :data:`ink.INK_FLOOR` whatever the ink) 11 of 15 read at 35 % and 6
    at 25 % (eight of the nine others refused)."""
    def reads(name: str) -> bool:
        try:
            img = photo_conditions.washed_out(read_image(DATA / name), contrast)
            return matches(BoardReader().read(img).text(), LABELS[name])
        except NoBoardError:
            return False

    assert ink.ink_floor(0.5, 0.0) == ink.ink_floor(0.1, 0.22) == ink.INK_FLOOR
    assert ink.ink_floor(0.1, 0.0) == pytest.approx(ink.INK_FLOOR * 0.1 / ink.FAINT_TOP)
    right = sum(reads(name) for name in LABELS)
    assert right >= len(LABELS) - 1, right
    monkeypatch.setattr(ink, "FAINT_TOP", 1e-9)
    plain = sum(reads(name) for name in LABELS)
    assert plain <= right - 3, (plain, right)


def noisy(img: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    """``img`` with white noise of ``sigma`` grey levels (a phone's sensor in dim light)."""
    noise = np.random.default_rng(seed).normal(0.0, sigma, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


def test_a_noisy_photo_is_smoothed_first_and_reads() -> None:
    """Sensor noise: the photos as taken estimate no noise and are read as they are; with white
    noise of 8 grey levels added the reader estimates it (:func:`noise_sigma`), smooths the photo
    first and every board reads (without smoothing 6 of 15 did, 5 of the others refused)."""
    right = 0
    for i, (name, label) in enumerate(sorted(LABELS.items())):
        img = read_image(DATA / name)
        clean: dict[str, object] = {}
        BoardReader().read(img, trace=clean)
        assert clean["noise"] < NOISY_SIGMA, (name, clean["noise"])
        trace: dict[str, object] = {}
        with contextlib.suppress(NoBoardError):  # a refusal counts as wrong
            right += matches(BoardReader().read(noisy(img, 8.0, 100 + i), trace=trace).text(), label)
        assert 4.0 < trace["noise"] < 7.0, (name, trace["noise"])
    assert right == len(LABELS), right


def test_the_noise_estimate_follows_the_noise() -> None:
    """:func:`noise_sigma` grows with the noise added and stays low on a clean photo (it reads
    8-bit, JPEG-rounded pixels: white noise of 4 / 8 / 12 levels estimates about 2.7 / 5.4 / 8)."""
    img = read_image(DATA / "kvuletic2_image13.jpeg")
    est = [noise_sigma(noisy(img, s, 0) if s else img) for s in (0, 4, 8, 12)]
    assert est[0] < 1.0 and all(a < b for a, b in zip(est, est[1:])), est
    assert 2.0 < est[1] < 3.5 and 4.5 < est[2] < 6.5 and 6.5 < est[3] < 9.5, est


def test_the_noise_floor_never_hides_ink_half_as_dark_as_the_strongest() -> None:
    """Dense rules (or heavy noise) spread a darkness map's middle: six robust sigmas above its
    median rose above the drawn lines. The floor is capped at half the strongest ink; where
    ink is sparse the cap does not bite."""
    rng = np.random.default_rng(3)
    d = (0.05 + np.abs(rng.normal(0.0, 0.02, (400, 400)))).astype(np.float32)
    sparse = d.copy()
    sparse[100:104, 50:350] = 0.64  # one dark stroke on clean paper
    t = ink_threshold(sparse, 0.0)
    assert t == pytest.approx(np.median(sparse[::2, ::2]) + 6 * 1.4826 * np.median(
        np.abs(sparse[::2, ::2] - np.median(sparse[::2, ::2]))), rel=1e-6) and t < 0.2
    ruled = d.copy()
    rules = rng.random(d.shape) < 0.55
    ruled[rules] = rng.uniform(0.1, 0.55, int(rules.sum()))
    ruled[200:203, 40:360] = 0.45  # a drawn line, as dark as the darker rules
    ruled[:, 300:304] = 0.64  # the strongest strokes
    sample = ruled[::2, ::2]
    floor = np.median(sample) + 6 * 1.4826 * np.median(np.abs(sample - np.median(sample)))
    top = float(np.percentile(sample, 99.7))
    t = ink_threshold(ruled, 0.0)
    assert floor > 0.45 and t == pytest.approx(NOISE_FLOOR_CAP * top) and t < 0.45, (floor, t, top)


def test_the_page_s_own_noise_floor_where_a_textured_table_raises_the_whole_map_s() -> None:
    """A textured table beside the page spreads the whole map's darkness: its one noise floor
    lies above a faint line on the quiet page. Each region's own floor lets the line in there,
    and is never above the whole map's anywhere (the table's texture stays out)."""
    rng = np.random.default_rng(5)
    d = (0.01 + np.abs(rng.normal(0.0, 0.004, (300, 400)))).astype(np.float32)  # the page
    d[:, :240] = np.abs(rng.normal(0.0, 0.1, (300, 240)))  # wood grain, cloth: the table
    d[150:152, 270:390] = 0.07  # a pencil line on the page
    d[40:46, 280:330] = 0.4  # the darkest strokes: a pen lying on the page
    whole = ink_threshold(d, 0.0)
    local = local_ink_threshold(d, 0.0)
    assert whole > 0.07 and local.shape == d.shape and float(local.max()) <= whole + 1e-7
    assert float(local[100:200, 280:380].max()) < 0.07 < float(local[:, :150].min())
    whole_mask = ink_mask(d, 0.0)[0]
    mask, t, _ = ink_mask(d, 0.0, local=True)
    assert mask[150, 280:380].all() and not whole_mask[150, 280:380].any() and isinstance(t, np.ndarray)
    assert np.array_equal(mask[:, :150], whole_mask[:, :150])  # on the table: the same mask


def test_a_faint_hash_on_a_page_over_a_textured_table_is_read(monkeypatch: pytest.MonkeyPatch) -> None:
    """Real-like photo 30,097 (an empty pencil '#' on a page, a pen lying on it, the table's texture
    around): no ink above the whole photo's noise forms a '#' - it was refused - but the page's own
    noise floor finds it."""
    sc = real_like_scene(30_097)
    trace: dict[str, object] = {}
    assert BoardReader(size=3).read(sc.image, trace).text() == sc.text() == "...|...|..."
    # of the kinds sought in the whole photo only the '#' above its noise is made (the arbiter, not sure of
    # it, may seek the '#' on the page alone too)
    assert [k for k, _ in trace["hypotheses"] if "page" not in k] == ["hash 0%"]  # type: ignore[union-attr]
    monkeypatch.setattr(ink, "local_ink_threshold",
                        lambda d, share, levels=None: np.full(d.shape, ink_threshold(d, share, levels)))
    monkeypatch.setattr(board_reader, "PAGE_KINDS", ())  # (the '#' sought on the page alone finds it too)
    with pytest.raises(NoBoardError):
        BoardReader(size=3).read(sc.image)


def test_a_photo_on_a_dark_noisy_table_reads(photo_conditions: ModuleType, monkeypatch: pytest.MonkeyPatch) -> None:
    """A dark table's sensor noise, divided by its little light, looked like ink: tracks along the
    page's edge were taken for the '#''s lines (stop 67's reader read image6 on a table 40 grey levels
    dark as ``...|.X.|...``). On a background under ``ink.DIM_BACKGROUND`` of the page's white only what
    stands above the dim parts' own noise is ink: on the table, nothing."""
    name = "kvuletic2_image6.jpeg"
    img = photo_conditions.on_a_dark_table(read_image(DATA / name), 1.3, 11)
    d = ink.ink_map(img)
    assert float(d[:8, :8].max()) == 0.0 and float(d.max()) > 0.3  # the table holds no ink; the page does
    assert matches(BoardReader(size=3).read(img).text(), LABELS[name])
    monkeypatch.setattr(ink, "DIM_BACKGROUND", 0.0)  # the table's noise as ink: the page's edge a line
    assert float(ink.ink_map(img)[:8, :8].max()) > 0.05
    assert not matches(BoardReader(size=3).read(img).text(), LABELS[name])


@pytest.mark.parametrize("name, seed", [("kvuletic2_image10.jpeg", 1), ("kvuletic2_image14.jpeg", 5)])
def test_a_pen_under_a_hand_s_deep_shadow_is_ink(photo_conditions: ModuleType, name: str, seed: int) -> None:
    """Under a shadow leaving a quarter of the light the background is dim too, but quiet: the pen's
    strokes there stand above its own noise and stay ink (a plain cut of dim backgrounds lost them:
    these two read empty or wrong)."""
    img = photo_conditions.under_a_hand_s_shadow(read_image(DATA / name), 0.25, seed)
    assert matches(BoardReader(size=3).read(img).text(), LABELS[name])


@pytest.mark.parametrize("name, seed", [("kvuletic2_image3.jpeg", 8), ("kvuletic2_image4.jpeg", 9)])
def test_a_pen_lying_beside_the_board_is_no_line_direction(photo_conditions: ModuleType, name: str, seed: int,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """A dark pen along the page's edge is the longest, darkest straight thing in view: the strongest
    line direction, with the '#''s rows within 40 deg of it never tried. It is thick ink (it holds a
    square two stroke widths wide), so the directions are sought again in the thin ink alone and
    the board reads; without that (:data:`tracks.THICK_SHARE` past 1) it is refused or read wrong."""
    from kinegym.vision import tracks

    img = photo_conditions.with_a_pen_beside(read_image(DATA / name), seed)
    assert matches(BoardReader(size=3).read(img).text(), LABELS[name])
    monkeypatch.setattr(tracks, "THICK_SHARE", 2.0)
    with contextlib.suppress(NoBoardError):
        assert not matches(BoardReader(size=3).read(img).text(), LABELS[name])


def test_a_pen_lying_across_the_column_lines_tops_is_no_row_line(photo_conditions: ModuleType,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Image10's pen lies across its column lines' tops, where a row line would be: the two column
    lines cross it, and the '#' of the pen and the drawn top row line scored best - a row line with
    ten times the ink of the other three, the board read a row low (stop 69: ``...|...|.X.``). One
    pen draws a '#': lines whose inks differ more than :data:`~kinegym.vision.tracks.INK_SPREAD_FREE`
    times score lower, and the pale drawn bottom row line is taken; without that the pen is again."""
    from kinegym.vision import hash_search

    name = "kvuletic2_image10.jpeg"
    img = photo_conditions.with_a_pen_beside(read_image(DATA / name), sorted(LABELS).index(name))
    assert BoardReader(size=3).read(img).text() == LABELS[name] == "...|.X.|..."
    monkeypatch.setattr(hash_search, "INK_SPREAD_FREE", math.inf)
    assert BoardReader(size=3).read(img).text() == "...|...|.X."


def test_a_notebook_s_spiral_binding_is_no_column_line(photo_conditions: ModuleType,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Image11 as a notebook's page, its spiral binding along the left side: the binding runs from
    the photo's top to its bottom, dark and straight, and was taken for the '#''s left column line,
    the board read a column to the right (``.XX|.OX|..O``). A '#' line from the photo's edge to its
    edge costs :data:`~kinegym.vision.tracks.EDGE_TO_EDGE_COST`; without that the binding is again."""
    from kinegym.vision import hash_search

    name = "kvuletic2_image11.jpeg"
    img = photo_conditions.with_a_spiral_binding(read_image(DATA / name), sorted(LABELS).index(name))
    assert BoardReader(size=3).read(img).text() == LABELS[name] == "XXX|OX.|.OO"
    monkeypatch.setattr(hash_search, "EDGE_TO_EDGE_COST", 0.0)
    assert BoardReader(size=3).read(img).text() == ".XX|.OX|..O"


def test_a_hand_s_converging_lines_read_on_the_affine_lattice() -> None:
    """Real-like photo 20,142: the '#''s lines converge so much that the projective lattice of its
    four crossings runs off towards a horizon beyond the outer cells (the bottom row read as a
    huge field, ``...|O.X|...``). Past :data:`MAX_PERSPECTIVE` the cells are read on the crossings'
    affine fit, and the arbiter still sees the lattice as found."""
    sc = real_like_scene(20_142)
    trace: dict[str, object] = {}
    reading = BoardReader(size=3).read(sc.image, trace)
    assert reading.text() == sc.text() == "..O|X.X|..."
    grid = trace["hash"]
    assert perspective_ratio(grid.H, 3) > MAX_PERSPECTIVE  # type: ignore[attr-defined]
    assert perspective_ratio(reading.homography, 3) == pytest.approx(1.0)
    to_photo = np.linalg.inv(reading.homography) @ trace["hash_to_image"] @ affine_lattice(grid)  # type: ignore
    assert np.allclose(to_photo / to_photo[2, 2], np.eye(3), atol=1e-6)
    damped = [h for h in BoardReader(size=3).hypotheses(sc.image) if h.lattice is not None]
    assert damped and all(perspective_ratio(h.found, 3) > MAX_PERSPECTIVE > perspective_ratio(h.H, 3) for h in damped)


def test_a_straight_field_s_lattice_is_read_the_hash_way_too() -> None:
    """Real-like photo 30,052: thick blue lines and pale grey marks. The straight field is found and
    read with its fixed ink floors (a pale mark missed); the '#' search finds the same lattice, and
    reading it the '#' way (the photo's own ink level, larger outer cells) reads the board. It used
    to be passed over as a grid already made. Since stop 65's networks the arbiter gives the straight
    field's reading p 0.921 (0.42 before), just over its accept level 0.92, so the default reader
    stops there - one of the 8 boards of 1,000 the new networks lose (bench/README.md) - and the
    '#' reading is asked for by making every hypothesis (accept 1). (Since stop 70 the share-0 '#'
    search makes a lattice of its own too, read less sure: its former choice, the same lattice, has a
    line from the photo's edge to its edge, which costs :data:`~kinegym.vision.tracks.EDGE_TO_EDGE_COST`.)"""
    sc = real_like_scene(30_052)
    trace: dict[str, object] = {}
    assert BoardReader(size=3, accept=1.0).read(sc.image, trace).text() == sc.text() == "XXO|XOO|OX."
    kinds = [k for k, _ in trace["hypotheses"]]  # type: ignore[union-attr]
    assert kinds[:2] == ["straight", "hash 22%"] and trace["kind"] == "hash 22%"
    made = BoardReader(size=3).hypotheses(sc.image)
    assert same_lattice(made[0].found, made[1].found, 3) and made[1].p > made[0].p


def test_a_track_keeps_to_its_own_stroke_across_a_crossing(photo_conditions: ModuleType) -> None:
    """Photo 14 turned 30 deg: the top row line runs on past the right column line, an O above it.
    Across the crossing a peak of other ink lay nearer the track's prediction than the line's own;
    the track took it, another track took the line's next peaks, and the line's track ended in the O
    (the O cut by the erased line, read X; the board ``XXO|XOX|O..``). A track now first takes a peak
    its ink runs on to (:func:`~kinegym.vision.tracks._joined`). The turn is the benchmark's +30 deg
    condition (``photo_conditions.turned_whole``)."""
    name = "kvuletic2_image14.jpeg"
    reading = BoardReader().read(photo_conditions.turned_whole(read_image(DATA / name), 30))
    assert matches(reading.text(), LABELS[name]), reading.text()


@pytest.mark.parametrize("name", ["kvuletic2_image13.jpeg", "kvuletic2_image15.jpeg"])
def test_a_curl_past_where_a_line_s_trace_stops_goes_with_the_line(photo_conditions: ModuleType, name: str) -> None:
    """Photos 13 and 15 turned 30 deg: the lower row line curls up at its right end, past where its
    trace stops; the curl leaves the column line about a fifth of a cell from the trace's tip, and
    left in it read as an X in the middle-right cell (``XXO|XOX|O..``). A stroke hanging at a tip
    is now sought within :data:`~kinegym.vision.hash_cells.TIP_CELLS` of a cell of it (a pen width
    and a half before stop 67). That wider circle would take a mark beside the line too; a piece
    goes with the line only if it also goes on from the tip or runs along the line."""
    reading = BoardReader().read(photo_conditions.turned_whole(read_image(DATA / name), 30))
    assert matches(reading.text(), LABELS[name]), reading.text()


def test_joined_steps_follow_ink_not_gaps() -> None:
    """A step from a track's last point to a peak is joined when ink runs along it at 85 % of its
    rows: along a stroke yes, across to a point beside it or in empty paper no, over a short gap in
    the pen yes unless the share asked for is higher."""
    from kinegym.vision.tracks import _joined

    wide = np.zeros((100, 100), np.uint8)
    cv2.line(wide, (20, 10), (30, 90), 1, 5)  # a stroke from (20, 10) to (30, 90)
    a = np.array([[20.0, 10.0], [20.0, 10.0], [60.0, 10.0]])
    b = np.array([[30.0, 90.0], [60.0, 90.0], [60.0, 90.0]])  # along it; off it to one side; no ink at all
    assert _joined(wide, a, b).tolist() == [True, False, False]
    wide[45:55] = 0  # a gap of a tenth of the step: still joined at 85 %, not at 95 %
    assert _joined(wide, a[:1], b[:1]).tolist() == [True]
    assert _joined(wide, a[:1], b[:1], share=0.95).tolist() == [False]


def _drawn_hash() -> tuple[np.ndarray, HashGrid]:
    """A 200 x 200 map with a straight '#' drawn on it (cells 50 px, lines 40..160 px) and its grid."""
    d = np.zeros((200, 200), np.float32)
    cols = [Track(np.array([[x, 40.0], [x, 160.0]]), 1.0, 10) for x in (75.0, 125.0)]
    rows = [Track(np.array([[40.0, y], [160.0, y]]), 1.0, 10) for y in (75.0, 125.0)]
    for tr in cols + rows:
        tr.dense = resample(tr.pts, 2.0)
        cv2.line(d, tuple(int(v) for v in tr.pts[0]), tuple(int(v) for v in tr.pts[1]), 1.0, 2)
    crossings = np.array([[[75.0, 75.0], [75.0, 125.0]], [[125.0, 75.0], [125.0, 125.0]]])
    return d, HashGrid(3, np.eye(3), cols, rows, crossings, 2.0, 0.3, 1.0, 0.0)


def test_a_flick_at_a_line_s_tip_goes_with_the_line_and_a_larger_piece_stays() -> None:
    """The '#' lines' erase mask takes a short elongated stroke hanging at a line's tip with the
    line; a longer one at a tip (marks joined up by graph paper's rules took whole marks with it,
    stop 60) and a round mark touching a tip stay."""
    d, grid = _drawn_hash()
    cv2.line(d, (75, 40), (60, 22), 1.0, 2)  # a flick at the left line's top: 0.3 cell across
    cv2.line(d, (125, 40), (185, 5), 1.0, 2)  # a longer stroke at the right line's top: 1.2 cells
    cv2.circle(d, (75, 173), 12, 1.0, 2)  # an O touching the left line's foot
    out = erase_mask(grid, d)
    assert out[100, 75] and out[75, 100]  # the lines
    assert out[24, 61] and out[30, 67]  # the flick
    assert 60 / 50 > FLICK_CELLS and not out[8, 180] and not out[20, 159]  # the longer stroke
    assert not out[185, 75] and not out[173, 87]  # the O


def test_a_flick_joined_up_by_paler_rules_still_goes_with_the_line() -> None:
    """On graph paper the rules, paler than the pen but above the search's ink level, join a flick at
    a line's tip up with everything around it: the piece was too large for a flick and stayed, and
    read as a mark in an outer cell (the 15 real photos on graph paper in black marker: 12 of 15).
    Where a piece at a tip is no flick, the ink above :data:`~kinegym.vision.hash_cells.TIP_INK` of
    the line's own darkness is looked at again: the flick goes; the rules, a longer stroke and a
    round mark at a tip stay."""
    from kinegym.vision.hash_cells import TIP_INK

    d, grid = _drawn_hash()
    cv2.line(d, (75, 40), (60, 22), 1.0, 2)  # the flick of the test above
    cv2.line(d, (125, 40), (185, 5), 1.0, 2)  # a longer stroke
    cv2.circle(d, (75, 173), 12, 1.0, 2)  # an O at the left line's foot
    rules = np.zeros_like(d)
    rules[::9, :] = rules[:, ::9] = 0.35  # graph paper, paler than the pen, above 0.6 x the ink level 0.3
    d = np.maximum(d, rules)
    assert 0.6 * grid.threshold < 0.35 < TIP_INK * 1.0
    out = erase_mask(grid, d)
    assert out[24, 61] and out[30, 67]  # the flick
    assert not out[8, 180] and not out[20, 159]  # the longer stroke
    assert not out[185, 75] and not out[173, 87]  # the O
    assert not out[27, 100] and not out[100, 27]  # the rules


def test_a_narrow_x_against_a_line_s_tip_stays_and_a_stroke_gone_over_goes() -> None:
    """A narrow X drawn against a '#' line's end, beside the line and behind its tip, is elongated
    and under a cell across like a flick, but it does not go on from the tip: it stays (real-like
    photo 60,131's X was erased and read empty). A second stroke along the line behind its tip (a
    line gone over twice) goes with the line."""
    d, grid = _drawn_hash()
    cv2.line(d, (160, 130), (144, 172), 1.0, 2)  # a narrow X below the lower row line's right tip
    cv2.line(d, (144, 130), (160, 172), 1.0, 2)
    cv2.line(d, (130, 158), (131, 130), 1.0, 2)  # the right column gone over again near its foot
    ys, xs = np.nonzero(d[128:, 138:] > 0.5)
    assert np.ptp(ys) < 50 * FLICK_CELLS  # the X is no larger than a flick, and elongated like one:
    ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(float)))
    assert ev[1] > 5.0 * ev[0]
    out = erase_mask(grid, d)
    assert not out[151, 152] and not out[167, 146] and not out[167, 158]  # the X stays
    assert out[145, 130] and out[135, 131]  # the stroke gone over goes
    assert 5.5 / 50 < ALONG_CELLS  # (it lies 5 to 6 px from the line's course)


def test_the_affine_lattice_of_crossings_and_the_perspective_ratio() -> None:
    """An affine lattice has ratio 1 and is its crossings' own fit; a camera's tilt gives a ratio
    above 1; a lattice whose horizon crosses the field has none."""
    A = np.array([[40.0, 8.0, 100.0], [-5.0, 38.0, 60.0], [0.0, 0.0, 1.0]])
    lat = np.array([[i + 1.0, j + 1.0] for i in range(2) for j in range(2)])
    pts = (lat @ A[:2, :2].T + A[:2, 2]).reshape(2, 2, 2)
    grid = HashGrid(3, A, [], [], pts, 2.0, 0.1, 1.0, 0.0)
    assert np.allclose(affine_lattice(grid), A) and perspective_ratio(A, 3) == 1.0
    tilted = A.copy()
    tilted[2] = [0.0, 0.1, 1.0]  # the field's far rows deeper: 1.3 at its bottom
    assert perspective_ratio(tilted, 3) == pytest.approx(1.3)
    tilted[2] = [0.0, -0.5, 1.0]  # its horizon at row 2
    assert perspective_ratio(tilted, 3) == math.inf


def test_a_noisy_empty_grid_and_dense_graph_rules_are_read() -> None:
    """With the floor capped: real photo 9 (an empty grid in thin teal) with white noise of 12
    grey levels reads as an empty board (it was refused), and real-like photo 20,109 (a teal
    '#' on graph paper at 520 px, its rules all over the photo) reads right (it was refused)."""
    img = noisy(read_image(DATA / "kvuletic2_image9.jpeg"), 12.0, 100 + sorted(LABELS).index("kvuletic2_image9.jpeg"))
    assert BoardReader(size=3).read(img).text() == LABELS["kvuletic2_image9.jpeg"] == "...|...|..."
    sc = real_like_scene(20_109)
    assert sc.notes["surface"] == "graph" and sc.image.shape[1] == 520
    assert BoardReader(size=3).read(sc.image).text() == sc.text()


def keystoned(img: np.ndarray) -> np.ndarray:
    """``img`` as a camera tilted back sees it: the top 20 % narrower, the corners it leaves
    filled with the photo's border colour (the table)."""
    h, w = img.shape[:2]
    src = np.float32([[0, 0], [w, 0], [w, h], [0, h]])
    dst = src + np.float32([[0.1 * w, 0], [-0.1 * w, 0], [0, 0], [0, 0]])
    table = np.median(np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]]), axis=0)
    return cv2.warpPerspective(img, cv2.getPerspectiveTransform(src, dst), (w, h), borderMode=cv2.BORDER_CONSTANT,
                               borderValue=tuple(float(v) for v in table))


def test_a_rival_line_direction_is_tried_too(monkeypatch: pytest.MonkeyPatch) -> None:
    """Keystone: image 11's bent, converging rows spread their direction's peak below the one
    its five X's strokes line up to. The '#' is sought along both (the rival is tried when it
    stands at least half as high above the median energy) and the better '#' wins: the board
    reads; with the best pair alone it read ``..X|..O|...``."""
    from kinegym.vision import tracks

    name = "kvuletic2_image11.jpeg"
    img = keystoned(read_image(DATA / name))
    assert matches(BoardReader().read(img).text(), LABELS[name])
    monkeypatch.setattr(tracks, "_RIVAL", math.inf)
    monkeypatch.setattr(board_reader, "PAGE_KINDS", ())  # (the keystone's wedges leave a page apart: found there too)
    with contextlib.suppress(NoBoardError):
        assert not matches(BoardReader().read(img).text(), LABELS[name])


def test_a_grid_cut_off_by_the_frame_edge() -> None:
    """The top of the photo cropped just above the grid's top crossings: the column lines
    run out of the picture and the top row is a sliver."""
    name = "kvuletic2_image10.jpeg"
    img = read_image(DATA / name)
    cut = np.ascontiguousarray(img[75:])
    assert matches(BoardReader().read(cut).text(), LABELS[name])


def test_debug_image_shows_the_traced_hand_drawn_lines() -> None:
    img = read_image(DATA / "kvuletic2_image14.jpeg")
    trace: dict[str, object] = {}
    reading = BoardReader().read(img, trace)
    assert "hash" in trace and "lines" not in trace  # the '#' was read, not straight lines
    out = debug_image(img, reading, trace)
    # the traced column lines are drawn red where the photo had teal ink
    red = (out[..., 0] > 200) & (out[..., 1] < 80) & (out[..., 2] < 80)
    assert red.sum() > 300 and not ((img[..., 0] > 200) & (img[..., 1] < 80)).any()


def on_graph_paper(img: np.ndarray, strength: float) -> np.ndarray:
    """The photo as if drawn on graph paper: pale blue 1 px rules every 3 % of its longer
    side over all of it, ``strength`` of the way to the rule colour."""
    out = img.astype(np.float64)
    h, w = img.shape[:2]
    step = 0.03 * max(h, w)
    tint = 1 - strength * (1 - np.array([90, 130, 220]) / 255.0)
    rule = np.zeros((h, w), bool)
    rule[:, np.arange(step / 2, w, step).astype(int)] = True
    rule[np.arange(step / 2, h, step).astype(int), :] = True
    out[rule] *= tint
    return np.clip(out, 0, 255).astype(np.uint8)


def test_real_photos_on_graph_paper() -> None:
    """The real photos with graph-paper rules laid over them, read as the game reads (3 x 3).
    Rules at 15 % strength: 14 of 15 (9 before the '#' was sought in the ink darker than
    the rules, 13 before stop 67 kept a mark beside a line's tip, behind it: image6's top-right
    X, against the upper row line's end, and its lower-right O, into which the right column's trace
    runs, had gone with the lines as flicks); at 25 %, as dark as the faintest '#' lines here: 13
    (0 before that, 4 before heavier rules were told from the pen, 13 before the hue kinds sought the '#' in the ink not
    of the rules' colour, 14 at stop 65). Since stop 66 (a track keeps to its own stroke)
    image14's '#' in the ink not of the rules' colour is traced right and preferred, but its bottom
    line's curling end, past where the trace stops, is left in and read as an O (p 0.53) in the
    middle-right cell.
    Measured, not met: graph paper is the reader's weakest surface."""
    def right(strength: float) -> int:
        return sum(matches(BoardReader(size=3).read(on_graph_paper(read_image(DATA / name), strength)).text(), label)
                   for name, label in LABELS.items())
    assert right(0.15) >= 14 and right(0.25) >= 13


def test_a_ruling_with_no_straight_runs_reads_without_numeric_warnings() -> None:
    """Real-like photo 1,003,349 (one the cell classifier trains on): its tracks look like a
    ruling but hold no long straight run of ink, so there are no rules to set a level from. The
    reader went on with the median of no pixels (NaN, numpy's "Mean of empty slice"); now it reads
    the photo, or refuses it, with no numeric warning."""
    sc = real_like_scene(1_003_349)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            BoardReader(size=3, model=None).read(sc.image)
        except NoBoardError:
            pass


def test_a_degenerate_lattice_fit_is_no_grid_and_no_warning() -> None:
    """Real-like photo 1,000,443 (a cell-classifier training photo): a straight-field lattice refitted
    to its crossings put them at infinity (numpy's "divide by zero" on every read). Such a fit is
    no lattice now: no warning, the straight field refused, and the '#' reads the board."""
    sc = real_like_scene(1_000_443)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        made = BoardReader(size=3, model=None, arbiter=None).hypotheses(sc.image)
        assert "straight" not in [h.kind for h in made] and made
        assert BoardReader(size=3).read(sc.image).text() == sc.text()
