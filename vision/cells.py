"""Reading the cells of a rectified board: grid lines masked out, each cell's ink features
(amount, centre ink, enclosed hole, extent, ...), and the rule that turns them into
empty / X / O probabilities.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["board_features"]


_FEATURES = ("peak", "ink", "hollow", "hole", "extent", "elongation", "spread")


def board_features(rect: np.ndarray, n: int, s: int, o: int, threshold: float, min_peak: float,
                   outer: float = 0.0) -> np.ndarray:
    """Features ``(n, n, 7)`` of every cell at once, from the rectified darkness map with
    the grid lines removed (cells ``s`` px, the field ``o`` px in from the map's edge).
    ``outer``: how far (cells) past the field a mark's centre may lie and still belong to the
    outer cell beside it (an unframed hand-drawn grid's outer cells are often larger than
    its middle one).

    * ``peak``: the darkest 3 x 3 mean inside the cell (is there real ink at all?).
    * ``ink``: the mark's ink area relative to the cell. The mark is the ink darker than
      ``threshold`` and than half the cell's peak, in connected pieces of at least 1.5 % of
      a cell whose centre lies in the cell (so a mark that crosses the border stays whole,
      and a neighbour's that reaches in does not count). Cells whose peak is below
      ``min_peak`` hold no real ink.
    * ``hollow``: how empty the mark's middle is: 1 minus the ink share of the region within
      0.4 whitened units of the ink's centroid (whitened by the ink's own second moments, so
      that an oval O of any size, tilt or aspect becomes a ring). An X crosses there.
    * ``hole``: the largest background region enclosed by the mark (after closing small
      gaps), relative to the mark's bounding box. An O encloses one.
    * ``extent``: the mark's bounding-box size relative to the cell.
    * ``elongation``: the square root of the ratio of the ink's principal second moments:
      about 1 for an X or an O, large for a stray straight stroke (the end of a grid line).
    * ``spread``: the coefficient of variation of the ink's whitened distance from its
      centroid: small for a ring (an O, closed or not), large for strokes that run from the
      middle out (an X, also a lopsided one whose crossing is off its centre).
    """
    cells = n * n
    side = rect.shape[0]
    peaks = cv2.blur(rect[o:o + n * s, o:o + n * s], (3, 3)).reshape(n, s, n, s).max(axis=(1, 3))
    out = np.zeros((n, n, 7))
    out[..., 0], out[..., 5] = peaks, 1.0
    # each cell's threshold over its own square; the margin goes with the outer cells
    reps = np.full(n, s)
    reps[0], reps[-1] = s + o, side - o - (n - 1) * s
    thr = np.repeat(np.repeat(np.maximum(threshold, 0.5 * peaks), reps, axis=0), reps, axis=1)
    m = (rect > thr).astype(np.uint8)
    n_lab, lab = cv2.connectedComponents(m, connectivity=8)  # (its statistics cost 4x the labels)
    flat = np.flatnonzero(lab)
    comp = lab.ravel()[flat]
    yi, xi = np.divmod(flat, side)
    area = np.bincount(comp, minlength=n_lab)
    a1 = np.maximum(area, 1)
    cx, cy = np.bincount(comp, xi, n_lab) / a1, np.bincount(comp, yi, n_lab) / a1
    comp_cell = _cell_of(cx, cy, n, s, o, outer)
    comp_cell[area < max(4, int(0.015 * s * s))] = -1
    comp_cell[0] = -1
    ok_cell = peaks.ravel() >= min_peak
    comp_cell[(comp_cell >= 0) & ~ok_cell[np.maximum(comp_cell, 0)]] = -1
    cell = comp_cell[comp]
    keep = cell >= 0
    if not keep.any():
        return out
    flat = flat[keep]
    ys, xs, cell = yi[keep].astype(np.float64), xi[keep].astype(np.float64), cell[keep]
    cnt = np.bincount(cell, minlength=cells).astype(np.float64)
    has = cnt > 0
    c1 = np.maximum(cnt, 1.0)
    mx, my = np.bincount(cell, xs, cells) / c1, np.bincount(cell, ys, cells) / c1
    dx, dy = xs - mx[cell], ys - my[cell]
    cxx = np.bincount(cell, dx * dx, cells) / c1 + 1e-6
    cyy = np.bincount(cell, dy * dy, cells) / c1 + 1e-6
    cxy = np.bincount(cell, dx * dy, cells) / c1
    det = cxx * cyy - cxy * cxy
    half_tr = 0.5 * (cxx + cyy)
    root = np.sqrt(np.maximum(half_tr * half_tr - det, 0.0))
    elong = np.sqrt((half_tr + root) / np.maximum(half_tr - root, 1e-6))
    r = np.sqrt(np.maximum((cyy[cell] * dx * dx - 2 * cxy[cell] * dx * dy + cxx[cell] * dy * dy) / det[cell], 0.0))
    r_mean = np.bincount(cell, r, cells) / c1
    r_var = np.maximum(np.bincount(cell, r * r, cells) / c1 - r_mean ** 2, 0.0)
    spread = np.sqrt(r_var) / np.maximum(r_mean, 1e-6)
    # ink within 0.4 whitened units of the centroid, over that region's area in pixels
    middle_area = np.pi * 0.16 * np.sqrt(det)
    fill = np.bincount(cell, (r < 0.4).astype(np.float64), cells) / np.maximum(middle_area, 1.0)
    x0, y0 = np.full(cells, np.inf), np.full(cells, np.inf)
    x1, y1 = np.full(cells, -np.inf), np.full(cells, -np.inf)
    np.minimum.at(x0, cell, xs)
    np.minimum.at(y0, cell, ys)
    np.maximum.at(x1, cell, xs)
    np.maximum.at(y1, cell, ys)
    bw, bh = np.where(has, x1 - x0 + 1, 0), np.where(has, y1 - y0 + 1, 0)
    # enclosed background: flood the outside of the (gap-closed) marks from the border
    marks = np.zeros_like(m)
    marks.ravel()[flat] = 1
    ck = max(3, int(round(0.08 * s)) | 1)
    closed = cv2.morphologyEx(marks, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (ck, ck)))
    # enclosed: the background's 4-connected pieces that do not reach the map's edge
    _, _, st_h, c_h = cv2.connectedComponentsWithStats((closed == 0).astype(np.uint8), connectivity=4)
    left, top = st_h[1:, cv2.CC_STAT_LEFT], st_h[1:, cv2.CC_STAT_TOP]
    enclosed = ((left > 0) & (top > 0) & (left + st_h[1:, cv2.CC_STAT_WIDTH] < side)
                & (top + st_h[1:, cv2.CC_STAT_HEIGHT] < side))
    hole = np.zeros(cells)
    if enclosed.any():
        hole_cell = _cell_of(c_h[1:, 0], c_h[1:, 1], n, s, o, outer)
        inside = enclosed & (hole_cell >= 0)
        np.maximum.at(hole, hole_cell[inside], st_h[1:, cv2.CC_STAT_AREA][inside].astype(np.float64))
        hole = hole / np.maximum(bw * bh, 1.0)
    f = out.reshape(cells, 7)
    f[has, 1] = cnt[has] / float(s * s)
    f[has, 2] = np.clip(1.0 - fill[has], 0.0, 1.0)
    f[has, 3] = hole[has]
    f[has, 4] = np.maximum(bw, bh)[has] / s
    f[has, 5] = elong[has]
    f[has, 6] = spread[has]
    return out


def _cell_of(x: np.ndarray, y: np.ndarray, n: int, s: int, o: int, outer: float) -> np.ndarray:
    """Flat cell index (row * n + col) of rectified points, or -1 for points more than
    ``outer`` cells outside the field; points in that band belong to the outer cell beside them."""
    cf, rf = (x - o + 0.5) / s, (y - o + 0.5) / s
    col, row = np.clip(np.floor(cf), 0, n - 1).astype(int), np.clip(np.floor(rf), 0, n - 1).astype(int)
    within = (cf >= -outer) & (cf < n + outer) & (rf >= -outer) & (rf < n + outer)
    return np.where(within, row * n + col, -1)


def _probabilities(f: np.ndarray, ref: float) -> np.ndarray:
    """``(..., 7)`` features -> ``(..., 3)`` probabilities of empty / X / O.

    A mark needs real ink - a peak at least 40 % as dark as the grid lines (``ref``), which
    ghosts of erased marks and graph paper are not - and some size, and it must not be a
    single straight stroke: ``p(mark)`` is the product of two sigmoids. Given a mark,
    ``p(O) = sigmoid(b)``: a ring-like spread of the ink about its centre, a hollow middle
    and an enclosed hole mean O. (On 20,000 rendered marks the spread alone separates them:
    every X above 0.40, every O below 0.30; the weights put the boundary between. A hollow
    middle weighs less than the spread: a real, lopsided X whose strokes cross near one end
    leaves its middle empty too.)
    """
    peak, ink, hollow, hole, extent, elongation, spread = (f[..., i] for i in range(7))
    a_dark = 25.0 * (peak / max(ref, 1e-3) - 0.4)
    a_size = 60.0 * (ink - 0.015) + 12.0 * (extent - 0.25) - 3.0 * np.maximum(elongation - 4.0, 0.0)
    b = 6.0 * (hollow - 0.5) + 30.0 * (0.36 - spread) + 5.0 * hole

    def sig(v: np.ndarray) -> np.ndarray:
        return 1.0 / (1.0 + np.exp(-np.clip(v, -50, 50)))

    p_mark = sig(a_dark) * sig(a_size)
    p_o = sig(b)
    return np.stack([1 - p_mark, p_mark * (1 - p_o), p_mark * p_o], axis=-1)


def _quadratic_fits(powers: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Least-squares ``y = a + b x + c x^2`` for each row of ``y`` ``(L, N)`` over the points
    that ``w`` ``(L, N)`` (bool) selects, by the normal equations: ``(L, 3)`` coefficients.
    ``powers`` is ``(N, 5)``: ``x**0 .. x**4``. Rows with fewer than 3 points, or degenerate
    ones, get their mean (or 0) as a constant."""
    wf = w.astype(np.float64)
    s0, s1, s2, s3, s4 = (wf @ powers).T
    t0, t1, t2 = ((wf * y) @ powers[:, :3]).T
    m0, m1, m2 = s2 * s4 - s3 * s3, s1 * s4 - s3 * s2, s1 * s3 - s2 * s2
    det = s0 * m0 - s1 * m1 + s2 * m2
    ok = (s0 >= 3) & (np.abs(det) >= 1e-12)
    dd = np.where(ok, det, 1.0)
    out = np.empty((len(w), 3))
    out[:, 0] = np.where(ok, (t0 * m0 - s1 * (t1 * s4 - s3 * t2) + s2 * (t1 * s3 - s2 * t2)) / dd,
                         t0 / np.maximum(s0, 1.0))
    out[:, 1] = np.where(ok, (s0 * (t1 * s4 - s3 * t2) - t0 * m1 + s2 * (s1 * t2 - t1 * s2)) / dd, 0.0)
    out[:, 2] = np.where(ok, (s0 * (s2 * t2 - t1 * s3) - s1 * (s1 * t2 - t1 * s2) + t0 * m2) / dd, 0.0)
    return out


def _remove_grid_lines(rect: np.ndarray, n: int, s: int, o: int, present: float) -> np.ndarray:
    """Blank the grid lines of a rectified board (cells ``s`` px, field offset ``o`` px).

    Each of the ``n + 1`` lines each way is tracked along its length - per row (column),
    where the darkness peaks within a fifth of a cell of its place - and the track is
    fitted with a quadratic, refitted without the rows that stray (a symbol touching the
    line pulls the peak away there). A line that is not there for most of its length (a
    missing frame side) is left alone; a line that is there is blanked over its own width
    along the fitted track. Only the line's band goes: an O drawn against a line keeps the
    rest of its ring. (All lines of a family are tracked and fitted at once.)
    """
    b = max(2, s // 5)
    side = rect.shape[0]
    n_lines, width = n + 1, 2 * b + 1
    yr = np.arange(side, dtype=np.float64) / side
    powers = yr[:, None] ** np.arange(5)
    field = slice(o, o + n * s)
    lo = o + s * np.arange(n_lines) - b  # each line's band: lo .. lo + 2b across it
    idx = lo[:, None] + np.arange(width)
    blank = np.zeros(rect.shape, bool)
    for flat, blank_view in ((rect.T, blank.T), (rect, blank)):  # columns, rows: bands as (line, across, along)
        raw = flat[idx]
        # smoothed along the line (9 px), as a blur of the stacked band rows
        bands = cv2.blur(raw.reshape(n_lines * width, side), (9, 1)).reshape(raw.shape)
        arg = bands.argmax(axis=1)
        peak = np.take_along_axis(bands, arg[:, None, :], axis=1)[:, 0, :]
        on = peak > present
        centre = (arg + lo[:, None]).astype(np.float64)
        live = on[:, field].mean(axis=1) >= 0.5  # lines not there for most of their length stay
        keep = on.copy()
        fitted = np.zeros(on.shape)
        for _ in range(3):  # quadratic track per line, refitted without the rows that stray
            coef = _quadratic_fits(powers, centre, keep)
            new_fit = coef[:, :1] + yr * (coef[:, 1:2] + yr * coef[:, 2:3])
            new_keep = on & (np.abs(centre - new_fit) <= 2.0)
            fitted[live] = new_fit[live]
            keep[live] = new_keep[live]
            live &= new_keep.sum(axis=1) >= 0.3 * on.sum(axis=1)
        # a line needs a straight track along most of the field (else: symbols only)
        count = keep.sum(axis=1)
        live &= count >= 0.7 * n * s
        if not live.any():
            continue
        # the line's own width: the median over its kept track of the samples above half its peak
        across = np.where(keep, (bands > 0.5 * peak[:, None, :]).sum(axis=1), width + 1)
        across.sort(axis=1)
        k = np.maximum(count, 1)
        rows = np.arange(n_lines)
        half = 0.25 * (across[rows, (k - 1) // 2] + across[rows, k // 2]) + 1.5
        cut = np.abs(idx[:, :, None] - fitted[:, None, :]) <= half[:, None, None]
        blank_view[idx] |= cut & on[:, None, :] & live[:, None, None]
    out = rect.copy()
    out[blank] = 0.0
    return out
