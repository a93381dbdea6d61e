"""What a board reader returns: the cells (EMPTY, X, O), confidences and the homography.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .ink import _apply

__all__ = ["EMPTY", "X", "O", "UNSURE_GRID", "BoardReading"]


EMPTY, X, O = 0, 1, 2
#: A grid the arbiter gives less than this is probably wrong: of 400 rendered real-like photos
#: (seeds 20,000-20,199 and 30,000-30,199) none of the 20 readings under 0.1 was right, 30 % of
#: those at 0.1-0.3 and 99 % of those at 0.88 or more; of 120 readings of real photos (the 15 of
#: ``tests/data/real`` as taken and under seven turns and keystones) none was under 0.05.
UNSURE_GRID = 0.05
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
        grid_confidence: the grid arbiter's probability that this grid and its reading are right
            (:class:`~kinegym.vision.grid_choice.GridArbiter`; None when the reader has no arbiter).
            Learnt on rendered photos, where it is calibrated; on real photos it runs low (real
            readings right at 0.1-0.3). Under :data:`UNSURE_GRID` a reading was almost never right.
    """

    cells: np.ndarray
    confidence: np.ndarray
    probs: np.ndarray
    homography: np.ndarray
    grid_error_px: float
    grid_points: int
    frame: tuple[bool, bool, bool, bool] = (False, False, False, False)
    features: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    grid_confidence: float | None = None

    @property
    def unsure(self) -> bool:
        """Whether the arbiter gave this grid less than :data:`UNSURE_GRID` (a wrong grid is likely)."""
        return self.grid_confidence is not None and self.grid_confidence < UNSURE_GRID

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
