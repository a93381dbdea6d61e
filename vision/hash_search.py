"""The '#' search's fast kernel: :func:`best_hash` gives what
:func:`~kinegym.vision.hand_grid._best_hash` (the readable reference) gives, bit for bit, with every
choice of tracks scored at once in numpy instead of one by one in Python (up to 35 x 35 choices of 4
tracks a family for a 5 x 5 '#'). On the 15 real photos at 960 x 720 a call takes a third to a quarter
of the reference's time (0.9 ms against 2.8 for 3 x 3, 0.8 against 3.2 for 5 x 5; the reference's
track sharing included, found once per search for the kernel). ``tests/test_hash_search.py`` holds
the two equal on real photos' tracks and on random ones.

Two steps, each the reference's own arithmetic in the same order (so the same floats):

1. **Every crossing at once** (:func:`pairs`, once for both board sizes): the segments of all tracks
   of one family against all of the other's in one array
   (:func:`~kinegym.vision.polylines.all_crossings`, which the reference's
   :func:`~kinegym.vision.polylines.first_crossing` runs for one pair).
2. **Every choice at once.** Each choice of ``k`` tracks per family is a row: its crossings ordered
   across, the lattice's folds, cell sizes, arms and colours tested, and its score summed line by line
   as the reference sums it. The first best row wins, as the reference's ``>`` keeps the first.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .ink import unit
from .polylines import all_crossings, extend
from .ruling import HUE_DEG
from .tracks import EDGE_TO_EDGE_COST, INK_SPREAD_FREE, INK_SPREAD_WEIGHT, Track, _sharing

__all__ = ["best_hash", "pairs", "Pairs"]


def _choices(n: int, k: int, share: np.ndarray) -> np.ndarray:
    """``(C, k)`` the choices of ``k`` of ``n`` tracks no two of which share a stroke, in
    :func:`itertools.combinations` order."""
    out = [c for c in itertools.combinations(range(n), k)
           if not any(share[i, j] for i, j in itertools.combinations(c, 2))]
    return np.array(out, np.intp).reshape(len(out), k)


@dataclass(frozen=True)
class Pairs:
    """What every choice of tracks of two families draws on, found once for every board size: the
    extension ``ext`` (px) each line was given at both ends, the pen ``width`` (px), which tracks of a
    family share a stroke at it (``share_a``/``share_b``, :func:`~kinegym.vision.tracks._sharing`), the
    first crossing of every a-line with every b-line (:func:`~kinegym.vision.polylines.all_crossings`
    of the extended lines)
    and each extended line's length (px)."""

    ext: float
    width: float
    share_a: np.ndarray
    share_b: np.ndarray
    found: np.ndarray
    point: np.ndarray
    pos_a: np.ndarray
    pos_b: np.ndarray
    length_a: np.ndarray
    length_b: np.ndarray


def pairs(fa: list[Track], fb: list[Track], ext: float, width: float) -> Pairs:
    """:class:`Pairs` of the two families ``fa``, ``fb``, their lines extended by ``ext`` px, drawn
    with a pen ``width`` px wide."""
    ea = [extend(t.pts, ext) for t in fa]
    eb = [extend(t.pts, ext) for t in fb]
    length_a, length_b = ([float(np.hypot(*np.diff(e, axis=0).T).sum()) for e in es] for es in (ea, eb))
    return Pairs(ext, width, _sharing(fa, width), _sharing(fb, width), *all_crossings(ea, eb), np.array(length_a),
                 np.array(length_b))


def best_hash(fa: list[Track], fb: list[Track], k: int, shape: tuple[int, int], p: Pairs
              ) -> tuple[float, tuple[int, ...], tuple[int, ...], np.ndarray] | None:
    """:func:`~kinegym.vision.hand_grid._best_hash` of the same tracks (``p``: their :func:`pairs` at the
    reference's ``ext`` and ``width``), scored as one array."""
    h, w = shape
    side = float(max(h, w))
    ext = p.ext
    ca, cb = _choices(len(fa), k, p.share_a), _choices(len(fb), k, p.share_b)
    if not len(ca) or not len(cb):
        return None
    found, point, pos_a0, pos_b0 = p.found, p.point, p.pos_a, p.pos_b
    # every choice pair (a's choice outer, b's inner: the reference's loop order) whose crossings all exist
    A = np.repeat(ca, len(cb), axis=0)  # (N, k)
    B = np.tile(cb, (len(ca), 1))
    ok = found[A[:, :, None], B[:, None, :]].all(axis=(1, 2))
    A, B = A[ok], B[ok]
    if not len(A):
        return None
    pts = point[A[:, :, None], B[:, None, :]]  # (N, k, k, 2)
    pos_a, pos_b = pos_a0[A[:, :, None], B[:, None, :]], pos_b0[A[:, :, None], B[:, None, :]]
    rows = np.arange(len(A))[:, None]
    oa = np.argsort(pos_b[:, :, 0], axis=1, kind="stable")
    ob = np.argsort(pos_a[:, 0, :], axis=1, kind="stable")
    pts = pts[rows[:, :, None], oa[:, :, None], ob[:, None, :]]
    pos_a = pos_a[rows[:, :, None], oa[:, :, None], ob[:, None, :]]
    pos_b = pos_b[rows[:, :, None], oa[:, :, None], ob[:, None, :]]
    A0, B0 = A, B  # (the colours are summed in the choice's own order, as the reference sums them)
    A, B = np.take_along_axis(A, oa, axis=1), np.take_along_axis(B, ob, axis=1)
    da, db = np.diff(pos_a, axis=2), np.diff(pos_b, axis=1)
    keep = (np.all(da > 0, axis=(1, 2)) | np.all(da < 0, axis=(1, 2))) & \
           (np.all(db > 0, axis=(1, 2)) | np.all(db < 0, axis=(1, 2)))
    allsz = np.concatenate([np.abs(da).reshape(len(A), -1), np.abs(db).reshape(len(A), -1)], axis=1)
    v = np.sort(allsz, axis=1)
    m = v.shape[1] // 2
    cell = v[:, m] if v.shape[1] % 2 else (v[:, m - 1] + v[:, m]) / 2
    keep &= ~(cell < 0.06 * max(h, w)) & ~(v[:, -1] > 2.6 * v[:, 0])
    score = np.zeros(len(A))
    short = np.zeros(len(A), bool)  # a line too short for its cells and an arm: no '#' (the reference skips it)
    missing = np.zeros(len(A), np.intp)
    across = np.zeros(len(A), np.intp)  # chosen lines that run from the photo's edge to its edge
    margin = 0.04 * max(h, w)

    def at_edge(p: np.ndarray) -> bool:
        return bool(p[0] < margin or p[1] < margin or p[0] > w - margin or p[1] > h - margin)

    for tracks, ln, chosen, pos, axis in ((fa, p.length_a, A, pos_a, 1), (fb, p.length_b, B, pos_b, 0)):
        span = np.array([t.span for t in tracks])
        strength = np.array([t.strength for t in tracks])
        edge0 = np.array([at_edge(t.pts[0]) for t in tracks])
        edge1 = np.array([at_edge(t.pts[-1]) for t in tracks])
        across += (edge0 & edge1)[chosen].sum(axis=1)
        for x in range(k):
            i = chosen[:, x]
            q = pos[:, x, :] if axis == 1 else pos[:, :, x]
            now_short = ~short & (span[i] < (k - 1 + 0.4) * cell)
            short |= now_short
            live = ~short
            score = np.where(live, score + strength[i] * np.minimum(span[i], (k + 1.5) * cell) / side, score)
            for arm, edge in ((q.min(axis=1) - ext, edge0[i]), (ln[i] - ext - q.max(axis=1), edge1[i])):
                no_arm = live & (arm < 0.15 * cell) & ~edge
                score = np.where(no_arm, score - 0.15, score)
                missing += no_arm
    keep &= ~(missing > k)
    score = score - EDGE_TO_EDGE_COST * across
    with np.errstate(divide="ignore", invalid="ignore"):  # (rows with a cell of size 0 are not kept)
        ratio = v[:, -1] / v[:, 0] - 1.0
    outside = (pos_a < ext - 2).sum(axis=(1, 2)) + (pos_b < ext - 2).sum(axis=(1, 2))
    score = score - 0.1 * outside
    score = score - 0.3 * ratio
    keep &= ~short
    if fa[0].colour is not None:  # one pen draws a '#': lines of another colour are something else
        hue = np.array([t.colour for t in fa + fb])
        u = hue[np.concatenate([A0, len(fa) + B0], axis=1)]  # (N, 2k, 3)
        for r in np.flatnonzero(keep):
            spread = math.degrees(math.acos(float(np.clip((u[r] @ unit(u[r].sum(axis=0))).min(), -1.0, 1.0))))
            score[r] -= 0.02 * max(0.0, spread - HUE_DEG)
    inks = np.array([t.ink for t in fa + fb])[np.concatenate([A0, len(fa) + B0], axis=1)]  # one pen: inks alike
    times = inks.max(axis=1) / np.maximum(inks.min(axis=1), 1e-9)
    for r in np.flatnonzero(keep & (times > INK_SPREAD_FREE)):  # (math.log, as the reference takes it)
        score[r] -= INK_SPREAD_WEIGHT * math.log(float(times[r]) / INK_SPREAD_FREE)
    if not keep.any():
        return None
    r = int(np.flatnonzero(keep)[np.argmax(score[keep])])
    return float(score[r]), tuple(int(i) for i in A[r]), tuple(int(j) for j in B[r]), pts[r]
