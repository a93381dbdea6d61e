"""Finding a hand-drawn '#' grid: wavy, converging, unframed lines traced as curves, and the
grid chosen as the set of long strokes that cross each other the way a tic-tac-toe grid does.

Steps (all on one working copy of the ink map, about :data:`GRID_SIDE_PX` on its longer side,
so that every photo from 500 to 4,000 px is processed at the same scale):

1. **Ink mask, adaptive.** A pixel is ink when it is darker than its background by more
   than the image's own noise (a robust spread of the darkness over the whole image, which
   is mostly paper) and than a share of its strongest strokes: pale ballpoint and light
   marker next to nothing darker are kept, paper texture is not. Where a textured table in
   view puts that noise above a pencil '#', the page's own noise is tried last. The stroke
   width is measured from the mask (median run across strokes).
2. **The two directions** (:mod:`~kinegym.vision.tracks`). The angles at which the ink's
   projection is most peaked (a Radon energy long strokes dominate); the second at least
   40 deg from the first, a rival second peak tried too. (Not "the longest line": long X
   strokes at 45 deg or a page edge do not seed it.)
3. **Tracks** (:mod:`~kinegym.vision.tracks`). The ink is turned so that a family runs
   vertically and cut into bands across it; in each band a stroke of that family is a peak of
   the ink summed along the band (strokes of the other family spread flat). Peaks are linked
   from band to band, allowing drift (perspective, waves) and gaps (faint or broken pen), a
   peak the track's own ink runs on to first: a track is a polyline that may bend. A family of
   sixteen long tracks, or eight evenly spaced, is ruled or graph paper
   (:mod:`~kinegym.vision.ruling`): the '#' is first sought in the ink darker than 1.6x the
   rules' (where its lines stand alone), less the rules' colour, then with it, dropping tracks
   that run on as dark at both ends (heavier rules); else only tracks with 1.5x the rules' ink
   or another colour stay candidates (a search asked for ``other_colour`` takes only the ink
   not of the rules' colour, however pale). The rules' ink (:attr:`HashGrid.rules`) is cleared
   from the cells (:func:`~kinegym.vision.ruling.clear_rules`).
4. **The '#'.** Every choice of ``n - 1`` tracks per family is a hypothesis: it must cross
   pairwise within the drawn extents, its cells must be no more than a plausible tilt apart
   in size, and each line should run on past its outer crossings (the outer cells). The
   score favours long, strongly inked, regular '#'s with arms, in one pen's colour and
   weight (lines whose inks differ more than :data:`~kinegym.vision.tracks.INK_SPREAD_FREE`
   times are a pen lying on the page beside drawn lines, say), ending on the page (a line from
   the photo's edge to its edge - a page's edge, a notebook's binding - costs
   :data:`~kinegym.vision.tracks.EDGE_TO_EDGE_COST`); the best wins. A frame line is never an
   interior one: the other lines stop at it (no arms).
   (:func:`_best_hash` is the readable definition; the search runs its fast kernel,
   :func:`~kinegym.vision.hash_search.best_hash`, tested equal to it.)

The result is the lattice of the crossings (a homography, cells of the '#' at 1..n-1) and the
chosen tracks, which the reader erases from the ink before reading the cells.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from .errors import NoBoardError
from .grid_lines import _median
from .hash_search import best_hash, pairs
from .ink import colour_at, ink_mask, median_at, noise_floor_and_top, unit
from .polylines import all_crossings, extend, first_crossing, prepare
from .ruling import HUE_DEG, Ruling, is_ruled, rules_mask, without_rules
from .tracks import (
    EDGE_TO_EDGE_COST,
    INK_SPREAD_FREE,
    INK_SPREAD_WEIGHT,
    Track,
    _dense,
    _line_directions,
    _sharing,
    _tracks,
)

__all__ = ["GRID_SIDE_PX", "HashGrid", "Track", "find_hash_grid", "search_copy", "crossing_lattice"]

#: The longer side of the working copy the grid is searched on (px).
GRID_SIDE_PX = 480
NO_HUED_RULING = "no ruled paper whose rules have a colour of their own"


@dataclass
class HashGrid:
    """A '#' found: ``H`` takes lattice coordinates (the '#' lines at 1..n-1) to working px;
    ``cols``/``rows`` the chosen tracks (left to right, top to bottom), ``crossings``
    ``(n-1, n-1, 2)`` px [col, row], ``stroke_px`` the measured pen width, ``threshold`` the
    ink mask's level, ``score`` the hypothesis's score."""

    n: int
    H: np.ndarray
    cols: list[Track]
    rows: list[Track]
    crossings: np.ndarray
    stroke_px: float
    threshold: float
    score: float
    error_px: float
    rules: np.ndarray | None = None  # uint8 mask of ruled paper's lines, if the paper is ruled
    rule_hue: np.ndarray | None = None  # their unit RGB darkness, if the colour is known


def search_copy(working: np.ndarray, photo: np.ndarray | None = None) -> np.ndarray:
    """The copy of a photo the '#' is sought on, about :data:`GRID_SIDE_PX` on its longer side:
    the ``photo``'s own means over k x k blocks where a whole k of 2 or 3 divides both its sides
    and gets within 10 % of that (OpenCV's area shrink is ten times faster at a whole factor: a
    960 x 720 frame halves in 0.25 ms, its 800 px working copy takes 3-4 ms to 480), else the
    ``working`` copy shrunk by area."""
    if photo is not None:
        h, w = photo.shape[:2]
        k = int(round(max(h, w) / GRID_SIDE_PX))
        if k in (2, 3) and not h % k and not w % k and abs(max(h, w) / k - GRID_SIDE_PX) <= 0.1 * GRID_SIDE_PX:
            return cv2.resize(photo, (w // k, h // k), interpolation=cv2.INTER_AREA)
    h, w = working.shape[:2]
    f = GRID_SIDE_PX / max(h, w)
    return cv2.resize(working, (max(1, int(round(w * f))), max(1, int(round(h * f)))), interpolation=cv2.INTER_AREA)


def _best_hash(fa: list[Track], fb: list[Track], k: int, shape: tuple[int, int], ext: float, width: float
               ) -> tuple[float, tuple[int, ...], tuple[int, ...], np.ndarray] | None:
    """The best choice of ``k`` tracks per family forming a '#': (score, chosen a, chosen b,
    crossings ``(k, k, 2)``)."""
    h, w = shape
    ea = [prepare(extend(t.pts, ext)) for t in fa]  # each line crosses up to 7 others
    eb = [prepare(extend(t.pts, ext)) for t in fb]
    la = [float(np.hypot(*p.seg.T).sum()) for p in ea]
    lb = [float(np.hypot(*p.seg.T).sum()) for p in eb]
    cross: dict[tuple[int, int], tuple[np.ndarray, float, float] | None] = {}

    def X(i: int, j: int) -> tuple[np.ndarray, float, float] | None:
        if (i, j) not in cross:
            cross[(i, j)] = first_crossing(ea[i], eb[j])
        return cross[(i, j)]

    def at_edge(p: np.ndarray) -> bool:
        m = 0.04 * max(h, w)
        return bool(p[0] < m or p[1] < m or p[0] > w - m or p[1] > h - m)

    share_a, share_b = _sharing(fa, width), _sharing(fb, width)
    hue = np.array([t.colour for t in fa + fb]) if fa[0].colour is not None else None
    best = None
    for ca in itertools.combinations(range(len(fa)), k):
        if any(share_a[i, j] for i, j in itertools.combinations(ca, 2)):
            continue
        for cb in itertools.combinations(range(len(fb)), k):
            if any(share_b[i, j] for i, j in itertools.combinations(cb, 2)):
                continue
            pts = np.zeros((k, k, 2))
            pos_a = np.zeros((k, k))
            pos_b = np.zeros((k, k))
            ok = True
            for x, i in enumerate(ca):
                for y, j in enumerate(cb):
                    c = X(i, j)
                    if c is None:
                        ok = False
                        break
                    pts[x, y], pos_a[x, y], pos_b[x, y] = c
                if not ok:
                    break
            if not ok:
                continue
            # order across: the crossings along each chosen a-line give the b-lines' order
            # and vice versa; the lattice must not fold
            oa, ob = np.argsort(pos_b[:, 0]), np.argsort(pos_a[0, :])
            pts, pos_a, pos_b = pts[oa][:, ob], pos_a[oa][:, ob], pos_b[oa][:, ob]
            if not (np.all(np.diff(pos_a, axis=1) > 0) or np.all(np.diff(pos_a, axis=1) < 0)):
                continue
            if not (np.all(np.diff(pos_b, axis=0) > 0) or np.all(np.diff(pos_b, axis=0) < 0)):
                continue
            # cell size along each line between its crossings
            sa = np.abs(np.diff(pos_a, axis=1))  # (k, k-1) along a-lines
            sb = np.abs(np.diff(pos_b, axis=0))  # (k-1, k) along b-lines
            allsz = np.concatenate([sa.ravel(), sb.ravel()])
            cell = _median(allsz)
            if cell < 0.06 * max(h, w):
                continue
            if allsz.max() > 2.6 * allsz.min():
                continue
            side = float(max(h, w))
            chosen = [(fa[i], la[i], pos_a[x]) for x, i in enumerate([ca[v] for v in oa])]
            chosen += [(fb[j], lb[j], pos_b[:, y]) for y, j in enumerate([cb[v] for v in ob])]
            if any(tr.span < (k - 1 + 0.4) * cell for tr, _, _ in chosen):  # a grid line spans its cells and
                continue  # some arm: one that does not is a frame's side seen whole, or a stroke
            score = 0.0
            missing = 0
            for tr, ln, pos in chosen:
                score += tr.strength * min(tr.span, (k + 1.5) * cell) / side  # no more than a '#' line's length
                for arm, end_pt in ((pos.min() - ext, tr.pts[0]), (ln - ext - pos.max(), tr.pts[-1])):
                    if arm < 0.15 * cell and not at_edge(end_pt):
                        score -= 0.15  # no arm: a frame line, or a stroke that ends at the crossing
                        missing += 1
            if missing > k:  # most lines stop at the outer ones: a frame, not a '#'
                continue
            # a line from the photo's edge to its edge: a page edge, a binding, a table's edge
            score -= EDGE_TO_EDGE_COST * sum(at_edge(tr.pts[0]) and at_edge(tr.pts[-1]) for tr, _, _ in chosen)
            # crossings outside both drawn extents (only on the extensions) are weaker
            outside = (pos_a < ext - 2).sum() + (pos_b < ext - 2).sum()
            score -= 0.1 * outside
            score -= 0.3 * (allsz.max() / allsz.min() - 1.0)
            if hue is not None:  # one pen draws a '#': lines of another colour are something else
                u = hue[list(ca) + [len(fa) + j for j in cb]]
                spread = math.degrees(math.acos(float(np.clip((u @ unit(u.sum(axis=0))).min(), -1.0, 1.0))))
                score -= 0.02 * max(0.0, spread - HUE_DEG)
            inks = [fa[i].ink for i in ca] + [fb[j].ink for j in cb]  # one pen: inks alike
            times = max(inks) / max(min(inks), 1e-9)
            if times > INK_SPREAD_FREE:
                score -= INK_SPREAD_WEIGHT * math.log(times / INK_SPREAD_FREE)
            if best is None or score > best[0]:
                best = (score, tuple(ca[v] for v in oa), tuple(cb[v] for v in ob), pts)
    return best


def find_hash_grid(d: np.ndarray, sizes: tuple[int, ...] = (3, 5), colour: np.ndarray | None = None,
                   share: float | None = None, other_colour: bool = False,
                   rulings: dict[tuple[float, bool], list[Ruling]] | None = None,
                   levels: tuple[float, float] | None = None) -> HashGrid:
    """The best hand-drawn '#' grid in a darkness map (see the module docstring); raises
    :class:`NoBoardError` when no two families of crossing strokes form one. The ink mask's
    threshold is ``share`` of the strongest ink (:func:`~kinegym.vision.ink.ink_mask`); by default
    first 22 % and, when that finds no '#', all ink above the noise (pale grid lines beside black
    marks). All ink above the noise (share 0) that finds none is tried again above each region's
    own noise where that is lower (a textured table around the page raises the whole map's above
    a pencil '#'). ``colour``, the map's RGB darkness (:func:`~kinegym.vision.ink.ink_colour`), lets
    the lines' pen count: one '#' is drawn in one colour, and rules of another colour are not its lines.
    ``other_colour``: on ruled paper whose rules have a colour of their own, the '#' only in the ink
    not of that colour, however pale (no darker-than-the-rules gate); elsewhere nothing is found.
    ``rulings``: a memo for one map - each ink level's search records the rulings it found there, and
    an ``other_colour`` search at a level recorded starts from them instead of tracing that level again.
    ``levels``: the map's :func:`~kinegym.vision.ink.noise_floor_and_top`, where already measured."""
    if share is not None and not 0.0 <= share < 1.0:
        raise ValueError(f"share={share!r}; expected a share of the strongest ink in [0, 1)")
    levels = levels or noise_floor_and_top(d)  # (every level's search measures the one map)
    tries = [(0.22, False), (0.0, False)] if share is None else [(float(share), False)]
    first: NoBoardError | None = None
    for level, local in tries + ([(0.0, True)] if tries[-1][0] == 0.0 else []):
        try:
            return _find_hash_grid(d, sizes, level, colour, local=local, other_colour=other_colour, rulings=rulings,
                                   levels=levels)
        except NoBoardError as exc:
            first = first or exc
    raise first  # type: ignore[misc]


def _find_hash_grid(d: np.ndarray, sizes: tuple[int, ...], share: float, colour: np.ndarray | None,
                    above: float = 0.0, ruling: Ruling | None = None, local: bool = False,
                    other_colour: bool = False, rulings: dict[tuple[float, bool], list[Ruling]] | None = None,
                    levels: tuple[float, float] | None = None) -> HashGrid:
    """:func:`find_hash_grid` at one ink level; ``ruling`` (with ``above``, the rules' darkness
    times 1.6, or 0) marks the search on ruled paper's own terms, inside the search that found it."""
    level = (share, local)
    if other_colour and rulings is not None and level in rulings:  # this level's rulings, already found
        return _best([_try(_in_other_colour, d, sizes, share, colour, own) for own in rulings[level]]
                     or [NoBoardError(NO_HUED_RULING)])
    mask, t, width = ink_mask(d, share, above, local, levels)
    if ruling is not None and ruling.by_colour and colour is not None:
        mask[ruling.paints(d, colour)] = 0  # the rules' own ink, where it is darker (they cross, say)
    if cv2.countNonZero(mask) < 1e-4 * mask.size:
        raise NoBoardError("the image holds no ink")
    # (the mask's px lie above 0.6 of a threshold >= 0, so ``dark`` is above 0 exactly on the mask)
    dark, memo = np.where(mask > 0, d, 0.0).astype(np.float32), {}

    def traced(phi: float) -> list[Track]:  # each direction traced once (a rival pair shares the first)
        if phi not in memo:
            memo[phi], M, rot = _tracks(mask, phi, width, dark)
            for tr in memo[phi]:
                tr.frame = (M, rot)
                tr.colour = None if colour is None else colour_at(d, colour, tr.pts)
        return memo[phi]

    owns: list[Ruling] = []  # the rulings found along each pair of directions
    tried = [_try(_hash_along, d, sizes, share, colour, above, ruling, mask, traced, t, width, phi_a, phi_b,
                  other_colour, owns)
             for phi_a, phi_b in _line_directions(mask, width)]  # rival directions are tried too: the better wins
    if rulings is not None and ruling is None:
        rulings[level] = owns
    return _best(tried)


def _try(f: Callable[..., HashGrid], *args: object) -> HashGrid | NoBoardError:
    try:
        return f(*args)
    except NoBoardError as exc:
        return exc


def _best(tried: list[HashGrid | NoBoardError]) -> HashGrid:
    """The best '#' of those found (its score per line), else the first reason none was."""
    grids = [g for g in tried if isinstance(g, HashGrid)]
    if not grids:
        raise next((e for e in tried if isinstance(e, NoBoardError)), NoBoardError("no line directions in the ink"))
    return max(grids, key=lambda g: g.score / (2 * (g.n - 1)))


def _in_other_colour(d: np.ndarray, sizes: tuple[int, ...], share: float, colour: np.ndarray | None,
                     own: Ruling | None) -> HashGrid:
    """The '#' in the ink not of ruling ``own``'s colour, however pale (:func:`find_hash_grid`'s ``other_colour``)."""
    if own is None or own.hue is None:
        raise NoBoardError(NO_HUED_RULING)
    return _on_ruled_paper(d, sizes, share, colour, 0.0, dataclasses.replace(own, by_colour=True), own)


def _on_ruled_paper(d: np.ndarray, sizes: tuple[int, ...], share: float, colour: np.ndarray | None, above: float,
                    inner: Ruling, own: Ruling) -> HashGrid:
    """The '#' sought on ruled paper's terms ``inner`` above ``above``; it carries the paper's rules
    and their colour (``own``), to be cleared from the cells."""
    grid = _find_hash_grid(d, sizes, share, colour, above, inner)
    grid.rules = own.rules if grid.rules is None else grid.rules | own.rules
    grid.rule_hue = own.hue
    return grid


def _hash_along(d: np.ndarray, sizes: tuple[int, ...], share: float, colour: np.ndarray | None, above: float,
                ruling: Ruling | None, mask: np.ndarray, traced: Callable[[float], list[Track]], t: float | np.ndarray,
                width: float, phi_a: float, phi_b: float, other_colour: bool = False, owns: list[Ruling] | None = None
                ) -> HashGrid:
    """:func:`_find_hash_grid` for one pair of line directions (``traced``: a direction's tracks); the
    paper's own ruling, if any, is added to ``owns``."""
    fa, fb = traced(phi_a), traced(phi_b)
    side = float(max(d.shape))
    ruled_a, ruled_b = is_ruled(fa, side), is_ruled(fb, side)
    ruled = [phi for phi, r in ((phi_a, ruled_a), (phi_b, ruled_b)) if r]
    # evenly spaced tracks with no long straight run of ink among them are no ruling to clear
    rules = r if ruled and (r := rules_mask(mask, ruled, max(9, int(0.06 * side)))).any() else None
    # (the search above the rules judges tracks by the ruling it was given: its own only joins the clearing)
    own = Ruling.of(rules, ruled, d, colour) if rules is not None and ruling is None else None
    if own is not None and owns is not None:
        owns.append(own)
    if other_colour and ruling is None:  # only the ink not of the rules' colour, however pale
        return _in_other_colour(d, sizes, share, colour, own)
    if own is not None:  # ruled paper: the '#' in the ink darker than the rules, if it shows there
        darker = 1.6 * float(np.median(d[own.rules > 0]))
        # first with the rules' colour left out (a pen of another colour), then all of that ink
        for inner in ((dataclasses.replace(own, by_colour=True), own) if own.hue is not None else (own,)):
            with contextlib.suppress(NoBoardError):
                return _on_ruled_paper(d, sizes, share, colour, darker, inner, own)
    fa = without_rules(fa, side) if ruled_a else fa
    fb = without_rules(fb, side) if ruled_b else fb
    if ruling is not None:  # heavier rules (every fifth, say) are as dark as a pen: they run on along a rule
        fa = [tr for tr in fa if not ruling.runs_on(tr, phi_a)]
        fb = [tr for tr in fb if not ruling.runs_on(tr, phi_b)]
    # the longest few of each family (symbol strokes make short tracks)
    fa = sorted(fa, key=lambda tr: -tr.span * tr.strength)[:7]
    fb = sorted(fb, key=lambda tr: -tr.span * tr.strength)[:7]
    if len(fa) < 2 or len(fb) < 2:
        raise NoBoardError(f"strokes in {len(fa)} and {len(fb)} lines of the two directions; a grid needs 2 + 2")
    ext = 0.06 * max(d.shape)
    found = []
    found_pairs = pairs(fa, fb, ext, width)  # (once for every size)
    for n in sizes:  # (best_hash: _best_hash's fast kernel, the same result)
        if len(fa) >= n - 1 and len(fb) >= n - 1:
            b = best_hash(fa, fb, n - 1, d.shape, found_pairs)
            if b is not None:
                found.append((b[0] / (2 * (n - 1)), n, b))
    if not found:
        raise NoBoardError("no four strokes cross like a '#'")
    # the larger board when its '#' holds up line for line (a 3 x 3 '#' hides in every 5 x 5)
    found.sort(key=lambda f: f[1])
    pick = found[0]
    for f in found[1:]:
        if f[0] >= 0.6 * pick[0]:
            pick = f
    _, n, (score, ca, cb, pts) = pick
    cols, rows = [fa[i] for i in ca], [fb[j] for j in cb]
    # columns: the family closer to the image vertical; left to right, top to bottom
    dir_a = cols[0].pts[-1] - cols[0].pts[0]
    if abs(dir_a[0]) > abs(dir_a[1]):
        cols, rows, pts = rows, cols, pts.transpose(1, 0, 2)
    if pts[0, 0, 0] > pts[-1, 0, 0]:
        cols, pts = cols[::-1], pts[::-1]
    if pts[0, 0, 1] > pts[0, -1, 1]:
        rows, pts = rows[::-1], pts[:, ::-1]
    # each chosen line traced densely along its ink, and the crossings taken from those
    for tr in cols + rows:
        tr.dense = _dense(tr, width)
    found, dense_pts, _, _ = all_crossings([extend(a.dense, ext) for a in cols], [extend(b.dense, ext) for b in rows])
    pts = np.where(found[..., None], dense_pts, pts)
    lat = crossing_lattice(n)
    img = pts.reshape(-1, 2).astype(np.float64)
    H, _ = cv2.findHomography(lat, img, 0)
    if H is None or not np.all(np.isfinite(H)):
        raise NoBoardError("the '#' crossings do not make a projective grid")
    p = np.concatenate([lat, np.ones((len(lat), 1))], axis=1) @ H.T
    err = float(np.sqrt(np.mean(np.sum((p[:, :2] / p[:, 2:3] - img) ** 2, axis=1))))
    level = median_at(t, np.concatenate([tr.dense for tr in cols + rows]))  # the ink level where the '#' lies
    return HashGrid(n, H, cols, rows, pts, width, level, float(score), err, rules)


def crossing_lattice(n: int) -> np.ndarray:
    """``((n-1)^2, 2)`` the lattice coordinates of an ``n`` x ``n`` '#''s crossings (its lines at
    1..n-1), in the order of :attr:`HashGrid.crossings` ``[col, row]`` flattened."""
    return np.array([[i + 1, j + 1] for i in range(n - 1) for j in range(n - 1)], np.float64)
