"""Polyline geometry for hand-drawn lines (points ``(N, 2)``, image px): straight extensions
at both ends, the first crossing of two polylines with its arc positions (of every pair of two
sets at once), points at a fixed
step along a polyline. Used by :mod:`~kinegym.vision.hand_grid`, whose traced grid lines are
polylines (a hand-drawn line is wavy, so it is followed, not fitted with one straight line).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["extend", "all_crossings", "first_crossing", "prepare", "Prepared", "resample"]


def extend(p: np.ndarray, by: float) -> np.ndarray:
    """A polyline with straight extensions of ``by`` px at both ends."""
    d0 = p[0] - p[1]
    d1 = p[-1] - p[-2]
    d0 = d0 / max(float(np.hypot(*d0)), 1e-9)
    d1 = d1 / max(float(np.hypot(*d1)), 1e-9)
    return np.concatenate([[p[0] + by * d0], p, [p[-1] + by * d1]])


@dataclass(frozen=True)
class Prepared:
    """A polyline with what :func:`first_crossing` needs of it, worked out once (a line crossed
    with many others): its points, segments, the segments' boxes (``lo_a``/``hi_a`` a hair
    wider, for the polyline's role as ``a``) and the arc length at each point."""

    pts: np.ndarray
    seg: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    lo_a: np.ndarray
    hi_a: np.ndarray
    arc: np.ndarray


def prepare(p: np.ndarray) -> Prepared:
    """:class:`Prepared` for polyline ``p`` ``(N, 2)``."""
    seg = p[1:] - p[:-1]
    lo, hi = np.minimum(p[:-1], p[1:]), np.maximum(p[:-1], p[1:])
    return Prepared(p, seg, lo, hi, lo - 1e-6, hi + 1e-6, np.concatenate([[0.0], np.cumsum(np.hypot(*seg.T))]))


def all_crossings(a: Sequence[np.ndarray | Prepared], b: Sequence[np.ndarray | Prepared]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first crossing of every polyline of ``a`` with every one of ``b`` (points, or :func:`prepare`'d),
    all segment pairs in one array: ``(found (A, B) bool, point (A, B, 2), arc position along the
    ``a`` line (A, B), along the ``b`` line (A, B))``. A pair's first crossing is its first in
    row-major order of segments (``a``'s, then ``b``'s)."""
    pa = [p if isinstance(p, Prepared) else prepare(p) for p in a]
    pb = [p if isinstance(p, Prepared) else prepare(p) for p in b]
    na, nb = len(pa), len(pb)
    found = np.zeros((na, nb), bool)
    point, pos_a, pos_b = np.zeros((na, nb, 2)), np.zeros((na, nb)), np.zeros((na, nb))
    if not na or not nb:
        return found, point, pos_a, pos_b
    la = np.repeat(np.arange(na), [len(p.seg) for p in pa])  # each segment's line
    lb = np.repeat(np.arange(nb), [len(p.seg) for p in pb])
    seg_a, seg_b = np.concatenate([p.seg for p in pa]), np.concatenate([p.seg for p in pb])
    pts_a, pts_b = np.concatenate([p.pts[:-1] for p in pa]), np.concatenate([p.pts[:-1] for p in pb])
    arc_a, arc_b = np.concatenate([p.arc[:-1] for p in pa]), np.concatenate([p.arc[:-1] for p in pb])
    lo_a, hi_a = np.concatenate([p.lo_a for p in pa]), np.concatenate([p.hi_a for p in pa])
    lo_b, hi_b = np.concatenate([p.lo for p in pb]), np.concatenate([p.hi for p in pb])
    # only segment pairs whose boxes meet can cross (a hair wider than exact: no rounding
    # could make a pair the boxes rule out cross); the pairs kept stay in row-major order
    ii, jj = np.nonzero((lo_a[:, None, 0] <= hi_b[None, :, 0]) & (lo_b[None, :, 0] <= hi_a[:, None, 0])
                        & (lo_a[:, None, 1] <= hi_b[None, :, 1]) & (lo_b[None, :, 1] <= hi_a[:, None, 1]))
    rr, ss = seg_a[ii], seg_b[jj]
    rxs = rr[:, 0] * ss[:, 1] - rr[:, 1] * ss[:, 0]
    qp = pts_b[jj] - pts_a[ii]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * ss[:, 1] - qp[:, 1] * ss[:, 0]) / rxs
        u = (qp[:, 0] * rr[:, 1] - qp[:, 1] * rr[:, 0]) / rxs
    ok = np.flatnonzero((np.abs(rxs) > 1e-9) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1))
    # each pair of lines' segments come in row-major order: its first entry is its first crossing
    _, first = np.unique(la[ii[ok]] * nb + lb[jj[ok]], return_index=True)
    for k in ok[first].tolist():
        i, j = ii[k], jj[k]
        x, y = la[i], lb[j]
        r, s = seg_a[i], seg_b[j]
        found[x, y] = True
        point[x, y] = pts_a[i] + t[k] * r
        pos_a[x, y] = float(arc_a[i] + t[k] * np.hypot(*r))
        pos_b[x, y] = float(arc_b[j] + u[k] * np.hypot(*s))
    return found, point, pos_a, pos_b


def first_crossing(a: np.ndarray | Prepared, b: np.ndarray | Prepared) -> tuple[np.ndarray, float, float] | None:
    """First crossing of polylines ``a`` and ``b`` (points, or :func:`prepare`'d): the point and
    its arc positions along each (:func:`all_crossings` of the one pair)."""
    found, point, pos_a, pos_b = all_crossings([a], [b])
    return (point[0, 0], float(pos_a[0, 0]), float(pos_b[0, 0])) if found[0, 0] else None


def resample(p: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` px along a polyline."""
    seg = np.hypot(*np.diff(p, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.arange(0.0, arc[-1] + 1e-9, step)
    return np.stack([np.interp(t, arc, p[:, 0]), np.interp(t, arc, p[:, 1])], axis=1)
