"""The '#' finder's array shortcuts give what the plain definitions give: the stroke width
(run lengths), the first crossing of two polylines (tried only where segment boxes meet; every pair
of two sets of polylines in one array) and
the Radon directions (in chunks of angles), on random inputs, to the last bit; the copy
the '#' is sought on, taken from the photo itself at a whole factor; and the turned mask, taken
from the turned darkness."""

from __future__ import annotations

import numpy as np
import pytest

from kinegym.vision import hand_grid, ink, polylines, tracks


def _runs(mask: np.ndarray) -> list[int]:
    out = []
    for row in mask:
        n = 0
        for v in list(row) + [0]:
            if v:
                n += 1
            elif n:
                out.append(n)
                n = 0
    return out


@pytest.mark.parametrize("seed", range(6))
def test_stroke_width_is_the_median_run(seed: int) -> None:
    rng = np.random.default_rng(seed)
    mask = (rng.random((37, 53)) < rng.uniform(0.1, 0.7)).astype(np.uint8)
    mask[0, 0] = seed % 2  # a run that starts at the very first pixel, or not
    want = [float(np.median(_runs(m))) for m in (mask, mask.T)]
    assert ink._stroke_width(mask) == max(1.0, min(want))


def _first_crossing(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """Every segment pair, row-major, the first that crosses (the plain definition)."""
    la = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(a, axis=0).T))])
    lb = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(b, axis=0).T))])
    for i in range(len(a) - 1):
        p, r = a[i], a[i + 1] - a[i]
        for j in range(len(b) - 1):
            q, s = b[j], b[j + 1] - b[j]
            rxs = r[0] * s[1] - r[1] * s[0]
            if abs(rxs) <= 1e-9:
                continue
            qp = q - p
            t = (qp[0] * s[1] - qp[1] * s[0]) / rxs
            u = (qp[0] * r[1] - qp[1] * r[0]) / rxs
            if 0 <= t <= 1 and 0 <= u <= 1:
                return p + t * r, float(la[i] + t * np.hypot(*r)), float(lb[j] + u * np.hypot(*s))
    return None


@pytest.mark.parametrize("seed", range(40))
def test_first_crossing_matches_every_pair_tried(seed: int) -> None:
    rng = np.random.default_rng(seed)
    # wavy strokes across a 400 px image, sometimes crossing several times, sometimes not at all
    n, m = int(rng.integers(2, 40)), int(rng.integers(2, 40))
    a = np.cumsum(rng.normal([8.0, 1.0], 6.0, (n, 2)), axis=0)
    b = np.cumsum(rng.normal([1.0, 8.0], 6.0, (m, 2)), axis=0)
    a += 200 - a[n // 2] + rng.normal(0, 5 if seed % 4 else 60, 2)  # mostly crossing near their middles
    b += 200 - b[m // 2]
    if seed % 5 == 0:  # a crossing exactly at a vertex
        b[m // 2] = a[n // 2]
    got, want = polylines.first_crossing(a, b), _first_crossing(a, b)
    prepared = polylines.first_crossing(polylines.prepare(a), polylines.prepare(b))  # as the '#' search crosses them
    assert (got is None) == (want is None) == (prepared is None)
    if seed in (1, 2, 3):  # the draws these seeds make do cross: the test compares crossings, not only misses
        assert want is not None
    if want is not None:
        assert np.array_equal(got[0], want[0]) and got[1:] == want[1:]
        assert np.array_equal(prepared[0], want[0]) and prepared[1:] == want[1:]


@pytest.mark.parametrize("seed", range(30))
def test_every_crossing_at_once_is_each_pair_s_first_crossing(seed: int) -> None:
    """All pairs' first crossings in one array (the '#' search's) are each pair's, as the plain
    definition finds it: its segments against the other's, row-major, the first that crosses."""
    rng = np.random.default_rng(seed)

    def _wavy(start: np.ndarray, step: np.ndarray, n: int) -> np.ndarray:
        return start + np.cumsum(step + rng.normal(0.0, 2.5, (n, 2)), axis=0)

    a = [_wavy(np.array([rng.uniform(50, 400), 0.0]), np.array([0.0, 30.0]), int(rng.integers(2, 16)))
         for _ in range(int(rng.integers(1, 7)))]
    b = [_wavy(np.array([0.0, rng.uniform(50, 400)]), np.array([30.0, 0.0]), int(rng.integers(2, 16)))
         for _ in range(int(rng.integers(1, 7)))]
    found, point, pos_a, pos_b = polylines.all_crossings(a, b)
    hits = 0
    for i, p in enumerate(a):
        for j, q in enumerate(b):
            want = _first_crossing(p, q)
            assert found[i, j] == (want is not None)
            if want is not None:
                hits += 1
                assert np.array_equal(point[i, j], want[0]) and (pos_a[i, j], pos_b[i, j]) == want[1:]
    if seed < 5:
        assert hits  # the draws cross: the test compares crossings, not only misses


@pytest.mark.parametrize("seed", range(4))
def test_directions_equal_the_one_pass_energy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    mask = np.zeros((240, 320), np.uint8)
    import cv2

    for _ in range(6):  # a few long strokes of two directions and some noise
        x, y = rng.uniform(0, 320), rng.uniform(0, 240)
        ang = rng.choice([0.3, 1.9]) + rng.normal(0, 0.05)
        cv2.line(mask, (int(x - 200 * np.cos(ang)), int(y - 200 * np.sin(ang))),
                 (int(x + 200 * np.cos(ang)), int(y + 200 * np.sin(ang))), 1, 2)
    mask[rng.random(mask.shape) < 0.01] = 1
    ys, xs = np.nonzero(mask)
    th = np.radians(np.arange(0, 180, 2))
    proj = np.outer(np.cos(th), xs) + np.outer(np.sin(th), ys)
    binw = max(2.0, ink._stroke_width(mask))
    b = ((proj - proj.min(axis=1, keepdims=True)) / binw).astype(np.intp)
    energy = np.array([(np.bincount(row).astype(np.float64) ** 2).sum() for row in b])
    energy = np.convolve(np.concatenate([energy[-2:], energy, energy[:2]]), [0.25, 0.5, 1.0, 0.5, 0.25], "same")[2:-2]
    i = int(np.argmax(energy))
    phi_a, _ = tracks._directions(mask, ink._stroke_width(mask))[0]
    assert phi_a == float(np.mod(th[i] + np.pi / 2, np.pi))


@pytest.mark.parametrize(("h", "w", "k"),
                         [(720, 960, 2), (1080, 1440, 3), (480, 640, 0), (721, 960, 0), (1200, 1600, 0)])
def test_search_copy_takes_whole_factors_from_the_photo(h: int, w: int, k: int) -> None:
    """A photo that a whole 2 or 3 brings to about 480 px gives its own k x k block means
    (one area shrink, not two); any other photo, the working copy shrunk to 480 px."""
    rng = np.random.default_rng(h + w)
    photo = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    working = rng.integers(0, 256, (300, 400, 3), dtype=np.uint8)  # stands apart from the photo
    got = hand_grid.search_copy(working, photo)
    if k:
        blocks = photo.reshape(h // k, k, w // k, k, 3).astype(np.float64).mean(axis=(1, 3))
        assert got.shape == (h // k, w // k, 3)
        assert np.abs(got - blocks).max() <= 0.5 + 1e-9  # the means, rounded
    else:
        assert got.shape == (360, 480, 3)
        assert np.array_equal(got, hand_grid.search_copy(working))


@pytest.mark.parametrize("seed", range(3))
def test_an_ink_mask_from_levels_measured_once_is_the_mask_measured_again(seed: int) -> None:
    """The reader measures a search copy's noise floor and strong ink once for every kind's search
    (``SearchCopy.levels``); each mask must be the one measuring them again would give."""
    rng = np.random.default_rng(seed)
    d = (rng.random((120, 160)) ** 3).astype(np.float32)
    d[40:44, 10:150] = 0.8  # a stroke: strong ink above the noise
    levels = ink.noise_floor_and_top(d)
    for share in (0.0, 0.22, 0.45):
        for local in (False, True):
            again, once = ink.ink_mask(d, share, 0.05, local), ink.ink_mask(d, share, 0.05, local, levels)
            assert np.array_equal(again[0], once[0]) and np.array_equal(again[1], once[1]) and again[2] == once[2]


@pytest.mark.parametrize("seed", range(3))
def test_the_turned_mask_is_where_the_turned_darkness_is(seed: int) -> None:
    """``tracks._tracks`` turns only the darkness under the mask and takes the turned mask as where
    it is above 0 (one warp less a direction): the same px as turning the mask itself, for masks
    made as the '#' search makes them (any share, level or local threshold, zero darkness in the map)."""
    import cv2

    rng = np.random.default_rng(seed)
    d = (rng.random((150, 200)) ** 3).astype(np.float32)
    d[rng.random(d.shape) < 0.2] = 0.0  # paper with no ink at all
    d[60:64, 10:190] = 0.8
    for share, above, local in ((0.0, 0.0, False), (0.22, 0.0, True), (0.45, 0.1, False)):
        mask, _, width = ink.ink_mask(d, share, above, local)
        dark = np.where(mask > 0, d, 0.0).astype(np.float32)  # as hand_grid._find_hash_grid makes it
        for phi in (0.0, 0.4, 1.9):
            _, M, rot = tracks._tracks(mask, phi, width, dark)
            want = cv2.warpAffine(mask, M, rot.shape[::-1], flags=cv2.INTER_NEAREST)
            assert rot.dtype == np.uint8 and np.array_equal(rot, want)
