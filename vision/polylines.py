"""Polyline geometry for hand-drawn lines (points ``(N, 2)``, image px): straight extensions
at both ends, the first crossing of two polylines with its arc positions, points at a fixed
step along a polyline. Used by :mod:`~kinegym.vision.hand_grid`, whose traced grid lines are
polylines (a hand-drawn line is wavy, so it is followed, not fitted with one straight line).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["extend", "first_crossing", "prepare", "Prepared", "resample"]


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


def first_crossing(a: np.ndarray | Prepared, b: np.ndarray | Prepared) -> tuple[np.ndarray, float, float] | None:
    """First crossing of polylines ``a`` and ``b`` (points, or :func:`prepare`'d): the point and
    its arc positions along each."""
    A = a if isinstance(a, Prepared) else prepare(a)
    B = b if isinstance(b, Prepared) else prepare(b)
    # only segment pairs whose boxes meet can cross (a hair wider than exact: no rounding
    # could make a pair the boxes rule out cross); the pairs kept stay in row-major order
    lo_a, hi_a, lo_b, hi_b = A.lo_a, A.hi_a, B.lo, B.hi
    ii, jj = np.nonzero((lo_a[:, None, 0] <= hi_b[None, :, 0]) & (lo_b[None, :, 0] <= hi_a[:, None, 0])
                        & (lo_a[:, None, 1] <= hi_b[None, :, 1]) & (lo_b[None, :, 1] <= hi_a[:, None, 1]))
    rr, ss = A.seg[ii], B.seg[jj]
    rxs = rr[:, 0] * ss[:, 1] - rr[:, 1] * ss[:, 0]
    qp = B.pts[jj] - A.pts[ii]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * ss[:, 1] - qp[:, 1] * ss[:, 0]) / rxs
        u = (qp[:, 0] * rr[:, 1] - qp[:, 1] * rr[:, 0]) / rxs
    ok = np.flatnonzero((np.abs(rxs) > 1e-9) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1))
    if not len(ok):
        return None
    k = ok[0]
    i, j = ii[k], jj[k]
    r, s = A.seg[i], B.seg[j]
    return A.pts[i] + t[k] * r, float(A.arc[i] + t[k] * np.hypot(*r)), float(B.arc[j] + u[k] * np.hypot(*s))


def resample(p: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` px along a polyline."""
    seg = np.hypot(*np.diff(p, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.arange(0.0, arc[-1] + 1e-9, step)
    return np.stack([np.interp(t, arc, p[:, 0]), np.interp(t, arc, p[:, 1])], axis=1)
