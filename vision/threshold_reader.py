"""Seed 003's board reader, kept as the baseline: the share of dark pixels in fixed image regions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from .errors import VisionError
from .ink import _apply, _as_rgb
from .reading import EMPTY, O, X

__all__ = ["ThresholdReader"]


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
