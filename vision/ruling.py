"""Ruled and graph paper: telling its printed rules from the lines of a '#' drawn on it.

The '#' finder (:mod:`~kinegym.vision.hand_grid`) traces strokes as tracks; on ruled or graph
paper most of its tracks are rules, some as dark as the pen. What tells them apart:

* **many evenly spaced long lines** of one direction are a ruling (:func:`is_ruled`); its
  ink lies on long straight runs (:func:`rules_mask`);
* **ink**: a pen's track carries more ink than a rule's, or another colour
  (:func:`without_rules`, :meth:`Ruling.paints`);
* **ends**: a drawn stroke ends on the paper; a rule runs on to the paper's edge, and a
  heavier rule (every fifth, say), which can be as dark as the pen, runs on as dark beyond
  any end its track has (:meth:`Ruling.runs_on`);
* in the cells, what lies on a rule and is no darker than the rules (up to 3x in the rules'
  colour) is cleared before the marks are read (:func:`clear_rules`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .ink import angle_deg, ink_colour, unit
from .polylines import resample

if TYPE_CHECKING:
    from .hand_grid import Track

__all__ = ["HUE_DEG", "Ruling", "clear_rules", "is_ruled", "rules_mask", "without_rules"]


#: Pens of one '#' differ by less than this in ink colour (deg between RGB darkness vectors);
#: rules this far off the drawn lines' colour are another pen's.
HUE_DEG = 12.0


def is_ruled(tracks: list[Track], side: float) -> bool:
    """Ruled or graph paper in this family: eight or more long lines of one direction, most
    of them evenly spaced (a '#' has two lines a way, a frame two more, a second grid or a
    page edge a few)."""
    long = [t for t in tracks if t.span >= 0.25 * side]
    if len(long) < 8:
        return False
    if len(long) >= 16:
        return True
    u = np.array([t.pts[-1] - t.pts[0] for t in long])
    u = u * np.where(u[:, 1:2] < 0, -1.0, 1.0)  # one sense along the family
    u = np.median(u / np.hypot(u[:, :1], u[:, 1:]), axis=0)
    gaps = np.diff(np.sort([float(np.mean(t.pts, axis=0) @ [-u[1], u[0]]) for t in long]))
    return bool(np.mean(np.abs(gaps - np.median(gaps)) <= 0.3 * np.median(gaps)) >= 0.5)


def without_rules(tracks: list[Track], side: float) -> list[Track]:
    """A ruled family's tracks (:func:`is_ruled`) less the printed rules: tracks with 1.5x the
    long ones' median ink, or more than :data:`HUE_DEG` off their colour (another pen), stay;
    with fewer than two long tracks left the family is kept as it is."""
    long = [t for t in tracks if t.span >= 0.25 * side]
    ink = float(np.median([t.ink for t in long]))
    hue = unit(np.median([t.colour for t in long], axis=0)) if long[0].colour is not None else None
    keep = [t for t in tracks if t.ink >= 1.5 * ink or (hue is not None and angle_deg(t.colour, hue) > HUE_DEG)]
    return keep if sum(t.span >= 0.25 * side for t in keep) >= 2 else tracks


def rules_mask(mask: np.ndarray, phis: list[float], length: int) -> np.ndarray:
    """uint8 mask of the ink that lies on straight runs ``length`` px long along any of the
    directions ``phis`` (or up to 8 deg off them: perspective makes rules converge): ruled
    paper's lines (openings with a line)."""
    out = np.zeros_like(mask)
    r = length // 2
    for phi in (p + math.radians(t) for p in phis for t in (-8, -4, 0, 4, 8)):  # perspective turns them
        k = np.zeros((2 * r + 1, 2 * r + 1), np.uint8)
        dx, dy = r * math.cos(phi), r * math.sin(phi)
        cv2.line(k, (int(round(r - dx)), int(round(r - dy))), (int(round(r + dx)), int(round(r + dy))), 1, 1)
        out |= cv2.morphologyEx(mask, cv2.MORPH_OPEN, k)
    return out


@dataclass
class Ruling:
    """Ruled or graph paper's lines: ``rules`` (uint8) all of them, ``phis`` the ruled
    directions, ``paper`` the convex hull of the rules, ``dark`` the darkness map's 5 x 5
    maximum (a line's darkness, a px or two off it), ``hue`` the rules' colour if known."""

    rules: np.ndarray
    phis: list[float]
    paper: np.ndarray
    dark: np.ndarray
    hue: np.ndarray | None
    by_colour: bool = False  # whether ink in the rules' colour is left out of the search (:meth:`paints`)

    @classmethod
    def of(cls, rules: np.ndarray, phis: list[float], d: np.ndarray, colour: np.ndarray | None) -> Ruling:
        """The ruling whose lines along ``phis`` are ``rules`` (:func:`rules_mask`, not empty)
        in darkness map ``d``, of RGB darkness ``colour`` if known."""
        paper = np.zeros_like(rules)
        cv2.fillConvexPoly(paper, cv2.convexHull(cv2.findNonZero(rules)), 1)
        hue = unit(np.median(colour[rules > 0], axis=0)) if colour is not None else None
        return cls(rules, phis, paper, cv2.dilate(d, np.ones((5, 5), np.uint8)), hue)

    def paints(self, d: np.ndarray, colour: np.ndarray) -> np.ndarray:
        """Bool map of the px in the rules' colour (within :data:`HUE_DEG`) and less than
        2.5x as dark as their median: the rules' ink, not a pen's."""
        level = 2.5 * float(np.median(d[self.rules > 0]))
        cos = (colour @ self.hue.astype(np.float32)) / np.maximum(np.linalg.norm(colour, axis=2), 1e-6)
        return (cos > math.cos(math.radians(HUE_DEG))) & (d < level)

    def runs_on(self, tr: Track, phi: float) -> bool:
        """Whether track ``tr`` of the family along ``phi`` is a rule (a heavier one, every
        fifth, is as dark as a pen): in the rules' colour, and at both ends its darkness runs
        on (three quarters of it, over 8 % of the image beyond the end) or it leaves the paper
        (within 3 %). A drawn stroke ends on the paper, or is darker than its rules."""
        if len(tr.pts) < 2 or not any(abs(math.remainder(p - phi, math.pi)) < math.radians(10) for p in self.phis):
            return False
        if self.hue is not None and tr.colour is not None and angle_deg(tr.colour, self.hue) > HUE_DEG:
            return False
        h, w = self.dark.shape
        side = float(max(h, w))
        body = np.rint(resample(tr.pts, 2.0)).astype(np.intp)
        level = 0.75 * float(np.median(self.dark[np.clip(body[:, 1], 0, h - 1), np.clip(body[:, 0], 0, w - 1)]))
        t = np.arange(2.0, 0.08 * side)
        for end, before in ((tr.pts[0], tr.pts[1]), (tr.pts[-1], tr.pts[-2])):
            q = np.rint(end + t[:, None] * unit(end - before)).astype(np.intp)
            inside = (q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)
            n = len(q) if inside.all() else int(np.argmin(inside))
            on_paper = self.paper[q[:n, 1], q[:n, 0]] > 0
            n = n if on_paper.all() else int(np.argmin(on_paper))
            if n < 0.03 * side:
                continue  # it leaves the picture or the paper there
            if float(np.median(self.dark[q[:n, 1], q[:n, 0]])) < level:
                return False  # it ends on the paper
        return True


def clear_rules(clean: np.ndarray, d: np.ndarray, rgb: np.ndarray, rules: np.ndarray, hue: np.ndarray | None,
                keep: np.ndarray) -> None:
    """Clear ruled paper's rules from ``clean`` (in place), the darkness map ``d`` of photo
    ``rgb`` less the '#' lines: what lies on ``rules`` (a mask at any scale, resized) outside
    ``keep`` and is less than twice as dark as the rules there, or, in the rules' colour
    ``hue`` (within :data:`HUE_DEG`), less than three times as dark (a heavier rule)."""
    h, w = d.shape
    on = cv2.dilate(cv2.resize(rules, (w, h), interpolation=cv2.INTER_NEAREST), np.ones((3, 3))) > 0
    on &= ~keep
    level = float(np.median(d[on])) if on.any() else 1.0
    gone = on & (d < 2.0 * level)
    if hue is not None:
        col = ink_colour(rgb, stroke_px=max(6.0, math.hypot(h, w) / 100))
        cos = (col @ hue.astype(np.float32)) / np.maximum(np.linalg.norm(col, axis=2), 1e-6)
        gone |= on & (cos > math.cos(math.radians(HUE_DEG))) & (d < 3.0 * level)
    clean[gone] = 0.0
