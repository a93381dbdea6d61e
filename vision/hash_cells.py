"""Reading a hand-drawn '#' board: the cells of a grid that :mod:`~kinegym.vision.hand_grid`
found, with the '#' lines erased from the ink, ruled paper's rules cleared, and the outer cells
reaching past the field (real outer cells are larger than the middle one)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .grid_choice import Hypothesis, same_lattice
from .hand_grid import erase_mask, find_hash_grid
from .ruling import clear_rules

if TYPE_CHECKING:
    from .board_reader import BoardReader

__all__ = ["read_hash"]


def _darkest_near(d: np.ndarray, px: np.ndarray) -> np.ndarray:
    """The darkest value within 2 px of each point ``px`` ``(N, 2)`` (x, y) of the map ``d``:
    a 5 x 5 dilation evaluated at those points only."""
    h, w = d.shape
    off = np.arange(-2, 3)
    ys = np.clip(px[:, 1, None, None] + off[None, :, None], 0, h - 1)
    xs = np.clip(px[:, 0, None, None] + off[None, None, :], 0, w - 1)
    return d[ys, xs].max(axis=(1, 2))


def read_hash(reader: BoardReader, rgb: np.ndarray, d: np.ndarray, trace: dict[str, object],
               hashed: tuple[np.ndarray, np.ndarray, np.ndarray], share: float,
               made: Sequence[Hypothesis] = ()) -> Hypothesis | None:
    """The board as a hand-drawn '#' (:mod:`~kinegym.vision.hand_grid`): the grid found, at
    ink ``share``, in ``hashed`` - a copy of the photo
    :data:`~kinegym.vision.hand_grid.GRID_SIDE_PX` on its longer side (the same scale
    whatever the camera; :func:`~kinegym.vision.hand_grid.search_copy`), its ink map and
    colour - its lines erased from the ink ``d``, the cells read with the outer cells
    reaching past the field. None, before any cell is read, when the grid is one of ``made``."""
    h, w = d.shape
    _, dg, colour = hashed
    sizes = (reader.size,) if reader.size is not None else (3, 5)
    grid = find_hash_grid(dg, sizes, colour, share=share)
    fx, fy = w / dg.shape[1], h / dg.shape[0]
    to_d = np.array([[fx, 0, 0.5 * (fx - 1)], [0, fy, 0.5 * (fy - 1)], [0, 0, 1.0]])
    H = to_d @ grid.H
    if any(m.n == grid.n and same_lattice(H, m.H, grid.n) for m in made):
        return None
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
    coverage = reader._line_contrast(d, H, grid.n)[1]
    return Hypothesis("hash", H, grid.error_px * fx, npts, (False, False, False, False), grid.n, probs, feats,
                      inputs, line_ref, coverage, grid.score / (grid.n - 1) ** 2, math.hypot(h, w))

