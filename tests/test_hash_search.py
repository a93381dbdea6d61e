"""The '#' search's fast kernel (:mod:`kinegym.vision.hash_search`) gives what the readable reference
(``hand_grid._best_hash``) gives, to the last bit: the best choice of tracks with its score and
crossings - on random wavy tracks, near-'#'s and not, and on the tracks the reader traces in real
photos (upright and turned). (The crossings of every pair at once: ``tests/test_hand_grid_fast.py``.)"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from kinegym.vision import hand_grid, hash_search
from kinegym.vision.board_reader import BoardReader
from kinegym.vision.hand_grid import Track
from kinegym.vision.image_io import read_image

REAL = Path(__file__).parent / "data" / "real"


def _same(a: tuple | None, b: tuple | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a[0] == b[0] and a[1] == b[1] and a[2] == b[2] and np.array_equal(a[3], b[3])


def _wavy(rng: np.random.Generator, start: np.ndarray, step: np.ndarray, n: int) -> np.ndarray:
    return start + np.cumsum(step + rng.normal(0.0, 2.5, (n, 2)), axis=0)


def _tracks(rng: np.random.Generator, vertical: bool, count: int, full: bool) -> list[Track]:
    """Wavy strokes of one family across a 480 x 480 copy, spaced like a '#''s lines, some short
    (every one long and the spacing regular when ``full``: 5 x 5 '#'s), one sometimes doubling
    another (a stroke shared)."""
    out = []
    spacing = rng.uniform(60, 90 if full else 110)
    for i in range(count):
        n = int(rng.integers(14, 17) if full else rng.integers(4, 19))
        across = 60 + spacing * i + rng.normal(0, 5 if full else 15)
        along = rng.uniform(0, 20 if full else 70)
        start, step = (np.array([across, along]), np.array([rng.normal(0, 2), 28.0])) if vertical else \
            (np.array([along, across]), np.array([28.0, rng.normal(0, 2)]))
        pts = _wavy(rng, start, step, n)
        out.append(Track(pts, float(rng.uniform(0.3, 1.0)), n,
                         colour=None if rng.random() < 0.5 else np.array([0.5, 0.5, 0.7]) + rng.normal(0, 0.1, 3)))
    if count > 2 and rng.random() < 0.4:  # a stroke traced twice: the two share it
        out.append(Track(out[0].pts + rng.normal(0, 1.0, out[0].pts.shape), 0.5, out[0].bands, colour=out[0].colour))
    if any(t.colour is None for t in out):  # one family's colours are all known or none
        for t in out:
            t.colour = None
    return out


def _draw(seed: int, inks: bool = True) -> tuple[list[Track], list[Track]]:
    """Seed ``seed``'s two families (a third of the seeds full 5 x 5 '#'s), their colours known for
    both or neither, their inks log-normal - a choice of lines often more than
    :data:`~kinegym.vision.tracks.INK_SPREAD_FREE` times apart - or all alike without ``inks``."""
    rng = np.random.default_rng(seed)
    full = seed % 3 == 0
    fa = _tracks(rng, True, int(rng.integers(4, 7) if full else rng.integers(2, 7)), full)
    fb = _tracks(rng, False, int(rng.integers(4, 7) if full else rng.integers(2, 7)), full)
    if (fa[0].colour is None) != (fb[0].colour is None):
        for t in fa + fb:
            t.colour = None
    ink_rng = np.random.default_rng(10_000 + seed)  # (its own stream: the tracks are as they were)
    for t in fa + fb:
        t.ink = float(np.exp(ink_rng.normal(0.0, 1.5))) if inks else 1.0
    return fa, fb


@pytest.mark.parametrize("seed", range(40))
def test_best_hash_equals_the_reference_on_random_tracks(seed: int) -> None:
    fa, fb = _draw(seed)
    width, ext = 3.0, 0.06 * 480
    for k in (2, 4):
        if len(fa) >= k and len(fb) >= k:
            want = hand_grid._best_hash(fa, fb, k, (480, 480), ext, width)
            got = hash_search.best_hash(fa, fb, k, (480, 480), hash_search.pairs(fa, fb, ext, width))
            assert _same(got, want)


def test_random_tracks_make_hashes_to_compare() -> None:
    """The draws above are not all misses: most seeds' 3 x 3 search finds a '#', some 5 x 5 ones do,
    and some have choices whose every line is too short for its cells, which are no '#' (None), never
    a '#' scored -inf."""
    found, none_with_crossings = {2: 0, 4: 0}, 0
    for seed in range(40):
        fa, fb = _draw(seed)
        for k in (2, 4):
            if len(fa) >= k and len(fb) >= k:
                best = hand_grid._best_hash(fa, fb, k, (480, 480), 0.06 * 480, 3.0)
                found[k] += best is not None
                assert best is None or np.isfinite(best[0])
                crossed = hash_search.pairs(fa, fb, 0.06 * 480, 3.0).found
                none_with_crossings += best is None and int(crossed.sum()) >= k * k
    assert found[2] >= 20 and found[4] >= 5 and none_with_crossings >= 2


def test_a_choice_of_lines_of_unlike_ink_scores_lower() -> None:
    """One pen draws a '#': on the random draws, lines whose inks differ more than
    :data:`~kinegym.vision.tracks.INK_SPREAD_FREE` times lose score - the best choice changes for
    some seeds, and never scores more than with the inks alike (the reference and the kernel agree
    on both, above)."""
    changed = 0
    for seed in range(40):
        unlike, alike = _draw(seed), _draw(seed, inks=False)
        for k in (2, 4):
            if len(unlike[0]) >= k and len(unlike[1]) >= k:
                got = hand_grid._best_hash(*unlike, k, (480, 480), 0.06 * 480, 3.0)
                want = hand_grid._best_hash(*alike, k, (480, 480), 0.06 * 480, 3.0)
                assert (got is None) == (want is None)
                if got is not None:
                    assert got[0] <= want[0]
                    changed += got[1:3] != want[1:3]
    assert changed >= 2


def test_a_line_from_the_photo_s_edge_to_its_edge_loses_to_a_drawn_one(monkeypatch: pytest.MonkeyPatch) -> None:
    """A notebook's spiral binding along the left edge runs from the photo's top to its bottom, dark
    and long: with the '#''s left column line it makes a '#' that outscores the drawn one (its rows
    reach the binding) - unless a line from edge to edge costs
    :data:`~kinegym.vision.tracks.EDGE_TO_EDGE_COST`. The reference and the kernel agree either way."""
    binding = Track(np.stack([np.full(12, 12.0), np.linspace(0.0, 479.0, 12)], 1), 1.0, 12)
    cols = [binding] + [Track(np.stack([np.full(12, x), np.linspace(80.0, 400.0, 12)], 1), 0.6, 12)
                        for x in (160.0, 300.0)]
    rows = [Track(np.stack([np.linspace(10.0, 420.0, 12), np.full(12, y)], 1), 0.6, 12) for y in (160.0, 300.0)]

    def both() -> tuple[int, ...]:
        want = hand_grid._best_hash(cols, rows, 2, (480, 480), 0.06 * 480, 3.0)
        got = hash_search.best_hash(cols, rows, 2, (480, 480), hash_search.pairs(cols, rows, 0.06 * 480, 3.0))
        assert want is not None and _same(got, want)
        return want[1]

    assert both() == (1, 2)  # the drawn columns
    monkeypatch.setattr(hand_grid, "EDGE_TO_EDGE_COST", 0.0)
    monkeypatch.setattr(hash_search, "EDGE_TO_EDGE_COST", 0.0)
    assert both() == (0, 1)  # the binding and the left column


def _frame(x0: float, y0: float, x1: float, y1: float) -> tuple[list[Track], list[Track]]:
    """A rectangle's four sides (a whiteboard's frame, a photo's border) as tracks: columns, rows."""
    cols = [Track(np.stack([np.full(12, x), np.linspace(y0, y1, 12)], 1), 1.0, 12) for x in (x0, x1)]
    rows = [Track(np.stack([np.linspace(x0, x1, 12), np.full(12, y)], 1), 1.0, 12) for y in (y0, y1)]
    return cols, rows


def test_a_frame_whose_sides_span_one_cell_is_no_hash() -> None:
    """A rectangle's sides meet at its corners: each spans the one cell between its crossings and no
    arm - too short for a '#' line (its cells and some arm). Before stop 68 the search returned such a
    choice scored -inf when nothing else crossed, and the reader read a whiteboard's frame around a
    drawn '#' as the board, the whole '#' in its middle cell."""
    cols, rows = _frame(100.0, 100.0, 380.0, 330.0)
    for fn in (lambda: hand_grid._best_hash(cols, rows, 2, (480, 480), 0.06 * 480, 3.0),
               lambda: hash_search.best_hash(cols, rows, 2, (480, 480), hash_search.pairs(cols, rows, 0.06 * 480,
                                                                                           3.0))):
        assert fn() is None
    # the same four lines run on a cell's third past each other make a '#'
    long_cols = [Track(np.stack([t.pts[:, 0], np.linspace(10, 420, 12)], 1), 1.0, 12) for t in cols]
    long_rows = [Track(np.stack([np.linspace(10, 470, 12), t.pts[:, 1]], 1), 1.0, 12) for t in rows]
    best = hand_grid._best_hash(long_cols, long_rows, 2, (480, 480), 0.06 * 480, 3.0)
    assert best is not None and np.isfinite(best[0])


@pytest.mark.parametrize("name, turn", [("kvuletic2_image5.jpeg", 0), ("kvuletic2_image11.jpeg", 0),
                                        ("kvuletic2_image13.jpeg", 30), ("kvuletic2_image7.jpeg", -15)])
def test_best_hash_equals_the_reference_on_real_photos(name: str, turn: float,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    img = read_image(REAL / name)
    if turn:
        h, w = img.shape[:2]
        img = cv2.warpAffine(img, cv2.getRotationMatrix2D((w / 2, h / 2), turn, 1.0), (w, h),
                             borderMode=cv2.BORDER_REPLICATE)
    calls: list[tuple[bool, bool]] = []  # (equal to the reference, a '#' found)
    fast = hash_search.best_hash

    def both(fa: list[Track], fb: list[Track], k: int, shape: tuple[int, int], p: hash_search.Pairs) -> tuple | None:
        got = fast(fa, fb, k, shape, p)
        calls.append((_same(got, hand_grid._best_hash(fa, fb, k, shape, p.ext, p.width)), got is not None))
        return got

    monkeypatch.setattr(hand_grid, "best_hash", both)
    hyps = BoardReader(accept=1.0).hypotheses(img)  # every kind's search, 3 x 3 and 5 x 5
    assert hyps and len(calls) >= 4
    assert all(same for same, _ in calls) and sum(hit for _, hit in calls) >= 2
