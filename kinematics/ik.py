"""Numeric inverse kinematics for any chain; every solver returns the same :class:`IKResult`.

* :func:`ccd` - cyclic coordinate descent (seed 001): sweeps the joints from the tool to
  the base, turning each revolute joint to swing the tool toward the target and sliding
  each prismatic joint along its axis; joint limits by clamping. Position targets, any
  :class:`~kinematics.chains.DHChain` (planar or spatial, tree chains: the path to one frame).
* :func:`dls` - Levenberg-Marquardt damped least squares (seed 003:
  ``dq = J^T (J J^T + lambda^2 I)^-1 e``, ``lambda = 0.001``, tolerance ``1e-5``) with an
  adaptive damping, an active set for joints resting on a limit (they are frozen while the
  step pushes them outward, so the others keep moving instead of stalling), and seeded
  random restarts inside the limits.
* :func:`solve_arm` - :func:`dls` on a :class:`~kinematics.writing_arm.WritingArm` with its
  analytic Jacobian, masks for position-only or position + pitch targets, and a start
  from a precomputed table of workspace samples (the nearest sample in task space), which
  is what makes it converge in a handful of iterations.

The LM core is plain Python on lists: for the 4 x 4 systems of the arms it is several
times faster than numpy's per-call overhead (see ``bench/bench_kinematics.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .chains import DHChain
from .errors import InvalidInputError, as_array
from .writing_arm import WritingArm

__all__ = ["IKResult", "ccd", "dls", "solve_arm", "ArmSeeds", "MASKS"]

#: Named task masks for the writing arm's (x, y, z, phi).
MASKS: dict[str, tuple[bool, bool, bool, bool]] = {
    "position": (True, True, True, False),
    "position+pitch": (True, True, True, True),
}

Residual = Callable[[list[float]], tuple[list[float], list[list[float]]]]


@dataclass(frozen=True)
class IKResult:
    """Outcome of a numeric IK solve.

    Attributes:
        q: joint values reached (radians / length units), shape (n,).
        success: ``error <= tol`` and ``q`` within the limits.
        error: norm of the (masked) task error at ``q`` (cm for positions; rad for pitch).
        iterations: iterations (LM steps or CCD sweeps) over all restarts.
        reason: ``"converged"``, ``"max_iterations"``, ``"stalled"`` or ``"unreachable"``.
        restarts: random restarts used.
    """

    q: np.ndarray
    success: bool
    error: float
    iterations: int
    reason: str
    restarts: int = 0


# ---------------------------------------------------------------------------- helpers
def _limits(limits: object | None, n: int) -> list[tuple[float, float]]:
    if limits is None:
        return [(-math.inf, math.inf)] * n
    lim = as_array("limits", limits, (2,))
    if lim.shape != (n, 2) or np.any(lim[:, 0] > lim[:, 1]):
        raise InvalidInputError(
            f"limits={lim.tolist()}; expected {n} rows of [low <= high] (one per joint)"
        )
    return [(float(a), float(b)) for a, b in lim]


def _solve_spd(a: list[list[float]], b: list[float]) -> list[float]:
    """Solve a small symmetric positive-definite system by Cholesky (plain Python)."""
    n = len(b)
    low = [[0.0] * n for _ in range(n)]
    for i in range(n):
        ai, li = a[i], low[i]
        for j in range(i + 1):
            lj = low[j]
            s = ai[j]
            for k in range(j):
                s -= li[k] * lj[k]
            if i == j:
                li[i] = math.sqrt(s) if s > 0 else 1e-300
            else:
                li[j] = s / lj[j]
    y = [0.0] * n
    for i in range(n):
        s = b[i]
        li = low[i]
        for k in range(i):
            s -= li[k] * y[k]
        y[i] = s / li[i]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= low[k][i] * x[k]
        x[i] = s / low[i][i]
    return x


# ---------------------------------------------------------------------------- LM / DLS
def dls(
    residual: Residual,
    q0: Sequence[float],
    limits: object | None = None,
    lam: float = 1e-3,
    tol: float = 1e-5,
    max_iter: int = 100,
    restarts: int = 10,
    rng: np.random.Generator | None = None,
) -> IKResult:
    """Levenberg-Marquardt damped least squares on a residual function.

    Args:
        residual: ``q -> (e, J)`` with ``e`` the wanted-minus-reached task error (list of
            m floats, already masked/wrapped) and ``J`` its m x n Jacobian ``d(reached)/dq``.
        q0: start (clamped into the limits).
        limits: ``(n, 2)`` joint limits or None.
        lam: initial (and smallest) damping; seed 003's 0.001.
        tol: success when ``|e| <= tol`` (seed 003: 1e-5).
        max_iter: iterations per attempt.
        restarts: random restarts (uniform inside finite limits, else in [-pi, pi]) after
            a stall or ``max_iter``.
        rng: generator for the restarts (reproducible); default ``np.random.default_rng(0)``.
    """
    n = len(q0)
    lim = _limits(limits, n)
    rng = rng if rng is not None else np.random.default_rng(0)
    q = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(q0, lim)]
    best_q, best_err = list(q), math.inf
    total_it = 0
    reason = "max_iterations"
    for attempt in range(restarts + 1):
        if attempt:
            q = [
                float(rng.uniform(lo, hi)) if math.isfinite(lo) and math.isfinite(hi)
                else float(rng.uniform(-math.pi, math.pi))
                for lo, hi in lim
            ]
        e, jac = residual(q)
        err2 = sum(v * v for v in e)
        damp = lam
        stall = 0
        for _ in range(max_iter):
            if err2 <= tol * tol:
                break
            total_it += 1
            m = len(e)
            # gradient g = J^T e ; normal matrix A = J^T J
            g = [sum(jac[r][c] * e[r] for r in range(m)) for c in range(n)]
            # active set: a joint on a limit whose descent direction leaves the box is frozen
            free = [
                c for c in range(n)
                if not ((q[c] <= lim[c][0] and g[c] < 0) or (q[c] >= lim[c][1] and g[c] > 0))
            ]
            if not free:
                reason = "stalled"
                break
            normal = [[sum(jac[r][i] * jac[r][j] for r in range(m)) for j in free] for i in free]
            improved = False
            while damp < 1e9:
                a = [row[:] for row in normal]
                d2 = damp * damp
                for i in range(len(free)):
                    a[i][i] += d2
                step = _solve_spd(a, [g[c] for c in free])
                qn = list(q)
                for i, c in enumerate(free):
                    lo, hi = lim[c]
                    qn[c] = min(max(q[c] + step[i], lo), hi)
                en, jn = residual(qn)
                errn = sum(v * v for v in en)
                if errn < err2:
                    rel = (err2 - errn) / err2
                    q, e, jac, err2 = qn, en, jn, errn
                    damp = max(damp * 0.1, lam)
                    improved = True
                    stall = stall + 1 if rel < 1e-9 else 0
                    break
                damp *= 10.0
            if not improved or stall >= 5:
                reason = "stalled"
                break
        err = math.sqrt(err2)
        if err < best_err:
            best_q, best_err = list(q), err
        if err <= tol:
            return IKResult(np.array(q), True, err, total_it, "converged", attempt)
    return IKResult(np.array(best_q), False, best_err, total_it, reason, restarts)


# ---------------------------------------------------------------------------- writing arm
class ArmSeeds:
    """A table of workspace samples of one arm, for starting numeric IK near the answer.

    ``n`` configurations are drawn inside the joint limits (seeded) and bucketed by their
    pen position on a grid of ``cell`` cm; :meth:`nearest` returns the sample of the
    target's cell (or a neighbouring one) whose pitch is closest - O(1), no tree search.
    """

    def __init__(self, arm: WritingArm, n: int = 20000, cell: float = 3.0, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        q = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (n, 4))
        f = arm.fk(q)
        self.cell = float(cell)
        self.table: dict[tuple[int, int, int], list[tuple[float, tuple[float, ...]]]] = {}
        keys = np.floor(f[:, :3] / cell).astype(int)
        for k, phi, qi in zip(map(tuple, keys), f[:, 3], q):
            self.table.setdefault(k, []).append((float(phi), tuple(map(float, qi))))
        self.fallback = tuple(map(float, 0.5 * (arm.limits[:, 0] + arm.limits[:, 1])))

    def nearest(self, x: float, y: float, z: float, phi: float | None = None) -> tuple[float, ...]:
        c = self.cell
        key = (math.floor(x / c), math.floor(y / c), math.floor(z / c))
        bucket = self.table.get(key)
        if bucket is None:
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        bucket = self.table.get((key[0] + dx, key[1] + dy, key[2] + dz))
                        if bucket:
                            break
                    if bucket:
                        break
                if bucket:
                    break
        if not bucket:
            return self.fallback
        if phi is None:
            return bucket[0][1]
        best = min(bucket, key=lambda item: abs(math.remainder(item[0] - phi, 2 * math.pi)))
        return best[1]


def solve_arm(
    arm: WritingArm,
    target: Sequence[float],
    mask: str | Sequence[bool] = "position+pitch",
    q0: Sequence[float] | None = None,
    seeds: ArmSeeds | None = None,
    lam: float = 1e-3,
    tol: float = 1e-5,
    max_iter: int = 100,
    restarts: int = 10,
    rng: np.random.Generator | None = None,
) -> IKResult:
    """Numeric IK of the writing arm for ``target = (x, y, z, phi)`` (cm, rad).

    ``mask`` selects the task rows: ``"position"``, ``"position+pitch"`` or four booleans.
    The start is ``q0``, else the nearest sample of ``seeds``, else the middle of the
    limits. Joint limits are always respected.
    """
    if isinstance(mask, str):
        if mask not in MASKS:
            raise InvalidInputError(f"mask={mask!r}; expected one of {sorted(MASKS)} or 4 booleans")
        m = MASKS[mask]
    else:
        m = tuple(bool(v) for v in mask)
        if len(m) != 4 or not any(m):
            raise InvalidInputError(f"mask={mask!r}; expected 4 booleans, at least one true")
    tx, ty, tz, tphi = (float(v) for v in target)
    if not all(math.isfinite(v) for v in (tx, ty, tz, tphi)):
        raise InvalidInputError(f"target={list(target)!r} holds NaN or infinity")
    rows = [i for i in range(4) if m[i]]
    goal = (tx, ty, tz, tphi)
    task = arm.task_one

    def residual(q: list[float]) -> tuple[list[float], list[list[float]]]:
        f, jac = task(q)
        e = [goal[i] - f[i] for i in rows]
        if m[3]:
            e[-1] = math.remainder(e[-1], 2 * math.pi)
        return e, [jac[i] for i in rows]

    if q0 is None:
        q0 = seeds.nearest(tx, ty, tz, tphi if m[3] else None) if seeds else None
    if q0 is None:
        q0 = tuple(0.5 * (arm.limits[:, 0] + arm.limits[:, 1]))
    return dls(residual, q0, arm.limits, lam=lam, tol=tol, max_iter=max_iter, restarts=restarts,
               rng=rng)


# ---------------------------------------------------------------------------- CCD
def ccd(
    chain: DHChain,
    target: Sequence[float],
    q0: Sequence[float] | None = None,
    limits: object | None = None,
    frame: int | str = -1,
    tol: float = 1e-3,
    max_sweeps: int = 200,
) -> IKResult:
    """Cyclic coordinate descent to put ``frame``'s origin on ``target`` (seed 001).

    Revolute joints rotate about their axis to align the projections of (tool - pivot)
    and (target - pivot); prismatic joints slide by the projection of (target - tool) on
    their axis (seed 001's ``L_i += [cos w, sin w] . (R - O_n)``, in 3-D). Each new value
    is clamped to ``limits``. Stops at ``tol`` or when a sweep gains less than ``tol/100``
    (seed 001's criterion).
    """
    n = chain.n_joints
    tgt = as_array("target", target, (3,))
    if tgt.shape != (3,):
        raise InvalidInputError(f"target has shape {tgt.shape}; expected (3,) - x, y, z")
    lim = _limits(limits, n)
    q = [0.0] * n if q0 is None else [float(v) for v in as_array("q0", q0, (n,))]
    q = [min(max(v, lo), hi) for v, (lo, hi) in zip(q, lim)]
    idx = chain.frame_index(frame)
    path = [i for i in chain.path(idx) if chain.links[i].kind != "F"]
    fk = chain._fk_scalar
    b = chain.base
    base = (b[0, 0], b[0, 1], b[0, 2], b[1, 0], b[1, 1], b[1, 2], b[2, 0], b[2, 1], b[2, 2],
            b[0, 3], b[1, 3], b[2, 3])
    t = [float(v) for v in tgt]

    def end_and_frames() -> tuple[tuple[float, ...], tuple]:
        frames = fk(*q)
        return frames[idx], frames

    def dist(p: tuple[float, ...]) -> float:
        return math.sqrt((t[0] - p[9]) ** 2 + (t[1] - p[10]) ** 2 + (t[2] - p[11]) ** 2)

    end, frames = end_and_frames()
    d = dist(end)
    prev = math.inf
    sweeps = 0
    while d > tol and abs(prev - d) > tol / 100.0 and sweeps < max_sweeps:
        prev = d
        sweeps += 1
        for li in reversed(path):
            lk = chain.links[li]
            par = base if lk.parent == -1 else frames[lk.parent]
            k = (par[2], par[5], par[8])  # z axis of the parent frame
            o = (par[9], par[10], par[11])
            j = lk.joint
            if lk.kind == "R":
                e = [end[9] - o[0], end[10] - o[1], end[11] - o[2]]
                r = [t[0] - o[0], t[1] - o[1], t[2] - o[2]]
                ke = k[0] * e[0] + k[1] * e[1] + k[2] * e[2]
                kr = k[0] * r[0] + k[1] * r[1] + k[2] * r[2]
                e = [e[i] - ke * k[i] for i in range(3)]
                r = [r[i] - kr * k[i] for i in range(3)]
                cx = (e[1] * r[2] - e[2] * r[1], e[2] * r[0] - e[0] * r[2], e[0] * r[1] - e[1] * r[0])
                ang = math.atan2(k[0] * cx[0] + k[1] * cx[1] + k[2] * cx[2],
                                 e[0] * r[0] + e[1] * r[1] + e[2] * r[2])
                val = q[j] + ang / lk.scale
                val = math.remainder(val, 2 * math.pi) if math.isinf(lim[j][0]) else val
            else:
                delta = sum(k[i] * (t[i] - end[9 + i]) for i in range(3))
                val = q[j] + delta / lk.scale
            q[j] = min(max(val, lim[j][0]), lim[j][1])
            end, frames = end_and_frames()
        d = dist(end)
    reason = "converged" if d <= tol else ("max_iterations" if sweeps >= max_sweeps else "stalled")
    return IKResult(np.array(q), d <= tol, d, sweeps, reason)
