"""A second look: a board read unsure whose field is small in the photo is read again on a crop
around it.

The reader works on one copy of the photo whatever its size (:mod:`~kinegym.vision.board_reader`:
800 px for the cells, 480 px for the '#'), so a board that fills a small part of the frame - a
page on a desk, a phone held far off - is read from few px: thin lines break, small marks fade.
When the grid arbiter is unsure of the reading (its probability under the accept level) and the
field spans less than :data:`ZOOM_FIELD` of the photo's shorter side, :func:`second_look` crops the
photo to the field and :data:`ZOOM_MARGIN` of its side around it (the outer cells and the lines'
arms) and reads the crop as a photo of its own; the more probable reading of the two is kept, its
homography taken back to the photo's px. A crop holds less of what misled the first reading too
(a table's edge, a second grid, stray strokes).

Stop 68 (``bench/README.md``, "A second look"): on the 1,000 real-like photos tuned on 876 -> 884
boards, on a fresh 300 257 -> 259; the real photos, whose boards fill their frames, are never
cropped.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from .errors import NoBoardError
from .ink import _apply
from .reading import BoardReading

__all__ = ["ZOOM_FIELD", "ZOOM_MARGIN", "crop_box", "second_look"]

#: A field read unsure is read again on a crop when its side spans less than this share of the
#: photo's shorter side.
ZOOM_FIELD = 0.8
#: How far the crop reaches past the field on each side, as a share of the field's side.
ZOOM_MARGIN = 0.5
_MIN_CROP_PX = 64


def crop_box(reading: BoardReading, shape: tuple[int, ...]) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` px of the crop around ``reading``'s field in a photo of ``shape``, or
    None when the field spans :data:`ZOOM_FIELD` of the shorter side or more (or leaves the photo
    so far that the crop is under 64 px)."""
    h, w = shape[:2]
    n = reading.n
    corners = _apply(reading.homography, np.array([[0, 0], [n, 0], [n, n], [0, n]], np.float64))
    if not np.all(np.isfinite(corners)):
        return None
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    side = float(max(x1 - x0, y1 - y0))
    if side >= ZOOM_FIELD * min(h, w):
        return None
    m = ZOOM_MARGIN * side
    box = (int(max(0.0, x0 - m)), int(max(0.0, y0 - m)), int(min(float(w), x1 + m)), int(min(float(h), y1 + m)))
    return box if min(box[2] - box[0], box[3] - box[1]) >= _MIN_CROP_PX else None


def second_look(read: Callable[[np.ndarray, dict[str, object] | None], BoardReading], image: np.ndarray,
                reading: BoardReading, accept: float, trace: dict[str, object] | None = None) -> BoardReading:
    """``reading`` of ``image``, or the reading of a crop around its field (:func:`crop_box`) by
    ``read`` (the reader's one pass) when ``reading`` is unsure (its grid confidence under
    ``accept``) and the crop's reading is more probable. ``trace`` (the first pass's) gets
    ``"zoom"``: the crop box, and the crop's hypotheses appended to ``"hypotheses"`` as
    ``"<kind> zoomed"``; when the crop's reading is taken, its own trace replaces the first pass's,
    with ``"offset"``: the crop's corner in the photo's px (for :func:`~kinegym.vision.debug.debug_image`)."""
    if reading.grid_confidence is None or reading.grid_confidence >= accept:
        return reading
    box = crop_box(reading, image.shape)
    if box is None:
        return reading
    x0, y0, x1, y1 = box
    sub: dict[str, object] = {}
    try:
        zoomed = read(np.ascontiguousarray(image[y0:y1, x0:x1]), sub)
    except NoBoardError:
        zoomed = None
    tried = [(f"{k} zoomed", p) for k, p in sub.get("hypotheses", [])]  # type: ignore[attr-defined]
    if trace is not None:
        trace["zoom"] = box
    if zoomed is None or (zoomed.grid_confidence or 0.0) <= reading.grid_confidence:
        if trace is not None:
            trace["hypotheses"] = [*trace.get("hypotheses", []), *tried]  # type: ignore[misc]
        return reading
    if trace is not None:
        first = trace.get("hypotheses", [])
        trace.clear()
        trace.update(sub)
        trace.update(zoom=box, offset=(float(x0), float(y0)), kind=f"{sub['kind']} zoomed",
                     hypotheses=[*first, *tried])  # type: ignore[misc]
    to_photo = np.array([[1.0, 0.0, x0], [0.0, 1.0, y0], [0.0, 0.0, 1.0]])
    return dataclasses.replace(zoomed, homography=to_photo @ zoomed.homography)
