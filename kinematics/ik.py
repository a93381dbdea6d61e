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
* :func:`solve_arm` - the same LM on a :class:`~kinematics.writing_arm.WritingArm` with its
  analytic Jacobian, masks for position-only or position + pitch targets, and a start
  from a precomputed table of workspace samples (:class:`ArmSeeds`: the sample nearest the
  target's cell centre, in position or in position and pitch), which is what makes it
  converge in about three iterations; when that start stalls (it lies on a branch of the
  arm that leaves the joint limits), the table's other branches are tried before the
  random restarts.

The readable LM is :func:`_lm_reference` (numpy, a dozen lines per step). What runs is
faster and fenced off in :mod:`kinegym.kinematics._kernels`: :func:`dls` takes the
plain-Python kernel (small systems on generated straight-line code; for the 4 x 4 systems
of the arms many times faster than numpy's per-call overhead), :func:`solve_arm` one
generated function per arm and mask with the residual, Jacobian and damped solve fused
(~1 us per LM iteration; a call takes ~6 us for position and ~9 us for position + pitch
targets). ``tests/test_kernels.py`` pins each kernel to the reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ._kernels.arm_lm import arm_kernel
from ._kernels.lm import Residual, lm_attempt
from .arm_seeds import ArmSeeds
from .chains import DHChain
from .errors import InvalidInputError, as_array
from .writing_arm import WritingArm

__all__ = ["IKResult", "ccd", "dls", "solve_arm", "ArmSeeds", "MASKS"]

#: Named task masks for the writing arm's (x, y, z, phi).
MASKS: dict[str, tuple[bool, bool, bool, bool]] = {
    "position": (True, True, True, False),
    "position+pitch": (True, True, True, True),
}

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


def _restart_loop(
    attempt: Callable[[list[float]], tuple[list[float], float, int, bool]],
    q: list[float],
    lim: list[tuple[float, float]],
    tol: float,
    restarts: int,
    rng: np.random.Generator | None,
    alternates: Iterable[Sequence[float]] = (),
    first: tuple[list[float], float, int, bool] | None = None,
) -> IKResult:
    """Attempts from ``q``, then ``alternates`` (clamped, drawn lazily), then random starts.

    ``attempt(q) -> (q, err2, iterations, stalled)``. ``first``: the outcome of the first
    attempt when the caller already ran it. The random starts draw from ``rng`` (created
    only when needed: ``np.random.default_rng(0)`` by default) exactly as before.
    """
    best_q, best_err = q, math.inf
    total_it = 0
    stalled_any = False
    alts = iter(alternates)
    for k in range(restarts + 1):
        if k == 0 and first is not None:
            res = first
        else:
            if k:
                alt = next(alts, None)
                if alt is not None:
                    q = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(alt, lim, strict=False)]
                else:
                    if rng is None:
                        rng = np.random.default_rng(0)
                    q = [
                        float(rng.uniform(lo, hi)) if math.isfinite(lo) and math.isfinite(hi)
                        else float(rng.uniform(-math.pi, math.pi))
                        for lo, hi in lim
                    ]
            res = attempt(q)
        q, err2, it, stalled = res
        total_it += it
        stalled_any = stalled_any or stalled
        err = math.sqrt(err2)
        if err < best_err:
            best_q, best_err = q, err
        if err <= tol:
            return IKResult(np.array(q), True, err, total_it, "converged", k)
    return IKResult(np.array(best_q), False, best_err, total_it,
                    "stalled" if stalled_any else "max_iterations", restarts)


def _lm_reference(
    residual: Residual, lim: list[tuple[float, float]], lam: float, tol: float, max_iter: int
) -> Callable[[list[float]], tuple[list[float], float, int, bool]]:
    """One Levenberg-Marquardt descent from a start, in numpy: the readable reference of :func:`dls`.

    Each iteration takes the damped Gauss-Newton step ``(J^T J + lambda^2 I) dq = J^T e``
    over the free joints (a joint resting on a limit is frozen while the gradient pushes it
    outward), clamps into the limits and keeps the step only if the error drops: then the
    damping falls tenfold (not below ``lam``), else it grows tenfold and the step is retried.
    It stops converged (``|e| <= tol``), stalled (no damping helps, or five steps in a row
    gain under 1e-9 relative) or after ``max_iter``. :mod:`kinegym.kinematics._kernels.lm`
    runs the same steps in plain Python, faster.
    """
    lo, hi = np.array([a for a, _ in lim]), np.array([b for _, b in lim])

    def attempt(q0: list[float]) -> tuple[list[float], float, int, bool]:
        q = np.array(q0, float)
        e, jac = (np.asarray(v, float) for v in residual(list(q0)))
        err2, damp, stall, it = float(e @ e), lam, 0, 0
        at_limit = bool(np.any((q <= lo) | (q >= hi)))
        for it in range(1, max_iter + 1):
            if err2 <= tol * tol:
                return list(q), err2, it - 1, False
            g = jac.T @ e
            free = ~(((q <= lo) & (g < 0)) | ((q >= hi) & (g > 0))) if at_limit else np.ones(len(q), bool)
            if not free.any():
                return list(q), err2, it, True
            jf = jac[:, free]
            while damp < 1e9:
                qn = q.copy()
                qn[free] += np.linalg.solve(jf.T @ jf + damp * damp * np.eye(len(g[free])), g[free])
                new_limit = bool(np.any((qn <= lo) | (qn >= hi)))
                qn = np.clip(qn, lo, hi)
                en, jn = (np.asarray(v, float) for v in residual(list(qn)))
                errn = float(en @ en)
                if errn < err2:
                    stall = stall + 1 if (err2 - errn) / err2 < 1e-9 else 0
                    q, e, jac, err2, at_limit = qn, en, jn, errn, new_limit
                    damp = max(damp * 0.1, lam)
                    break
                damp *= 10.0
            else:
                return list(q), err2, it, True
            if stall >= 5:
                return list(q), err2, it, True
        return list(q), err2, it, False

    return attempt

def dls(
    residual: Residual,
    q0: Sequence[float],
    limits: object | None = None,
    lam: float = 1e-3,
    tol: float = 1e-5,
    max_iter: int = 100,
    restarts: int = 10,
    rng: np.random.Generator | None = None,
    fast: bool = True,
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

        fast: run the plain-Python kernel (:mod:`kinegym.kinematics._kernels.lm`, systems up
            to 6 x 6 on generated straight-line code); False runs the numpy reference
            :func:`_lm_reference` (the same steps, slower).
    """
    n = len(q0)
    lim = _limits(limits, n)
    q = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(q0, lim, strict=False)]
    descent = lm_attempt if fast else _lm_reference
    return _restart_loop(descent(residual, lim, lam, tol, max_iter), q, lim, tol, restarts, rng)


# ---------------------------------------------------------------------------- writing arm
_POSITION = MASKS["position"]
_PITCH = MASKS["position+pitch"]


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
    limits; when it stalls, the other samples ``seeds`` keeps for that cell are tried
    before the random restarts. Joint limits are always respected.

    The two named masks run a fused LM descent generated for the arm (see
    :mod:`kinegym.kinematics._kernels.arm_lm`; the same steps as :func:`dls`), other masks run :func:`dls`.
    """
    m = MASKS.get(mask) if isinstance(mask, str) else None
    if m is None:
        if isinstance(mask, str):
            raise InvalidInputError(f"mask={mask!r}; expected one of {sorted(MASKS)} or 4 booleans")
        m = tuple(bool(v) for v in mask)
        if len(m) != 4 or not any(m):
            raise InvalidInputError(f"mask={mask!r}; expected 4 booleans, at least one true")
    tx, ty, tz, tphi = map(float, target)
    # x - x is 0.0 for every finite x and NaN for NaN and +-inf
    if (tx - tx) + (ty - ty) + (tz - tz) + (tphi - tphi) != 0.0:
        raise InvalidInputError(f"target={list(target)!r} holds NaN or infinity")
    pitch = m[3]
    seeded = q0 is None and bool(seeds)
    if seeded:
        start = seeds._start(tx, ty, tz, tphi if pitch else None)  # type: ignore[union-attr]
    elif q0 is None:
        start = _middle(arm)
    else:
        lim = arm._lim  # type: ignore[attr-defined]
        start = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(q0, lim, strict=False)]
    kernels = getattr(arm, "_kernels", None)
    if kernels is None or not (m is _PITCH or m is _POSITION or m == _PITCH or m == _POSITION):
        return _solve_arm_generic(arm, (tx, ty, tz, tphi), m, start, seeds if seeded else None,
                                  lam, tol, max_iter, restarts, rng)
    kern = kernels.get(pitch) or arm_kernel(arm, pitch)
    tol2 = tol * tol
    q1, q2, q3, q4, err2, it, stalled = kern(*start, tx, ty, tz, tphi, lam, tol2, max_iter)
    err = math.sqrt(err2)
    if err <= tol:
        r = _new(IKResult)
        d = r.__dict__  # a frozen dataclass; filled directly (its __init__ costs ~0.5 us)
        d["q"] = np.array((q1, q2, q3, q4))
        d["success"] = True
        d["error"] = err
        d["iterations"] = it
        d["reason"] = "converged"
        d["restarts"] = 0
        return r
    alts = _alternates(seeds, tx, ty, tz, tphi if pitch else None, start) if seeded else ()  # type: ignore[arg-type]
    return _restart_loop(_kernel_attempt(kern, (tx, ty, tz, tphi, lam, tol2, max_iter)),
                         list(start), arm._lim, tol, restarts, rng, alts,  # type: ignore[attr-defined]
                         first=([q1, q2, q3, q4], err2, it, stalled))


_new = object.__new__


def _kernel_attempt(
    kern: Callable[..., tuple], args: tuple
) -> Callable[[list[float]], tuple[list[float], float, int, bool]]:
    def attempt(q: list[float]) -> tuple[list[float], float, int, bool]:
        r = kern(*q, *args)
        return list(r[:4]), r[4], r[5], r[6]

    return attempt


def _alternates(
    seeds: ArmSeeds, x: float, y: float, z: float, phi: float | None, first: Sequence[float]
) -> Iterator[tuple[float, ...]]:
    """Lazily, the starts after ``first``: the other samples of the target's cells, then
    those around it (:meth:`ArmSeeds.candidates`), each far from every start before."""
    tried = [tuple(first)]
    for wide in (False, True):
        for c in seeds.candidates(x, y, z, phi, wide=wide):
            if all(max(abs(a - b) for a, b in zip(c, o, strict=True)) > 1.0 for o in tried):
                tried.append(c)
                yield c


def _middle(arm: WritingArm) -> tuple[float, ...]:
    return tuple(map(float, 0.5 * (arm.limits[:, 0] + arm.limits[:, 1])))


def _solve_arm_generic(
    arm: WritingArm,
    goal: tuple[float, float, float, float],
    m: tuple[bool, ...],
    start: Sequence[float],
    seeds: ArmSeeds | None,
    lam: float,
    tol: float,
    max_iter: int,
    restarts: int,
    rng: np.random.Generator | None,
    fast: bool = True,
) -> IKResult:
    """:func:`dls` on the arm's residual for any mask (the path of unusual masks; with
    ``fast=False`` the numpy reference, which the fused kernels are tested against)."""
    rows = [i for i in range(4) if m[i]]
    task = arm.task_one
    wrap = m[3]

    def residual(q: list[float]) -> tuple[list[float], list[list[float]]]:
        f, jac = task(q)
        e = [goal[i] - f[i] for i in rows]
        if wrap:
            e[-1] = math.remainder(e[-1], 2 * math.pi)
        return e, [jac[i] for i in rows]

    lim = arm._lim  # type: ignore[attr-defined]
    phi = goal[3] if wrap else None
    alts = _alternates(seeds, goal[0], goal[1], goal[2], phi, start) if seeds else ()
    q = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(start, lim, strict=False)]
    descent = lm_attempt if fast else _lm_reference
    return _restart_loop(descent(residual, lim, lam, tol, max_iter), q, lim, tol, restarts, rng, alts)


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
