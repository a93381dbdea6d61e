"""Reading a hand-drawn '#' board: the cells of a grid that :mod:`~kinegym.vision.hand_grid`
found, with the '#' lines erased from the ink (:func:`erase_mask`, flicks at their tips too),
ruled paper's rules cleared, and the outer cells reaching past the field (real outer cells are
larger than the middle one)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .grid_choice import HUE_KINDS, PAGE_KINDS, SHARES, Hypothesis, same_lattice
from .grid_lines import _median
from .hand_grid import HashGrid, crossing_lattice, find_hash_grid, search_copy
from .ink import _apply, ink_colour, ink_map, noise_floor_and_top
from .page import page_apart
from .polylines import extend
from .ruling import Ruling, clear_rules

if TYPE_CHECKING:
    from .board_reader import BoardReader

__all__ = ["SearchCopy", "read_hash", "line_contrast", "erase_mask", "perspective_ratio", "affine_lattice",
           "FLICK_CELLS", "ALONG_CELLS", "TIP_CELLS", "TIP_INK", "MAX_PERSPECTIVE"]

#: The most a flick at a '#' line's tip spans (cells, its box's longer side) that
#: :func:`erase_mask` takes for the line's. Uncapped, a piece in which graph paper's rules
#: joined marks up went with the line, marks and all (stop 60: +13 -2 of 1,000 real-like photos);
#: at 0.75 a real wavy line's untraced tail (0.85 cell) stayed and read as an X.
FLICK_CELLS = 1.0

#: The circle round a '#' line's tip (cells; at least a pen width and a half) that a stroke left hanging
#: there touches. A line's trace can stop short of a curl at its end (real photos 13 and 15 turned +30
#: deg: the curl left the column line a fifth of a cell from the row line's tip and read as an X).
#: With marks beside the line kept (:func:`_goes_on`), 0.15 / 0.20 / 0.25 / 0.30 read 254 / 255 / 255
#: / 255 of the 255 real condition readings, 873 / 872 / 873 / 872 of 1,000 tuned real-like photos and
#: 257 of a fresh 300 each (a pen width and a half: 253, 873, 257; bench/README.md).
TIP_CELLS = 0.25

#: A piece at a '#' line's tip whose px lie within this much of a cell of the line's course (half of
#: them, across it) runs along the line - a stroke gone over twice - and goes with it even behind the
#: tip (:func:`_goes_on`). On 1,000 tuned real-like photos 0.10 and 0.15 read 873 boards, 0.20 and
#: 0.22 871; on a fresh 300 257, 257 and 258; none at all 873 and 256 (bench/README.md).
ALONG_CELLS = 0.15

#: Where a piece of ink at a '#' line's tip is no flick (:func:`erase_mask`), the ink there darker than
#: this share of the line's own darkness (its median along its trace) is looked at again: the same pen's
#: stroke. Paler ink - graph paper's rules, most of all - had joined a flick up into a piece too large to
#: go with the line, which stayed and read as a mark in an outer cell (stop 71: the 15 real photos on
#: graph paper in black marker, cut off at the top, 12 -> 14 of 15; bench/README.md).
TIP_INK = 0.5

#: the most a '#' lattice's far field corner may lie deeper than its near one (:func:`perspective_ratio`);
#: beyond it the lines' convergence is the hand's and the cells are read on the crossings' affine
#: fit. A camera tilted 35 deg over a board filling most of the frame gives about 1.5. On 400
#: real-like photos 2.5 gained 3 boards and lost 1, 2.0 gained 5 and lost 3, 1.5 gained 7 and lost
#: 7: the cell network learnt projectively rectified cells, and only far past a camera's
#: perspective is the projective lattice's outer row mostly wrong.
MAX_PERSPECTIVE = 2.5


def _darkest_near(d: np.ndarray, px: np.ndarray) -> np.ndarray:
    """The darkest value within 2 px of each point ``px`` ``(N, 2)`` (x, y) of the map ``d``:
    a 5 x 5 dilation evaluated at those points only."""
    h, w = d.shape
    off = np.arange(-2, 3)
    ys = np.clip(px[:, 1, None, None] + off[None, :, None], 0, h - 1)
    xs = np.clip(px[:, 0, None, None] + off[None, None, :], 0, w - 1)
    return d[ys, xs].max(axis=(1, 2))


def line_contrast(d: np.ndarray, H: np.ndarray, n: int) -> tuple[float, float]:
    """Median peak darkness along the interior grid lines of the ``n`` x ``n`` field ``H`` (cells to
    px of the ink map ``d``): the contrast of real ink; and the share of the lines' length that
    carries ink at all."""
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
    vals = _darkest_near(d, px[ok])
    floor = 0.15
    on = vals[vals > floor]
    return (_median(on) if len(on) else floor), float(np.mean(vals > floor)) * float(ok.mean())


@dataclass
class SearchCopy:
    """The copy of a photo the '#' is sought on (:func:`~kinegym.vision.hand_grid.search_copy`):
    its ``rgb``, ink map ``d`` and ink colour, and (when first asked) its page apart from the
    rest of the photo (:func:`~kinegym.vision.page.page_apart`)."""

    rgb: np.ndarray
    d: np.ndarray
    colour: np.ndarray
    ruled: bool = False  # a '#' was found on ruled paper (:attr:`~kinegym.vision.hand_grid.HashGrid.rules`)
    #: the rulings each ink level's search on the whole copy found (``find_hash_grid``'s memo)
    rulings: dict[tuple[float, bool], list[Ruling]] = field(default_factory=dict)

    @classmethod
    def of(cls, working: np.ndarray, photo: np.ndarray | None) -> SearchCopy:
        """The search copy of the reader's ``working`` copy of a ``photo`` (None: not its own means)."""
        small = search_copy(working, photo)
        st = max(6.0, math.hypot(*small.shape[:2]) / 100)
        return cls(small, ink_map(small, stroke_px=st), ink_colour(small, stroke_px=st))

    @cached_property
    def page(self) -> np.ndarray | None:
        return page_apart(self.rgb)

    @cached_property
    def levels(self) -> tuple[float, float]:
        """The ink map's noise floor and strong ink (:func:`~kinegym.vision.ink.noise_floor_and_top`),
        measured once for every kind's search."""
        return noise_floor_and_top(self.d)


def read_hash(reader: BoardReader, rgb: np.ndarray, d: np.ndarray, trace: dict[str, object],
              hashed: SearchCopy, kind: str, made: Sequence[Hypothesis] = ()) -> Hypothesis | None:
    """The board as a hand-drawn '#' (:mod:`~kinegym.vision.hand_grid`): the grid found, at
    the ink share of ``kind`` (:data:`~kinegym.vision.grid_choice.SHARES`), in ``hashed`` - a copy of the photo
    :data:`~kinegym.vision.hand_grid.GRID_SIDE_PX` on its longer side (the same scale
    whatever the camera; :func:`~kinegym.vision.hand_grid.search_copy`), its ink map and
    colour - its lines erased from the ink ``d``, the cells read with the outer cells
    reaching past the field. None, before any cell is read, when the grid is one of the '#'s
    ``made``; a straight field on the same lattice is read again the '#' way (its cells with the
    photo's own ink level and the larger outer cells), and the arbiter weighs both readings.
    A page kind seeks the '#' in the ink on the page alone (None when the page is not apart from
    the rest of the photo: nothing new to seek); a hue kind in the ink not of ruled paper's colour
    (:func:`~kinegym.vision.hand_grid.find_hash_grid`'s ``other_colour``). A '#' found on ruled
    paper marks ``hashed.ruled``."""
    h, w = d.shape
    dg, colour = hashed.d, hashed.colour
    if kind in PAGE_KINDS:
        if hashed.page is None:
            return None
        dg = np.where(hashed.page > 0, dg, np.float32(0.0))
    sizes = (reader.size,) if reader.size is not None else (3, 5)
    page = kind in PAGE_KINDS  # (the page's map is another: its own rulings and levels)
    grid = find_hash_grid(dg, sizes, colour, share=SHARES[kind], other_colour=kind in HUE_KINDS,
                          rulings=None if page else hashed.rulings, levels=None if page else hashed.levels)
    hashed.ruled |= grid.rules is not None
    fx, fy = w / dg.shape[1], h / dg.shape[0]
    to_d = np.array([[fx, 0, 0.5 * (fx - 1)], [0, fy, 0.5 * (fy - 1)], [0, 0, 1.0]])
    found = to_d @ grid.H
    if any(m.n == grid.n and m.kind != "straight" and same_lattice(found, m.found, grid.n) for m in made):
        return None
    # lines converging more than a camera's perspective does are the hand's: the outer cells
    # from the crossings' affine fit (a projective one runs off towards its horizon there)
    H = found if perspective_ratio(grid.H, grid.n) <= MAX_PERSPECTIVE else to_d @ affine_lattice(grid)
    erase = cv2.resize(erase_mask(grid, dg), (w, h), interpolation=cv2.INTER_NEAREST)
    clean = d.copy()
    clean[erase > 0] = 0.0
    if grid.rules is not None:  # ruled paper: what is no darker than its rules, on a rule, is a rule
        clear_rules(clean, d, rgb, grid.rules, grid.rule_hue, erase > 0)
    # the contrast of real ink: the lines' darkness along their traces
    pts = np.concatenate([tr.dense for tr in grid.cols + grid.rows]) @ to_d[:2, :2].T + to_d[:2, 2]
    line_ref = max(float(np.median(_darkest_near(d, np.rint(pts).astype(np.intp)))), 1e-3)
    floor = 0.6 * grid.threshold
    trace["hash"] = grid
    trace["hash_to_px"] = to_d
    # a cell of the photo spans several rectified px: a thin pen would alias into dots
    # there, so each px takes the darkest of the photo's px it stands for (a max filter)
    step = float(np.median(np.hypot(*np.diff(grid.crossings, axis=0).reshape(-1, 2).T))) * fx
    k = int(step / reader.cell_px)
    if k >= 2:
        clean = cv2.dilate(clean, np.ones((k, k), np.uint8))
    probs, feats, inputs = reader._read_cells(clean, H, grid.n, line_ref, floor=floor, margin_cells=1.0, outer=0.9)
    trace["cell_inputs"] = inputs
    npts = int(grid.crossings.shape[0] * grid.crossings.shape[1])
    coverage = line_contrast(d, H, grid.n)[1]
    return Hypothesis("hash", H, grid.error_px * fx, npts, (False, False, False, False), grid.n, probs, feats,
                      inputs, line_ref, coverage, grid.score / (grid.n - 1) ** 2, math.hypot(h, w),
                      lattice=None if H is found else found)


def perspective_ratio(H: np.ndarray, n: int) -> float:
    """How much farther the far corner of the ``n`` x ``n`` field under ``H`` (cells to px) lies than
    the near one, as the lattice's projective depth (its third row) says: 1 for an affine lattice,
    inf when the field reaches the lattice's horizon."""
    w = np.array([[0, 0, 1], [n, 0, 1], [0, n, 1], [n, n, 1]], np.float64) @ H[2]
    return float(w.max() / w.min()) if w.min() > 0 or w.max() < 0 else math.inf


def affine_lattice(grid: HashGrid) -> np.ndarray:
    """The least-squares affine map (3 x 3) of the lattice coordinates of ``grid``'s crossings
    (the '#' lines at 1..n-1) to their px."""
    lat = crossing_lattice(grid.n)
    A = np.linalg.lstsq(np.c_[lat, np.ones(len(lat))], grid.crossings.reshape(-1, 2).astype(np.float64), rcond=None)[0]
    return np.vstack([A.T, [0.0, 0.0, 1.0]])


def erase_mask(grid: HashGrid, d: np.ndarray) -> np.ndarray:
    """uint8 mask (the shape of ``d``, the map the grid was found on) of the chosen lines'
    ink: along their dense traces, a pen width and a half either side, plus any stroke left
    hanging at a line's tip, touching a circle of :data:`TIP_CELLS` of a cell round it (a
    hand-drawn line often ends in a hook or a flick that leaves its straight course, and its trace
    can stop short of it; left in, it would read as a mark in an outer cell). A flick is
    elongated, no more than :data:`FLICK_CELLS` of a cell across, and goes on from the tip or
    runs along the line (:func:`_goes_on`): a larger piece at a tip is a mark, or marks joined up
    by graph paper's rules, and an elongated piece beside the line, behind its tip, is a narrow X
    drawn against the line's end; both stay. Where a piece at a tip is no flick, the ink there above
    :data:`TIP_INK` of the line's own darkness is looked at again (:func:`_pieces_at`): paler rules
    may have joined a flick up into something larger."""
    out = np.zeros(d.shape, np.uint8)
    thick = max(3, int(round(2.0 * grid.stroke_px + 3.0)))
    tips = np.zeros(d.shape, np.uint8)
    g = grid.crossings
    cell = float(np.median(np.concatenate([np.hypot(*np.diff(g, axis=k).reshape(-1, 2).T) for k in (0, 1)])))
    ends = []  # each line's two tips: (tip, its outward unit direction)
    dark = []  # the darkness of each tip's line (the median along its trace)
    tip_px = int(max(thick + 2, TIP_CELLS * cell))
    for tr in grid.cols + grid.rows:
        p = np.rint(extend(tr.dense, 0.5 * grid.stroke_px) * 4).astype(np.int32)
        cv2.polylines(out, [p], False, 1, thick, cv2.LINE_8, shift=2)
        q = np.rint(tr.dense).astype(np.intp)
        line = float(np.median(d[np.clip(q[:, 1], 0, d.shape[0] - 1), np.clip(q[:, 0], 0, d.shape[1] - 1)]))
        for from_tip in (tr.dense, tr.dense[::-1]):
            ends.append(_tip_and_direction(from_tip, 0.3 * cell))
            dark.append(line)
            cv2.circle(tips, tuple(int(v) for v in np.rint(ends[-1][0])), tip_px, 1, -1)
    lines = out.copy()  # (the pieces are sought beside the traces alone)
    low = 0.6 * grid.threshold
    again: set[int] = set()  # the tips where a piece stayed
    for ys, xs in _pieces_at(d, lines, tips, low):
        if _is_flick(xs, ys, ends, tip_px, cell):
            out[ys, xs] = 1
        else:
            again.update(i for i, (tip, _) in enumerate(ends)
                         if float(np.min(np.hypot(xs - tip[0], ys - tip[1]))) <= tip_px)
    for level in sorted({TIP_INK * dark[i] for i in again if TIP_INK * dark[i] > low}):
        at_these = np.zeros_like(tips)
        for i in again:
            if TIP_INK * dark[i] == level:
                cv2.circle(at_these, tuple(int(v) for v in np.rint(ends[i][0])), tip_px, 1, -1)
        for ys, xs in _pieces_at(d, lines, at_these, level):
            if _is_flick(xs, ys, ends, tip_px, cell):
                out[ys, xs] = 1
    return out


def _pieces_at(d: np.ndarray, lines: np.ndarray, tips: np.ndarray, level: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pieces of ink (``d`` above ``level``, off the ``lines`` mask) that touch the ``tips`` mask:
    ``(ys, xs)`` px of each, in label order."""
    left = ((d > level) & (lines == 0)).astype(np.uint8)
    n_lab, lab = cv2.connectedComponents(left, connectivity=8)
    touching = np.unique(lab[(tips > 0) & (left > 0)])
    touching = touching[touching > 0]
    wanted = np.zeros(n_lab, bool)
    wanted[touching] = True
    at = np.flatnonzero(wanted[lab.ravel()])  # the touching pieces' px in one pass, row by row
    of = lab.ravel()[at]
    return [np.divmod(at[of == c], d.shape[1]) for c in touching]


def _is_flick(xs: np.ndarray, ys: np.ndarray, ends: list[tuple[np.ndarray, np.ndarray]], tip_px: int,
              cell: float) -> bool:
    """Whether the piece at px ``xs``, ``ys`` touching a line's tip goes with the line
    (:func:`erase_mask`): a speck, or elongated, at most :data:`FLICK_CELLS` across and going on."""
    if len(xs) < 3:
        return True
    if max(xs.max() - xs.min(), ys.max() - ys.min()) > FLICK_CELLS * cell:
        return False  # too large for a flick
    ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(np.float64)))
    return bool(ev[1] > 5.0 * max(ev[0], 1e-6) and _goes_on(xs, ys, ends, tip_px + 1.5, cell))


def _tip_and_direction(from_tip: np.ndarray, back: float) -> tuple[np.ndarray, np.ndarray]:
    """A traced line's tip (the first point of ``from_tip``, its trace read from that tip) and the
    unit direction in which the line leaves it, from the point ``back`` px along the trace (the
    line's last stretch, not one wavy step)."""
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(from_tip, axis=0).T))])
    u = from_tip[0] - from_tip[min(int(np.searchsorted(along, back)), len(from_tip) - 1)]
    return from_tip[0], u / max(float(np.hypot(*u)), 1e-9)


def _goes_on(xs: np.ndarray, ys: np.ndarray, ends: list[tuple[np.ndarray, np.ndarray]], near: float,
             cell: float) -> bool:
    """Whether the piece of ink at px ``xs``, ``ys`` goes on from a line's tip that it touches (within
    ``near`` px; ``ends``: (tip, outward direction) of each line): its px lie ahead of the tip on
    the whole, or along the line (half of them within :data:`ALONG_CELLS` of a cell of its course,
    a stroke gone over twice). A piece beside the line behind its tip - a mark drawn against the
    line's end - does not."""
    pts = np.stack([xs, ys], axis=1).astype(np.float64)
    for tip, u in ends:
        rel = pts - tip
        if float(np.min(np.hypot(rel[:, 0], rel[:, 1]))) > near:
            continue
        ahead, aside = rel @ u, np.abs(rel @ np.array([-u[1], u[0]]))
        if float(ahead.mean()) > 0.0 or float(np.median(aside)) < ALONG_CELLS * cell:
            return True
    return False
