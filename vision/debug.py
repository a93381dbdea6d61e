"""A picture of what the board reader did: lines, lattice crossings, the fitted field, each cell's call.
"""

from __future__ import annotations

import cv2
import numpy as np

from .ink import _apply, _as_rgb
from .reading import _SYMBOL, BoardReading

__all__ = ["debug_image"]


def debug_image(image: object, reading: BoardReading | None, trace: dict[str, object],
                error: str | None = None) -> np.ndarray:
    """An RGB picture of what the reader did: the straight lines it found (columns red,
    rows blue, others grey), the lattice crossings it used, the field it fitted (green) and
    each cell's call with its confidence (orange with a star where the count rule called the cell
    otherwise than its own most probable call), the grid's confidence and the kind of grid
    hypothesis read at the top left (red: an unsure grid) - or, without a board, the reason in red. A
    reading taken from a crop (:mod:`~kinegym.vision.zoom`) is drawn where the crop lies (``trace["offset"]``)."""
    img = _as_rgb(image).copy()
    k = 1.0 / float(trace.get("scale", 1.0))  # type: ignore[arg-type]
    o = np.asarray(trace.get("offset", (0.0, 0.0)), np.float64)  # a crop's corner (a second look's reading)
    for key, colour in (("lines", (150, 150, 150)), ("cols", (255, 40, 40)), ("rows", (40, 90, 255))):
        for ln in trace.get(key, []):  # type: ignore[union-attr]
            cv2.line(img, tuple(np.rint(ln.p0 * k + o).astype(int)), tuple(np.rint(ln.p1 * k + o).astype(int)),
                     colour, 2, cv2.LINE_AA)
    if "hash_to_image" in trace:  # a hand-drawn '#': its traced lines (columns red, rows blue)
        T = trace["hash_to_image"]
        grid = trace["hash"]
        for tracks, colour in ((grid.cols, (255, 40, 40)), (grid.rows, (40, 90, 255))):  # type: ignore[union-attr]
            for tr in tracks:
                p = np.rint((_apply(T, tr.dense) + o) * 4).astype(np.int32)  # type: ignore[arg-type]
                cv2.polylines(img, [p], False, colour, 2, cv2.LINE_AA, shift=2)
        for p in _apply(T, grid.crossings.reshape(-1, 2)) + o:  # type: ignore[union-attr, arg-type]
            cv2.circle(img, tuple(np.rint(p).astype(int)), 4, (255, 200, 0), -1, cv2.LINE_AA)
    elif "lattice" in trace and "nodes" in trace:
        for p in _apply(trace["lattice"], trace["nodes"].astype(float)) * k + o:  # type: ignore[union-attr, arg-type]
            cv2.circle(img, tuple(np.rint(p).astype(int)), 4, (255, 200, 0), -1, cv2.LINE_AA)
    if reading is not None:
        n, H = reading.n, reading.homography
        changed_cells = {tuple(rc) for rc in trace.get("count_changed", [])}  # type: ignore[attr-defined]
        for i in range(n + 1):
            for a, b in (((i, 0), (i, n)), ((0, i), (n, i))):
                p = np.rint(_apply(H, np.array([a, b], float))).astype(int)
                cv2.line(img, tuple(p[0]), tuple(p[1]), (0, 200, 0), 1, cv2.LINE_AA)
        for r in range(n):
            for c in range(n):
                p = np.rint(_apply(H, np.array([[c + 0.5, r + 0.5]]))).astype(int)[0]
                label = f"{_SYMBOL[int(reading.cells[r, c])]}{reading.confidence[r, c]:.2f}"
                changed = (r, c) in changed_cells  # called so by the count rule: orange
                cv2.putText(img, label + "*" * changed, (p[0] - 16, p[1] + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.38,
                            (230, 120, 0) if changed else (0, 120, 0), 1, cv2.LINE_AA)
    if reading is not None and reading.grid_confidence is not None:  # the arbiter's word on the grid
        unsure = reading.unsure
        kind = f" ({trace['kind']})" if "kind" in trace else ""  # the kind of grid hypothesis read
        text = f"{'unsure grid' if unsure else 'grid confidence'} {reading.grid_confidence:.2f}{kind}"
        cv2.putText(img, text, (8, 40 if error else 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5,  # under an error, if any
                    (220, 0, 0) if unsure else (0, 120, 0), 1, cv2.LINE_AA)
    if error:
        cv2.putText(img, error[:90], (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (220, 0, 0), 1, cv2.LINE_AA)
    return img
