"""Straight lines of a drawn grid: Hough segments merged into lines, refitted on the ink map,
split into the grid's two families and kept where they cross the other family.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np


@dataclass
class _Line:
    theta: float  # normal direction (rad, 0..pi)
    rho: float  # signed distance of the line from the origin along the normal (px)
    length: float  # total length of the merged segments (px)
    p0: np.ndarray = field(default_factory=lambda: np.zeros(2))
    p1: np.ndarray = field(default_factory=lambda: np.zeros(2))  # extent along the line

    @property
    def normal(self) -> np.ndarray:
        return np.array([math.cos(self.theta), math.sin(self.theta)])

    @property
    def direction(self) -> np.ndarray:
        return np.array([-math.sin(self.theta), math.cos(self.theta)])

    def homog(self) -> np.ndarray:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.array([c, s, -self.rho])


def _segments(mask: np.ndarray, min_len: float) -> np.ndarray:
    segs = cv2.HoughLinesP(mask, 1, np.pi / 180, threshold=max(10, int(min_len * 0.5)),
                           minLineLength=int(min_len), maxLineGap=int(max(3, min_len * 0.12)))
    return np.zeros((0, 4)) if segs is None else segs.reshape(-1, 4).astype(np.float64)


def _fit_lines(pts: np.ndarray, wts: np.ndarray, lengths: Sequence[float]) -> list[_Line]:
    """Total-least-squares lines through weighted points, one per row of ``pts`` ``(L, N, 2)``
    (weights ``(L, N)``; 0 pads a row), each spanning its points' extent: the principal axis
    of the 2 x 2 weighted scatter, in closed form."""
    c = (wts[..., None] * pts).sum(axis=1) / wts.sum(axis=1)[:, None]
    dx, dy = pts[..., 0] - c[:, None, 0], pts[..., 1] - c[:, None, 1]
    wx = wts * dx
    sxx, sxy, syy = (wx * dx).sum(axis=1), (wx * dy).sum(axis=1), (wts * dy * dy).sum(axis=1)
    # the normal is the minor axis: a quarter turn from the major one
    th = np.mod(0.5 * np.arctan2(2.0 * sxy, sxx - syy) + 0.5 * math.pi, math.pi)
    cs, sn = np.cos(th), np.sin(th)
    t = dx * -sn[:, None] + dy * cs[:, None]
    used = wts > 0
    t0, t1 = np.where(used, t, np.inf).min(axis=1), np.where(used, t, -np.inf).max(axis=1)
    rho = c[:, 0] * cs + c[:, 1] * sn
    return [_Line(float(th[i]), float(rho[i]), float(lengths[i]),
                  np.array([c[i, 0] - t0[i] * sn[i], c[i, 1] + t0[i] * cs[i]]),
                  np.array([c[i, 0] - t1[i] * sn[i], c[i, 1] + t1[i] * cs[i]])) for i in range(len(th))]


def _merge(segs: np.ndarray, tol: float) -> list[_Line]:
    """Merge collinear segments ``(K, 4)`` into lines, longest first: a segment joins a line
    when both its ends lie within ``tol`` px of it (hand-drawn lines break into pieces
    whose own angles scatter, but whose ends stay on the line)."""
    if not len(segs):
        return []
    d = segs[:, 2:] - segs[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    # each group is founded by the longest segment left, whose line decides membership
    # (taken in turn, a segment joins the first group whose founder's line it fits)
    members: list[np.ndarray] = []
    free = np.ones(len(segs), bool)
    order = np.argsort(-length)
    while free.any():
        i = order[free[order]][0]
        a, b = segs[i, :2], segs[i, 2:]
        nrm = np.array([a[1] - b[1], b[0] - a[0]]) / max(float(length[i]), 1e-9)
        rho = float(a @ nrm)
        fits = free & (np.abs(segs[:, :2] @ nrm - rho) <= tol) & (np.abs(segs[:, 2:] @ nrm - rho) <= tol)
        fits[i] = True
        ix = order[fits[order]]  # longest first, as the segments would have joined
        members.append(ix)
        free[ix] = False
    # every group's line through its segments' ends, weighted by the segments' lengths
    most = max(len(ix) for ix in members)
    pts = np.zeros((len(members), 2 * most, 2))
    wts = np.zeros((len(members), 2 * most))
    for g, ix in enumerate(members):
        k = len(ix)
        pts[g, :k], pts[g, most:most + k] = segs[ix, :2], segs[ix, 2:]
        wts[g, :k] = wts[g, most:most + k] = length[ix]
    out = []
    for ix, ln in zip(members, _fit_lines(pts, wts, [0.0] * len(members))):
        # length: the union of the pieces along the line, not their sum
        ta, tb = (segs[ix, :2] - ln.p0) @ ln.direction, (segs[ix, 2:] - ln.p0) @ ln.direction
        iv = list(zip(np.minimum(ta, tb).tolist(), np.maximum(ta, tb).tolist()))
        out.append(_Line(ln.theta, ln.rho, _union_length(iv), ln.p0, ln.p1))
    return out


def _median(values: np.ndarray) -> float:
    """``np.median`` of a small 1-D array, without its overhead (it runs many times a frame)."""
    v = np.sort(values)
    k = len(v) // 2
    return float(v[k] if len(v) % 2 else (v[k - 1] + v[k]) / 2)


def _percentile(values: np.ndarray, q: float) -> float:
    """``np.percentile(values, q)`` (linear interpolation) by a partial sort: several times
    faster on an image."""
    pos = q / 100.0 * (len(values) - 1)
    k = int(math.floor(pos))
    if k + 1 >= len(values):
        return float(np.max(values))
    part = np.partition(values, (k, k + 1))
    a, b, g = float(part[k]), float(part[k + 1]), pos - k
    return a + (b - a) * g if g < 0.5 else b - (b - a) * (1.0 - g)


def _union_length(intervals: Sequence[tuple[float, float]]) -> float:
    """Total length covered by 1-D intervals ``(a, b)``, a <= b."""
    iv = sorted(intervals)
    cover, (lo, hi) = 0.0, iv[0]
    for a, b in iv[1:]:
        if a > hi:
            cover, lo = cover + hi - lo, a
        hi = max(hi, b)
    return float(cover + hi - lo)


def _line_arrays(lines: list[_Line]) -> tuple[np.ndarray, ...]:
    """cos, sin of the normals, rho, start points ``(L, 2)`` and drawn lengths of lines."""
    th = np.array([ln.theta for ln in lines])
    p0 = np.array([ln.p0 for ln in lines])
    p1 = np.array([ln.p1 for ln in lines])
    return np.cos(th), np.sin(th), np.array([ln.rho for ln in lines]), p0, np.hypot(*(p1 - p0).T)


def _refit(lines: list[_Line], ink: np.ndarray, floor: float, band: float) -> list[_Line | None]:
    """Each line refitted to the full-resolution ink map around it: every 3 px along the line
    (and a little past its ends), the darkness-weighted centre of the ink within ``band`` px
    across it, then a weighted total-least-squares line through those centres. None for a
    line with no ink there. (All lines at once: the samples of shorter lines are padded.)"""
    if not lines:
        return []
    h, w = ink.shape
    cs, sn, _, p0, length = _line_arrays(lines)
    nrm, dirv = np.stack([cs, sn], -1), np.stack([-sn, cs], -1)
    count = np.ceil((length + 2.0 * band + 1.0) / 3.0).astype(np.intp)  # samples along each line
    t = -band + 3.0 * np.arange(int(count.max()))
    u = np.arange(-math.ceil(band), math.ceil(band) + 1.0)
    pts = (p0[:, None, None, :] + t[None, :, None, None] * dirv[:, None, None, :]
           + u[None, None, :, None] * nrm[:, None, None, :])
    x = np.clip(np.rint(pts[..., 0]).astype(np.intp), 0, w - 1)
    y = np.clip(np.rint(pts[..., 1]).astype(np.intp), 0, h - 1)
    wt = np.maximum(ink[y, x] - floor, 0.0)
    tot = wt.sum(axis=2)
    on = (tot > 0) & (np.arange(len(t))[None, :] < count[:, None])
    off = (wt * u).sum(axis=2) / np.where(on, tot, 1.0)
    centres = p0[:, None, :] + t[None, :, None] * dirv[:, None, :] + off[..., None] * nrm[:, None, :]
    good = np.flatnonzero(on.sum(axis=1) >= 5)
    out: list[_Line | None] = [None] * len(lines)
    fits = _fit_lines(centres[good], np.where(on[good], tot[good], 0.0), [lines[i].length for i in good])
    for i, fit in zip(good, fits):
        out[i] = fit
    return out


def _crossings(fam: list[_Line], other: list[_Line]) -> tuple[np.ndarray, ...]:
    """Crossing points of every line of ``fam`` with every line of ``other``: ``x, y`` (px)
    and ``ok`` (not parallel), each ``(len(fam), len(other))``, and the two families' line
    arrays (:func:`_line_arrays`) for further use."""
    A, B = _line_arrays(fam), _line_arrays(other)
    ca, sa, ra = (v[:, None] for v in A[:3])
    cb, sb, rb = (v[None, :] for v in B[:3])
    det = ca * sb - sa * cb
    ok = np.abs(det) >= 1e-9
    det = np.where(ok, det, 1.0)
    return (ra * sb - rb * sa) / det, (ca * rb - cb * ra) / det, ok, A, B


def _crossing(fam: list[_Line], other: list[_Line], slack: float) -> list[_Line]:
    """The lines of ``fam`` that cross at least two lines of ``other``, and at least half
    of them, within both lines' drawn extents (``slack`` px beyond the ends allowed): a
    paper edge, a shadow's edge or a row of symbol strokes crosses few of the field's lines."""
    if len(other) < 2 or not fam:
        return fam
    x, y, ok, (ca, sa, _, pa, la), (cb, sb, _, pb, lb) = _crossings(fam, other)
    # positions along each line (direction: the normal turned a quarter)
    ta = (x - pa[:, None, 0]) * -sa[:, None] + (y - pa[:, None, 1]) * ca[:, None]
    tb = (x - pb[None, :, 0]) * -sb[None, :] + (y - pb[None, :, 1]) * cb[None, :]
    hit = (ok & (ta >= -slack) & (ta <= la[:, None] + slack) & (tb >= -slack) & (tb <= lb[None, :] + slack))
    need = max(2, (len(other) + 1) // 2)
    return [a for a, h in zip(fam, hit.sum(axis=1)) if h >= need]


def _families(lines: list[_Line]) -> tuple[list[_Line], list[_Line]]:
    """Split lines into the two grid directions: a length-weighted circular 2-means on the
    doubled normal angle, seeded by the longest line; lines more than 20 deg off their
    family's mean direction are dropped."""
    if len(lines) < 2:
        return lines, []
    ang = np.array([2 * ln.theta for ln in lines])
    wts = np.array([ln.length for ln in lines])
    c0 = ang[int(np.argmax(wts))]
    c1 = c0 + np.pi
    for _ in range(10):
        d0 = np.abs(np.angle(np.exp(1j * (ang - c0))))
        d1 = np.abs(np.angle(np.exp(1j * (ang - c1))))
        lab = d1 < d0
        if lab.all() or (~lab).all():
            break
        c0 = float(np.angle((wts[~lab] * np.exp(1j * ang[~lab])).sum()))
        c1 = float(np.angle((wts[lab] * np.exp(1j * ang[lab])).sum()))
    # perspective fans a family out by some degrees; a symbol's stroke runs at about 45 deg
    # to both families and joins neither
    d0 = np.abs(np.angle(np.exp(1j * (ang - c0)))) / 2
    d1 = np.abs(np.angle(np.exp(1j * (ang - c1)))) / 2
    limit = math.radians(20)
    fa = [ln for ln, k, d in zip(lines, lab, d0) if not k and d <= limit]
    fb = [ln for ln, k, d in zip(lines, lab, d1) if k and d <= limit]
    return fa, fb
