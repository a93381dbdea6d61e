"""Tracing a hand-drawn grid's candidate lines: the two line directions of the ink and, along each,
its strokes traced as *tracks* (polylines that may bend), for :mod:`~kinegym.vision.hand_grid`'s
'#' search (its steps 2 and 3).

- **Directions** (:func:`_directions`): the angles at which the ink's projection is most peaked
  (a Radon energy that long strokes dominate); the second at least 40 deg from the first, and a
  rival second peak tried too.
- **Thick ink apart** (:func:`_line_directions`): a pen, a ruler or a binding lying in view is
  thicker than the strokes and, long and straight, the strongest direction of all; where such
  thick ink holds a share of the mask, the directions are sought again in the thin ink alone.
- **Tracks** (:func:`_tracks`): the ink turned so that a family runs vertically and cut into
  :data:`_BANDS` bands across it; in each band a stroke of the family is a peak of the ink summed
  along the band. Peaks are linked from band to band, allowing drift (perspective, waves) and gaps
  (a faint or broken pen); a peak that the track's own ink runs on to is taken before a nearer one
  it does not (:func:`_joined`: across a crossing, another stroke's peak may lie nearer the
  prediction). Each track is then lengthened along the ink at both ends (:func:`_follow_ends`).
- **Dense trace** (:func:`_dense`): a chosen track followed every 2 px along its stroke.
- **Sharing** (:func:`_sharing`): which tracks of a family run along the same stroke (a track that
  strays off a line into a mark shares the line's start); no two of them are one '#''s lines.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from .polylines import resample

__all__ = ["Track"]

_BANDS = 18  # bands across a family (each about a 1/18 of the image)
_RIVAL = 0.5  # a second direction peak this high (above the median energy) as the first is tried too

#: Ink that holds a square this many stroke widths wide is *thick* (a pen lying on the page, a ruler,
#: a binding, not a stroke); where it is :data:`THICK_SHARE` of the mask or more, the line directions
#: are sought again in the thin ink alone (:func:`_line_directions`). The 15 real photos with a pen
#: lying beside the board (a bar 2.5 stroke widths thick) read 8 -> 13 of 15 (stop 69; at 3 widths
#: it was not found thick there: 9).
THICK_WIDTHS = 2.0
#: The share of the ink mask thick ink must hold (stop 69: at 0.05 and 0.2 the pen scenes read 13 of
#: 15 alike; on the real-like sets 0.05 read +5 -5 / +4 of a fresh 300, 0.2 +3 -3 / +3).
THICK_SHARE = 0.2
#: One pen draws a '#': a choice of lines whose inks (:attr:`Track.ink`) differ more than this many
#: times - a dark pen lying on the page taken for a row line beside pale drawn ones (ink 6.8 against
#: 0.6) - scores :data:`INK_SPREAD_WEIGHT` less per e-fold beyond it (the '#' search, reference and
#: kernel). A line gone over twice, or fading, stays well within. Stop 70: the real photos with a pen
#: beside them read image10's '#' right; of the real-like photos 20,000-20,999, 40,000-40,299 and
#: 60,000-60,299, at 3 x +3 -4 boards, at 8 x one reading changed (20,205, a zoomed second look's).
INK_SPREAD_FREE = 8.0
#: What a choice of '#' lines loses per e-fold of ink spread past :data:`INK_SPREAD_FREE`.
INK_SPREAD_WEIGHT = 0.5
#: What a choice of '#' lines loses for each line that runs from the photo's edge to its edge (both
#: ends within 4 % of the side of a border): a page's edge, a notebook's spiral binding, a table's
#: edge. A drawn line ends on the page, or is cut off at one end. Stop 70: the 15 real photos with a
#: spiral binding along a side read 8 -> 11 of 15 (the binding had been a column line).
EDGE_TO_EDGE_COST = 1.0


@dataclass
class Track:
    """One traced stroke of a family: ``pts`` ``(K, 2)`` image px along it, one per band it
    shows in, ``strength`` the mean ink of its peaks relative to a straight stroke of the
    measured width, ``bands`` the number of bands with ink."""

    pts: np.ndarray
    strength: float
    bands: int
    frame: tuple[np.ndarray, np.ndarray] | None = None  # (turning affine, turned mask) it was traced in
    ink: float = 0.0  # darkness summed across the stroke (px x darkness), mean over its bands
    dense: np.ndarray | None = None  # traced every 2 px, once chosen
    colour: np.ndarray | None = None  # unit RGB darkness of its ink (:func:`~kinegym.vision.ink.ink_colour`)

    @property
    def span(self) -> float:
        """End-to-end distance (px): a track that zigzags between strokes gains nothing."""
        return float(np.hypot(*(self.pts[-1] - self.pts[0])))


def _directions(mask: np.ndarray, width: float) -> list[tuple[float, float]]:
    """The two families' line directions (rad, 0..pi), best pair first: the angles at which the
    ink's projection is most peaked (sum of squared counts in stroke-wide bins, a Radon energy
    long strokes dominate), the second at least 40 deg from the first. A rival second peak, at
    least :data:`_RIVAL` as high above the median (converging or bent lines spread their peak,
    X's line up their strokes), makes a second pair: the '#' scores decide."""
    ink = cv2.findNonZero(mask)  # (np.nonzero's row-major order, in a third of its time)
    xs, ys = (ink[:, 0, 0], ink[:, 0, 1]) if ink is not None else (np.zeros(0, np.int32), np.zeros(0, np.int32))
    if len(xs) > 12000:  # a fixed subsample: the energy's shape needs no more
        pick = np.linspace(0, len(xs) - 1, 12000).astype(np.intp)
        xs, ys = xs[pick], ys[pick]
    step = 2
    th = np.radians(np.arange(0, 180, step))  # normal angles
    c, s = np.cos(th), np.sin(th)
    xs, ys = xs.astype(np.float64), ys.astype(np.float64)
    binw = max(2.0, width)
    energy = np.empty(len(th))
    for a0 in range(0, len(th), 30):  # 30 angles at a time, in place: a quarter of the time
        proj = np.outer(c[a0:a0 + 30], xs)  # (30, N)
        proj += np.outer(s[a0:a0 + 30], ys)
        proj -= proj.min(axis=1, keepdims=True)
        proj /= binw
        b = proj.astype(np.intp)
        nb = int(b.max()) + 1
        b += nb * np.arange(len(b))[:, None]
        counts = np.bincount(b.ravel(), minlength=nb * len(b)).reshape(len(b), nb)
        energy[a0:a0 + 30] = (counts.astype(np.float64) ** 2).sum(axis=1)
    energy = np.convolve(np.concatenate([energy[-2:], energy, energy[:2]]), [0.25, 0.5, 1.0, 0.5, 0.25], "same")[2:-2]
    i = int(np.argmax(energy))
    m = len(th)
    off = np.abs(((np.arange(m) - i + m // 2) % m) - m // 2) * step  # degrees apart
    peak = (energy >= np.roll(energy, 1)) & (energy >= np.roll(energy, -1)) & (off >= 40)
    js = [int(j) for j in np.argsort(-np.where(peak, energy, -1.0))[:2] if peak[j]] or [(i + m // 2) % m]
    floor = float(np.median(energy))
    js = js[:1] + [j for j in js[1:] if energy[j] - floor >= _RIVAL * (energy[js[0]] - floor)]
    # line directions: the normals turned a quarter
    return [(float(np.mod(th[i] + np.pi / 2, np.pi)), float(np.mod(th[j] + np.pi / 2, np.pi))) for j in js]


def _line_directions(mask: np.ndarray, width: float) -> list[tuple[float, float]]:
    """:func:`_directions` of ``mask`` (stroke ``width`` px), then, where :data:`THICK_SHARE` of it
    or more is thick ink (it holds a square :data:`THICK_WIDTHS` widths wide), the pairs of the
    thin ink alone that are new (one of their directions 6 deg or more off each found pair's):
    the thick thing's own direction took the first place, and a family within 40 deg of it was
    never tried."""
    dirs = _directions(mask, width)
    k = int(math.ceil(THICK_WIDTHS * width)) | 1
    thick = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((k, k), np.uint8))
    if cv2.countNonZero(thick) < THICK_SHARE * max(cv2.countNonZero(mask), 1):
        return dirs
    thin = mask.copy()
    thin[cv2.dilate(thick, np.ones((3, 3), np.uint8)) > 0] = 0

    def same(p: tuple[float, float], q: tuple[float, float]) -> bool:
        return any(all(abs(math.remainder(a - b, math.pi)) < math.radians(6) for a, b in zip(p, r))
                   for r in (q, q[::-1]))

    return dirs + [p for p in _directions(thin, width) if not any(same(p, q) for q in dirs)]


def _rotation(phi: float, shape: tuple[int, int]) -> tuple[np.ndarray, tuple[int, int]]:
    """Affine ``(2, 3)`` turning direction ``phi`` to +y (image px -> turned px), and the
    turned image's size (w, h)."""
    h, w = shape
    a = math.pi / 2 - phi
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], float) @ R.T
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    M = np.concatenate([R, -lo[:, None]], axis=1)
    size = (int(math.ceil(hi[0] - lo[0])), int(math.ceil(hi[1] - lo[1])))
    return M, size


def _tracks(mask: np.ndarray, phi: float, width: float, dark: np.ndarray
            ) -> tuple[list[Track], np.ndarray, np.ndarray]:
    """Tracks of the family running along ``phi``; also the turning affine and the turned
    mask. ``dark`` is the darkness under the mask (float32, above 0 exactly where the mask is
    set): a track's ``ink``."""
    M, (wr, hr) = _rotation(phi, mask.shape)
    turned_dark = cv2.warpAffine(dark, M, (wr, hr), flags=cv2.INTER_NEAREST)
    # the turned mask is where the turned darkness is: the same px as turning the mask, one warp less
    rot = (turned_dark > 0).view(np.uint8)
    hb = max(4, hr // _BANDS)
    nb = hr // hb
    ww = max(3, int(round(0.3 * hb)) | 1)
    prof, dprof = (cv2.blur(m[: nb * hb].reshape(nb, hb, wr).sum(axis=1, dtype=np.float32), (ww, 1)) * ww
                   for m in (rot, turned_dark))
    # (the band's ink within a window - a slanted stroke stays whole - as sums, not means)
    full = hb * width  # a stroke of the family crossing the whole band
    thr = 0.5 * full
    local_max = cv2.dilate(prof, np.ones((1, ww), np.uint8))
    peaks = (prof >= thr) & (prof >= local_max)
    peaks[:, 1:] &= ~peaks[:, :-1]  # one peak per plateau: its first px
    tol0 = max(3.0, 0.4 * hb)
    r = int(math.ceil(width)) + 1
    wide: np.ndarray | None = None  # the turned mask widened r px across, when first needed
    active: list[dict] = []
    done: list[dict] = []
    for k in range(nb):
        xs = np.flatnonzero(peaks[k])
        vals = prof[k, xs].tolist()
        taken = [False] * len(xs)
        # extend active tracks: a peak the track's ink runs on to first, then the nearest prediction
        # (ties: the older track, then the left peak)
        if active and len(xs):
            last_k = np.array([tr["k"][-1] for tr in active])
            last_x = np.array([tr["x"][-1] for tr in active])
            gap = k - last_k
            pred = last_x + np.array([tr["slope"] for tr in active]) * gap
            dist = np.abs(xs[None, :] - pred[:, None])
            ti, pi = np.nonzero(dist <= (tol0 * gap)[:, None])
            if len(np.unique(ti)) < len(ti) or len(np.unique(pi)) < len(pi):
                # rivals: a peak the track's ink runs on to comes first (across a crossing, another
                # stroke's peak may lie nearer the prediction than the track's own)
                if wide is None:
                    wide = cv2.dilate(rot, np.ones((1, 2 * r + 1), np.uint8))  # ink within r px across
                ends = np.stack([last_x[ti], (last_k[ti] + 0.5) * hb], axis=1)
                joined = _joined(wide, ends, np.stack([xs[pi], np.full(len(pi), (k + 0.5) * hb)], axis=1))
            else:  # no track or peak has two candidates: the order changes nothing
                joined = np.ones(len(ti), bool)
            order = np.lexsort((pi, ti, dist[ti, pi], ~joined))
            cand = zip(ti[order].tolist(), pi[order].tolist())
        else:
            cand = iter(())
        used_t: set[int] = set()
        for ti, pi in cand:
            if ti in used_t or taken[pi]:
                continue
            tr = active[ti]
            gap = k - tr["k"][-1]
            new_slope = (xs[pi] - tr["x"][-1]) / gap
            tr["slope"] = new_slope if len(tr["k"]) == 1 else 0.5 * (tr["slope"] + new_slope)
            tr["k"].append(k)
            tr["x"].append(float(xs[pi]))
            tr["v"].append(vals[pi])
            tr["d"].append(float(dprof[k, xs[pi]]))
            used_t.add(ti)
            taken[pi] = True
        for pi, t in enumerate(taken):
            if not t:
                active.append({"k": [k], "x": [float(xs[pi])], "v": [vals[pi]], "d": [float(dprof[k, xs[pi]])],
                               "slope": 0.0})
        still = []
        for tr in active:
            (still if k - tr["k"][-1] <= 2 else done).append(tr)
        active = still
    done.extend(active)
    Minv = cv2.invertAffineTransform(M)
    out = []
    for tr in done:
        # strength: peak ink per band, times the share of the spanned bands that show ink (a
        # chain of marks in a row links into a track too, with gaps between the marks)
        cover = len(tr["k"]) / (tr["k"][-1] - tr["k"][0] + 1)
        if len(tr["k"]) < 3 or cover < 0.6:
            continue
        q = np.array([tr["x"], [(kk + 0.5) * hb for kk in tr["k"]]]).T
        q = _follow_ends(rot, q, width, hb)
        pts = q @ Minv[:, :2].T + Minv[:, 2]
        out.append(Track(pts, min(1.0, float(np.mean(tr["v"])) / full) * cover, len(tr["k"]),
                         ink=float(np.mean(tr["d"])) / hb))
    return out, M, rot


def _joined(wide: np.ndarray, a: np.ndarray, b: np.ndarray, share: float = 0.85) -> np.ndarray:
    """``(N,)`` bool: whether ink (``wide``, the turned mask widened across) runs along the straight
    step from each point of ``a`` ``(N, 2)`` to the one of ``b`` (turned px), at ``share`` of its rows."""
    hr, wr = wide.shape
    t = np.linspace(0.0, 1.0, 33)[None, :]
    x = np.clip(np.rint(a[:, :1] + t * (b[:, :1] - a[:, :1])).astype(np.intp), 0, wr - 1)
    y = np.clip(np.rint(a[:, 1:] + t * (b[:, 1:] - a[:, 1:])).astype(np.intp), 0, hr - 1)
    return (wide[y, x] > 0).mean(axis=1) >= share


def _follow_ends(rot: np.ndarray, q: np.ndarray, width: float, hb: int) -> np.ndarray:
    """A track ``q`` (turned px, rows increasing) lengthened at both ends along the ink: the
    band peaks stop up to a band short of a stroke's end (a part-filled band is below the
    threshold). Rows beyond each end are searched within a stroke width or two of the track's
    straight continuation; two rows in three without ink end the stroke."""
    hr, wr = rot.shape
    r = int(math.ceil(width + 2))
    out = [q]
    for end, nxt, sign in ((q[0], q[1], -1), (q[-1], q[-2], 1)):
        slope = (end[0] - nxt[0]) / (end[1] - nxt[1]) if end[1] != nxt[1] else 0.0
        rows = end[1] + sign * np.arange(1, int(1.5 * hb))
        ri = np.rint(rows).astype(np.intp)  # the rows as indexed: a row at 535.6 is row 536
        keep = (ri >= 0) & (ri < hr)
        rows, ri = rows[keep], ri[keep]
        if not len(rows):
            continue
        xc = np.rint(end[0] + slope * (rows - end[1])).astype(np.intp)
        cols = xc[:, None] + np.arange(-r, r + 1)[None, :]
        inside = (cols >= 0) & (cols < wr)
        hit = (rot[ri[:, None], np.clip(cols, 0, wr - 1)] > 0) & inside
        ink = hit.any(axis=1)
        miss = ~ink
        gap = miss[:-2] & miss[1:-1] | miss[1:-1] & miss[2:] if len(miss) > 2 else miss
        stop = int(np.argmax(gap)) if gap.any() else len(ink)
        on = np.flatnonzero(ink[:stop])
        if not len(on):
            continue
        last = on[-1]
        p = np.array([[end[0] + slope * (rows[last] - end[1]), rows[last]]])
        out = [p] + out if sign < 0 else out + [p]
    return np.concatenate(out, axis=0)


def _dense(tr: Track, width: float) -> np.ndarray:
    """The track traced every 2 px along its stroke (image px): per row of the turned
    image, the ink pixel nearest the band polyline within a third of a band; rows without
    ink keep the polyline. A wavy line is followed, not cut across."""
    M, rot = tr.frame
    hr, wr = rot.shape
    q = tr.pts @ M[:, :2].T + M[:, 2]
    if q[0, 1] > q[-1, 1]:
        q = q[::-1]
    hb = max(4, hr // _BANDS)
    rows = np.arange(q[0, 1], q[-1, 1], 2.0)
    if len(rows) < 2:
        return tr.pts
    pred = np.interp(rows, q[:, 1], q[:, 0])
    r = max(2, int(0.35 * hb))
    off = np.arange(-r, r + 1)
    cols = np.rint(pred).astype(np.intp)[:, None] + off[None, :]
    ri = np.clip(np.rint(rows).astype(np.intp), 0, hr - 1)
    inside = (cols >= 0) & (cols < wr)
    hit = (rot[ri[:, None], np.clip(cols, 0, wr - 1)] > 0) & inside
    near = np.where(hit, np.abs(off)[None, :], 10 ** 6).argmin(axis=1)
    x = np.where(hit.any(axis=1), np.rint(pred) + off[near], pred)
    if len(x) >= 5:  # a run of 5 rows' median (the middle of the 5 sorted): a stray pixel does not pull the trace
        x = np.sort(np.lib.stride_tricks.sliding_window_view(np.pad(x, 2, mode="edge"), 5), axis=1)[:, 2]
    Minv = cv2.invertAffineTransform(M)
    return np.stack([x, rows], axis=1) @ Minv[:, :2].T + Minv[:, 2]


def _sharing(tracks: list[Track], width: float) -> np.ndarray:
    """``(T, T)`` bool: pairs of tracks that run along the same stroke for a quarter of the
    shorter one (a track that strays off a line into a mark shares the line's start)."""
    pts = [resample(t.pts, 3.0) for t in tracks]
    out = np.zeros((len(tracks), len(tracks)), bool)
    near = 2.0 * width + 2.0
    lo = np.array([p.min(axis=0) for p in pts]) - near
    hi = np.array([p.max(axis=0) for p in pts]) + near
    for i, j in itertools.combinations(range(len(tracks)), 2):
        if np.any(lo[i] > hi[j]) or np.any(lo[j] > hi[i]):
            continue  # no point of one is near the other's box, let alone the other
        a, b = (pts[i], pts[j]) if len(pts[i]) <= len(pts[j]) else (pts[j], pts[i])
        dx, dy = a[:, 0, None] - b[None, :, 0], a[:, 1, None] - b[None, :, 1]
        dist = np.sqrt((dx * dx + dy * dy).min(axis=1))  # (the root of the least square: the least distance)
        out[i, j] = out[j, i] = bool(np.mean(dist < near) > 0.25)
    return out
