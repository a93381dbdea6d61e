"""Pictures of seed 001's beacon experiment: the localisation error as a heat map (the seed's
figure 3.3) and the frames of a target-following run, as RGB arrays drawn with OpenCV.

* :func:`error_map` - the error image of a grid search over its window (dark = small error),
  the beacons (red dots), the real robot (green diamond) and the estimate (magenta diamond),
  as the seed's ``localizacion(..., mostrar=1)`` drew it with matplotlib;
* :func:`follow_frame` - the field at one step of a run: beacons, targets (numbered), the
  believed (ideal) path in magenta, the real one in green, both robots with their headings,
  and a caption.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from kinegym.envs.draw import Canvas
from kinegym.kinematics.beacons import Estimate

__all__ = ["error_map", "follow_frame", "field_canvas"]

_REAL = (30, 160, 60)
_IDEAL = (220, 0, 220)
_BEACON = (214, 39, 40)
_TARGET = (31, 119, 180)


def _diamond(canvas: Canvas, at: Sequence[float], colour: tuple[int, int, int], size_px: int = 9) -> None:
    u, v = (int(c) for c in canvas.px(at[:2]))
    pts = np.array([[u, v - size_px], [u + size_px, v], [u, v + size_px], [u - size_px, v]], np.int32)
    cv2.polylines(canvas.image, [pts.reshape(-1, 1, 2)], True, colour, 2, cv2.LINE_AA)


def _heading(canvas: Canvas, pose: Sequence[float], colour: tuple[int, int, int], length: float) -> None:
    x, y, th = pose[:3]
    canvas.line((x, y), (x + length * np.cos(th), y + length * np.sin(th)), colour, width=length / 8)


def error_map(est: Estimate, beacons: np.ndarray, real: Sequence[float], px: int = 480,
              caption: Sequence[str] = ()) -> np.ndarray:
    """The heat map of ``est.image`` (a grid search's error over its window, rows from the
    bottom) with the beacons, the real pose and the estimate; ``px`` wide."""
    if est.image is None or est.extent is None:
        raise ValueError(f"a {est.method!r} estimate has no error image; use grid_search or coarse_to_fine")
    x0, x1, y0, y1 = est.extent
    canvas = Canvas(x0, y0, x1, y1, scale=px / (x1 - x0))
    err = np.asarray(est.image, float)
    lo, hi = float(err.min()), float(np.percentile(err, 99))
    norm = np.clip((err - lo) / max(hi - lo, 1e-12), 0, 1)
    grey = (255 * norm[::-1]).astype(np.uint8)  # rows from the top for the picture
    heat = cv2.cvtColor(cv2.applyColorMap(grey, cv2.COLORMAP_VIRIDIS), cv2.COLOR_BGR2RGB)
    canvas.image[...] = cv2.resize(heat, (canvas.width, canvas.height), interpolation=cv2.INTER_NEAREST)
    for b in np.asarray(beacons, float):
        canvas.circle(b, 6 / canvas.scale, _BEACON)
    _diamond(canvas, est.pose, _IDEAL, 12)
    _diamond(canvas, real, _REAL, 7)
    canvas.caption([*caption, "red: beacons  green: real  magenta: estimate"], colour=(255, 255, 255))
    return canvas.image.copy()


def field_canvas(points: np.ndarray, px: int = 600, margin: float = 0.6) -> Canvas:
    """A canvas ``px`` wide showing every point ``(N, 2)`` with ``margin`` around (square pixels)."""
    p = np.asarray(points, float).reshape(-1, 2)
    lo, hi = p.min(0) - margin, p.max(0) + margin
    side = float(max(hi - lo))
    return Canvas(lo[0], lo[1], lo[0] + side, lo[1] + side, scale=px / side)


def follow_frame(canvas: Canvas, beacons: np.ndarray, targets: np.ndarray, ideal: np.ndarray, real: np.ndarray,
                 caption: Sequence[str] = (), relocalised: Sequence[int] = ()) -> np.ndarray:
    """One frame: the paths so far (``ideal``/``real`` ``(k, 3)``), the robots at their last pose,
    the steps where the robot relocalised (small magenta rings), and a caption."""
    canvas.clear()
    size = 0.12 * (canvas.width / canvas.scale) / 5
    for i, t in enumerate(np.asarray(targets, float)):
        canvas.circle(t, size * 0.8, _TARGET, fill=False, width=size / 4)
        canvas.text(t, str(i + 1), _TARGET, size=0.6, offset_px=(8, -8))
    for b in np.asarray(beacons, float):
        canvas.circle(b, size * 0.5, _BEACON)
    if len(ideal) > 1:
        canvas.polyline(ideal[:, :2], _IDEAL, width=size / 5)
        canvas.polyline(real[:, :2], _REAL, width=size / 5)
    for k in relocalised:
        if k < len(ideal):
            canvas.circle(ideal[k, :2], size * 0.35, _IDEAL, fill=False, width=size / 8)
    for pose, col in ((ideal[-1], _IDEAL), (real[-1], _REAL)):
        _diamond(canvas, pose, col, 7)
        _heading(canvas, pose, col, 2 * size)
    canvas.caption([*caption, "magenta: believed  green: real  red: beacons  blue: targets"])
    return canvas.image.copy()
