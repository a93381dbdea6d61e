"""Localisation: which three holes the climber holds, and where its body is.

:class:`Localizer` matches the oriented triangle of the three hands (from six noisy encoder
angles) against the map's :class:`~kinegym.kinematics.triangles.TriangleIndex`, fits the
pose of every candidate triple (:mod:`kinegym.kinematics.pose_fit`) and gates it by
chi-square: a global fix, a tracking fix near the previous holes after a known move, and
the public pieces (:meth:`Localizer.measure`, :meth:`Localizer.passes`,
:meth:`Localizer.search_measured`, :meth:`Localizer.track_candidates`) that the lost-start
filter (:mod:`kinegym.kinematics.bayes`) builds on.
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Iterable, Sequence

import numpy as np

from .climber import ClimberGeometry
from .errors import InvalidInputError, as_array
from .holes import HoleMap
from .pose_fit import (
    AmbiguousFixError,
    Candidate,
    Fix,
    NoFixError,
    NoiseModel,
    _fit,
    _fit_one,
    _inv3,
)
from .triangles import TriangleIndex

__all__ = ["Localizer"]


_OTHERS = ((1, 2), (0, 2), (0, 1))  # the kept arms when arm 0, 1 or 2 moves
_PROBE_BLOCK = 64  # triples screened at a time when a grip's own index cell is probed


class Localizer:
    """Localises the climber on one wall: global fixes, tracking, and lost starts.

    Build once per (map, robot, noise); it owns the :class:`TriangleIndex`. Every method
    takes the six measured joint angles ``q (3, 2)`` in radians (seed convention: shoulder
    from the body x axis, elbow between the links).
    """

    def __init__(self, holes: HoleMap, geom: ClimberGeometry | None = None,
                 noise: NoiseModel | None = None, index: TriangleIndex | None = None) -> None:
        if len(holes) < 3:
            raise InvalidInputError(f"map '{holes.name}' has {len(holes)} holes; a fix needs at least 3")
        self.holes = holes
        self.geom = geom or ClimberGeometry()
        self.noise = noise or NoiseModel()
        self.index = index or TriangleIndex(holes, self.geom)
        holes.within(holes.xy[0], 0.0)  # build the spatial hash now, not during a fix
        self._grid = holes.__dict__["_grid"]
        g = self.geom
        self._arms = [(float(g.l1[i]), float(g.l2[i]), float(g.shoulders[i, 0]), float(g.shoulders[i, 1]))
                      for i in range(3)]
        self._var_a, self._var_m = self.noise.sigma_angle ** 2, self.noise.sigma_map ** 2
        self._limit = self.noise.chi2_limit
        self._z = math.sqrt(self._limit)
        # the side screen's first-order chi-square may differ a little from the exact fit's
        self._screen_limit = 1.5 * self._limit + 2.0
        self._xs, self._ys = holes.xy[:, 0].tolist(), holes.xy[:, 1].tolist()
        self._ids = [(int(a), int(b)) for a, b in holes.ids.tolist()]

    # -------------------------------------------------------------- measurement model
    def measure(self, q: object) -> tuple[list[float], list[float], list[tuple[float, float, float]],
                                          list[tuple[float, float, float]]]:
        """Hands (body frame), their covariances (a, b, c) and inverse covariances, plain floats."""
        if isinstance(q, np.ndarray) and q.shape == (3, 2):
            rows = q.tolist()
        else:
            qa = as_array("joint angles q", q, (3, 2))
            if qa.shape != (3, 2):
                raise InvalidInputError(f"joint angles q have shape {qa.shape}; expected (3, 2) - one grip")
            rows = qa.tolist()
        (s0, e0), (s1, e1), (s2, e2) = rows
        if not math.isfinite(s0 + e0 + s1 + e1 + s2 + e2):
            raise InvalidInputError(f"joint angles q={rows!r} hold NaN or infinity; expected radians")
        hx, hy, cov, w = [], [], [], []
        va, vm = self._var_a, self._var_m
        cos, sin = math.cos, math.sin
        for (s, e), (l1, l2, ox, oy) in zip(rows, self._arms):
            cs, ss = cos(s), sin(s)
            d = s - e  # the lower link points along s - e + pi
            dlx, dly = l2 * sin(d), -l2 * cos(d)
            hx.append(ox + l1 * cs + dly)
            hy.append(oy + l1 * ss - dlx)
            dsx, dsy = dlx - l1 * ss, dly + l1 * cs  # d hand / d shoulder; d hand / d elbow = -(dlx, dly)
            a = va * (dsx * dsx + dlx * dlx) + vm
            b = va * (dsx * dsy + dlx * dly)
            c = va * (dsy * dsy + dly * dly) + vm
            r = 1.0 / (a * c - b * b)
            cov.append((a, b, c))
            w.append((c * r, -b * r, a * r))
        return hx, hy, cov, w

    def candidate(self, holes: Sequence[int], x: float, y: float, th: float, chi2: float,
                  res: Sequence[float], lik: float = 1.0) -> Candidate:
        """A :class:`Candidate` for map rows ``holes`` with a fitted pose, chi-square and residuals."""
        ids = self._ids
        h0, h1, h2 = int(holes[0]), int(holes[1]), int(holes[2])
        return Candidate((h0, h1, h2), (ids[h0], ids[h1], ids[h2]), (float(x), float(y), float(th)), float(chi2),
                         res, float(lik))

    def _evaluate(self, verts: list[tuple[int, int, int]], hx: list[float], hy: list[float],
                  w: list[tuple[float, float, float]]) -> list[Candidate]:
        """Fit a few triples (plain Python); best first."""
        xs, ys = self._xs, self._ys
        out = []
        for v in verts:
            x, y, th, chi2, res = _fit_one([xs[v[0]], xs[v[1]], xs[v[2]]], [ys[v[0]], ys[v[1]], ys[v[2]]],
                                           hx, hy, w)
            out.append(self.candidate(v, x, y, th, chi2, res))
        out.sort(key=lambda c: c.chi2)
        return out

    def passes(self, cand: Candidate, hx: list[float], hy: list[float]) -> bool:
        """Whether ``cand`` passes the gate (chi-square, or the seed's fixed tolerance) for hands ``hx, hy``."""
        tol = self.noise.tolerance
        if tol is None:
            return cand.chi2 <= self._limit
        xs, ys = self._xs, self._ys
        v = cand.holes
        for i, j in ((0, 1), (1, 2), (2, 0)):
            dp = math.hypot(xs[v[i]] - xs[v[j]], ys[v[i]] - ys[v[j]])
            dh = math.hypot(hx[i] - hx[j], hy[i] - hy[j])
            if abs(dp - dh) > tol:
                return False
        return True

    def _decide(self, cands: list[Candidate], hx: list[float], hy: list[float],
                cov: list[tuple[float, float, float]], what: str, n_examined: int | None = None) -> Fix:
        passed = [c for c in cands if self.passes(c, hx, hy)]
        n = len(cands) if n_examined is None else n_examined
        if len(passed) == 1:
            best = passed[0]
            runner = next((c for c in cands if c is not best), None)
            return Fix(best, runner, n, (hx, hy), cov)
        if not passed:
            best = cands[0] if cands else None
            extra = (f"; best candidate {best.ids} has chi2 {best.chi2:.3g} (gate {self._limit:.3g}), "
                     f"residual up to {max(best.residual_cm):.3g} cm" if best else "; no hole triple of matching shape")
            raise NoFixError(f"no fix on map '{self.holes.name}' ({what}){extra}", best)
        raise self._ambiguous(passed, what)

    def _ambiguous(self, passed: list[Candidate], what: str) -> AmbiguousFixError:
        if self.noise.tolerance is None:
            lo = min(c.chi2 for c in passed)
            wts = [math.exp(-0.5 * (c.chi2 - lo)) for c in passed]
        else:
            wts = [1.0] * len(passed)
        tot = sum(wts)
        passed = [Candidate(c.holes, c.ids, c.pose, c.chi2, c.residual_cm, wt / tot) for c, wt in zip(passed, wts)]
        passed.sort(key=lambda c: -c.likelihood)
        listing = ", ".join(f"{c.ids} (p={c.likelihood:.3g})" for c in passed[:5])
        more = f" and {len(passed) - 5} more" if len(passed) > 5 else ""
        return AmbiguousFixError(
            f"{len(passed)} hole triples on map '{self.holes.name}' fit the hands ({what}): {listing}{more}", passed)

    def _sides(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
               order: Sequence[int]) -> tuple[list[float], list[float], list[list[float]] | None]:
        """``(sides, S, S^-1)``: the hand triangle's sides taken in ``order``, their covariance
        and its inverse (None with a fixed tolerance).

        ``S`` is the side covariance (nested lists); with a tolerance, ``[tol] * 3`` half-widths.

        Side lengths are what a rigid fit tests: a pose does not change them, and to first
        order the fit's chi-square equals the Mahalanobis distance of the side residuals under
        their covariance, propagated from the hands' (each side ``|h_i - h_j|`` moves with
        ``u . (dh_i - dh_j)``; two sides sharing a hand are correlated through it). That gives
        a vectorised screen over every indexed triple before any fit.
        """
        o0, o1, o2 = order
        sides, us = [], []
        for i, j in ((o0, o1), (o1, o2), (o2, o0)):
            dx, dy = hx[i] - hx[j], hy[i] - hy[j]
            d = math.hypot(dx, dy)
            sides.append(d)
            us.append((dx / d, dy / d) if d > 0 else (1.0, 0.0))
        if self.noise.tolerance is not None:
            return sides, [self.noise.tolerance] * 3, None

        def q(c: tuple[float, float, float], u: tuple[float, float], v: tuple[float, float]) -> float:
            return u[0] * (c[0] * v[0] + c[1] * v[1]) + u[1] * (c[1] * v[0] + c[2] * v[1])

        (u0, u1, u2), (c0, c1, c2) = us, (cov[o0], cov[o1], cov[o2])
        # side k runs from hand o_k to o_(k+1); two sides share one hand, with opposite signs
        s01, s12, s02 = -q(c1, u0, u1), -q(c2, u1, u2), -q(c0, u0, u2)
        S = [[q(c0, u0, u0) + q(c1, u0, u0), s01, s02],
             [s01, q(c1, u1, u1) + q(c2, u1, u1), s12],
             [s02, s12, q(c2, u2, u2) + q(c0, u2, u2)]]
        return sides, S, _inv3(S)

    def _screen(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                limit: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Triples of the measured oriented shape that pass the side screen (first-order
        chi-square <= ``limit``, default 1.5 x the gate + 2).

        Returns their vertices ``(K, 3)`` (map rows, arm order) sorted by the first-order
        chi-square ``(K,)`` (zeros with a fixed tolerance), and the best triple the screen
        rejected (or None) so a failed fix can still name its closest candidate.
        """
        cross = (hx[1] - hx[0]) * (hy[2] - hy[0]) - (hy[1] - hy[0]) * (hx[2] - hx[0])
        screen = self._screen_limit if limit is None else limit
        found_v, found_c, spare, spare_c = [], [], None, math.inf
        # Both vertex orders have the same three sides, so one order's widths decide which
        # orientations the noise admits; |cross| this small: orientation within the noise.
        ccw = self._sides(hx, hy, cov, (0, 1, 2))
        sides, S, sinv = ccw
        width = max(S) if sinv is None else math.sqrt(screen * max(S[0][0], S[1][1], S[2][2]))
        slack = 2 * width * max(sides)
        orders = [o for o, ok in (((0, 1, 2), cross >= -slack), ((0, 2, 1), cross <= slack)) if ok]
        for order in orders:
            sides, S, sinv = ccw if order == (0, 1, 2) else self._sides(hx, hy, cov, order)
            if sinv is None:
                verts, got = self.index.query(sides, S)
            else:
                verts, got = self.index.query(sides, None, S, screen)
            if not len(verts):
                continue
            if order != (0, 1, 2):
                verts = verts[:, (0, 2, 1)]  # query order (arm 1, 3, 2) back to arm order
            if sinv is None:
                c1 = np.zeros(len(verts))
            else:
                r = got - sides
                c1 = ((r @ np.array(sinv)) * r).sum(axis=1)
                keep = c1 <= screen
                if not keep.all():
                    if not keep.any():
                        j = int(np.argmin(c1))
                        if c1[j] < spare_c:
                            spare, spare_c = verts[j], float(c1[j])
                    verts, c1 = verts[keep], c1[keep]
            found_v.append(verts)
            found_c.append(c1)
        if not found_v:
            return np.empty((0, 3), np.int64), np.empty(0), spare
        verts, c1 = (found_v[0], found_c[0]) if len(found_v) == 1 else (np.concatenate(found_v),
                                                                          np.concatenate(found_c))
        if len(found_v) > 1:
            verts, first = np.unique(verts, axis=0, return_index=True)
            c1 = c1[first]
        o = np.argsort(c1, kind="stable")
        return verts[o], c1[o], spare

    def _fit_rows(self, verts: np.ndarray, hx: list[float], hy: list[float],
                  w: list[tuple[float, float, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact rigid fits of many triples: ``pose (K, 3)``, ``chi2 (K,)``, ``residual_cm (K, 3)``."""
        if len(verts) <= 16:  # a few candidates: the scalar fit beats numpy's per-call overhead
            xs, ys = self._xs, self._ys
            fits = [_fit_one([xs[v[0]], xs[v[1]], xs[v[2]]], [ys[v[0]], ys[v[1]], ys[v[2]]], hx, hy, w)
                    for v in verts.tolist()]
            if not fits:
                return np.empty((0, 3)), np.empty(0), np.empty((0, 3))
            return np.array([f[:3] for f in fits]), np.array([f[3] for f in fits]), np.array([f[4] for f in fits])
        h = np.array([hx, hy]).T
        return _fit(self.holes.xy[verts], h, np.array([[[a, b], [b, c]] for a, b, c in w]))

    # -------------------------------------------------------------- public API
    def search(self, q: object) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every hole triple of the measured oriented shape that the side screen lets through
        (first-order chi-square within 1.5 x the gate + 2), fitted exactly, best first.

        Returns ``verts (K, 3)`` (map rows, arm order), ``pose (K, 3)``, ``chi2 (K,)``,
        ``residual_cm (K, 3)``.
        """
        hx, hy, cov, w = self.measure(q)
        return self.search_measured(hx, hy, cov, w)

    def search_measured(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                        w: list[tuple[float, float, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`search` from hands already measured (:meth:`measure`): vertices, poses, chi-square,
        residuals of every screened triple, best first."""
        verts, _, _ = self._screen(hx, hy, cov)
        pose, chi2, res = self._fit_rows(verts, hx, hy, w)
        order = np.argsort(chi2, kind="stable")
        return verts[order], pose[order], chi2[order], res[order]

    def candidates(self, q: object) -> list[Candidate]:
        """:meth:`search` as :class:`Candidate` objects (can be thousands on a big wall)."""
        verts, pose, chi2, res = self.search(q)
        return [self.candidate(v, *p, c, r) for v, p, c, r in zip(verts.tolist(), pose.tolist(), chi2.tolist(),
                                                                   res.tolist())]

    def localize(self, q: object) -> Fix:
        """Global fix from one grip: which hole each arm holds and the body pose.

        The side screen orders the indexed triples by their first-order chi-square; exact
        fits follow in that order and stop as soon as two pass the gate (then the grip is
        ambiguous, whatever the rest hold). A first pass looks only where the sides match
        closely, so on a wall of 40,000 holes - where one grip fits hundreds of triples - the
        verdict costs a small query and two fits.

        Raises:
            NoFixError: no triple passes the gate (carries the best candidate).
            AmbiguousFixError: several pass (carries them with their likelihoods; the full list,
                its ``count`` and the message are worked out on first use).
        """
        hx, hy, cov, w = self.measure(q)
        if self.noise.tolerance is not None:  # the seed's way: every triple within the tolerance
            verts, pose, chi2, res = self.search_measured(hx, hy, cov, w)
            cands = [self.candidate(verts[i], *pose[i], chi2[i], res[i].tolist()) for i in range(len(verts))]
            return self._decide(cands, hx, hy, cov, "global search")
        # Phase 0, for dense regular walls: the one index cell holding the measured sides;
        # two exact passes there settle "ambiguous" without any wider query.
        if (verdict := self._probe_cell(hx, hy, cov, w)) is not None:
            raise verdict
        # Phase 1: look only where the sides match closely, the screen widening step by step
        # (its volume grows as limit^1.5), so a wall where thousands of triples fit at 1 deg
        # still answers from a query of a few hundred.
        for screen in (0.25, 1.0, 4.0):
            verts, _, _ = self._screen(hx, hy, cov, min(screen, self._limit))
            if len(verts) >= 2:
                passed, _ = self._fit_until_two(verts[:8].tolist(), hx, hy, w)
                if len(passed) == 2:
                    raise self._lazy_ambiguity(hx, hy, cov, w, [c.holes for c in passed])
        # Phase 2: the whole screen, fitted in order of the first-order chi-square.
        verts, _, spare = self._screen(hx, hy, cov)
        rows: Iterable[list[int]] = verts[:8].tolist()  # rarely more are needed: two passes end it
        if len(verts) > 8:
            rows = itertools.chain(rows, (v for v in verts[8:].tolist()))
        if spare is not None:
            rows = itertools.chain(rows, [spare.tolist()])
        passed, others = self._fit_until_two(rows, hx, hy, w)
        if len(passed) == 2:
            raise self._lazy_ambiguity(hx, hy, cov, w, [c.holes for c in passed])
        cands = sorted(passed + others, key=lambda c: c.chi2)
        return self._decide(cands, hx, hy, cov, "global search", n_examined=len(verts))

    def _probe_cell(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                    w: list[tuple[float, float, float]]) -> AmbiguousFixError | None:
        """An ambiguity verdict from the single cell of the measured sides, or None.

        Two triples that pass prove it, and on a dense wall the cell holds hundreds that do:
        the cell is screened a block at a time (first-order chi-square, best first within a
        block) and at most 8 triples get the exact test, so the verdict costs a block, not
        the cell."""
        cross = (hx[1] - hx[0]) * (hy[2] - hy[0]) - (hy[1] - hy[0]) * (hx[2] - hx[0])
        order = (0, 1, 2) if cross > 0 else (0, 2, 1)
        sides, S, sinv = self._sides(hx, hy, cov, order)
        verts, got = self.index.cell_of(sides)
        if len(verts) < 2:
            return None
        m = np.array(sinv)
        xs, ys, limit, proof, tries = self._xs, self._ys, self._limit, [], 0
        for start in range(0, len(verts), _PROBE_BLOCK):
            r = got[start:start + _PROBE_BLOCK] - sides
            c1 = ((r @ m) * r).sum(axis=1)
            ok = np.flatnonzero(c1 <= limit)
            if not len(ok):
                continue
            rows = verts[start + ok[np.argsort(c1[ok], kind="stable")]]
            if order != (0, 1, 2):
                rows = rows[:, (0, 2, 1)]
            for v in rows.tolist():  # the Kabsch pose's chi-square bounds the optimum's from above
                if _fit_one([xs[v[0]], xs[v[1]], xs[v[2]]], [ys[v[0]], ys[v[1]], ys[v[2]]], hx, hy, w, 0)[3] <= limit:
                    proof.append(v)
                    if len(proof) == 2:
                        return self._lazy_ambiguity(hx, hy, cov, w, proof)
                tries += 1
                if tries >= 8:
                    return None
        return None

    def _lazy_ambiguity(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                        w: list[tuple[float, float, float]], proof: Sequence[Sequence[int]]) -> AmbiguousFixError:
        """An ambiguity proven by two passing triples; the full list is worked out on first use."""
        return AmbiguousFixError(resolve=lambda: self._all_passing(hx, hy, cov, w, "global search", proof))

    def _fit_until_two(self, rows: Iterable[list[int]], hx: list[float], hy: list[float],
                       w: list[tuple[float, float, float]]) -> tuple[list[Candidate], list[Candidate]]:
        """Fit triples in order until two pass the gate: ``(passed, failed)``."""
        xs, ys, limit = self._xs, self._ys, self._limit
        passed, others = [], []
        for v in rows:
            x, y, th, chi2, res = _fit_one([xs[v[0]], xs[v[1]], xs[v[2]]], [ys[v[0]], ys[v[1]], ys[v[2]]], hx, hy, w)
            cand = self.candidate(v, x, y, th, chi2, res)
            if chi2 <= limit:
                passed.append(cand)
                if len(passed) == 2:
                    break
            else:
                others.append(cand)
        return passed, others

    def _all_passing(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                     w: list[tuple[float, float, float]], what: str,
                     proof: Sequence[Sequence[int]] = ()) -> AmbiguousFixError:
        """The full ambiguity report: every triple passing the exact gate, with likelihoods
        (``proof``: triples already shown to pass, kept even if the side screen missed them)."""
        verts, pose, chi2, res = self.search_measured(hx, hy, cov, w)
        n = int(np.searchsorted(chi2, self._limit, "right"))
        cands = [self.candidate(verts[i], *pose[i], chi2[i], res[i].tolist()) for i in range(n)]
        seen = {c.holes for c in cands}
        extra = [list(v) for v in proof if tuple(v) not in seen]
        cands += [c for c in self._evaluate(extra, hx, hy, w) if c.chi2 <= self._limit]
        return self._ambiguous(cands, what)

    def predict_moved_hand(self, holes: Sequence[int], hx: list[float], hy: list[float],
                           moved: int) -> tuple[float, float]:
        """Wall position of hand ``moved`` (0..2) placed by the two kept hands on their holes."""
        xs, ys = self._xs, self._ys
        i, j = _OTHERS[moved]
        dpx, dpy = xs[holes[j]] - xs[holes[i]], ys[holes[j]] - ys[holes[i]]
        dhx, dhy = hx[j] - hx[i], hy[j] - hy[i]
        # the rotation taking the kept hands' direction onto their holes' direction
        norm = math.sqrt((dpx * dpx + dpy * dpy) * (dhx * dhx + dhy * dhy)) or 1.0
        c, s = (dhx * dpx + dhy * dpy) / norm, (dhx * dpy - dhy * dpx) / norm
        rx, ry = hx[moved] - 0.5 * (hx[i] + hx[j]), hy[moved] - 0.5 * (hy[i] + hy[j])
        return (0.5 * (xs[holes[i]] + xs[holes[j]]) + c * rx - s * ry,
                0.5 * (ys[holes[i]] + ys[holes[j]]) + s * rx + c * ry)

    def _track_verts(self, holes: Sequence[int], hx: list[float], hy: list[float],
                     cov: list[tuple[float, float, float]], moved_arm: int | None) -> list[tuple[int, int, int]]:
        """The hole triples a tracking step examines: the previous holes with the moved arm's
        replaced by each hole near where the kept hands put that hand."""
        if moved_arm is None:
            return [(holes[0], holes[1], holes[2])]
        m = moved_arm - 1
        px, py = self.predict_moved_hand(holes, hx, hy, m)
        if self.noise.tolerance is not None:
            radius = 3 * self.noise.tolerance
        else:
            a, b, c = cov[m]
            lam = 0.5 * (a + c) + math.sqrt(0.25 * (a - c) ** 2 + b * b)
            radius = 3 * self._z * math.sqrt(lam)
        h0, h1, h2 = holes
        near = self._grid.within_list(px, py, radius)
        if m == 0:
            return [(j, h1, h2) for j in near if j != h1 and j != h2]
        if m == 1:
            return [(h0, j, h2) for j in near if j != h0 and j != h2]
        return [(h0, h1, j) for j in near if j != h0 and j != h1]

    def track_candidates(self, holes: Sequence[int], hx: list[float], hy: list[float],
                         cov: list[tuple[float, float, float]], w: list[tuple[float, float, float]],
                         moved_arm: int | None) -> list[Candidate]:
        """Fitted candidates near the previous holes ``holes`` after ``moved_arm`` moved (None: a body shift)."""
        return self._evaluate(self._track_verts(holes, hx, hy, cov, moved_arm), hx, hy, w)

    def track(self, previous: Fix | Sequence[int], q: object, moved_arm: int | None) -> Fix:
        """Fix after a known move, in constant time: arms other than ``moved_arm`` (1..3) still
        hold their holes; the moved hand is looked for near where the kept hands put it.
        ``moved_arm=None``: no hand moved (e.g. a body shift), only the pose is refitted.
        """
        if isinstance(previous, Fix):
            holes = previous.best.holes
        else:
            try:
                h0, h1, h2 = previous
                holes = (operator.index(h0), operator.index(h1), operator.index(h2))
            except (TypeError, ValueError):
                raise InvalidInputError(f"previous holes {previous!r}; expected a Fix or 3 integer map rows") from None
        n = len(self._xs)
        if not (0 <= holes[0] < n and 0 <= holes[1] < n and 0 <= holes[2] < n):
            raise InvalidInputError(f"previous holes {holes}; expected 3 map rows in 0..{n - 1}")
        if moved_arm is not None and moved_arm not in (1, 2, 3):
            raise InvalidInputError(f"moved_arm={moved_arm!r}; expected 1, 2, 3 or None")
        hx, hy, cov, w = self.measure(q)
        xs, ys = self._xs, self._ys
        fits = []
        for v in self._track_verts(holes, hx, hy, cov, moved_arm):
            x, y, th, chi2, res = _fit_one((xs[v[0]], xs[v[1]], xs[v[2]]), (ys[v[0]], ys[v[1]], ys[v[2]]), hx, hy, w)
            fits.append((chi2, v, x, y, th, res))
        if self.noise.tolerance is None and len(fits) == 1 and fits[0][0] <= self._limit:
            return Fix(self._from_fit(fits[0]), None, 1, (hx, hy), cov)  # the usual step: one hole near
        fits.sort(key=lambda f: f[0])
        if self.noise.tolerance is None:  # without building every candidate
            passed = [f for f in fits if f[0] <= self._limit]
            if len(passed) == 1:
                best = passed[0]
                runner = next((f for f in fits if f is not best), None)
                lazy = None if runner is None else (lambda r=runner: self._from_fit(r))
                return Fix(self._from_fit(best), lazy, len(fits), (hx, hy), cov)
        what = "tracking" if moved_arm is None else f"tracking arm {moved_arm}"
        return self._decide([self._from_fit(f) for f in fits], hx, hy, cov, what)

    def _from_fit(self, f: tuple) -> Candidate:
        """A :class:`Candidate` from a tracking fit ``(chi2, holes, x, y, heading, residuals)``."""
        ids, (h0, h1, h2) = self._ids, f[1]
        return Candidate(f[1], (ids[h0], ids[h1], ids[h2]), f[2:5], f[0], f[5])
