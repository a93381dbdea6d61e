"""Fitting the climber's body pose to a hole triple, and what a fit says.

The measured hands (body frame, from the six encoder angles) are laid onto three holes by a
weighted rigid 2-D least-squares fit (x, y, heading); its chi-square, with three degrees of
freedom, is gated by :class:`NoiseModel` (encoder and map noise propagated to each hand).
One fit gives a :class:`Candidate`; a localisation's answer is a :class:`Fix` (best
candidate, runner-up, pose covariance), and its failures are :class:`NoFixError` and
:class:`AmbiguousFixError`. ``_fit`` is the vectorised fit of many triples at once,
``_fit_one`` the scalar one the tracking path uses; both reach the same optimum.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .errors import InvalidInputError, KinematicsError

__all__ = ["NoiseModel", "Candidate", "Fix", "LocalizationError", "NoFixError", "AmbiguousFixError", "chi2_3_cdf",
           "chi2_3_quantile"]


class LocalizationError(KinematicsError):
    """Base class of localisation failures."""


class NoFixError(LocalizationError):
    """No hole triple explains the measured hands. ``best`` is the closest candidate (or None)."""

    def __init__(self, message: str, best: Candidate | None = None) -> None:
        super().__init__(message)
        self.best = best


class AmbiguousFixError(LocalizationError):
    """Several hole triples pass the gate. ``candidates`` lists them, most likely first, each
    with its ``likelihood`` (probability among them); ``count`` says how many there are.

    A global fix on a big regular wall stops as soon as two triples pass; the full list
    (hundreds of triples there) is worked out only when ``candidates``, ``count`` or the
    message is first asked for (``resolve``).
    """

    def __init__(self, message: str | None = None, candidates: Sequence[Candidate] | None = None,
                 count: int | None = None, build: Callable[[], list[Candidate]] | None = None,
                 resolve: Callable[[], AmbiguousFixError] | None = None) -> None:
        super().__init__(message if message is not None else "ambiguous fix (details on demand)")
        self._message = message
        self._candidates = None if candidates is None else tuple(candidates)
        self._build = build
        self._count = count
        self._resolve = resolve

    def _resolved(self) -> None:
        if self._resolve is not None:
            full, self._resolve = self._resolve(), None
            self._message, self._candidates, self._count = full._message, full.candidates, full.count
            self.args = (self._message,)

    @property
    def candidates(self) -> tuple[Candidate, ...]:
        self._resolved()
        if self._candidates is None:
            self._candidates = tuple(self._build()) if self._build else ()
        return self._candidates

    @property
    def count(self) -> int:
        self._resolved()
        return len(self.candidates) if self._count is None else self._count

    def __str__(self) -> str:
        self._resolved()
        return str(self._message)


def chi2_3_cdf(x: float) -> float:
    """CDF of the chi-square distribution with 3 degrees of freedom (closed form)."""
    if x <= 0:
        return 0.0
    return math.erf(math.sqrt(x / 2)) - math.sqrt(2 * x / math.pi) * math.exp(-x / 2)


def chi2_3_quantile(p: float) -> float:
    """Inverse of :func:`chi2_3_cdf` (bisection, 1e-12 relative)."""
    if not 0.0 < p < 1.0:
        raise InvalidInputError(f"probability {p!r}; expected 0 < p < 1")
    lo, hi = 0.0, 200.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if chi2_3_cdf(mid) < p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class NoiseModel:
    """What the measurements may get wrong; it sets the acceptance gate of a fix.

    Attributes:
        sigma_angle: 1-sigma encoder noise of every joint (rad). Seed 000 asks for +-0.5 deg.
        sigma_map: 1-sigma error of each mapped hole coordinate (cm).
        p_gate: probability that the *true* holes are rejected (the chi-square tail with
            3 degrees of freedom: 6 residual coordinates minus the 3 fitted pose values).
        tolerance: if set (cm), the seed's way instead: accept when every hand-to-hand
            distance matches the holes' within ``tolerance``, no statistics.
    """

    sigma_angle: float = math.radians(0.5)
    sigma_map: float = 0.05
    p_gate: float = 1e-4
    tolerance: float | None = None

    def __post_init__(self) -> None:
        for key in ("sigma_angle", "sigma_map"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InvalidInputError(f"{key}={v!r}; expected a finite value >= 0")
        if self.sigma_angle == 0 and self.sigma_map == 0 and self.tolerance is None:
            raise InvalidInputError("sigma_angle and sigma_map are both 0; give a noise or a tolerance")
        if not 0 < self.p_gate < 1:
            raise InvalidInputError(f"p_gate={self.p_gate!r}; expected 0 < p_gate < 1")
        if self.tolerance is not None and not (math.isfinite(self.tolerance) and self.tolerance > 0):
            raise InvalidInputError(f"tolerance={self.tolerance!r}; expected a length > 0 cm")
        object.__setattr__(self, "_limit", chi2_3_quantile(1.0 - self.p_gate))

    @classmethod
    def from_degrees(cls, sigma_deg: float, **kw: float) -> NoiseModel:
        return cls(sigma_angle=math.radians(sigma_deg), **kw)

    @property
    def chi2_limit(self) -> float:
        """Gate on the fit's chi-square: ``P(chi2_3 > limit) = p_gate``."""
        return self._limit  # type: ignore[attr-defined]


class Candidate:
    """One hole triple with the rigid fit of the hands onto it.

    ``holes``: map rows of the holes of arms 1, 2, 3; ``ids``: their ``(col, row)``;
    ``pose``: body ``(x, y, heading)`` (cm, cm, rad); ``chi2``: fit statistic (3 dof);
    ``residual_cm``: distance of each hand from its hole after the fit;
    ``likelihood``: probability among the candidates that passed the gate (equal priors).
    Treat it as read-only. A plain slotted class, not a dataclass: tracking builds one per
    fix, so ``pose`` and ``residual_cm`` may be given as float sequences and become numpy
    arrays on first use (two arrays cost ~0.9 us of a ~10 us tracking fix).
    """

    __slots__ = ("holes", "ids", "_pose", "chi2", "_res", "likelihood")

    def __init__(self, holes: tuple[int, int, int], ids: tuple[tuple[int, int], tuple[int, int], tuple[int, int]],
                 pose: np.ndarray | Sequence[float], chi2: float, residual_cm: np.ndarray | Sequence[float],
                 likelihood: float = 1.0) -> None:
        self.holes, self.ids, self._pose, self.chi2, self._res = holes, ids, pose, chi2, residual_cm
        self.likelihood = likelihood

    @property
    def pose(self) -> np.ndarray:
        return self._pose if type(self._pose) is np.ndarray else self._to_array("_pose")

    @property
    def residual_cm(self) -> np.ndarray:
        return self._res if type(self._res) is np.ndarray else self._to_array("_res")

    def _to_array(self, slot: str) -> np.ndarray:
        a = np.array(getattr(self, slot), dtype=float)
        setattr(self, slot, a)
        return a

    def __repr__(self) -> str:
        return (f"Candidate(holes={self.holes}, ids={self.ids}, pose={self.pose!r}, chi2={self.chi2!r}, "
                f"residual_cm={self.residual_cm!r}, likelihood={self.likelihood!r})")

    def as_dict(self) -> dict[str, object]:
        return {"ids": [list(i) for i in self.ids], "centre_cm": [round(float(v), 4) for v in self.pose[:2]],
                "heading_deg": round(math.degrees(float(self.pose[2])), 4), "chi2": round(self.chi2, 4),
                "residual_cm": [round(float(v), 4) for v in self.residual_cm],
                "likelihood": round(self.likelihood, 6)}


class Fix:
    """A unique localisation: the held holes, the body pose and how sure we are.

    ``best`` is the accepted :class:`Candidate`; ``covariance`` the 3x3 covariance of
    ``pose`` (cm^2, cm rad, rad^2) propagated from the noise model (computed on first use);
    ``runner_up`` the next best candidate of the search (None if there was none);
    ``n_candidates`` how many triples of matching shape were examined.
    """

    __slots__ = ("best", "_runner", "n_candidates", "_h", "_cov", "_covariance")

    def __init__(self, best: Candidate, runner_up: Candidate | Callable[[], Candidate] | None, n_candidates: int,
                 hands: tuple[list[float], list[float]] | None = None,
                 hand_cov: Sequence[tuple[float, float, float]] | None = None,
                 covariance: np.ndarray | None = None) -> None:
        self.best, self._runner, self.n_candidates = best, runner_up, n_candidates
        self._h, self._cov, self._covariance = hands, hand_cov, covariance

    @property
    def runner_up(self) -> Candidate | None:
        """The next best candidate (built on first use when tracking made it lazily)."""
        if self._runner is not None and not isinstance(self._runner, Candidate):
            self._runner = self._runner()
        return self._runner

    @property
    def covariance(self) -> np.ndarray:
        if self._covariance is None:
            if self._h is None:
                self._covariance = np.full((3, 3), np.nan)
            else:
                hx, hy = self._h
                self._covariance = _pose_covariance(float(self.best.pose[2]), list(zip(hx, hy)),
                                                    self._cov)  # type: ignore[arg-type]
        return self._covariance

    @property
    def holes(self) -> tuple[int, int, int]:
        return self.best.holes

    @property
    def ids(self) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
        return self.best.ids

    @property
    def pose(self) -> np.ndarray:
        return self.best.pose

    @property
    def centre(self) -> np.ndarray:
        return self.best.pose[:2]

    @property
    def heading(self) -> float:
        return float(self.best.pose[2])

    def __repr__(self) -> str:
        x, y, th = (float(v) for v in self.pose)
        return (f"Fix(ids={self.ids}, centre=({x:.4f}, {y:.4f}) cm, heading={math.degrees(th):.3f} deg, "
                f"chi2={self.best.chi2:.3g})")

    def as_dict(self) -> dict[str, object]:
        std = np.sqrt(np.diag(self.covariance))
        return {**self.best.as_dict(), "centre_std_cm": [round(float(v), 4) for v in std[:2]],
                "heading_std_deg": round(math.degrees(float(std[2])), 4),
                "runner_up": None if self.runner_up is None else self.runner_up.as_dict(),
                "candidates_examined": self.n_candidates}


_GN_STEPS = 2
_STEP_TOL = 1e-2  # rad: a Newton step this small ends the scalar fit (see _fit_one)


_GN_STEPS = 2
_STEP_TOL = 1e-2  # rad: a Newton step this small ends the scalar fit (see _fit_one)


def _fit(p: np.ndarray, h: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted rigid 2-D fit of body hands ``h (3, 2)`` onto holes ``p (K, 3, 2)``, vectorised.

    Kabsch gives the start; two Gauss-Newton steps then minimise the chi-square
    ``sum_i b_i^T W_i b_i`` with ``b_i = R^T (p_i - t) - h_i`` (hand residual in the body
    frame, where the hand covariances ``W_i^-1`` live), so that the statistic follows a
    chi-square law with 3 degrees of freedom even for very anisotropic hand noise.
    Returns ``pose (K, 3)``, ``chi2 (K,)`` and the residual distances ``(K, 3)``.
    """
    k = len(p)
    hm = h.mean(axis=0)
    pm = p.mean(axis=1)
    hc = h - hm
    pc = p - pm[:, None, :]
    dot = (pc[..., 0] * hc[None, :, 0] + pc[..., 1] * hc[None, :, 1]).sum(axis=1)
    cross = (hc[None, :, 0] * pc[..., 1] - hc[None, :, 1] * pc[..., 0]).sum(axis=1)
    th = np.arctan2(cross, dot)
    c, s = np.cos(th), np.sin(th)
    tx = pm[:, 0] - (c * hm[0] - s * hm[1])
    ty = pm[:, 1] - (s * hm[0] + c * hm[1])
    w00, w01, w11 = weights[:, 0, 0], weights[:, 0, 1], weights[:, 1, 1]
    for _ in range(_GN_STEPS + 1):
        dx, dy = p[..., 0] - tx[:, None], p[..., 1] - ty[:, None]
        bx = c[:, None] * dx + s[:, None] * dy - h[None, :, 0]
        by = -s[:, None] * dx + c[:, None] * dy - h[None, :, 1]
        if _ == _GN_STEPS:
            break
        # Jacobian of b_i w.r.t. (tx, ty, th): columns -R^T e_x, -R^T e_y, dR^T/dth (p_i - t)
        jx = np.stack([-c, s], -1)[:, None, :].repeat(3, 1)    # (K, 3, 2) d b / d tx = -R^T e_x
        jy = np.stack([-s, -c], -1)[:, None, :].repeat(3, 1)   # d b / d ty = -R^T e_y
        jt = np.stack([-s[:, None] * dx + c[:, None] * dy, -c[:, None] * dx - s[:, None] * dy], -1)
        cols = (jx, jy, jt)
        wb = np.stack([w00 * bx + w01 * by, w01 * bx + w11 * by], -1)
        g = np.stack([(cj * wb).sum(axis=(1, 2)) for cj in cols], -1)
        hess = np.empty((k, 3, 3))
        for i, ci in enumerate(cols):
            wci = np.stack([w00 * ci[..., 0] + w01 * ci[..., 1], w01 * ci[..., 0] + w11 * ci[..., 1]], -1)
            for j in range(i, 3):
                hess[:, i, j] = hess[:, j, i] = (wci * cols[j]).sum(axis=(1, 2))
        step = np.linalg.solve(hess, -g[..., None])[..., 0]
        tx, ty, th = tx + step[:, 0], ty + step[:, 1], th + step[:, 2]
        c, s = np.cos(th), np.sin(th)
    chi2 = (w00 * bx * bx + 2 * w01 * bx * by + w11 * by * by).sum(axis=1)
    th = np.mod(th + np.pi, 2 * np.pi) - np.pi
    return np.stack([tx, ty, th], -1), chi2, np.hypot(bx, by)


def _fit_one(px: Sequence[float], py: Sequence[float], hx: Sequence[float], hy: Sequence[float],
             w: Sequence[tuple[float, float, float]], steps: int = _GN_STEPS, tol: float = _STEP_TOL
             ) -> tuple[float, float, float, float, list[float]]:
    """:func:`_fit` for one triple in plain Python: ``(x, y, heading, chi2, residuals)``.

    Variable projection: with ``q_i = R^T p_i`` and ``u = R^T t`` the residuals are
    ``b_i = q_i - u - h_i``, linear in ``u``; for a heading the best ``u`` is
    ``S^-1 sum W_i (q_i - h_i)`` (``S = sum W_i``), which leaves a one-dimensional
    problem in the heading. Its gradient is ``g = sum j_i^T W_i b_i`` (``j_i = dq_i/dth =
    (q_iy, -q_ix)``), its Gauss-Newton curvature ``sum j_i^T W_i j_i - m^T S^-1 m``
    (``m = sum W_i j_i``), and its exact curvature that less ``sum b_i^T W_i q_i`` (as
    ``dj_i/dth = -q_i``). Newton steps (Gauss-Newton where the exact curvature is not
    clearly positive, far from the optimum) start at the Kabsch heading and stop after
    ``steps`` or once a step is under ``tol`` rad: on 1,000 grips at 1 deg of noise the
    default ends within 3e-4 of the optimum's chi-square and 4e-4 cm of its centre, mostly
    after one step (Gauss-Newton needed two for 5e-5 and 3e-4 cm).

    ``steps=0`` stops at the Kabsch heading (with its best translation): its chi-square is an
    upper bound of the weighted optimum's, so ``chi2 <= gate`` there proves the triple passes.
    """
    px0, px1, px2 = px
    py0, py1, py2 = py
    hx0, hx1, hx2 = hx
    hy0, hy1, hy2 = hy
    hmx, hmy = (hx0 + hx1 + hx2) / 3, (hy0 + hy1 + hy2) / 3
    pmx, pmy = (px0 + px1 + px2) / 3, (py0 + py1 + py2) / 3
    ax0, ay0, ax1, ay1, ax2, ay2 = hx0 - hmx, hy0 - hmy, hx1 - hmx, hy1 - hmy, hx2 - hmx, hy2 - hmy
    bx0, by0, bx1, by1, bx2, by2 = px0 - pmx, py0 - pmy, px1 - pmx, py1 - pmy, px2 - pmx, py2 - pmy
    th = math.atan2(ax0 * by0 - ay0 * bx0 + ax1 * by1 - ay1 * bx1 + ax2 * by2 - ay2 * bx2,
                    ax0 * bx0 + ay0 * by0 + ax1 * bx1 + ay1 * by1 + ax2 * bx2 + ay2 * by2)
    (a0, b0, c0), (a1, b1, c1), (a2, b2, c2) = w
    sa, sb, sc = a0 + a1 + a2, b0 + b1 + b2, c0 + c1 + c2
    det = sa * sc - sb * sb
    ia, ib, ic = sc / det, -sb / det, sa / det  # S^-1
    it = 0
    while True:
        c, s = math.cos(th), math.sin(th)
        qx0, qy0 = c * px0 + s * py0, c * py0 - s * px0
        qx1, qy1 = c * px1 + s * py1, c * py1 - s * px1
        qx2, qy2 = c * px2 + s * py2, c * py2 - s * px2
        dx0, dy0, dx1, dy1, dx2, dy2 = qx0 - hx0, qy0 - hy0, qx1 - hx1, qy1 - hy1, qx2 - hx2, qy2 - hy2
        rx = a0 * dx0 + b0 * dy0 + a1 * dx1 + b1 * dy1 + a2 * dx2 + b2 * dy2
        ry = b0 * dx0 + c0 * dy0 + b1 * dx1 + c1 * dy1 + b2 * dx2 + c2 * dy2
        ux, uy = ia * rx + ib * ry, ib * rx + ic * ry
        ex0, ey0, ex1, ey1, ex2, ey2 = dx0 - ux, dy0 - uy, dx1 - ux, dy1 - uy, dx2 - ux, dy2 - uy
        wx0, wy0 = a0 * ex0 + b0 * ey0, b0 * ex0 + c0 * ey0
        wx1, wy1 = a1 * ex1 + b1 * ey1, b1 * ex1 + c1 * ey1
        wx2, wy2 = a2 * ex2 + b2 * ey2, b2 * ex2 + c2 * ey2
        if it >= steps:
            chi2 = ex0 * wx0 + ey0 * wy0 + ex1 * wx1 + ey1 * wy1 + ex2 * wx2 + ey2 * wy2
            res = [math.sqrt(ex0 * ex0 + ey0 * ey0), math.sqrt(ex1 * ex1 + ey1 * ey1),
                   math.sqrt(ex2 * ex2 + ey2 * ey2)]
            return c * ux - s * uy, s * ux + c * uy, math.remainder(th, 2 * math.pi), chi2, res
        g = qy0 * wx0 - qx0 * wy0 + qy1 * wx1 - qx1 * wy1 + qy2 * wx2 - qx2 * wy2
        mx0, my0 = a0 * qy0 - b0 * qx0, b0 * qy0 - c0 * qx0
        mx1, my1 = a1 * qy1 - b1 * qx1, b1 * qy1 - c1 * qx1
        mx2, my2 = a2 * qy2 - b2 * qx2, b2 * qy2 - c2 * qx2
        mx, my = mx0 + mx1 + mx2, my0 + my1 + my2
        hh = (qy0 * mx0 - qx0 * my0 + qy1 * mx1 - qx1 * my1 + qy2 * mx2 - qx2 * my2
              - (mx * (ia * mx + ib * my) + my * (ib * mx + ic * my)))
        exact = hh - (wx0 * qx0 + wy0 * qy0 + wx1 * qx1 + wy1 * qy1 + wx2 * qx2 + wy2 * qy2)
        if exact > 0.25 * hh:
            hh = exact
        if hh > 0:
            step = g / hh
            th -= step
            if -tol < step < tol:
                steps = it + 1  # converged: evaluate there and stop
        else:  # a degenerate triple (all holes in one point): keep the heading
            steps = it
        it += 1


def _inv3(m: list[list[float]]) -> list[list[float]]:
    """Inverse of a 3 x 3 matrix (nested lists) by cofactors: no numpy call overhead."""
    (a, b, c), (d, e, f), (g, h, i) = m
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    if det == 0:
        raise InvalidInputError("degenerate hand triangle: its side covariance is singular")
    r = 1.0 / det
    return [[A * r, (c * h - b * i) * r, (b * f - c * e) * r],
            [B * r, (a * i - c * g) * r, (c * d - a * f) * r],
            [C * r, (b * g - a * h) * r, (a * e - b * d) * r]]


def _pose_covariance(heading: float, hands: Sequence[tuple[float, float]],
                     hand_cov: Sequence[tuple[float, float, float]]) -> np.ndarray:
    """The 3x3 covariance of a fitted pose ``(x, y, heading)``: the inverse of the Fisher
    information ``sum_i J_i^T W_i J_i`` of the three hands, ``J_i`` the wall-frame hand's
    derivative by the pose (hand ``i`` at body-frame ``hands[i]``) and ``W_i`` the inverse
    of its wall-frame covariance (body-frame ``(a, b, c)`` = ``[[a, b], [b, c]]``, rotated by
    the heading). Plain floats: it is on the tracking path of every env step."""
    c, s = math.cos(heading), math.sin(heading)
    i00 = i01 = i02 = i11 = i12 = i22 = 0.0
    for (hx, hy), (a, b, cc) in zip(hands, hand_cov):
        # R C R^T, then its inverse W (symmetric 2x2)
        r00 = c * (c * a - s * b) - s * (c * b - s * cc)
        r01 = s * (c * a - s * b) + c * (c * b - s * cc)
        r11 = s * (s * a + c * b) + c * (s * b + c * cc)
        det = r00 * r11 - r01 * r01
        w00, w01, w11 = r11 / det, -r01 / det, r00 / det
        j0, j1 = -s * hx - c * hy, c * hx - s * hy  # d(hand)/d(heading)
        i00 += w00
        i01 += w01
        i11 += w11
        i02 += w00 * j0 + w01 * j1
        i12 += w01 * j0 + w11 * j1
        i22 += j0 * (w00 * j0 + w01 * j1) + j1 * (w01 * j0 + w11 * j1)
    return np.array(_inv3([[i00, i01, i02], [i01, i11, i12], [i02, i12, i22]]))
