"""Maps of holes on a wall, for the climber to grip and to localise itself against.

A :class:`HoleMap` is a set of holes, each with an id ``(col, row)`` and a position in cm
(wall frame, x to the right, y up). Maps come from YAML (``configs/walls/*.yaml``; the
seed's measured 4 x 4 map is ``seed_4x4``) or are generated as a jittered grid with
missing holes, reproducibly from a seed.
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import kinegym.configs as _configs

from .climber import ClimberGeometry, hand_positions, inverse_program
from .errors import InvalidInputError, KinematicsError, as_array

__all__ = [
    "HoleMap", "WALL_SCHEMA", "NoiseModel", "TriangleIndex", "Localizer", "Fix", "Candidate",
    "LocalizationError", "NoFixError", "AmbiguousFixError", "BayesLocalizer", "seed_adjacent_search",
    "chi2_3_cdf", "chi2_3_quantile", "Grip", "GripSimulator", "sensor_study",
]

WALL_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(default="wall"),
    "description": _configs.Text(default=""),
    "holes": _configs.ListOf(
        item=_configs.Section(fields={
            "id": _configs.Vector(length=2, item=_configs.Number(integer=True)),
            "xy_cm": _configs.Vector(length=2),
        }),
        min_len=1,
        doc="holes with id [col, row] and position xy_cm",
    ),
}


@dataclass(frozen=True)
class HoleMap:
    """Holes of a wall: ``ids`` (N, 2) integer ``(col, row)`` and ``xy`` (N, 2) in cm."""

    ids: np.ndarray
    xy: np.ndarray
    name: str = "wall"

    def __post_init__(self) -> None:
        xy = as_array("xy", self.xy, (2,))
        ids = np.asarray(self.ids)
        if xy.ndim != 2 or xy.shape[0] == 0:
            raise InvalidInputError(f"xy has shape {xy.shape}; expected (N, 2) with N >= 1 holes")
        if ids.shape != xy.shape or not np.issubdtype(ids.dtype, np.integer):
            raise InvalidInputError(
                f"ids has shape {ids.shape} and dtype {ids.dtype}; expected integers of shape {xy.shape}"
            )
        keys = [tuple(map(int, i)) for i in ids]
        if len(set(keys)) != len(keys):
            dup = next(k for k in keys if keys.count(k) > 1)
            raise InvalidInputError(f"hole id {dup} appears more than once; ids must be unique")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "ids", ids.astype(np.int64))
        object.__setattr__(self, "_index", {k: n for n, k in enumerate(keys)})

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @property
    def xy_list(self) -> list[tuple[float, float]]:
        """Hole positions as Python floats (cached): for scalar hot loops."""
        got = self.__dict__.get("_xy_list")
        if got is None:
            got = [(float(a), float(b)) for a, b in self.xy.tolist()]
            object.__setattr__(self, "_xy_list", got)
        return got

    @property
    def id_list(self) -> list[tuple[int, int]]:
        """Hole ids as Python tuples (cached)."""
        got = self.__dict__.get("_id_list")
        if got is None:
            got = [(int(a), int(b)) for a, b in self.ids.tolist()]
            object.__setattr__(self, "_id_list", got)
        return got

    def index(self, hole_id: tuple[int, int]) -> int:
        """Row of hole ``(col, row)``; raises ``KeyError`` naming the id."""
        key = tuple(int(v) for v in hole_id)
        try:
            return self._index[key]  # type: ignore[attr-defined]
        except KeyError:
            raise KeyError(f"no hole {key} in map '{self.name}' ({len(self)} holes)") from None

    def position(self, hole_id: tuple[int, int]) -> np.ndarray:
        """Position (cm) of hole ``(col, row)``."""
        return self.xy[self.index(hole_id)].copy()

    @property
    def spacing(self) -> float:
        """Median nearest-neighbour distance (cm); the cell size of the spatial hash."""
        cached = self.__dict__.get("_spacing")
        if cached is None:
            grid = _SpatialHash(self.xy, cell=max(1e-6, float(np.ptp(self.xy, axis=0).max()) / 64 or 1.0))
            d = [grid.nearest_other(i) for i in range(min(len(self), 400))]
            cached = float(np.median(d)) if len(self) > 1 else 1.0
            object.__setattr__(self, "_spacing", cached)
        return cached

    def within(self, point: object, radius: float) -> np.ndarray:
        """Indices of the holes within ``radius`` cm of ``point`` (constant time on average)."""
        grid = self.__dict__.get("_grid")
        if grid is None:
            grid = _SpatialHash(self.xy, cell=max(self.spacing, 1e-6))
            object.__setattr__(self, "_grid", grid)
        return grid.within(point, radius)

    @classmethod
    def from_config(cls, name_or_path: str | Path = "seed_4x4") -> HoleMap:
        """Load ``configs/walls/<name>.yaml`` or a YAML path; raises ``configs.ConfigError``."""
        cfg = _configs.load("walls", name_or_path, WALL_SCHEMA)
        ids = np.array([h["id"] for h in cfg["holes"]], dtype=np.int64)
        xy = np.array([h["xy_cm"] for h in cfg["holes"]], dtype=np.float64)
        try:
            return cls(ids=ids, xy=xy, name=cfg["name"])
        except InvalidInputError as exc:
            raise _configs.ConfigError(str(_configs.resolve("walls", name_or_path)), "holes",
                                       "duplicate id", str(exc)) from exc

    @classmethod
    def grid(
        cls,
        cols: int,
        rows: int,
        spacing: float = 20.0,
        jitter: float = 0.0,
        missing: float = 0.0,
        seed: int | None = 0,
        name: str | None = None,
    ) -> HoleMap:
        """A ``cols`` x ``rows`` grid, ``spacing`` cm apart, ids from (1, 1) at the origin.

        ``jitter``: each coordinate moved uniformly within +-jitter cm; ``missing``: the
        share of holes removed (at random, at least one kept). Reproducible from ``seed``.
        """
        if not (isinstance(cols, int) and isinstance(rows, int) and cols >= 1 and rows >= 1):
            raise InvalidInputError(f"cols={cols!r}, rows={rows!r}; expected integers >= 1")
        if not (np.isfinite(spacing) and spacing > 0):
            raise InvalidInputError(f"spacing={spacing!r}; expected a length > 0 cm")
        if not (np.isfinite(jitter) and 0 <= jitter < spacing / 2):
            raise InvalidInputError(f"jitter={jitter!r}; expected 0 <= jitter < spacing/2 cm")
        if not (0.0 <= missing < 1.0):
            raise InvalidInputError(f"missing={missing!r}; expected a share in [0, 1)")
        rng = np.random.default_rng(seed)
        c, r = np.meshgrid(np.arange(1, cols + 1), np.arange(1, rows + 1), indexing="ij")
        ids = np.stack([c.ravel(), r.ravel()], axis=-1)
        xy = (ids - 1) * float(spacing) + rng.uniform(-jitter, jitter, ids.shape)
        keep = rng.random(len(ids)) >= missing
        if not keep.any():
            keep[rng.integers(len(ids))] = True
        return cls(ids=ids[keep], xy=xy[keep], name=name or f"grid_{cols}x{rows}")


class _SpatialHash:
    """Points binned into square cells of a dict: neighbourhood queries in microseconds."""

    def __init__(self, xy: np.ndarray, cell: float) -> None:
        self.xy, self.cell = xy, float(cell)
        self.pts = [tuple(p) for p in xy.tolist()]
        cells: dict[tuple[int, int], list[tuple[int, float, float]]] = {}
        for i, (cx, cy) in enumerate(np.floor(xy / self.cell).astype(np.int64).tolist()):
            cells.setdefault((cx, cy), []).append((i, *self.pts[i]))
        self.cells = cells

    def within_list(self, px: float, py: float, radius: float) -> list[int]:
        c = self.cell
        x0, x1 = math.floor((px - radius) / c), math.floor((px + radius) / c)
        y0, y1 = math.floor((py - radius) / c), math.floor((py + radius) / c)
        r2 = radius * radius
        out = []
        get = self.cells.get
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                for i, hx, hy in get((cx, cy), ()):
                    dx, dy = hx - px, hy - py
                    if dx * dx + dy * dy <= r2:
                        out.append(i)
        return out

    def within(self, point: object, radius: float) -> np.ndarray:
        return np.array(self.within_list(float(point[0]), float(point[1]), radius),  # type: ignore[index]
                        dtype=np.int64)

    def nearest_other(self, i: int) -> float:
        r = self.cell
        while True:
            idx = [j for j in self.within_list(*self.pts[i], r) if j != i]
            if idx:
                return float(np.min(np.hypot(*(self.xy[idx] - self.xy[i]).T)))
            r *= 2


# ============================================================================ localisation
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
                hands = np.array(self._h, dtype=float).T
                cov = np.array([[[a, b], [b, c]] for a, b, c in self._cov])  # type: ignore[union-attr]
                self._covariance = _pose_covariance(self.best.pose, hands, cov)
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
_OTHERS = ((1, 2), (0, 2), (0, 1))  # the kept arms when arm 0, 1 or 2 moves
_PROBE_BLOCK = 64  # triples screened at a time when a grip's own index cell is probed


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


def _pose_covariance(pose: np.ndarray, h: np.ndarray, cov_body: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    info = np.zeros((3, 3))
    for i in range(3):
        jac = np.array([[1.0, 0.0, -s * h[i, 0] - c * h[i, 1]], [0.0, 1.0, c * h[i, 0] - s * h[i, 1]]])
        w = np.linalg.inv(rot @ cov_body[i] @ rot.T)
        info += jac.T @ w @ jac
    return np.linalg.inv(info)


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
    def _measure(self, q: object) -> tuple[list[float], list[float], list[tuple[float, float, float]],
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

    def _candidate(self, holes: Sequence[int], x: float, y: float, th: float, chi2: float,
                   res: Sequence[float], lik: float = 1.0) -> Candidate:
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
            out.append(self._candidate(v, x, y, th, chi2, res))
        out.sort(key=lambda c: c.chi2)
        return out

    def _passes(self, cand: Candidate, hx: list[float], hy: list[float]) -> bool:
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
        passed = [c for c in cands if self._passes(c, hx, hy)]
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
        hx, hy, cov, w = self._measure(q)
        return self._search(hx, hy, cov, w)

    def _search(self, hx: list[float], hy: list[float], cov: list[tuple[float, float, float]],
                w: list[tuple[float, float, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        verts, _, _ = self._screen(hx, hy, cov)
        pose, chi2, res = self._fit_rows(verts, hx, hy, w)
        order = np.argsort(chi2, kind="stable")
        return verts[order], pose[order], chi2[order], res[order]

    def candidates(self, q: object) -> list[Candidate]:
        """:meth:`search` as :class:`Candidate` objects (can be thousands on a big wall)."""
        verts, pose, chi2, res = self.search(q)
        return [self._candidate(v, *p, c, r) for v, p, c, r in zip(verts.tolist(), pose.tolist(), chi2.tolist(),
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
        hx, hy, cov, w = self._measure(q)
        if self.noise.tolerance is not None:  # the seed's way: every triple within the tolerance
            verts, pose, chi2, res = self._search(hx, hy, cov, w)
            cands = [self._candidate(verts[i], *pose[i], chi2[i], res[i].tolist()) for i in range(len(verts))]
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
            cand = self._candidate(v, x, y, th, chi2, res)
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
        verts, pose, chi2, res = self._search(hx, hy, cov, w)
        n = int(np.searchsorted(chi2, self._limit, "right"))
        cands = [self._candidate(verts[i], *pose[i], chi2[i], res[i].tolist()) for i in range(n)]
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

    def _track_candidates(self, holes: Sequence[int], hx: list[float], hy: list[float],
                          cov: list[tuple[float, float, float]], w: list[tuple[float, float, float]],
                          moved_arm: int | None) -> list[Candidate]:
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
        hx, hy, cov, w = self._measure(q)
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


class BayesLocalizer:
    """Lost start: a discrete Bayes filter over hole-triple hypotheses, grip after grip.

    The first grip seeds the hypotheses with every candidate that passes the gate (weights
    ``exp(-chi2/2)``, equal priors); every later grip (naming the arm that moved, or None
    for a body shift) propagates each hypothesis by a tracking step and multiplies in the
    new fit's likelihood. :attr:`fix` is the best hypothesis once it holds at least
    ``threshold`` of the probability. If every hypothesis dies, the grip starts over globally.
    """

    def __init__(self, localizer: Localizer, threshold: float = 0.999) -> None:
        if not 0.5 <= threshold < 1:
            raise InvalidInputError(f"threshold={threshold!r}; expected 0.5 <= threshold < 1")
        self.loc, self.threshold = localizer, threshold
        self.reset()

    def reset(self) -> None:
        self.hypotheses: dict[tuple[int, int, int], float] = {}
        self._last: dict[tuple[int, int, int], Candidate] = {}
        self.grips = 0
        self.restarts = 0

    def observe(self, q: object, moved_arm: int | None = None) -> Fix | None:
        """Add one grip; returns the :class:`Fix` once localised, else None."""
        if moved_arm is not None and moved_arm not in (1, 2, 3):
            raise InvalidInputError(f"moved_arm={moved_arm!r}; expected 1, 2, 3 or None")
        loc = self.loc
        hx, hy, cov, w = loc._measure(q)
        self.grips += 1
        new: dict[tuple[int, int, int], float] = {}
        last: dict[tuple[int, int, int], Candidate] = {}
        for holes, weight in self.hypotheses.items():
            for c in loc._track_candidates(holes, hx, hy, cov, w, moved_arm):
                if loc._passes(c, hx, hy):
                    new[c.holes] = new.get(c.holes, 0.0) + weight * math.exp(-0.5 * c.chi2)
                    last[c.holes] = c
        if not new:  # first grip, or every hypothesis died: start over from this grip
            if self.hypotheses:
                self.restarts += 1
            verts, pose, chi2, res = loc._search(hx, hy, cov, w)
            n = len(chi2) if loc.noise.tolerance is not None else int(np.searchsorted(chi2, loc._limit, "right"))
            for i in range(n):
                c = loc._candidate(verts[i], *pose[i], chi2[i], res[i])
                if loc._passes(c, hx, hy):
                    new[c.holes] = math.exp(-0.5 * (c.chi2 - chi2[0]))
                    last[c.holes] = c
        total = sum(new.values())
        self.hypotheses = {k: v / total for k, v in new.items()} if total > 0 else {}
        self._last = last
        return self.fix

    @property
    def posterior(self) -> list[tuple[Candidate, float]]:
        """Hypotheses with their probabilities, most likely first."""
        return sorted(((self._last[k], p) for k, p in self.hypotheses.items()), key=lambda t: -t[1])

    @property
    def fix(self) -> Fix | None:
        """The localisation once one hypothesis holds ``threshold`` of the probability, else None."""
        if not self.hypotheses:
            return None
        key, p = max(self.hypotheses.items(), key=lambda kv: kv[1])
        if p < self.threshold:
            return None
        b = self._last[key]
        runner = max(((self._last[k], q) for k, q in self.hypotheses.items() if k != key),
                     key=lambda t: t[1], default=(None, 0.0))[0]
        return Fix(Candidate(b.holes, b.ids, b.pose, b.chi2, b.residual_cm, p), runner, len(self.hypotheses))


def seed_adjacent_search(holes: HoleMap, q: object, geom: ClimberGeometry | None = None,
                         precision: float = 0.1) -> list[tuple[tuple[int, int], ...]]:
    """Seed 000's part 2, kept as the baseline: compare distances of *adjacent* holes only.

    For every hole and its right / up-right / up / up-left neighbour (by grid id), if their
    distance matches ``|hand1 - hand2|`` within ``precision`` cm, every hole adjacent to both
    whose distances match the other two hand distances (either way round) completes a
    solution. Unlabelled and unoriented, like the seed: mirror images are accepted, and the
    first pair is not told apart (arm 1 or 2). Returns every match as three ids, in the
    seed's order (p1, p2, p3). The seed's own code mixes ``&&`` and ``||`` and prints only
    the last match; this is the search it describes, done right, O(N) over the whole map.
    """
    g = geom or ClimberGeometry()
    h = hand_positions(as_array("joint angles q", q, (3, 2)), g)
    h1 = float(np.linalg.norm(h[0] - h[1]))
    h2 = float(np.linalg.norm(h[2] - h[1]))
    h3 = float(np.linalg.norm(h[0] - h[2]))
    index = holes._index  # type: ignore[attr-defined]
    xy = holes.xy
    out: list[tuple[tuple[int, int], ...]] = []
    neighbours = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)]
    for (cx, cy), a in index.items():
        for dx, dy in ((1, 0), (1, 1), (0, 1), (-1, 1)):
            b = index.get((cx + dx, cy + dy))
            if b is None:
                continue
            d_ab = math.dist(xy[a], xy[b])
            if abs(d_ab - h1) >= precision:
                continue
            bx, by = cx + dx, cy + dy
            for ex, ey in neighbours:
                kx, ky = cx + ex, cy + ey
                if (kx, ky) == (bx, by) or max(abs(kx - bx), abs(ky - by)) > 1:
                    continue
                c = index.get((kx, ky))
                if c is None:
                    continue
                d_bc, d_ac = math.dist(xy[b], xy[c]), math.dist(xy[a], xy[c])
                if ((abs(d_bc - h2) < precision and abs(d_ac - h3) < precision)
                        or (abs(d_bc - h3) < precision and abs(d_ac - h2) < precision)):
                    out.append(((cx, cy), (bx, by), (kx, ky)))
    return out


@dataclass(frozen=True)
class Grip:
    """One simulated grip: the truth and what the encoders said (rad)."""

    holes: tuple[int, int, int]
    pose: np.ndarray
    q_true: np.ndarray
    q_measured: np.ndarray
    moved_arm: int | None = None


class GripSimulator:
    """Random grips and climbing walks on a wall, with encoder noise - the seed's
    "emulate with artificial errors", used by the sensor study, the benchmark and the tests.

    Stances are drawn uniformly over the holdable triangles of the index, with a random arm
    assignment, a body centre uniform where every hole is within reach (``margin`` cm inside
    the annulus), a random heading and random elbow branches. Encoder readings get Gaussian
    noise ``sigma`` (rad) and are then rounded to ``quantum`` (rad, 0 = none).
    """

    def __init__(self, index: TriangleIndex, geom: ClimberGeometry, sigma: float, quantum: float = 0.0,
                 margin: float = 0.5, seed: int | None = 0) -> None:
        self.index, self.geom = index, geom
        self.holes = index.holes
        self.sigma, self.quantum, self.margin = float(sigma), float(quantum), float(margin)
        self.rng = np.random.default_rng(seed)
        self.r_out = geom.l1 + geom.l2 - margin
        self.r_in = np.abs(geom.l1 - geom.l2) + margin
        if len(index) == 0:
            raise InvalidInputError(f"map '{self.holes.name}' has no hole triangle the robot can hold")

    def _centre(self, p: np.ndarray) -> np.ndarray | None:
        """A body centre with hole i within [r_in, r_out] of shoulder i (heading 0 offsets ignored)."""
        rng = self.rng
        k = int(np.argmin(self.r_out))
        for _ in range(200):
            ang, rad = rng.uniform(0, 2 * math.pi), self.r_out[k] * math.sqrt(rng.uniform())
            c = p[k] + rad * np.array([math.cos(ang), math.sin(ang)])
            d = np.linalg.norm(p - c, axis=1)
            if np.all(d <= self.r_out) and np.all(d >= self.r_in):
                return c
        return None

    def _read(self, holes: Sequence[int], moved: int | None) -> Grip | None:
        p = self.holes.xy[list(holes)]
        c = self._centre(p)
        if c is None:
            return None
        heading = self.rng.uniform(-math.pi, math.pi)
        branch = self.rng.choice([-1, 1], size=3)
        q = inverse_program(p, c, heading, self.geom, branch)
        qm = q + self.rng.normal(0.0, self.sigma, q.shape) if self.sigma > 0 else q.copy()
        if self.quantum > 0:
            qm = np.round(qm / self.quantum) * self.quantum
        return Grip(tuple(int(v) for v in holes), np.array([c[0], c[1], heading]), q, qm, moved)  # type: ignore[arg-type]

    def grip(self) -> Grip:
        """A random stance anywhere on the wall."""
        tri = self.index.triangles
        while True:
            t = tri[self.rng.integers(len(tri))][self.rng.permutation(3)]
            g = self._read(t, None)
            if g is not None:
                return g

    def step(self, grip: Grip) -> Grip:
        """One climbing move: one arm lets go and grips another hole, the body re-centres."""
        rng = self.rng
        for arm in rng.permutation(3):
            kept = [grip.holes[i] for i in range(3) if i != arm]
            near = self.holes.within(self.holes.xy[kept[0]], 2 * float(self.r_out.max()))
            near = [int(j) for j in rng.permutation(near) if j not in grip.holes]
            for j in near:
                holes = list(grip.holes)
                holes[arm] = j
                g = self._read(holes, int(arm) + 1)
                if g is not None:
                    return g
        return self.grip()

    def walk(self, n: int) -> list[Grip]:
        """A lost start: a random stance and ``n - 1`` moves."""
        out = [self.grip()]
        while len(out) < n:
            out.append(self.step(out[-1]))
        return out


def _outcome(attempt: Callable[[], Fix], truth: tuple[int, int, int]) -> str:
    """Classify one localisation attempt: correct, wrong (unique but wrong), ambiguous or none."""
    try:
        return "correct" if attempt().holes == truth else "wrong"
    except AmbiguousFixError:
        return "ambiguous"
    except NoFixError:
        return "none"


def sensor_study(
    holes: HoleMap,
    sigmas_rad: Sequence[float],
    geom: ClimberGeometry | None = None,
    trials: int = 2000,
    walks: int = 100,
    max_grips: int = 10,
    map_sigma: float = 0.01,
    quantum: float = 0.0,
    seed: int = 0,
    progress: Callable[[int], None] | None = None,
) -> list[dict[str, float]]:
    """What encoders does the robot need on this wall? Simulated grips per noise level.

    For every ``sigma`` (rad): ``trials`` random grips localised globally, classified as
    correct (unique and right), ambiguous, none, or wrong (unique but wrong); how often the
    gate keeps the true holes; the centre error at the true holes (median, p99, cm); global
    and tracking times; and ``walks`` lost starts (random climbing walks, a Bayes filter
    over hypotheses) - grips needed until one hypothesis holds 0.999 (median, and the share
    localised correctly within 3 grips), plus tracking along the walks (correct / wrong).
    ``progress`` is called with the number of finished units (grips and walks).
    """
    import time

    g = geom or ClimberGeometry()
    index = TriangleIndex(holes, g)
    rows = []
    for k, sigma in enumerate(sigmas_rad):
        noise = NoiseModel(sigma_angle=float(sigma), sigma_map=map_sigma)
        loc = Localizer(holes, g, noise, index)
        sim = GripSimulator(index, g, float(sigma), quantum=quantum, seed=seed + 1000 * k)
        counts = {"correct": 0, "ambiguous": 0, "none": 0, "wrong": 0}
        kept, err, t_global = 0, [], []
        for _ in range(trials):
            grip = sim.grip()
            t0 = time.perf_counter()
            counts[_outcome(lambda g=grip, lc=loc: lc.localize(g.q_measured), grip.holes)] += 1
            t_global.append(time.perf_counter() - t0)
            hx, hy, _, w = loc._measure(grip.q_measured)
            v = grip.holes
            x, y, _, chi2, _ = _fit_one([loc._xs[i] for i in v], [loc._ys[i] for i in v], hx, hy, w)
            kept += chi2 <= loc._limit
            err.append(math.hypot(x - grip.pose[0], y - grip.pose[1]))
            if progress:
                progress(1)
        bayes = BayesLocalizer(loc)
        needed, within3, walk_wrong = [], 0, 0
        track = {"correct": 0, "ambiguous": 0, "none": 0, "wrong": 0}
        t_track = []
        for _ in range(walks):
            bayes.reset()
            path = sim.walk(max_grips)
            done = None
            for n, grip in enumerate(path, start=1):
                fix = bayes.observe(grip.q_measured, grip.moved_arm)
                if fix is not None and done is None:
                    done = n
                    walk_wrong += fix.holes != grip.holes
                    within3 += n <= 3 and fix.holes == grip.holes
                if n > 1:
                    t0 = time.perf_counter()
                    prev = path[n - 2].holes
                    track[_outcome(lambda g=grip, h=prev, lc=loc: lc.track(h, g.q_measured, g.moved_arm),
                                   grip.holes)] += 1
                    t_track.append(time.perf_counter() - t0)
            needed.append(done if done is not None else math.inf)
            if progress:
                progress(1)
        n_track = max(1, sum(track.values()))
        rows.append({
            "sigma_deg": math.degrees(float(sigma)),
            "grips": trials,
            "correct": counts["correct"] / trials,
            "ambiguous": counts["ambiguous"] / trials,
            "none": counts["none"] / trials,
            "wrong": counts["wrong"] / trials,
            "true_kept": kept / trials,
            "centre_err_median_cm": float(np.median(err)),
            "centre_err_p99_cm": float(np.percentile(err, 99)),
            "global_us_median": float(np.median(t_global) * 1e6),
            "walks": walks,
            "grips_needed_median": float(np.median(needed)),
            "lost_within_3": within3 / max(1, walks),
            "lost_wrong": walk_wrong / max(1, walks),
            "track_correct": track["correct"] / n_track,
            "track_wrong": track["wrong"] / n_track,
            "track_us_median": float(np.median(t_track) * 1e6) if t_track else float("nan"),
        })
    return rows
