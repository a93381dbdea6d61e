"""Read a tic-tac-toe board from a camera image: find the grid, undo the perspective, and
call every cell empty, X or O with a confidence. OpenCV + numpy only.

Pipeline of :class:`BoardReader` (every frame from scratch: the paper may move):

1. **Ink map.** Luma darkness against the local background, ``1 - Y / background(Y)``,
   with the background a morphological closing of a shrunk copy (removes strokes, keeps
   light gradients, shadows and glare). Luma makes every pen colour dark and a yellow
   highlighter nearly invisible; normalising by the background makes the map independent
   of uneven light.
2. **Grid.** Long straight segments (probabilistic Hough on the thresholded map) are
   merged into lines, split into the two families of the grid by direction (perspective
   lets each family fan out), and ordered across. The longest lines of each family are
   the field's; a family's outermost line is a *frame* line when the other family stops
   at it, an *interior* line when the other family runs on for about a cell - so an
   interior-only field (the thesis's 4 + 4 lines), a full frame and a frame with sides
   missing all work. The board size follows from the number of interior lines, or is
   given.
3. **Homography.** Every intersection of a column line with a row line is a point of the
   ideal grid; a least-squares homography maps grid coordinates (cells) to pixels. Its
   reprojection error and the count of grid points found are the grid's confidence. A
   lattice whose cells grow more than 3 x from one corner of the field to another (a camera
   tilted 35 deg manages about 2.6 x) was extrapolated from wrong lines: the next lattice
   hypothesis is tried instead.
4. **Cells.** The ink map is warped onto a square grid of ``cell_px`` per cell, the grid
   lines are masked out, and each cell's ink is measured: its amount (empty or not,
   against a threshold set from the contrast of the grid lines themselves, so faint
   ghosts of erased games fall below it), and two shape features that do not depend on
   the symbol's rotation, size or placement in the cell - ink at the centre of the mark
   (an X crosses there, an O is hollow) and an enclosed hole (an O encloses one, an X
   does not). A logistic rule turns them into probabilities.

Rows are returned top to bottom and columns left to right *as the image shows them*
(a board turned more than 45 degrees reads turned). :class:`ThresholdReader` keeps seed
003's rule as the baseline: the share of pixels darker than a grey level in fixed image
regions, which says "filled" or "empty" and cannot tell X from O.

No board in the image raises :class:`NoBoardError` (with the reason), never a guess.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from .errors import NoBoardError, VisionError

__all__ = [
    "EMPTY",
    "X",
    "O",
    "BoardReading",
    "BoardReader",
    "ThresholdReader",
    "NoBoardError",
    "VisionError",
    "ink_map",
    "board_features",
    "debug_image",
]

EMPTY, X, O = 0, 1, 2
_SYMBOL = {EMPTY: ".", X: "X", O: "O"}


@dataclass
class BoardReading:
    """What the reader saw.

    Attributes:
        cells: ``(n, n)`` int array, 0 empty, 1 X, 2 O; row 0 at the top of the image.
        confidence: ``(n, n)`` probability of each call.
        probs: ``(n, n, 3)`` probabilities of empty / X / O per cell.
        homography: 3 x 3 taking grid coordinates (cells; (0, 0) the top-left corner of the
            field, (n, n) the bottom-right) to image pixels.
        grid_error_px: RMS distance of the found grid points from the fitted grid (px).
        grid_points: how many line intersections the homography rests on.
        frame: which border sides were drawn (left, right, top, bottom).
    """

    cells: np.ndarray
    confidence: np.ndarray
    probs: np.ndarray
    homography: np.ndarray
    grid_error_px: float
    grid_points: int
    frame: tuple[bool, bool, bool, bool] = (False, False, False, False)
    features: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def n(self) -> int:
        return int(self.cells.shape[0])

    def text(self) -> str:
        """The board in the game's text form, e.g. ``"X..|.O.|..."``."""
        return "|".join("".join(_SYMBOL[int(v)] for v in row) for row in self.cells)

    def corners(self) -> np.ndarray:
        """The field's corners in the image (px): top-left, top-right, bottom-right, bottom-left."""
        n = self.n
        return _apply(self.homography, np.array([[0, 0], [n, 0], [n, n], [0, n]], float))


def _apply(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = np.concatenate([pts, np.ones((len(pts), 1))], axis=1) @ H.T
    return p[:, :2] / p[:, 2:3]


def _as_rgb(image: object) -> np.ndarray:
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (3, 4)):
        raise VisionError(f"image of dtype {img.dtype} and shape {img.shape}; expected uint8 (H, W) or (H, W, 3)")
    if min(img.shape[:2]) < 32:
        raise VisionError(f"image of shape {img.shape} is too small; expected at least 32 x 32 pixels")
    if img.ndim == 2:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    return img[..., :3]


def ink_map(image: object, stroke_px: float = 12.0) -> np.ndarray:
    """Ink darkness ``(H, W)`` float32 in 0..1: luma darkness against the local background.

    The background is a grey closing (max then min filter) over a square a little wider
    than ``stroke_px``, the widest stroke expected: it removes thin dark strokes and keeps
    anything wide - light gradients, shadows, glare, and the table around the paper, whose
    edge therefore does not turn into a line of ink.
    """
    rgb = _as_rgb(image)
    y8 = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    k = 2 * int(math.ceil(stroke_px)) + 1
    # replicate the border first: a sliver of dark table along the image edge would
    # otherwise look like a stroke (8-bit morphology: several times faster than float)
    padded = cv2.copyMakeBorder(y8, k, k, k, k, cv2.BORDER_REPLICATE)
    bg = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))[k:-k, k:-k]
    # a closing never darkens, so 0 <= y8 <= bg and the darkness lies in 0..1 as it is
    d = y8.astype(np.float32)
    np.divide(d, cv2.max(bg, 8).astype(np.float32), out=d)  # (cv2.max: numpy's is 6x slower on uint8)
    return np.subtract(1.0, d, out=d)


# ------------------------------------------------------------------ lines
@dataclass
class _Line:
    theta: float  # normal direction (rad, 0..pi)
    rho: float  # signed distance of the line from the origin along the normal (px)
    length: float  # total length of the merged segments (px)
    p0: np.ndarray = field(default_factory=lambda: np.zeros(2))
    p1: np.ndarray = field(default_factory=lambda: np.zeros(2))  # extent along the line

    @property
    def normal(self) -> np.ndarray:
        return np.array([math.cos(self.theta), math.sin(self.theta)])

    @property
    def direction(self) -> np.ndarray:
        return np.array([-math.sin(self.theta), math.cos(self.theta)])

    def homog(self) -> np.ndarray:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.array([c, s, -self.rho])


def _segments(mask: np.ndarray, min_len: float) -> np.ndarray:
    segs = cv2.HoughLinesP(mask, 1, np.pi / 180, threshold=max(10, int(min_len * 0.5)),
                           minLineLength=int(min_len), maxLineGap=int(max(3, min_len * 0.12)))
    return np.zeros((0, 4)) if segs is None else segs.reshape(-1, 4).astype(np.float64)


def _fit_lines(pts: np.ndarray, wts: np.ndarray, lengths: Sequence[float]) -> list[_Line]:
    """Total-least-squares lines through weighted points, one per row of ``pts`` ``(L, N, 2)``
    (weights ``(L, N)``; 0 pads a row), each spanning its points' extent: the principal axis
    of the 2 x 2 weighted scatter, in closed form."""
    c = (wts[..., None] * pts).sum(axis=1) / wts.sum(axis=1)[:, None]
    dx, dy = pts[..., 0] - c[:, None, 0], pts[..., 1] - c[:, None, 1]
    wx = wts * dx
    sxx, sxy, syy = (wx * dx).sum(axis=1), (wx * dy).sum(axis=1), (wts * dy * dy).sum(axis=1)
    # the normal is the minor axis: a quarter turn from the major one
    th = np.mod(0.5 * np.arctan2(2.0 * sxy, sxx - syy) + 0.5 * math.pi, math.pi)
    cs, sn = np.cos(th), np.sin(th)
    t = dx * -sn[:, None] + dy * cs[:, None]
    used = wts > 0
    t0, t1 = np.where(used, t, np.inf).min(axis=1), np.where(used, t, -np.inf).max(axis=1)
    rho = c[:, 0] * cs + c[:, 1] * sn
    return [_Line(float(th[i]), float(rho[i]), float(lengths[i]),
                  np.array([c[i, 0] - t0[i] * sn[i], c[i, 1] + t0[i] * cs[i]]),
                  np.array([c[i, 0] - t1[i] * sn[i], c[i, 1] + t1[i] * cs[i]])) for i in range(len(th))]


def _merge(segs: np.ndarray, tol: float) -> list[_Line]:
    """Merge collinear segments ``(K, 4)`` into lines, longest first: a segment joins a line
    when both its ends lie within ``tol`` px of it (hand-drawn lines break into pieces
    whose own angles scatter, but whose ends stay on the line)."""
    if not len(segs):
        return []
    d = segs[:, 2:] - segs[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    # each group is founded by the longest segment left, whose line decides membership
    # (taken in turn, a segment joins the first group whose founder's line it fits)
    members: list[np.ndarray] = []
    free = np.ones(len(segs), bool)
    order = np.argsort(-length)
    while free.any():
        i = order[free[order]][0]
        a, b = segs[i, :2], segs[i, 2:]
        nrm = np.array([a[1] - b[1], b[0] - a[0]]) / max(float(length[i]), 1e-9)
        rho = float(a @ nrm)
        fits = free & (np.abs(segs[:, :2] @ nrm - rho) <= tol) & (np.abs(segs[:, 2:] @ nrm - rho) <= tol)
        fits[i] = True
        ix = order[fits[order]]  # longest first, as the segments would have joined
        members.append(ix)
        free[ix] = False
    # every group's line through its segments' ends, weighted by the segments' lengths
    most = max(len(ix) for ix in members)
    pts = np.zeros((len(members), 2 * most, 2))
    wts = np.zeros((len(members), 2 * most))
    for g, ix in enumerate(members):
        k = len(ix)
        pts[g, :k], pts[g, most:most + k] = segs[ix, :2], segs[ix, 2:]
        wts[g, :k] = wts[g, most:most + k] = length[ix]
    out = []
    for ix, ln in zip(members, _fit_lines(pts, wts, [0.0] * len(members))):
        # length: the union of the pieces along the line, not their sum
        ta, tb = (segs[ix, :2] - ln.p0) @ ln.direction, (segs[ix, 2:] - ln.p0) @ ln.direction
        iv = list(zip(np.minimum(ta, tb).tolist(), np.maximum(ta, tb).tolist()))
        out.append(_Line(ln.theta, ln.rho, _union_length(iv), ln.p0, ln.p1))
    return out


def _median(values: np.ndarray) -> float:
    """``np.median`` of a small 1-D array, without its overhead (it runs many times a frame)."""
    v = np.sort(values)
    k = len(v) // 2
    return float(v[k] if len(v) % 2 else (v[k - 1] + v[k]) / 2)


def _percentile(values: np.ndarray, q: float) -> float:
    """``np.percentile(values, q)`` (linear interpolation) by a partial sort: several times
    faster on an image."""
    pos = q / 100.0 * (len(values) - 1)
    k = int(math.floor(pos))
    if k + 1 >= len(values):
        return float(np.max(values))
    part = np.partition(values, (k, k + 1))
    a, b, g = float(part[k]), float(part[k + 1]), pos - k
    return a + (b - a) * g if g < 0.5 else b - (b - a) * (1.0 - g)


def _union_length(intervals: Sequence[tuple[float, float]]) -> float:
    """Total length covered by 1-D intervals ``(a, b)``, a <= b."""
    iv = sorted(intervals)
    cover, (lo, hi) = 0.0, iv[0]
    for a, b in iv[1:]:
        if a > hi:
            cover, lo = cover + hi - lo, a
        hi = max(hi, b)
    return float(cover + hi - lo)


def _line_arrays(lines: list[_Line]) -> tuple[np.ndarray, ...]:
    """cos, sin of the normals, rho, start points ``(L, 2)`` and drawn lengths of lines."""
    th = np.array([ln.theta for ln in lines])
    p0 = np.array([ln.p0 for ln in lines])
    p1 = np.array([ln.p1 for ln in lines])
    return np.cos(th), np.sin(th), np.array([ln.rho for ln in lines]), p0, np.hypot(*(p1 - p0).T)


def _refit(lines: list[_Line], ink: np.ndarray, floor: float, band: float) -> list[_Line | None]:
    """Each line refitted to the full-resolution ink map around it: every 3 px along the line
    (and a little past its ends), the darkness-weighted centre of the ink within ``band`` px
    across it, then a weighted total-least-squares line through those centres. None for a
    line with no ink there. (All lines at once: the samples of shorter lines are padded.)"""
    if not lines:
        return []
    h, w = ink.shape
    cs, sn, _, p0, length = _line_arrays(lines)
    nrm, dirv = np.stack([cs, sn], -1), np.stack([-sn, cs], -1)
    count = np.ceil((length + 2.0 * band + 1.0) / 3.0).astype(np.intp)  # samples along each line
    t = -band + 3.0 * np.arange(int(count.max()))
    u = np.arange(-math.ceil(band), math.ceil(band) + 1.0)
    pts = (p0[:, None, None, :] + t[None, :, None, None] * dirv[:, None, None, :]
           + u[None, None, :, None] * nrm[:, None, None, :])
    x = np.clip(np.rint(pts[..., 0]).astype(np.intp), 0, w - 1)
    y = np.clip(np.rint(pts[..., 1]).astype(np.intp), 0, h - 1)
    wt = np.maximum(ink[y, x] - floor, 0.0)
    tot = wt.sum(axis=2)
    on = (tot > 0) & (np.arange(len(t))[None, :] < count[:, None])
    off = (wt * u).sum(axis=2) / np.where(on, tot, 1.0)
    centres = p0[:, None, :] + t[None, :, None] * dirv[:, None, :] + off[..., None] * nrm[:, None, :]
    good = np.flatnonzero(on.sum(axis=1) >= 5)
    out: list[_Line | None] = [None] * len(lines)
    fits = _fit_lines(centres[good], np.where(on[good], tot[good], 0.0), [lines[i].length for i in good])
    for i, fit in zip(good, fits):
        out[i] = fit
    return out


def _crossings(fam: list[_Line], other: list[_Line]) -> tuple[np.ndarray, ...]:
    """Crossing points of every line of ``fam`` with every line of ``other``: ``x, y`` (px)
    and ``ok`` (not parallel), each ``(len(fam), len(other))``, and the two families' line
    arrays (:func:`_line_arrays`) for further use."""
    A, B = _line_arrays(fam), _line_arrays(other)
    ca, sa, ra = (v[:, None] for v in A[:3])
    cb, sb, rb = (v[None, :] for v in B[:3])
    det = ca * sb - sa * cb
    ok = np.abs(det) >= 1e-9
    det = np.where(ok, det, 1.0)
    return (ra * sb - rb * sa) / det, (ca * rb - cb * ra) / det, ok, A, B


def _crossing(fam: list[_Line], other: list[_Line], slack: float) -> list[_Line]:
    """The lines of ``fam`` that cross at least two lines of ``other``, and at least half
    of them, within both lines' drawn extents (``slack`` px beyond the ends allowed): a
    paper edge, a shadow's edge or a row of symbol strokes crosses few of the field's lines."""
    if len(other) < 2 or not fam:
        return fam
    x, y, ok, (ca, sa, _, pa, la), (cb, sb, _, pb, lb) = _crossings(fam, other)
    # positions along each line (direction: the normal turned a quarter)
    ta = (x - pa[:, None, 0]) * -sa[:, None] + (y - pa[:, None, 1]) * ca[:, None]
    tb = (x - pb[None, :, 0]) * -sb[None, :] + (y - pb[None, :, 1]) * cb[None, :]
    hit = (ok & (ta >= -slack) & (ta <= la[:, None] + slack) & (tb >= -slack) & (tb <= lb[None, :] + slack))
    need = max(2, (len(other) + 1) // 2)
    return [a for a, h in zip(fam, hit.sum(axis=1)) if h >= need]


def _families(lines: list[_Line]) -> tuple[list[_Line], list[_Line]]:
    """Split lines into the two grid directions: a length-weighted circular 2-means on the
    doubled normal angle, seeded by the longest line; lines more than 20 deg off their
    family's mean direction are dropped."""
    if len(lines) < 2:
        return lines, []
    ang = np.array([2 * ln.theta for ln in lines])
    wts = np.array([ln.length for ln in lines])
    c0 = ang[int(np.argmax(wts))]
    c1 = c0 + np.pi
    for _ in range(10):
        d0 = np.abs(np.angle(np.exp(1j * (ang - c0))))
        d1 = np.abs(np.angle(np.exp(1j * (ang - c1))))
        lab = d1 < d0
        if lab.all() or (~lab).all():
            break
        c0 = float(np.angle((wts[~lab] * np.exp(1j * ang[~lab])).sum()))
        c1 = float(np.angle((wts[lab] * np.exp(1j * ang[lab])).sum()))
    # perspective fans a family out by some degrees; a symbol's stroke runs at about 45 deg
    # to both families and joins neither
    d0 = np.abs(np.angle(np.exp(1j * (ang - c0)))) / 2
    d1 = np.abs(np.angle(np.exp(1j * (ang - c1)))) / 2
    limit = math.radians(20)
    fa = [ln for ln, k, d in zip(lines, lab, d0) if not k and d <= limit]
    fb = [ln for ln, k, d in zip(lines, lab, d1) if k and d <= limit]
    return fa, fb


# ------------------------------------------------------------------ cells
_FEATURES = ("peak", "ink", "hollow", "hole", "extent", "elongation", "spread")


def board_features(rect: np.ndarray, n: int, s: int, o: int, threshold: float, min_peak: float) -> np.ndarray:
    """Features ``(n, n, 7)`` of every cell at once, from the rectified darkness map with
    the grid lines removed (cells ``s`` px, the field ``o`` px in from the map's edge).

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
    col, row = np.floor((cx - o + 0.5) / s).astype(int), np.floor((cy - o + 0.5) / s).astype(int)
    comp_cell = np.where((col >= 0) & (col < n) & (row >= 0) & (row < n), row * n + col, -1)
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
        hc, hr = np.floor((c_h[1:, 0] - o + 0.5) / s).astype(int), np.floor((c_h[1:, 1] - o + 0.5) / s).astype(int)
        inside = enclosed & (hc >= 0) & (hc < n) & (hr >= 0) & (hr < n)
        np.maximum.at(hole, (hr * n + hc)[inside], st_h[1:, cv2.CC_STAT_AREA][inside].astype(np.float64))
        hole = hole / np.maximum(bw * bh, 1.0)
    f = out.reshape(cells, 7)
    f[has, 1] = cnt[has] / float(s * s)
    f[has, 2] = np.clip(1.0 - fill[has], 0.0, 1.0)
    f[has, 3] = hole[has]
    f[has, 4] = np.maximum(bw, bh)[has] / s
    f[has, 5] = elong[has]
    f[has, 6] = spread[has]
    return out


def _probabilities(f: np.ndarray, ref: float) -> np.ndarray:
    """``(..., 7)`` features -> ``(..., 3)`` probabilities of empty / X / O.

    A mark needs real ink - a peak at least 40 % as dark as the grid lines (``ref``), which
    ghosts of erased marks and graph paper are not - and some size, and it must not be a
    single straight stroke: ``p(mark)`` is the product of two sigmoids. Given a mark,
    ``p(O) = sigmoid(b)``: a ring-like spread of the ink about its centre, a hollow middle
    and an enclosed hole mean O. (On 20,000 rendered marks the spread alone separates them:
    every X above 0.40, every O below 0.30; the weights put the boundary between.)
    """
    peak, ink, hollow, hole, extent, elongation, spread = (f[..., i] for i in range(7))
    a_dark = 25.0 * (peak / max(ref, 1e-3) - 0.4)
    a_size = 60.0 * (ink - 0.015) + 12.0 * (extent - 0.25) - 3.0 * np.maximum(elongation - 4.0, 0.0)
    b = 12.0 * (hollow - 0.5) + 25.0 * (0.34 - spread) + 4.0 * hole

    def sig(v: np.ndarray) -> np.ndarray:
        return 1.0 / (1.0 + np.exp(-np.clip(v, -50, 50)))

    p_mark = sig(a_dark) * sig(a_size)
    p_o = sig(b)
    return np.stack([1 - p_mark, p_mark * (1 - p_o), p_mark * p_o], axis=-1)


# ------------------------------------------------------------------ the reader
class BoardReader:
    """Finds the grid and reads every cell (see the module docstring).

    Args:
        size: 3 or 5 cells a side, or None to decide from the number of grid lines.
        cell_px: side of a rectified cell (px) for the cell features.
        max_side_px: larger images are shrunk to this longer side first (speed).
        grid_px: the grid is searched on a copy shrunk to about this longer side.
    """

    def __init__(self, size: int | None = None, cell_px: int = 40, max_side_px: int = 800,
                 grid_px: int = 400) -> None:
        if size not in (None, 3, 5):
            raise VisionError(f"size={size!r}; expected 3, 5 or None (decide from the image)")
        if not 12 <= int(cell_px) <= 200:  # a grid line's band (a fifth of a cell) must fit in the margin
            raise VisionError(f"cell_px={cell_px!r}; expected 12..200 pixels per rectified cell")
        if min(int(max_side_px), int(grid_px)) < 64:
            raise VisionError(f"max_side_px={max_side_px!r}, grid_px={grid_px!r}; expected at least 64 pixels each")
        self.size = size
        self.cell_px = int(cell_px)
        self.max_side_px = int(max_side_px)
        self.grid_px = int(grid_px)

    def read(self, image: object, trace: dict[str, object] | None = None) -> BoardReading:
        """Read one image (uint8 RGB or grey); raises :class:`NoBoardError` without a board.

        ``trace``, if given, is filled with the intermediate results (lines, lattice, ...),
        in the coordinates of the possibly shrunk working image (``trace["scale"]``), for
        :func:`debug_image`.
        """
        rgb = _as_rgb(image)
        h0, w0 = rgb.shape[:2]
        scale = min(1.0, self.max_side_px / max(h0, w0))
        if scale < 1.0:
            rgb = cv2.resize(rgb, (int(round(w0 * scale)), int(round(h0 * scale))), interpolation=cv2.INTER_AREA)
        h, w = rgb.shape[:2]
        diag = math.hypot(h, w)
        d = ink_map(rgb, stroke_px=max(6.0, diag / 100))
        # the grid is found on a copy of about grid_px (long lines need no more), the cells
        # are read at full resolution
        g = max(1, int(round(max(h, w) / self.grid_px)))
        dg = cv2.resize(d, (w // g, h // g), interpolation=cv2.INTER_AREA) if g > 1 else d
        if trace is not None:
            trace["scale"] = scale / g
        Hg, err, npts, frame, n = self._find_grid(dg, math.hypot(*dg.shape), trace)
        H = np.array([[g, 0, 0.5 * (g - 1)], [0, g, 0.5 * (g - 1)], [0, 0, 1.0]]) @ Hg
        err *= g
        line_ref, _ = self._line_contrast(d, H, n)
        probs, feats = self._read_cells(d, H, n, line_ref)
        cells = probs.argmax(axis=-1)
        conf = probs.max(axis=-1)
        if scale < 1.0:
            H = np.diag([1 / scale, 1 / scale, 1.0]) @ H
            err /= scale
        return BoardReading(cells.astype(np.int64), conf, probs, H, float(err), npts, frame, feats)

    # -- grid ------------------------------------------------------------------------
    def _find_grid(self, d: np.ndarray, diag: float, trace: dict[str, object] | None = None
                   ) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        """The field's homography (grid cells -> px), fit error, crossings used, frame sides
        and size. Ink is "dark" above a share of the image's darkest strokes; if no grid
        shows at that share, a lower one is tried (a light, thin field next to bold marks)."""
        trace = {} if trace is None else trace
        top = _percentile(d[::2, ::2].ravel(), 99.5)
        try:
            return self._find_grid_at(d, diag, max(0.18, 0.35 * top), trace)
        except NoBoardError as first:
            if 0.25 * top < 0.15:
                raise
            try:
                return self._find_grid_at(d, diag, 0.25 * top, trace)
            except NoBoardError:
                raise first from None

    def _find_grid_at(self, d: np.ndarray, diag: float, t0: float, trace: dict[str, object]
                      ) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        h, w = d.shape
        mask = (d > t0).astype(np.uint8)
        if cv2.countNonZero(mask) < 1e-4 * mask.size:
            raise NoBoardError("the image holds no ink")
        # straight segments on a shrunk copy (Hough costs grow with the ink pixels), then
        # each merged line refitted to the full-resolution ink around it
        f = max(1, int(round(max(h, w) / 400)))  # (1 when the caller already shrank it)
        small = cv2.resize(d, (w // f, h // f), interpolation=cv2.INTER_AREA) if f > 1 else d
        segs = _segments((small > 0.8 * t0).astype(np.uint8), 0.08 * diag / f) * f
        tol = 0.006 * diag + 2
        merged = _merge(segs, tol)
        shortest = 0.25 * max((ln.length for ln in merged), default=0.0)  # symbol strokes: not worth a refit
        refit = _refit([ln for ln in merged if ln.length >= shortest], d, t0, tol)
        lines = [ln for ln in refit if ln is not None]
        trace["lines"] = lines
        if len(lines) < 4:
            raise NoBoardError(f"{len(lines)} straight lines found; a grid needs at least 2 + 2")
        fa, fb = _families(lines)
        if len(fa) < 2 or len(fb) < 2:
            raise NoBoardError(f"lines in one direction only ({len(fa)} and {len(fb)}); a grid needs two")
        # columns: the family whose lines run closer to the image vertical
        if np.mean([abs(math.cos(ln.theta)) for ln in fa]) < np.mean([abs(math.cos(ln.theta)) for ln in fb]):
            fa, fb = fb, fa
        cols, rows = self._field_lines(fa, d, t0, tol), self._field_lines(fb, d, t0, tol)
        for _ in range(2):  # a field line crosses the other family's lines where both are drawn
            cols, rows = _crossing(cols, rows, 3 * tol), _crossing(rows, cols, 3 * tol)
        if len(cols) < 2 or len(rows) < 2:
            raise NoBoardError(f"{len(cols)} column and {len(rows)} row lines of field length; a grid needs 2 + 2")
        # columns left to right and rows top to bottom, as the image shows them
        if (cols[0].p0 + cols[0].p1)[0] > (cols[-1].p0 + cols[-1].p1)[0]:
            cols.reverse()
        if (rows[0].p0 + rows[0].p1)[1] > (rows[-1].p0 + rows[-1].p1)[1]:
            rows.reverse()
        trace["cols"], trace["rows"] = cols, rows
        near = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_RECT, (5, 5)))
        # the best lattice from the cells around the middle first; if no field follows from
        # it (a stray line took part), the next best lattices from every cell
        failure: NoBoardError | None = None
        tried = 0
        for Hl, nodes, err in self._lattices(cols, rows):
            try:
                return self._field(Hl, nodes, err, d, near, diag, trace)
            except NoBoardError as exc:
                failure = failure or exc
            tried += 1
            if tried >= 6:
                break
        raise failure or NoBoardError("the grid lines do not make a projective grid")

    def _field(self, Hl: np.ndarray, nodes: np.ndarray, err: float, d: np.ndarray, near: np.ndarray, diag: float,
               trace: dict[str, object]) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        """The field that a lattice implies: its extent, border and size (or NoBoardError)."""
        (i0, j0), (i1, j1) = nodes.min(axis=0), nodes.max(axis=0)
        # the outermost lattice lines must be drawn along their length: a line of symbol
        # strokes that happens to fall on the lattice is not (its ink covers little of it)
        i0, i1 = self._drawn_range(Hl, near, 0, i0, i1, j0, j1)
        j0, j1 = self._drawn_range(Hl, near, 1, j0, j1, i0, i1)
        nodes = nodes[(nodes[:, 0] >= i0) & (nodes[:, 0] <= i1) & (nodes[:, 1] >= j0) & (nodes[:, 1] <= j1)]
        trace["lattice"], trace["nodes"] = Hl, nodes
        # where is the border? the field's lines run one cell past its outermost interior
        # lines; a frame line is where the other lines stop
        ext = [self._extension(Hl, near, axis, at, out, lo, hi)
               for axis, at, out, lo, hi in ((0, i0, -1, j0, j1), (0, i1, 1, j0, j1), (1, j0, -1, i0, i1),
                                             (1, j1, 1, i0, i1))]
        trace["extension"] = ext
        steps, n = self._border_steps(ext, i1 - i0, j1 - j0)
        start_c, start_r = i0 - steps[0], j0 - steps[2]
        H = Hl @ np.array([[1.0, 0, start_c], [0, 1.0, start_r], [0, 0, 1.0]])
        src = nodes - [start_c, start_r]
        corners = _apply(H, np.array([[0, 0], [n, 0], [n, n], [0, n]], float))
        side = math.sqrt(max(cv2.contourArea(corners.astype(np.float32)), 0.0))
        if side < 0.1 * diag:
            raise NoBoardError("the grid found is too small to read")
        # a camera tilted up to ~35 deg scales the field's cells by at most ~2.5 from one
        # corner to another; a lattice that implies more was extrapolated from wrong lines
        cells = np.array([[c, r] for c in (0, n - 1) for r in (0, n - 1)], float)
        areas = [abs(cv2.contourArea(_apply(H, q + [[0, 0], [1, 0], [1, 1], [0, 1]]).astype(np.float32)))
                 for q in cells]
        if max(areas) > 3.0 * max(min(areas), 1e-9):
            raise NoBoardError(f"the lattice implies cells {max(areas) / max(min(areas), 1e-9):.1f} x larger "
                               "in one corner than in another; no camera tilts that much")
        _, coverage = self._line_contrast(d, H, n)
        if coverage < 0.6:
            raise NoBoardError(f"only {coverage:.0%} of the field's interior lines carry ink; not a grid")
        frame = (steps[0] == 0, steps[1] == 0, steps[2] == 0, steps[3] == 0)
        return H, err, len(src), frame, n

    def _field_lines(self, fam: list[_Line], d: np.ndarray, floor: float, tol: float) -> list[_Line]:
        """The field's lines of one family, ordered across.

        Pieces of one hand-drawn line (it bends, so its pieces fit slightly different lines)
        sit at nearly the same place across the family: they are joined and refitted; then
        lines with less than 45 % of the best line's ink are dropped (symbol strokes).
        """
        nrm = np.mean([ln.normal if ln.normal @ fam[0].normal >= 0 else -ln.normal for ln in fam], axis=0)
        nrm /= np.linalg.norm(nrm)
        mid = np.mean([0.5 * (ln.p0 + ln.p1) for ln in fam], axis=0)
        pos = []
        for ln in fam:
            den = float(ln.normal @ nrm)
            pos.append((ln.rho - float(ln.normal @ mid)) / den if abs(den) > 1e-6 else 0.0)
        order = np.argsort(pos)
        fam, pos = [fam[i] for i in order], [pos[i] for i in order]
        longest = max(ln.length for ln in fam)
        long_pos = [p for ln, p in zip(fam, pos) if ln.length >= 0.45 * longest]
        typical = _median(np.diff(long_pos)) if len(long_pos) > 1 else longest
        gaps = np.diff(long_pos)
        if len(gaps) > 1 and (gaps > 0.35 * typical).sum() >= 1:  # double detections shrink the median
            typical = _median(gaps[gaps > 0.35 * typical])
        groups: list[list[_Line]] = []
        last = -math.inf
        for ln, p in zip(fam, pos):
            if groups and p - last < 0.35 * typical:
                groups[-1].append(ln)
            else:
                groups.append([ln])
            last = p
        merged = []
        for g in groups:
            if len(g) == 1:
                merged.append(g[0])
                continue
            base = max(g, key=lambda ln: ln.length)
            iv = [tuple(sorted(((ln.p0 - base.p0) @ base.direction, (ln.p1 - base.p0) @ base.direction)))
                  for ln in g]
            cover = _union_length(iv)  # ink length: the union of the pieces' extents
            t0, t1 = min(a for a, _ in iv), max(b for _, b in iv)
            span = _Line(base.theta, base.rho, float(cover), base.p0 + t0 * base.direction,
                         base.p0 + t1 * base.direction)
            fit = _refit([span], d, floor, 2 * tol)[0]
            merged.append(_Line(fit.theta, fit.rho, float(cover), fit.p0, fit.p1) if fit else span)
        best = max(ln.length for ln in merged)
        return [ln for ln in merged if ln.length >= 0.45 * best]

    def _lattices(self, cols: list[_Line], rows: list[_Line]):  # type: ignore[no-untyped-def]
        """Lattices fitted to the line crossings, best first: ``(H, nodes, rms)``, H taking
        lattice coordinates (cells) to pixels, ``nodes`` the integer lattice points that
        crossings support and ``rms`` the crossings' distance from them (px).

        Every cell made by two neighbouring column lines and two neighbouring row lines is a
        hypothesis; it predicts the whole lattice, and scores by the crossings that fall on
        lattice points (within a fifth of a cell) less half the lattice points inside the
        supported range that no crossing supports - so a stray line between two real ones,
        which would halve the spacing, loses. The cells around the middle come first (stray
        lines sit at the ends); each hypothesis is refined on its inliers.
        """
        x, y, ok, _, _ = _crossings(cols, rows)
        cross = np.stack([x, y], -1)  # (cols, rows, 2)
        P = cross[ok]
        if len(P) < 4:
            raise NoBoardError("the grid lines do not intersect")
        unit = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
        mid_a = range(max(0, (len(cols) - 1) // 2 - 1), min(len(cols) - 1, (len(cols) - 1) // 2 + 2))
        mid_b = range(max(0, (len(rows) - 1) // 2 - 1), min(len(rows) - 1, (len(rows) - 1) // 2 + 2))
        middle = [(a, b) for a in mid_a for b in mid_b]
        rest = [(a, b) for a in range(len(cols) - 1) for b in range(len(rows) - 1) if (a, b) not in middle]
        seen: list[np.ndarray] = []
        for group in (middle, rest):
            H0s = []
            for a, b in group:
                corners = ((a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1))
                if not all(ok[c] for c in corners):
                    continue
                try:
                    H0 = cv2.getPerspectiveTransform(unit, np.array([cross[c] for c in corners], np.float32)
                                                     ).astype(np.float64)
                except cv2.error:
                    continue
                if abs(np.linalg.det(H0)) > 1e-12:
                    H0s.append(H0)
            if not H0s:
                continue
            scores = self._score_lattices(np.linalg.inv(np.array(H0s)), P)
            for k in np.argsort(-scores, kind="stable"):
                if not np.isfinite(scores[k]):
                    break
                fit = self._refine_lattice(H0s[k], P)
                if fit is None:
                    continue
                key = np.rint(_apply(fit[0], np.array([[0.0, 0.0], [1.0, 1.0]]))).ravel()
                if any(np.abs(key - prev).max() < 3 for prev in seen):  # the same lattice again
                    continue
                seen.append(key)
                yield fit

    @staticmethod
    def _refine_lattice(H: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
        for _ in range(2):  # refine on the inliers, re-assign
            L = _apply(np.linalg.inv(H), P)
            R = np.rint(L)
            inl = np.all(np.abs(L - R) < 0.2, axis=1)
            if inl.sum() < 4:
                break
            Hn, _ = cv2.findHomography(R[inl], P[inl], 0)
            if Hn is None or not np.all(np.isfinite(Hn)):
                break
            H = Hn
        L = _apply(np.linalg.inv(H), P)
        R = np.rint(L)
        inl = np.all(np.abs(L - R) < 0.2, axis=1)
        if inl.sum() < 4:
            return None
        ij = R[inl].astype(np.int64)
        nodes = np.array(sorted(set(map(tuple, ij.tolist()))), dtype=np.int64)
        res = _apply(H, R[inl]) - P[inl]
        return H, nodes, float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))

    @staticmethod
    def _score_lattices(Hinv: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Scores of lattice hypotheses ``Hinv`` ``(G, 3, 3)`` (px -> cells) against the line
        crossings ``P``: the distinct lattice points that crossings fall on (within 0.2 of a
        cell) less half the unsupported points of the box they span; -inf for a hypothesis
        with fewer than 4 such crossings, a box over 9 lattice lines, or points at infinity."""
        Lh = np.concatenate([P, np.ones((len(P), 1))], axis=1) @ Hinv.transpose(0, 2, 1)  # (G, N, 3)
        with np.errstate(divide="ignore", invalid="ignore"):
            L = Lh[..., :2] / Lh[..., 2:3]
        finite = np.isfinite(L).all(axis=(1, 2))
        L = np.where(finite[:, None, None], L, 0.0)
        R = np.rint(L)
        inl = np.all(np.abs(L - R) < 0.2, axis=2)
        big = np.iinfo(np.int64).max // 4
        ij = R.astype(np.int64)
        lo = np.where(inl[..., None], ij, big).min(axis=1)
        hi = np.where(inl[..., None], ij, -big).max(axis=1)
        ok = finite & (inl.sum(axis=1) >= 4)
        ok &= np.where(ok[:, None], hi - lo, 0).max(axis=1) <= 8
        rel = np.where(ok[:, None, None], ij - lo[:, None, :], 0)
        codes = np.sort(np.where(inl, rel[..., 0] * 16 + rel[..., 1], big), axis=1)
        distinct = ((codes[:, 1:] != codes[:, :-1]) & (codes[:, 1:] != big)).sum(axis=1) + (codes[:, 0] != big)
        box = np.where(ok[:, None], hi - lo + 1, 0).prod(axis=1)
        return np.where(ok, distinct - 0.5 * (box - distinct), -np.inf)

    def _border_steps(self, ext: list[float], span_c: int, span_r: int) -> tuple[list[int], int]:
        """Cells from the outermost lines to the border, per side (left, right, top, bottom),
        and the board size. Each side's run of the other lines past the outermost one says
        how many (0: a frame line; about 1: the last interior line); when a run sits between
        two counts, the count that makes a square board of an allowed size wins."""
        options = []
        for e in ext:
            near = {0} if e < 0.35 else {max(1, math.floor(e)), max(1, math.ceil(e))} if e >= 0.65 else {0, 1}
            options.append(sorted(near, key=lambda k: abs(k - e)))
        sizes = (self.size,) if self.size is not None else (3, 5)
        best: tuple[float, list[int], int] | None = None
        for a in options[0]:
            for b in options[1]:
                for c in options[2]:
                    for d in options[3]:
                        nc, nr = span_c + a + b, span_r + c + d
                        if nc != nr or nc not in sizes:
                            continue
                        cost = sum(abs(k - e) for k, e in zip((a, b, c, d), ext))
                        if best is None or cost < best[0]:
                            best = (cost, [a, b, c, d], nc)
        if best is None:
            guess = [o[0] for o in options]
            nc, nr = span_c + guess[0] + guess[1], span_r + guess[2] + guess[3]
            want = f"{self.size} x {self.size}" if self.size else "3 x 3 or 5 x 5"
            raise NoBoardError(f"a field of {nc} x {nr} cells found; expected {want}")
        return best[1], best[2]

    @staticmethod
    def _lattice_ink(H: np.ndarray, near: np.ndarray, axis: int, ks: np.ndarray, t: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Ink (``near``) at lattice points ``(ks, t)`` (axis 0: column lines ``u = ks``,
        ``v = t``; 1: row lines) and which of them lie in the image: two ``(len(ks), len(t))``
        bool arrays (no ink outside the image)."""
        h, w = near.shape
        u, v = np.broadcast_arrays(ks[:, None], t[None, :])
        pts = np.stack([u, v] if axis == 0 else [v, u], -1).reshape(-1, 2).astype(np.float64)
        px = np.rint(_apply(H, pts)).astype(np.intp)
        inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
        hit = np.zeros(len(px), bool)
        hit[inside] = near[px[inside, 1], px[inside, 0]] > 0
        return hit.reshape(u.shape), inside.reshape(u.shape)

    @classmethod
    def _drawn_range(cls, H: np.ndarray, near: np.ndarray, axis: int, lo: int, hi: int, a: int, b: int
                     ) -> tuple[int, int]:
        """Trim ``lo..hi`` (lattice lines along ``axis``; 0 = columns) to the outermost lines
        that carry ink along at least 60 % of their length between ``a`` and ``b``."""
        t = np.linspace(a, b, 12 * max(1, b - a) + 1)
        t = t[np.abs(t - np.rint(t)) > 0.15]  # away from the crossings, which any line has
        ks = np.arange(int(lo), int(hi) + 1)
        hit, inside = cls._lattice_ink(H, near, axis, ks, t)
        seen = inside.sum(axis=1)
        drawn = (seen > 0) & (hit.sum(axis=1) / np.maximum(seen, 1) >= 0.6)
        first = np.flatnonzero(drawn[:-1])  # the first drawn line, keeping at least one line
        lo_i = int(first[0]) if len(first) else len(ks) - 1
        last = np.flatnonzero(drawn[lo_i + 1:])
        hi_i = lo_i + 1 + int(last[-1]) if len(last) else lo_i
        return int(ks[lo_i]), int(ks[hi_i])

    @classmethod
    def _extension(cls, H: np.ndarray, near: np.ndarray, axis: int, at: int, outwards: int, lo: int, hi: int
                   ) -> float:
        """How far (in cells) the lattice lines that cross lattice line ``at`` run on past it
        as ink, going ``outwards`` (-1 or +1): the median over those lines (``lo..hi``) of
        the ink run from the crossing; two misses in a row end a run.

        ``axis`` 0: the column line ``u = at``, crossed by the rows; 1: the row line ``v = at``.
        """
        if hi < lo:
            return 0.0
        t = np.arange(0.1, 2.6, 0.1)
        # the crossing lines run along the other axis, at their own index k
        hit, _ = cls._lattice_ink(H, near, 1 - axis, np.arange(int(lo), int(hi) + 1), at + outwards * t)
        miss = ~hit[:, :-1] & ~hit[:, 1:]
        runs = np.where(miss.any(axis=1), t[miss.argmax(axis=1)] - 0.1, t[-1])
        return _median(runs)

    def _line_contrast(self, d: np.ndarray, H: np.ndarray, n: int) -> tuple[float, float]:
        """Median peak darkness along the interior grid lines (the contrast of real ink) and
        the share of the lines' length that carries ink at all."""
        t = np.linspace(0.15, n - 0.15, 6 * n)
        pts = []
        for i in range(1, n):
            pts.append(np.stack([np.full_like(t, i), t], -1))
            pts.append(np.stack([t, np.full_like(t, i)], -1))
        px = np.rint(_apply(H, np.concatenate(pts))).astype(int)
        hgt, wid = d.shape
        ok = (px[:, 0] >= 0) & (px[:, 0] < wid) & (px[:, 1] >= 0) & (px[:, 1] < hgt)
        if not ok.any():
            return 0.5, 0.0
        # the darkest pixel within 2 px of each sample (a 5 x 5 dilation, at the samples only)
        off = np.arange(-2, 3)
        ys = np.clip(px[ok, 1, None, None] + off[None, :, None], 0, hgt - 1)
        xs = np.clip(px[ok, 0, None, None] + off[None, None, :], 0, wid - 1)
        vals = d[ys, xs].max(axis=(1, 2))
        floor = 0.15
        on = vals[vals > floor]
        return (_median(on) if len(on) else floor), float(np.mean(vals > floor)) * float(ok.mean())

    # -- cells -----------------------------------------------------------------------
    def _read_cells(self, d: np.ndarray, H: np.ndarray, n: int, line_ref: float) -> tuple[np.ndarray, np.ndarray]:
        s = self.cell_px
        o = s // 2  # half a cell of margin all round: marks that cross the border stay whole
        # rectified px -> grid cells, with the margin
        M = H @ np.array([[1.0 / s, 0, -o / s], [0, 1.0 / s, -o / s], [0, 0, 1.0]])
        side = n * s + 2 * o
        rect = cv2.warpPerspective(d, M, (side, side), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                   borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        rect = _remove_grid_lines(rect, n, s, o, max(0.12, 0.4 * line_ref))
        feats = board_features(rect, n, s, o, max(0.1, 0.25 * line_ref), 0.25 * line_ref)
        return _probabilities(feats, line_ref), feats


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


def debug_image(image: object, reading: BoardReading | None, trace: dict[str, object],
                error: str | None = None) -> np.ndarray:
    """An RGB picture of what the reader did: the straight lines it found (columns red,
    rows blue, others grey), the lattice crossings it used, the field it fitted (green) and
    each cell's call with its confidence - or, without a board, the reason in red."""
    img = _as_rgb(image).copy()
    k = 1.0 / float(trace.get("scale", 1.0))  # type: ignore[arg-type]
    for key, colour in (("lines", (150, 150, 150)), ("cols", (255, 40, 40)), ("rows", (40, 90, 255))):
        for ln in trace.get(key, []):  # type: ignore[union-attr]
            cv2.line(img, tuple(np.rint(ln.p0 * k).astype(int)), tuple(np.rint(ln.p1 * k).astype(int)), colour, 2,
                     cv2.LINE_AA)
    if "lattice" in trace and "nodes" in trace:
        for p in _apply(trace["lattice"], trace["nodes"].astype(float)) * k:  # type: ignore[union-attr, arg-type]
            cv2.circle(img, tuple(np.rint(p).astype(int)), 4, (255, 200, 0), -1, cv2.LINE_AA)
    if reading is not None:
        n, H = reading.n, reading.homography
        for i in range(n + 1):
            for a, b in (((i, 0), (i, n)), ((0, i), (n, i))):
                p = np.rint(_apply(H, np.array([a, b], float))).astype(int)
                cv2.line(img, tuple(p[0]), tuple(p[1]), (0, 200, 0), 1, cv2.LINE_AA)
        for r in range(n):
            for c in range(n):
                p = np.rint(_apply(H, np.array([[c + 0.5, r + 0.5]]))).astype(int)[0]
                label = f"{_SYMBOL[int(reading.cells[r, c])]}{reading.confidence[r, c]:.2f}"
                cv2.putText(img, label, (p[0] - 16, p[1] + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 120, 0), 1,
                            cv2.LINE_AA)
    if error:
        cv2.putText(img, error[:90], (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (220, 0, 0), 1, cv2.LINE_AA)
    return img


class ThresholdReader:
    """Seed 003's camera rule, kept as the baseline: in each of ``n x n`` fixed image regions
    (calibrated once, for a camera that never moves), the share of pixels darker than
    ``grey_level`` (of 255); above ``min_share`` the cell is "filled". It cannot tell X
    from O: as in the thesis, filled cells that are not the arm's own (``own``) are the
    opponent's.

    Args:
        regions: ``(n * n, 4, 2)`` quadrilaterals (px), row-major from the top-left cell.
        grey_level: the thesis's threshold (80).
        min_share: share of dark pixels that makes a cell filled.
    """

    def __init__(self, regions: object, grey_level: float = 80.0, min_share: float = 0.03) -> None:
        reg = np.asarray(regions, dtype=np.float64)
        n = int(round(math.sqrt(reg.shape[0]))) if reg.ndim == 3 else 0
        if reg.ndim != 3 or reg.shape[1:] != (4, 2) or n * n != reg.shape[0]:
            raise VisionError(f"regions of shape {reg.shape}; expected (n*n, 4, 2) quadrilaterals")
        self.regions, self.n = reg, n
        self.grey_level, self.min_share = float(grey_level), float(min_share)

    @classmethod
    def calibrated(cls, homography: object, n: int, inset: float = 0.2, **kw: float) -> ThresholdReader:
        """Regions from a one-time calibration: ``homography`` maps grid cells to image px
        (as :attr:`BoardReading.homography`); each region is its cell shrunk by ``inset``."""
        H = np.asarray(homography, dtype=np.float64)
        regs = []
        for r in range(n):
            for c in range(n):
                q = np.array([[c + inset, r + inset], [c + 1 - inset, r + inset],
                              [c + 1 - inset, r + 1 - inset], [c + inset, r + 1 - inset]])
                regs.append(_apply(H, q))
        return cls(np.array(regs), **kw)

    def shares(self, image: object) -> np.ndarray:
        """Share of dark pixels per region, ``(n, n)``."""
        rgb = _as_rgb(image)
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        dark = (grey < self.grey_level).astype(np.uint8)
        out = np.zeros(self.n * self.n)
        mask = np.zeros_like(dark)
        for i, q in enumerate(self.regions):
            mask[...] = 0
            cv2.fillConvexPoly(mask, np.rint(q).astype(np.int32), 1)
            area = int(mask.sum())
            out[i] = float((dark & mask).sum()) / area if area else 0.0
        return out.reshape(self.n, self.n)

    def read(self, image: object, own: Sequence[tuple[int, int]] = (), own_symbol: int = X) -> np.ndarray:
        """Cells ``(n, n)``: 0 empty, else ``own_symbol`` for cells in ``own`` and the other
        symbol for every other filled cell (the thesis's "Percent-process")."""
        filled = self.shares(image) > self.min_share
        other = O if own_symbol == X else X
        cells = np.where(filled, other, EMPTY)
        for r, c in own:
            if filled[r, c]:
                cells[r, c] = own_symbol
        return cells
