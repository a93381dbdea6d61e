"""The drawing board: a canvas in cm on which strokes leave ink, and hand-drawn marks.

Frame: x to the right, y up, origin at the canvas's lower-left corner, lengths in cm;
image rows run top to bottom. The canvas stores ink as *optical density* per RGB channel:
a stroke adds ``opacity * log10(paper / ink colour)`` under its anti-aliased footprint,
so ink over ink darkens as real ink does, a highlighter over black stays black, and the
picture is ``paper * 10 ** -density``. Erasing multiplies the density down where the
sponge passes; an efficiency below 1 leaves the faint ghosts of earlier games that real
whiteboards keep.

Hand-drawn marks (:func:`hand_x`, :func:`hand_o`, :func:`hand_line`) are polylines with a
person's variation: size, rotation, placement in the cell, low-frequency wobble, an O that
does not quite close or overlaps itself, an X whose strokes overshoot. They draw from the
``numpy.random.Generator`` they are given, so a seeded scene is the same every time.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = [
    "Pen",
    "PENS",
    "PAPERS",
    "BoardCanvas",
    "field_segments",
    "cell_centre",
    "hand_line",
    "hand_x",
    "hand_o",
    "draw_graph_paper",
    "scribble",
]

Colour = tuple[int, int, int]


@dataclass(frozen=True)
class Pen:
    """Ink of a pen: RGB colour of a full stroke on white, stroke width (cm), opacity 0..1."""

    colour: Colour = (25, 25, 35)
    width_cm: float = 0.15
    opacity: float = 1.0

    def __post_init__(self) -> None:
        if not (len(self.colour) == 3 and all(0 <= int(c) <= 255 for c in self.colour)):
            raise ValueError(f"pen colour {self.colour!r}; expected three integers 0..255 (RGB)")
        if not self.width_cm > 0:
            raise ValueError(f"pen width_cm={self.width_cm!r}; expected > 0")
        if not 0 < self.opacity <= 1:
            raise ValueError(f"pen opacity={self.opacity!r}; expected 0 < opacity <= 1")

    def with_(self, **kw: object) -> Pen:
        return Pen(**{**self.__dict__, **kw})  # type: ignore[arg-type]


#: A few real pens: permanent / whiteboard markers in common colours, a pencil, a highlighter.
PENS: dict[str, Pen] = {
    "black": Pen((25, 25, 35), 0.15),
    "blue": Pen((25, 60, 175), 0.15),
    "green": Pen((20, 125, 55), 0.15),
    "red": Pen((195, 30, 35), 0.15),
    "purple": Pen((95, 40, 140), 0.15),
    "pencil": Pen((95, 95, 100), 0.08, 0.8),
    "highlighter": Pen((250, 240, 70), 0.6, 0.6),
}
#: Surfaces: paper, a whiteboard (cool, slightly blue), recycled paper.
PAPERS: dict[str, Colour] = {"paper": (246, 244, 238), "whiteboard": (240, 244, 248), "recycled": (232, 226, 210)}


class BoardCanvas:
    """A ``width_cm x height_cm`` board sampled at ``px_per_cm``.

    Args:
        width_cm, height_cm: size of the board (cm).
        px_per_cm: resolution of the ink (16 px/cm resolves a 1.5 mm stroke with 2-3 px).
        paper: RGB of the bare surface.
    """

    def __init__(self, width_cm: float = 20.0, height_cm: float = 20.0, px_per_cm: float = 16.0,
                 paper: Colour = PAPERS["whiteboard"]) -> None:
        if not (width_cm > 0 and height_cm > 0 and px_per_cm > 0):
            raise ValueError(f"canvas {width_cm} x {height_cm} cm at {px_per_cm} px/cm; expected positive sizes")
        self.width_cm, self.height_cm, self.px_per_cm = float(width_cm), float(height_cm), float(px_per_cm)
        self.shape = (int(round(height_cm * px_per_cm)), int(round(width_cm * px_per_cm)))
        self.paper = np.asarray(paper, dtype=np.float32)
        self.density = np.zeros((*self.shape, 3), dtype=np.float32)
        self._mask = np.zeros(self.shape, dtype=np.uint8)
        self._image: np.ndarray | None = None

    # -- geometry --------------------------------------------------------------------
    def to_px(self, pts_cm: object) -> np.ndarray:
        """Board points ``(..., 2)`` cm -> pixel coordinates ``(..., 2)`` (col, row), float."""
        p = np.asarray(pts_cm, dtype=np.float64)
        s = self.px_per_cm
        return np.stack([p[..., 0] * s - 0.5, (self.height_cm - p[..., 1]) * s - 0.5], axis=-1)

    def px_to_cm(self) -> np.ndarray:
        """3 x 3 matrix taking homogeneous pixel coordinates (col, row, 1) to board cm."""
        s = 1.0 / self.px_per_cm
        return np.array([[s, 0.0, 0.5 * s], [0.0, -s, self.height_cm - 0.5 * s], [0.0, 0.0, 1.0]])

    # -- ink -------------------------------------------------------------------------
    def _footprint(self, polylines: Iterable[np.ndarray], width_cm: float, closed: bool = False
                   ) -> tuple[tuple[slice, slice], np.ndarray] | None:
        """Anti-aliased footprint (0..1 float32) of polylines over their bounding box."""
        pts = [self.to_px(np.asarray(p, dtype=np.float64).reshape(-1, 2)) for p in polylines]
        pts = [p for p in pts if len(p)]
        if not pts:
            return None
        thick = max(1, int(round(width_cm * self.px_per_cm)))
        allp = np.concatenate(pts)
        pad = thick + 2
        h, w = self.shape
        c0 = max(0, int(np.floor(allp[:, 0].min())) - pad)
        c1 = min(w, int(np.ceil(allp[:, 0].max())) + pad + 1)
        r0 = max(0, int(np.floor(allp[:, 1].min())) - pad)
        r1 = min(h, int(np.ceil(allp[:, 1].max())) + pad + 1)
        if c1 <= c0 or r1 <= r0:
            return None
        roi = (slice(r0, r1), slice(c0, c1))
        m = self._mask[roi]
        m[...] = 0
        shift = 4  # sub-pixel precision: coordinates in 1/16 px
        ipts = [np.rint((p - [c0, r0]) * (1 << shift)).astype(np.int32).reshape(-1, 1, 2) for p in pts]
        cv2.polylines(m, ipts, closed, 255, thick, cv2.LINE_AA, shift)
        return roi, m.astype(np.float32) * (1.0 / 255.0)

    def stroke(self, points_cm: object, pen: Pen = PENS["black"], closed: bool = False) -> None:
        """Ink a polyline ``(N, 2)`` cm (a single point makes a dot)."""
        pts = np.asarray(points_cm, dtype=np.float64).reshape(-1, 2)
        if len(pts) == 1:
            pts = np.repeat(pts, 2, axis=0)
        self.strokes([pts], pen, closed)

    def strokes(self, polylines: Sequence[object], pen: Pen = PENS["black"], closed: bool = False) -> None:
        """Ink several polylines of one pen at once (their union: no double ink where one
        pen stroke crosses itself within a call)."""
        fp = self._footprint([np.asarray(p, dtype=np.float64) for p in polylines], pen.width_cm, closed)
        if fp is None:
            return
        roi, m = fp
        ink = np.maximum(np.asarray(pen.colour, np.float32), 1.0)
        d = pen.opacity * np.log10(np.maximum(self.paper / ink, 1.0))
        view = self.density[roi]
        view += m[..., None] * d
        np.minimum(view, 3.0, out=view)
        self._image = None

    def erase(self, points_cm: object, width_cm: float, efficiency: float = 0.98) -> None:
        """Wipe along a polyline with a sponge ``width_cm`` wide: the density under it drops
        by ``efficiency`` per pass (1 = spotless)."""
        if not 0 <= efficiency <= 1:
            raise ValueError(f"erase efficiency={efficiency!r}; expected 0..1")
        fp = self._footprint([np.asarray(points_cm, dtype=np.float64).reshape(-1, 2)], width_cm)
        if fp is None:
            return
        roi, m = fp
        self.density[roi] *= (1.0 - efficiency * m)[..., None]
        self._image = None

    def clear(self) -> None:
        """A spotless board."""
        self.density.fill(0.0)
        self._image = None

    # -- looking at it ----------------------------------------------------------------
    def image(self) -> np.ndarray:
        """The board as an RGB ``uint8`` image (cached until the next stroke)."""
        if self._image is None:
            img = self.paper * np.power(10.0, -self.density, dtype=np.float32)
            self._image = np.clip(img + 0.5, 0, 255).astype(np.uint8)
        return self._image.copy()

    def ink(self) -> np.ndarray:
        """Ink amount per pixel ``(H, W)``: the largest channel density (0 = bare surface)."""
        return self.density.max(axis=2)

    def ink_near(self, points_cm: object, radius_cm: float, threshold: float = 0.1) -> np.ndarray:
        """Per query point: is there ink (density > ``threshold``) within ``radius_cm``?"""
        mask = (self.ink() > threshold).astype(np.uint8)
        r = max(1, int(round(radius_cm * self.px_per_cm)))
        grown = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
        px = np.rint(self.to_px(points_cm)).astype(int).reshape(-1, 2)
        h, w = self.shape
        inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
        out = np.zeros(len(px), dtype=bool)
        out[inside] = grown[px[inside, 1], px[inside, 0]] > 0
        return out

    def copy(self) -> BoardCanvas:
        c = BoardCanvas.__new__(BoardCanvas)
        c.width_cm, c.height_cm, c.px_per_cm, c.shape = self.width_cm, self.height_cm, self.px_per_cm, self.shape
        c.paper, c.density = self.paper.copy(), self.density.copy()
        c._mask, c._image = np.zeros(self.shape, np.uint8), None
        return c


# ------------------------------------------------------------------ field geometry
def field_segments(n: int, cell_cm: float, origin_cm: Sequence[float], frame: bool = False
                   ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The playing field's straight lines as ``(start, end)`` cm: ``n - 1`` lines each way
    (the thesis's 4 + 4 lines, 15 cm long, 3 cm apart, for n = 5), plus the four border
    lines with ``frame=True``. ``origin_cm`` is the field's lower-left corner; vertical
    lines first, left to right, then horizontal ones, bottom to top."""
    if n < 2 or cell_cm <= 0:
        raise ValueError(f"field of n={n} cells of {cell_cm} cm; expected n >= 2 and cell_cm > 0")
    x0, y0 = float(origin_cm[0]), float(origin_cm[1])
    side = n * cell_cm
    idx = range(0, n + 1) if frame else range(1, n)
    segs = [(np.array([x0 + i * cell_cm, y0]), np.array([x0 + i * cell_cm, y0 + side])) for i in idx]
    segs += [(np.array([x0, y0 + i * cell_cm]), np.array([x0 + side, y0 + i * cell_cm])) for i in idx]
    return segs


def cell_centre(row: int, col: int, n: int, cell_cm: float, origin_cm: Sequence[float]) -> np.ndarray:
    """Centre (cm) of cell ``(row, col)``; row 0 is the top row (as the game's text form reads)."""
    return np.array([origin_cm[0] + (col + 0.5) * cell_cm, origin_cm[1] + (n - row - 0.5) * cell_cm])


# ------------------------------------------------------------------ hand-drawn marks
def _wobble(t: np.ndarray, amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """Smooth random displacement along a parameter ``t`` in [0, 1]: three low sinusoids."""
    out = np.zeros_like(t)
    for k in (1.0, 2.0, 3.5):
        out += rng.normal(0, amplitude / k) * np.sin(np.pi * k * t + rng.uniform(0, 2 * np.pi))
    return out


def hand_line(a: Sequence[float], b: Sequence[float], rng: np.random.Generator, wobble_cm: float = 0.05,
              points: int = 24) -> np.ndarray:
    """A hand-drawn straight stroke from ``a`` to ``b`` (cm): it wobbles sideways."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.linspace(0.0, 1.0, points)
    d = b - a
    normal = np.array([-d[1], d[0]]) / (np.linalg.norm(d) or 1.0)
    return a + t[:, None] * d + _wobble(t, wobble_cm, rng)[:, None] * normal


def hand_x(centre: Sequence[float], size_cm: float, rng: np.random.Generator, jitter: float = 1.0
           ) -> list[np.ndarray]:
    """Two crossing strokes of an X about ``size_cm`` across (cm), as a person draws them."""
    c = np.asarray(centre, float) + rng.normal(0, 0.05 * size_cm * jitter, 2)
    half = 0.5 * size_cm * rng.uniform(1 - 0.2 * jitter, 1 + 0.1 * jitter)
    tilt = rng.normal(0, np.radians(7) * jitter)
    out = []
    for base in (np.pi / 4, 3 * np.pi / 4):
        ang = base + tilt + rng.normal(0, np.radians(5) * jitter)
        u = np.array([np.cos(ang), np.sin(ang)])
        h1 = half * rng.uniform(0.85, 1.1)
        h2 = half * rng.uniform(0.85, 1.1)
        out.append(hand_line(c - h1 * u, c + h2 * u, rng, 0.03 * size_cm * jitter))
    return out


def hand_o(centre: Sequence[float], size_cm: float, rng: np.random.Generator, jitter: float = 1.0,
           points: int = 60) -> list[np.ndarray]:
    """One loop of an O about ``size_cm`` across (cm): a little oval, started anywhere,
    sometimes not quite closed, sometimes overlapping its start."""
    c = np.asarray(centre, float) + rng.normal(0, 0.05 * size_cm * jitter, 2)
    r = 0.5 * size_cm * rng.uniform(1 - 0.2 * jitter, 1 + 0.1 * jitter)
    aspect = 1 + rng.normal(0, 0.1 * jitter)
    start = rng.uniform(0, 2 * np.pi)
    sweep = 2 * np.pi + rng.uniform(-0.35, 0.45) * jitter
    direction = rng.choice([-1.0, 1.0])
    t = np.linspace(0, 1, points)
    ang = start + direction * sweep * t
    rad = r * (1 + _wobble(t, 0.05 * jitter, rng))
    tilt = rng.uniform(0, np.pi)
    ex, ey = rad * np.cos(ang) * aspect, rad * np.sin(ang) / aspect
    pts = np.stack([ex * np.cos(tilt) - ey * np.sin(tilt), ex * np.sin(tilt) + ey * np.cos(tilt)], -1)
    return [c + pts]


# ------------------------------------------------------------------ distractors
def draw_graph_paper(canvas: BoardCanvas, spacing_cm: float = 0.5, pen: Pen | None = None) -> None:
    """Fine ruled grid over the whole canvas (graph paper): thin, faint, everywhere."""
    pen = pen or Pen((150, 185, 215), 0.03, 0.55)
    lines = []
    for x in np.arange(spacing_cm, canvas.width_cm, spacing_cm):
        lines.append(np.array([[x, 0.0], [x, canvas.height_cm]]))
    for y in np.arange(spacing_cm, canvas.height_cm, spacing_cm):
        lines.append(np.array([[0.0, y], [canvas.width_cm, y]]))
    canvas.strokes(lines, pen)


def scribble(canvas: BoardCanvas, centre: Sequence[float], size_cm: float, rng: np.random.Generator,
             pen: Pen | None = None) -> None:
    """A zig-zag of highlighter (or any pen) about ``size_cm`` long across ``centre``."""
    pen = pen or PENS["highlighter"]
    n = int(rng.integers(3, 7))
    ang = rng.uniform(0, np.pi)
    u, v = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
    t = np.linspace(-0.5, 0.5, n)
    side = np.where(np.arange(n) % 2 == 0, 1.0, -1.0) * 0.15 * size_cm
    pts = np.asarray(centre, float) + t[:, None] * size_cm * u + side[:, None] * v
    canvas.stroke(pts, pen)
