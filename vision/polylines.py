"""Polyline geometry for hand-drawn lines (points ``(N, 2)``, image px): straight extensions
at both ends, the first crossing of two polylines with its arc positions, points at a fixed
step along a polyline. Used by :mod:`~kinegym.vision.hand_grid`, whose traced grid lines are
polylines (a hand-drawn line is wavy, so it is followed, not fitted with one straight line).
"""

from __future__ import annotations

import numpy as np

__all__ = ["extend", "first_crossing", "resample"]


def extend(p: np.ndarray, by: float) -> np.ndarray:
    """A polyline with straight extensions of ``by`` px at both ends."""
    d0 = p[0] - p[1]
    d1 = p[-1] - p[-2]
    d0 = d0 / max(float(np.hypot(*d0)), 1e-9)
    d1 = d1 / max(float(np.hypot(*d1)), 1e-9)
    return np.concatenate([[p[0] + by * d0], p, [p[-1] + by * d1]])


def first_crossing(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """First crossing of polylines ``a`` and ``b``: the point and its arc positions along each."""
    p, r = a[:-1], a[1:] - a[:-1]
    q, s = b[:-1], b[1:] - b[:-1]
    # only segment pairs whose boxes meet can cross (a hair wider than exact: no rounding
    # could make a pair the boxes rule out cross); the pairs kept stay in row-major order
    lo_a, hi_a = np.minimum(a[:-1], a[1:]) - 1e-6, np.maximum(a[:-1], a[1:]) + 1e-6
    lo_b, hi_b = np.minimum(b[:-1], b[1:]), np.maximum(b[:-1], b[1:])
    ii, jj = np.nonzero((lo_a[:, None, 0] <= hi_b[None, :, 0]) & (lo_b[None, :, 0] <= hi_a[:, None, 0])
                        & (lo_a[:, None, 1] <= hi_b[None, :, 1]) & (lo_b[None, :, 1] <= hi_a[:, None, 1]))
    rr, ss = r[ii], s[jj]
    rxs = rr[:, 0] * ss[:, 1] - rr[:, 1] * ss[:, 0]
    qp = q[jj] - p[ii]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * ss[:, 1] - qp[:, 1] * ss[:, 0]) / rxs
        u = (qp[:, 0] * rr[:, 1] - qp[:, 1] * rr[:, 0]) / rxs
    ok = np.flatnonzero((np.abs(rxs) > 1e-9) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1))
    if not len(ok):
        return None
    k = ok[0]
    i, j = ii[k], jj[k]
    la = np.concatenate([[0.0], np.cumsum(np.hypot(*r.T))])
    lb = np.concatenate([[0.0], np.cumsum(np.hypot(*s.T))])
    pt = p[i] + t[k] * r[i]
    return pt, float(la[i] + t[k] * np.hypot(*r[i])), float(lb[j] + u[k] * np.hypot(*s[j]))


def resample(p: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` px along a polyline."""
    seg = np.hypot(*np.diff(p, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.arange(0.0, arc[-1] + 1e-9, step)
    return np.stack([np.interp(t, arc, p[:, 0]), np.interp(t, arc, p[:, 1])], axis=1)
