"""The ink map: how dark each pixel is against its local background (uneven light, shadows and
glare removed), and small image helpers every reader shares.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .errors import VisionError

__all__ = ["ink_map"]


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
