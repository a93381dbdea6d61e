"""The triangle index: every hole triangle the climber can hold, found by its side lengths.

A localisation compares the triangle of the three hands with the map's triangles; this
index makes that a binary search over quantised sides instead of a scan of all triples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .climber import ClimberGeometry
from .holes import HoleMap

__all__ = ["TriangleIndex"]


class TriangleIndex:
    """Every hole triangle the climber can hold, keyed by its sides in counter-clockwise order.

    A triangle is *holdable* when its three holes fit in a disc of the robot's largest
    reach (``l1 + l2`` plus the shoulder offset): some body centre then has every hole
    within reach. Each triangle is stored with its vertices counter-clockwise and under
    its three cyclic rotations, keyed by the side lengths ``(|v0 v1|, |v1 v2|, |v2 v0|)``
    quantised into ``cell`` cm: a query with the hands' sides in counter-clockwise arm order
    finds, by binary search, exactly the triangles of the same orientation - a mirror image
    has its sides in the other cyclic order and never matches. Built once per map and robot
    (O(N) memory); a query touches only the few cells around the measured sides.
    """

    def __init__(self, holes: HoleMap, geom: ClimberGeometry, cell: float = 0.25) -> None:
        self.holes, self.cell = holes, float(cell)
        reach = float(np.max(geom.l1 + geom.l2 + np.linalg.norm(geom.shoulders, axis=1)))
        self.reach = reach
        tri = _holdable_triangles(holes.xy, reach)
        xy = holes.xy
        sides = np.stack([
            np.linalg.norm(xy[tri[:, 0]] - xy[tri[:, 1]], axis=1),
            np.linalg.norm(xy[tri[:, 1]] - xy[tri[:, 2]], axis=1),
            np.linalg.norm(xy[tri[:, 2]] - xy[tri[:, 0]], axis=1),
        ], -1)
        self.triangles, self.sides = tri, sides
        rot_sides = np.concatenate([sides, np.roll(sides, -1, axis=1), np.roll(sides, -2, axis=1)])
        rot_tri = np.concatenate([tri, np.roll(tri, -1, axis=1), np.roll(tri, -2, axis=1)])
        keys = self._keys(np.floor(rot_sides / self.cell).astype(np.int64))
        order = np.argsort(keys, kind="stable")
        self.keys = keys[order]
        # each entry's vertices and sides in its own rotation, contiguous in key order, so a
        # query is a few slices: no per-entry gather through the triangle table
        self.entry_verts = np.ascontiguousarray(rot_tri[order].astype(np.int32 if len(xy) < 2**31 else np.int64))
        self.entry_sides = np.ascontiguousarray(rot_sides[order])

    @staticmethod
    def _keys(cells: np.ndarray) -> np.ndarray:
        cells = np.clip(cells, 0, (1 << 20) - 1)
        return (cells[..., 0] << 40) | (cells[..., 1] << 20) | cells[..., 2]

    def __len__(self) -> int:
        return len(self.triangles)

    def cell_of(self, sides: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Entries of the one cell that holds ``sides`` (cm, the query's vertex order):
        ``verts (K, 3)`` and their sides ``(K, 3)``, views into the index (one binary search)."""
        lim, cell = (1 << 20) - 1, self.cell
        i0, i1, i2 = (min(max(math.floor(v / cell), 0), lim) for v in sides)
        key = (i0 << 40) | (i1 << 20) | i2
        a = int(self.keys.searchsorted(key, "left"))
        b = int(self.keys.searchsorted(key, "right"))
        return self.entry_verts[a:b], self.entry_sides[a:b]

    def query(self, sides: Sequence[float], half_width: Sequence[float],
              cov: Sequence[Sequence[float]] | None = None, limit: float | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Triples whose sides lie near ``sides`` (cm, the query's vertex order).

        Without ``cov``: within the box ``|side - sides| <= half_width``. With ``cov`` (the
        3 x 3 covariance of the measured sides) and ``limit``: every triple whose side
        residual ``r`` may satisfy ``r' cov^-1 r <= limit``. The ellipsoid is sliced axis by
        axis (the range of side 1 given side 0's cell, of side 2 given both), so a strongly
        correlated covariance - all three sides stretching together - does not drag in the
        whole bounding box. The caller applies the exact test to what comes back.

        Returns ``verts (K, 3)`` (map rows in the query's vertex order) and their sides
        ``(K, 3)`` in the same order.
        """
        s0, s1, s2 = (float(v) for v in sides)
        cell, lim = self.cell, (1 << 20) - 1
        first: list[int] = []
        last: list[int] = []

        def add(i0: int, i1: int, lo2: int, hi2: int) -> None:
            if hi2 < lo2:
                return
            i0, i1 = min(max(i0, 0), lim), min(max(i1, 0), lim)
            base = (i0 << 40) | (i1 << 20)
            first.append(base | min(max(lo2, 0), lim))
            last.append(base | min(max(hi2, 0), lim))

        if cov is None:
            w0, w1, w2 = (float(v) for v in half_width)
            lo2, hi2 = math.floor((s2 - w2) / cell), math.floor((s2 + w2) / cell)
            for i0 in range(math.floor((s0 - w0) / cell), math.floor((s0 + w0) / cell) + 1):
                for i1 in range(math.floor((s1 - w1) / cell), math.floor((s1 + w1) / cell) + 1):
                    add(i0, i1, lo2, hi2)
        else:
            (c00, c01, c02), (_, c11, c12), (_, _, c22) = cov
            L = float(limit if limit is not None else 1.0)
            b10 = c01 / c00                                   # E[r1 | r0] = b10 r0
            v1 = max(c11 - c01 * b10, 0.0)
            det = c00 * c11 - c01 * c01                       # E[r2 | r0, r1] = g0 r0 + g1 r1
            g0, g1 = (c02 * c11 - c12 * c01) / det, (c12 * c00 - c02 * c01) / det
            v2 = max(c22 - g0 * c02 - g1 * c12, 0.0)
            h0, h1, h2 = math.sqrt(L * c00), math.sqrt(L * v1), math.sqrt(L * v2)
            for i0 in range(math.floor((s0 - h0) / cell), math.floor((s0 + h0) / cell) + 1):
                a0, b0 = max(i0 * cell - s0, -h0), min((i0 + 1) * cell - s0, h0)
                m_lo, m_hi = min(b10 * a0, b10 * b0) - h1, max(b10 * a0, b10 * b0) + h1
                for i1 in range(math.floor((s1 + m_lo) / cell), math.floor((s1 + m_hi) / cell) + 1):
                    a1, b1 = max(i1 * cell - s1, m_lo), min((i1 + 1) * cell - s1, m_hi)
                    corners = (g0 * a0 + g1 * a1, g0 * a0 + g1 * b1, g0 * b0 + g1 * a1, g0 * b0 + g1 * b1)
                    add(i0, i1, math.floor((s2 + min(corners) - h2) / cell),
                        math.floor((s2 + max(corners) + h2) / cell))
        keys = self.keys
        a = np.searchsorted(keys, first, "left")
        b = np.searchsorted(keys, last, "right")
        if len(first) == 1:
            idx: slice | np.ndarray = slice(int(a[0]), int(b[0]))
        else:
            counts = b - a
            total = int(counts.sum())
            idx = np.repeat(a - np.cumsum(counts) + counts, counts) + np.arange(total)
        if isinstance(idx, slice):
            got, verts = self.entry_sides[idx], self.entry_verts[idx]
        else:  # np.take: several times faster than fancy indexing here
            got, verts = np.take(self.entry_sides, idx, axis=0), np.take(self.entry_verts, idx, axis=0)
        if cov is None:
            keep = ((np.abs(got[:, 0] - s0) <= w0) & (np.abs(got[:, 1] - s1) <= w1)
                    & (np.abs(got[:, 2] - s2) <= w2))
            verts, got = verts[keep], got[keep]
        return verts, got


def _holdable_triangles(xy: np.ndarray, reach: float) -> np.ndarray:
    """All triples (counter-clockwise) whose minimum enclosing circle has radius <= reach."""
    n = len(xy)
    if n < 3:
        return np.empty((0, 3), dtype=np.int64)
    diam = 2.0 * reach
    cells = np.floor(xy / diam).astype(np.int64)
    shift = 1 << 31
    key = (cells[:, 0] + shift // 2) * shift + (cells[:, 1] + shift // 2)
    order = np.argsort(key, kind="stable")
    skey = key[order]
    pi_list, pj_list = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            q = key + dx * shift + dy
            a = np.searchsorted(skey, q, "left")
            b = np.searchsorted(skey, q, "right")
            cnt = b - a
            tot = int(cnt.sum())
            if tot == 0:
                continue
            i = np.repeat(np.arange(n), cnt)
            j = order[np.repeat(a - np.cumsum(cnt) + cnt, cnt) + np.arange(tot)]
            m = (j > i) & (np.sum((xy[i] - xy[j]) ** 2, axis=1) <= diam * diam)
            pi_list.append(i[m])
            pj_list.append(j[m])
    pi = np.concatenate(pi_list)
    pj = np.concatenate(pj_list)
    o = np.lexsort((pj, pi))
    pi, pj = pi[o], pj[o]
    pair_key = pi * n + pj
    # for pair (i, j), every k in i's forward list after j: candidate (i, j, k); keep if (j, k) is a pair
    seg_end = np.searchsorted(pi, pi, "right")
    cnt = seg_end - np.arange(len(pi)) - 1
    tot = int(cnt.sum())
    if tot == 0:
        return np.empty((0, 3), dtype=np.int64)
    base = np.repeat(np.arange(len(pi)), cnt)
    off = np.arange(tot) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1
    ti, tj, tk = pi[base], pj[base], pj[base + off]
    pos = np.searchsorted(pair_key, tj * n + tk)
    pos = np.minimum(pos, len(pair_key) - 1)
    ok = pair_key[pos] == tj * n + tk
    ti, tj, tk = ti[ok], tj[ok], tk[ok]
    a, b, c = xy[ti], xy[tj], xy[tk]
    # minimum enclosing circle: half the longest side if the triangle is right/obtuse, else circumradius
    ab2, bc2, ca2 = ((a - b) ** 2).sum(1), ((b - c) ** 2).sum(1), ((c - a) ** 2).sum(1)
    longest2 = np.maximum(np.maximum(ab2, bc2), ca2)
    obtuse = 2 * longest2 >= ab2 + bc2 + ca2
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        circ = np.sqrt(ab2 * bc2 * ca2) / (2 * np.abs(cross))
    radius = np.where(obtuse, 0.5 * np.sqrt(longest2), circ)
    keep = radius <= reach + 1e-9
    ti, tj, tk, cross = ti[keep], tj[keep], tk[keep], cross[keep]
    cw = cross < 0
    tj2 = np.where(cw, tk, tj)
    tk2 = np.where(cw, tj, tk)
    return np.stack([ti, tj2, tk2], -1).astype(np.int64)
