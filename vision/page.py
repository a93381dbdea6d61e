"""The writing surface: where in a photo the page (paper or whiteboard) lies.

A '#' is drawn on a page, and a photo often shows more than the page: a table's grain, a
patterned cloth, stripes of light on a wall, a shadow's edge. Their ink-like structure can
lead the '#' search astray or bury a faint '#' among stronger strokes. The page is what is
bright and weakly coloured for its photo: the pixels at or above Otsu's threshold of the value
(the largest of R, G, B) with a saturation under :data:`MAX_SATURATION`, closed over strokes;
the largest such region (at least :data:`MIN_AREA` of the photo), as its convex hull grown by
:data:`MARGIN` of the photo's longer side (lines drawn to the page's edge stay whole).

The reader (:mod:`~kinegym.vision.board_reader`) seeks the '#' once more in the ink on the
page alone (:data:`~kinegym.vision.grid_choice.PAGE_KINDS`) when no hypothesis was sure and
the page covers at most :data:`PAGE_COVER` of the photo: a page amid something else.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["MARGIN", "MAX_SATURATION", "MIN_AREA", "PAGE_COVER", "WORK_PX", "page_mask", "page_apart"]

#: The longer side (px) of the copy the page is found on.
WORK_PX = 160
#: The largest saturation (0..255, OpenCV's HSV) of a page's pixel.
MAX_SATURATION = 90
#: The least share of the photo a page covers.
MIN_AREA = 0.1
#: How far (share of the photo's longer side) the page's hull is grown.
MARGIN = 0.04
#: The most of the photo a page may cover to be searched on its own (more is the whole photo;
#: the 15 real whiteboard photos, which nearly fill their frames, measure 0.66-0.80).
PAGE_COVER = 0.7


def page_mask(rgb: np.ndarray) -> np.ndarray | None:
    """uint8 mask (1 on the page) of an RGB photo, or None when no region is page-like. Found on
    a copy :data:`WORK_PX` on its longer side (a page is large; 10 ms at 480 px, 1 ms there)."""
    h, w = rgb.shape[:2]
    f = min(1.0, WORK_PX / max(h, w))
    small = cv2.resize(rgb, (max(1, round(w * f)), max(1, round(h * f))), interpolation=cv2.INTER_AREA)
    hsv = cv2.cvtColor(np.ascontiguousarray(small), cv2.COLOR_RGB2HSV)
    v, s = hsv[..., 2], hsv[..., 1]
    level, _ = cv2.threshold(v, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    bright = ((v >= level) & (s < MAX_SATURATION)).astype(np.uint8)
    k = max(3, int(0.02 * max(v.shape)) | 1)  # strokes and marks on the page are closed over
    bright = cv2.morphologyEx(bright, cv2.MORPH_CLOSE, np.ones((k, k), np.uint8))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(bright)
    if n <= 1:
        return None
    i = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    if stats[i, cv2.CC_STAT_AREA] < MIN_AREA * bright.size:
        return None
    outline, _ = cv2.findContours((labels == i).astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hull = np.zeros_like(bright)
    cv2.fillConvexPoly(hull, cv2.convexHull(np.concatenate(outline)), 1)
    out = cv2.resize(hull, (w, h), interpolation=cv2.INTER_NEAREST)
    g = max(3, int(MARGIN * max(h, w)) | 1)
    return cv2.dilate(out, np.ones((g, g), np.uint8))


def page_apart(rgb: np.ndarray) -> np.ndarray | None:
    """:func:`page_mask` when the page covers at most :data:`PAGE_COVER` of the photo (a page
    amid something else), else None (the page is the photo, or no page is seen)."""
    page = page_mask(rgb)
    return page if page is not None and float(page.mean()) <= PAGE_COVER else None
