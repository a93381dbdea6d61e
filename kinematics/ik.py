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

The LM core is plain Python: for the 4 x 4 systems of the arms it is many times faster
than numpy's per-call overhead. :func:`dls` runs small systems (up to 6 x 6) on generated
straight-line code; :func:`solve_arm` runs one generated function per arm and mask with
the residual, Jacobian and damped solve fused and the constants folded (~1 us per LM
iteration; a call takes ~6 us for position and ~9 us for position + pitch targets).
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from .chains import DHChain
from .errors import InvalidInputError, as_array
from .writing_arm import TWO_PI, WritingArm

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
# Straight-line kernels for small dense systems (generated once per size, like the DH
# chains of chains.py): ``prep(e, jac)`` returns the gradient ``g = J^T e`` and the data of
# the damped system; ``solve(data, dl)`` returns the step for the damping ``dl = lambda^2``.
# For m >= n the system is the normal one, ``(J^T J + dl I) dq = J^T e`` (n x n); for m < n
# it is the equivalent ``dq = J^T (J J^T + dl I)^-1 e`` (m x m, the push-through identity,
# seed 003's form), which is smaller. Cholesky as in :func:`_solve_spd`.
_DENSE_MAX = 6
_dense_kernels: dict[tuple[int, int], tuple[Callable, Callable]] = {}


def _chol_lines(k: int, a: Callable[[int, int], str], b: Callable[[int], str]) -> list[str]:
    """Lines solving ``(A + dl I) x = b`` by Cholesky into ``x0..x{k-1}``."""
    lines = []
    for i in range(k):
        for j in range(i + 1):
            terms = "".join(f" - l{i}_{t}*l{j}_{t}" for t in range(j))
            if i == j:
                lines.append(f"s = {a(i, i)} + dl{terms}")
                lines.append(f"l{i}_{i} = sqrt(s) if s > 0 else 1e-300")
            else:
                lines.append(f"l{i}_{j} = ({a(j, i)}{terms}) / l{j}_{j}")
    for i in range(k):
        terms = "".join(f" - l{i}_{t}*y{t}" for t in range(i))
        lines.append(f"y{i} = ({b(i)}{terms}) / l{i}_{i}")
    for i in range(k - 1, -1, -1):
        terms = "".join(f" - l{t}_{i}*x{t}" for t in range(i + 1, k))
        lines.append(f"x{i} = (y{i}{terms}) / l{i}_{i}")
    return lines


def _dense_kernel(m: int, n: int) -> tuple[Callable, Callable]:
    kern = _dense_kernels.get((m, n))
    if kern is not None:
        return kern
    unpack = [f"e{r}" for r in range(m)]
    prep = [f"    {', '.join(unpack)}, = e"]
    for r in range(m):
        prep.append(f"    {', '.join(f'j{r}_{c}' for c in range(n))}, = jac[{r}]")
    for c in range(n):
        prep.append(f"    g{c} = " + " + ".join(f"j{r}_{c}*e{r}" for r in range(m)))
    if m >= n:  # normal equations, n x n
        k = n
        ent = [(i, j) for i in range(k) for j in range(i, k)]
        for i, j in ent:
            prep.append(f"    a{i}_{j} = " + " + ".join(f"j{r}_{i}*j{r}_{j}" for r in range(m)))
        data = [f"a{i}_{j}" for i, j in ent] + [f"g{c}" for c in range(n)]
        rhs = [f"g{c}" for c in range(n)]
        tail = [f"    return [{', '.join(f'x{c}' for c in range(n))}]"]
    else:  # J J^T form, m x m
        k = m
        ent = [(i, j) for i in range(k) for j in range(i, k)]
        for i, j in ent:
            prep.append(f"    a{i}_{j} = " + " + ".join(f"j{i}_{c}*j{j}_{c}" for c in range(n)))
        flat_j = [f"j{r}_{c}" for r in range(m) for c in range(n)]
        data = [f"a{i}_{j}" for i, j in ent] + unpack + flat_j
        rhs = unpack
        cols = (" + ".join(f"j{r}_{c}*x{r}" for r in range(m)) for c in range(n))
        tail = [f"    return [{', '.join(cols)}]"]
    prep.append(f"    return [{', '.join(f'g{c}' for c in range(n))}], ({', '.join(data)},)")
    solve = [f"    {', '.join(data)}, = data"]
    solve += ["    " + ln for ln in _chol_lines(k, lambda i, j: f"a{i}_{j}", lambda i: rhs[i])]
    src = ("def prep(e, jac):\n" + "\n".join(prep) + "\n\n"
           "def solve(data, dl):\n" + "\n".join(solve + tail) + "\n")
    ns: dict[str, object] = {"sqrt": math.sqrt}
    exec(compile(src, f"<dls {m}x{n}>", "exec"), ns)  # noqa: S102 - generated above
    kern = (ns["prep"], ns["solve"])  # type: ignore[assignment]
    _dense_kernels[(m, n)] = kern  # type: ignore[assignment]
    return kern  # type: ignore[return-value]


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


def _lm_attempt(
    residual: Residual, lim: list[tuple[float, float]], lam: float, tol: float, max_iter: int
) -> Callable[[list[float]], tuple[list[float], float, int, bool]]:
    """One LM descent from a start (the generic path of :func:`dls`)."""
    n = len(lim)
    tol2 = tol * tol
    los = [lo for lo, _ in lim]
    his = [hi for _, hi in lim]

    def attempt(q: list[float]) -> tuple[list[float], float, int, bool]:
        e, jac = residual(q)
        err2 = 0.0
        for v in e:
            err2 += v * v
        m = len(e)
        kern = _dense_kernel(m, n) if m <= _DENSE_MAX and n <= _DENSE_MAX else None
        damp = lam
        stall = 0
        it = 0
        atlim = any(v <= lo or v >= hi for v, lo, hi in zip(q, los, his, strict=False))
        for _ in range(max_iter):
            if err2 <= tol2:
                break
            it += 1
            if kern is not None:
                g, data = kern[0](e, jac)
            else:
                g = [sum(jac[r][c] * e[r] for r in range(m)) for c in range(n)]
            # active set: a joint on a limit whose descent direction leaves the box is frozen
            if atlim:
                free = [
                    c for c in range(n)
                    if not ((q[c] <= los[c] and g[c] < 0) or (q[c] >= his[c] and g[c] > 0))
                ]
                if not free:
                    return q, err2, it, True
                if len(free) == n:
                    free = None
            else:
                free = None
            if free is None and kern is not None:
                solve = kern[1]
            else:
                solve = None
                fr = free if free is not None else list(range(n))
                normal = [[sum(jac[r][i] * jac[r][j] for r in range(m)) for j in fr] for i in fr]
                gf = [g[c] for c in fr]
            improved = False
            while damp < 1e9:
                dl = damp * damp
                if solve is not None:
                    step = solve(data, dl)
                    qn = [q[c] + step[c] for c in range(n)]
                else:
                    a = [row[:] for row in normal]
                    for i in range(len(fr)):
                        a[i][i] += dl
                    step = _solve_spd(a, gf)
                    qn = list(q)
                    for i, c in enumerate(fr):
                        qn[c] += step[i]
                nlim = False
                for c in range(n):
                    v = qn[c]
                    if v <= los[c]:
                        qn[c] = los[c]
                        nlim = True
                    elif v >= his[c]:
                        qn[c] = his[c]
                        nlim = True
                en, jn = residual(qn)
                errn = 0.0
                for v in en:
                    errn += v * v
                if errn < err2:
                    rel = (err2 - errn) / err2
                    q, e, jac, err2, atlim = qn, en, jn, errn, nlim
                    damp = max(damp * 0.1, lam)
                    improved = True
                    stall = stall + 1 if rel < 1e-9 else 0
                    break
                damp *= 10.0
            if not improved or stall >= 5:
                return q, err2, it, True
        return q, err2, it, False

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

    Systems up to 6 x 6 run on generated straight-line code (see :func:`_dense_kernel`).
    """
    n = len(q0)
    lim = _limits(limits, n)
    q = [min(max(float(v), lo), hi) for v, (lo, hi) in zip(q0, lim, strict=False)]
    return _restart_loop(_lm_attempt(residual, lim, lam, tol, max_iter), q, lim, tol, restarts, rng)


# ---------------------------------------------------------------------------- writing arm
def _arm_kernel_source(arm: WritingArm, pitch: bool) -> str:
    """Source of the fused LM descent of :func:`solve_arm` for one arm and mask.

    The same algorithm as :func:`dls` (damping, active set, stall rule), with the arm's
    analytic Jacobian folded in. The task error is taken in the frame of the arm's current
    heading, ``u = (cos yaw, sin yaw)``, ``t = (-sin yaw, cos yaw)`` (a rotation of the x, y
    rows: ``J^T J``, ``J^T e`` and hence every LM step are unchanged). There the Jacobian is
    sparse::

        t row: [r,  0,   0,   0 ]        r  = A cos psiA + B cos psiB + T cos psiT
        u row: [lf, -S2, -S3, -S4]       S2 = A sin psiA + S3, S3 = B sin psiB + S4, S4 = T sin psiT
        z row: [0,  r,   z3,  ct]        z3 = B cos psiB + ct, ct = T cos psiT
        phi  : [0,  1,   1,   1 ]        (position + pitch only)

    and the damped step ``dq = J^T (J J^T + dl I)^-1 e`` needs a 2x2 (position) or 3x3
    (position + pitch) solve after eliminating the t row. With a joint frozen by the active
    set, the reduced normal equations are solved by :func:`_solve_spd` as in :func:`dls`.
    """
    A, B, T = float(arm.upper_arm), float(arm.forearm), float(arm.tool)
    LF = float(arm.lateral_offset)
    YO, PO = float(arm.yaw_offset), float(arm.pitch_offset)
    lims = [tuple(map(float, r)) for r in arm.limits]

    def plus(expr: str, c: float) -> str:
        return expr if c == 0.0 else f"({expr} + {c!r})"

    def evaluate(q: tuple[str, ...], o: str, ind: str) -> list[str]:
        q1, q2, q3, q4 = q
        lines = [
            f"yw = {plus(q1, YO)}",
            "c = cos(yw)",
            "s = sin(yw)",
            f"pa = {plus(q2, PO)}",
            f"pb = pa + {q3}",
            f"pt = pb + {q4}",
            f"{o}ct = {T!r}*cos(pt)",
            f"{o}S4 = {T!r}*sin(pt)",
            f"{o}S3 = {B!r}*sin(pb) + {o}S4",
            f"{o}S2 = {A!r}*sin(pa) + {o}S3",
            f"{o}z3 = {B!r}*cos(pb) + {o}ct",
            f"{o}r = {A!r}*cos(pa) + {o}z3",
            f"{o}eu = X*c + Y*s - {o}r",
            f"{o}et = {plus('Y*c - X*s', LF)}",
            f"{o}ez = Z - {o}S2",
        ]
        if pitch:
            lines += [
                f"{o}ep = remainder(gp - ({q2} + {q3} + {q4}), {TWO_PI!r})",
                f"{o}err2 = {o}eu*{o}eu + {o}et*{o}et + {o}ez*{o}ez + {o}ep*{o}ep",
            ]
        else:
            lines.append(f"{o}err2 = {o}eu*{o}eu + {o}et*{o}et + {o}ez*{o}ez")
        return [ind + ln for ln in lines]

    state = ["r", "z3", "ct", "S2", "S3", "S4", "eu", "et", "ez"] + (["ep"] if pitch else [])
    EP = " + ep" if pitch else ""
    qs = ("q1", "q2", "q3", "q4")
    ns = ("n1", "n2", "n3", "n4")
    at_lim = " or ".join(f"{q} <= {lo!r} or {q} >= {hi!r}"
                         for q, (lo, hi) in zip(qs, lims, strict=True))
    L = [
        "def attempt(q1, q2, q3, q4, gx, gy, gz, gp, lam, tol2, max_iter):",
        f"    X = {plus('gx', -float(arm.base_xy[0]))}",
        f"    Y = {plus('gy', -float(arm.base_xy[1]))}",
        f"    Z = {plus('gz', -float(arm.shoulder_height))}",
        *evaluate(qs, "", "    "),
        "    damp = lam",
        "    stall = 0",
        "    it = 0",
        "    stalled = False",
        f"    atlim = {at_lim}",
        "    while it < max_iter:",
        "        if err2 <= tol2:",
        "            break",
        "        it += 1",
        "        free = None",
        "        if atlim:",
        f"            g = [r*et{f' + {LF!r}*eu' if LF else ''}, r*ez - S2*eu{EP},"
        f" z3*ez - S3*eu{EP}, ct*ez - S4*eu{EP}]",
        "            # active set: a joint on a limit pushed outward is frozen",
        "            free = [j for j, (v, lo, hi) in enumerate(zip((q1, q2, q3, q4), LO, HI))",
        "                    if not ((v <= lo and g[j] < 0) or (v >= hi and g[j] > 0))]",
        "            if not free:",
        "                stalled = True",
        "                break",
        "            if len(free) == 4:",
        "                free = None",
        "            else:",
        f"                jt = [[r, 0.0, 0.0, 0.0], [{LF!r}, -S2, -S3, -S4], [0.0, r, z3, ct]"
        + (", [0.0, 1.0, 1.0, 1.0]]" if pitch else "]"),
        "                normal = [[sum(row[i]*row[j] for row in jt) for j in free] for i in free]",
        "                gf = [g[c] for c in free]",
        "        m00 = S2*S2 + S3*S3 + S4*S4" + (f" + {LF * LF!r}" if LF else ""),
        "        m01 = -(S2*r + S3*z3 + S4*ct)",
        "        m11 = r*r + z3*z3 + ct*ct",
    ]
    if pitch:
        L += ["        m02 = -(S2 + S3 + S4)", "        m12 = r + z3 + ct"]
    L += [
        "        rr = r*r",
        "        improved = False",
        "        while damp < 1e9:",
        "            dl = damp*damp",
        "            if free is None:",
    ]
    I4 = "                "
    if LF:
        L += [f"{I4}kk = {LF!r}*r/(rr + dl)",
              f"{I4}a = m00 + dl - kk*{LF!r}*r",
              f"{I4}bu = eu - kk*et"]
    else:
        L += [f"{I4}a = m00 + dl", f"{I4}bu = eu"]
    L.append(f"{I4}d = m11 + dl")
    if pitch:
        L += [
            f"{I4}f = 3.0 + dl",
            f"{I4}c00 = d*f - m12*m12",
            f"{I4}c01 = m02*m12 - m01*f",
            f"{I4}c02 = m01*m12 - m02*d",
            f"{I4}idet = 1.0/(a*c00 + m01*c01 + m02*c02)",
            f"{I4}yu = (c00*bu + c01*ez + c02*ep)*idet",
            f"{I4}yz = (c01*bu + (a*f - m02*m02)*ez + (m01*m02 - a*m12)*ep)*idet",
            f"{I4}yp = (c02*bu + (m01*m02 - a*m12)*ez + (a*d - m01*m01)*ep)*idet",
            f"{I4}n2 = q2 + (r*yz - S2*yu + yp)",
            f"{I4}n3 = q3 + (z3*yz - S3*yu + yp)",
            f"{I4}n4 = q4 + (ct*yz - S4*yu + yp)",
        ]
    else:
        L += [
            f"{I4}idet = 1.0/(a*d - m01*m01)",
            f"{I4}yu = (d*bu - m01*ez)*idet",
            f"{I4}yz = (a*ez - m01*bu)*idet",
            f"{I4}n2 = q2 + (r*yz - S2*yu)",
            f"{I4}n3 = q3 + (z3*yz - S3*yu)",
            f"{I4}n4 = q4 + (ct*yz - S4*yu)",
        ]
    if LF:
        L.append(f"{I4}n1 = q1 + (r*(et - {LF!r}*r*yu)/(rr + dl) + {LF!r}*yu)")
    else:
        L.append(f"{I4}n1 = q1 + r*et/(rr + dl)")
    L += [
        "            else:",
        "                aa = [row[:] for row in normal]",
        "                for i in range(len(free)):",
        "                    aa[i][i] += dl",
        "                st = solve_spd(aa, gf)",
        "                nn = [q1, q2, q3, q4]",
        "                for i, j in enumerate(free):",
        "                    nn[j] += st[i]",
        "                n1, n2, n3, n4 = nn",
        "            nl = False",
    ]
    for nv, (lo, hi) in zip(ns, lims, strict=True):
        L += [
            f"            if {nv} <= {lo!r}:",
            f"                {nv} = {lo!r}",
            "                nl = True",
            f"            elif {nv} >= {hi!r}:",
            f"                {nv} = {hi!r}",
            "                nl = True",
        ]
    L += evaluate(ns, "n", "            ")
    L += [
        "            if nerr2 < err2:",
        "                rel = (err2 - nerr2)/err2",
        "                q1, q2, q3, q4, err2, atlim = n1, n2, n3, n4, nerr2, nl",
        f"                {', '.join(state)} = {', '.join('n' + v for v in state)}",
        "                damp *= 0.1",
        "                if damp < lam:",
        "                    damp = lam",
        "                improved = True",
        "                stall = stall + 1 if rel < 1e-9 else 0",
        "                break",
        "            damp *= 10.0",
        "        if not improved or stall >= 5:",
        "            stalled = True",
        "            break",
        "    return q1, q2, q3, q4, err2, it, stalled",
    ]
    return "\n".join(L) + "\n"


def _arm_kernel(arm: WritingArm, pitch: bool) -> Callable[..., tuple]:
    """The compiled fused LM descent for ``arm`` (cached on the arm)."""
    cache = arm._kernels  # type: ignore[attr-defined]
    kern = cache.get(pitch)
    if kern is None:
        ns: dict[str, object] = {
            "cos": math.cos, "sin": math.sin, "remainder": math.remainder,
            "solve_spd": _solve_spd,
            "LO": tuple(float(v) for v in arm.limits[:, 0]),
            "HI": tuple(float(v) for v in arm.limits[:, 1]),
        }
        src = _arm_kernel_source(arm, pitch)
        exec(compile(src, f"<solve_arm {arm.name} {'pitch' if pitch else 'position'}>", "exec"), ns)  # noqa: S102
        kern = cache[pitch] = ns["attempt"]
    return kern  # type: ignore[return-value]


def _cell_table(
    key: np.ndarray, score: np.ndarray, q: np.ndarray, ncells: int, k: int, gap: float
) -> np.ndarray:
    """Per cell, up to ``k`` sample indices (-1: none): the best-scored sample, then the
    best ones farther than ``gap`` (max joint difference) from every one kept before."""
    order = np.argsort(key + score * (0.999 / max(float(score.max()), 1e-300)))
    ks = key[order]
    first = np.empty(len(ks), dtype=bool)
    first[0] = True
    np.not_equal(ks[1:], ks[:-1], out=first[1:])
    group = np.cumsum(first) - 1
    cells = ks[first]
    table = np.full((ncells, k), -1, dtype=np.int32)
    kept = order[first]
    table[cells, 0] = kept
    if k > 1:
        cols = [q[order, j] for j in range(q.shape[1])]
        far = ~first
    for c in range(1, k):
        ref = kept[group]
        dist = np.abs(cols[0] - q[ref, 0])
        for j in range(1, len(cols)):
            np.maximum(dist, np.abs(cols[j] - q[ref, j]), out=dist)
        far &= dist > gap
        rows = np.flatnonzero(far)
        if not len(rows):
            break
        rk = ks[rows]
        take = np.empty(len(rows), dtype=bool)
        take[0] = True
        np.not_equal(rk[1:], rk[:-1], out=take[1:])
        hit = rows[take]
        kept = kept.copy()  # cells without a new alternate keep comparing with the last one
        kept[group[hit]] = order[hit]
        table[ks[hit], c] = order[hit]
        far[hit] = False
    return table


def _dilate(table: np.ndarray, strides: Sequence[int], passes: int) -> None:
    """Give empty cells (no first sample) the samples of a filled face neighbour.

    ``table`` is (cells, k) of a C-ordered grid whose outer x, y, z layer is empty
    padding, so the flat shifts never carry a sample across those edges (a pitch-bin
    shift at the +-pi seam borrows from the next z cell: still a nearby start)."""
    for _ in range(passes):
        src = table.copy()
        for s in strides:
            for a, b in ((slice(s, None), slice(None, -s)), (slice(None, -s), slice(s, None))):
                d, n = table[a], src[b]
                hole = (d[:, :1] < 0) & (n[:, :1] >= 0)
                np.copyto(d, n, where=hole)


class _Grid:
    """A dense grid over (x, y, z) or (x, y, z, phi) holding sample rows (offsets into
    the sample array, -1: none) per cell."""

    def __init__(self, f: np.ndarray, q: np.ndarray, cell: float, phi_cell: float | None,
                 score_extra: np.ndarray, k: int, gap: float, passes: int) -> None:
        score = score_extra.copy()
        org, dims, key = [], [], None
        for ax in range(3):
            p = f[:, ax]
            o = math.floor(float(p.min()) / cell) * cell - cell  # one empty layer of padding
            org.append(o)
            dims.append(int((float(p.max()) - o) / cell) + 2)
            u = (p - o) * (1.0 / cell)
            i = u.astype(np.int64)
            r = u - i - 0.5
            score += r * r
            key = i if key is None else key * dims[-1] + i
        nphi = 0
        if phi_cell is not None:
            nphi = int(math.ceil(TWO_PI / phi_cell))
            w = (f[:, 3] + math.pi) * (nphi / TWO_PI)
            ip = np.minimum(w.astype(np.int64), nphi - 1)
            key = key * nphi + ip
            r = w - ip - 0.5
            score += r * r
        ncells = dims[0] * dims[1] * dims[2] * max(nphi, 1)
        self.table = _cell_table(key, score, q, ncells, k, gap)
        inner = max(nphi, 1)
        strides = (inner, dims[2] * inner, dims[1] * dims[2] * inner) + ((1,) if nphi else ())
        _dilate(self.table, strides, passes)
        self.params = (float(org[0]), float(org[1]), float(org[2]), 1.0 / cell,
                       dims[0], dims[1], dims[2], nphi, nphi / TWO_PI)

    def key(self, x: float, y: float, z: float, phi: float | None) -> int:
        ox, oy, oz, inv, nx, ny, nz, nphi, iphi = self.params
        i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
        if not (0 <= i < nx and 0 <= j < ny and 0 <= k < nz):
            return -1
        flat = (i * ny + j) * nz + k
        if nphi:
            if not -math.pi < phi <= math.pi:  # type: ignore[operator]
                phi = math.remainder(phi, TWO_PI)  # type: ignore[arg-type]
            ip = int((phi + math.pi) * iphi)  # type: ignore[operator]
            flat = flat * nphi + (ip if ip < nphi else nphi - 1)
        return flat


class ArmSeeds:
    """A table of workspace samples of one arm, for starting numeric IK near the answer.

    ``n`` configurations are drawn inside the joint limits (seeded) and binned on dense
    grids: by pen position (cells of ``cell`` cm) for position targets, and by pen position
    and pitch (``pitch_cell`` cm x ``phi_cell`` rad) for position + pitch targets, each also
    on a grid twice as coarse. A cell keeps the sample nearest its centre (samples close to
    a joint limit ranked down: they tend to stall on it) and alternates farther than
    ``branch_gap`` rad in joint space from it (the arm's other branches: elbow up/down,
    facing the target or reaching over the base), which :func:`solve_arm` tries when the
    first start stalls. Empty cells borrow a neighbour's samples. :meth:`nearest` is O(1):
    a few multiplications and one array look-up. With the defaults (Pincher) the build
    takes ~0.35 s and the tables ~17 MB.
    """

    def __init__(
        self,
        arm: WritingArm,
        n: int = 250_000,
        cell: float = 1.0,
        seed: int = 0,
        pitch_cell: float = 2.5,
        phi_cell: float = 0.25,
        candidates: int = 4,
        branch_gap: float = 1.0,
        limit_weight: float = 2.0,
        limit_margin: float = 0.6,
        cell_weight: float = 2.0,
    ) -> None:
        rng = np.random.default_rng(seed)
        lo, hi = arm.limits[:, 0], arm.limits[:, 1]
        q = rng.uniform(lo, hi, (n, 4))
        f = arm.fk(q)
        self.cell = float(cell)
        self.pitch_cell = float(pitch_cell)
        self.phi_cell = float(phi_cell)
        self.fallback = tuple(map(float, 0.5 * (lo + hi)))
        # rank down starts that would run into a joint limit: for position targets, those
        # within limit_margin rad of one; for position + pitch targets (no redundancy),
        # those whose branch leaves the limits within the cell (:meth:`_reach_penalty`)
        penalty = np.zeros(n)
        for j in range(4):
            gap = np.minimum(q[:, j] - lo[j], hi[j] - q[:, j])
            near = np.maximum(0.0, 1.0 - gap / limit_margin)
            penalty += near * near
        penalty *= limit_weight
        k = max(int(candidates), 1)
        fine, coarse = self._reach_penalty(
            arm, q, ((pitch_cell, phi_cell), (2 * pitch_cell, 2 * phi_cell)), cell_weight)
        grids = [
            _Grid(f, q, cell, None, penalty, min(k, 2), branch_gap, 2),
            _Grid(f, q, 2 * cell, None, penalty, k, branch_gap, 1),
            _Grid(f, q, pitch_cell, phi_cell, fine, min(k, 2), branch_gap, 1),
            _Grid(f, q, 2 * pitch_cell, 2 * phi_cell, coarse, k, branch_gap, 1),
        ]
        # keep only the samples some cell refers to; tables then hold offsets into _q
        mark = np.zeros(n + 1, dtype=bool)
        for g in grids:
            mark[g.table.ravel()] = True  # -1 marks the extra last slot
        used = np.flatnonzero(mark[:n])
        remap = np.full(n + 1, -1, dtype=np.int32)
        remap[used] = 4 * np.arange(len(used), dtype=np.int32)
        self._q = array("d", q[used].ravel().tobytes())
        for g in grids:
            g.table = remap[g.table]  # -1 stays -1 (remap[-1] == -1)
        self._grids = grids
        self._g3 = array("i", np.ascontiguousarray(grids[0].table[:, 0]).tobytes())
        self._g4 = array("i", np.ascontiguousarray(grids[2].table[:, 0]).tobytes())
        self._p3, self._p4 = grids[0].params, grids[2].params
        self._arm = arm

    @staticmethod
    def _reach_penalty(
        arm: WritingArm, q: np.ndarray, cells: Sequence[tuple[float, float]], weight: float
    ) -> list[np.ndarray]:
        """Rank of position + pitch samples, per ``(cell, phi_cell)``: how far the cell's
        extent, mapped to the joints through the inverse Jacobian (to first order), would
        push the sample past a joint limit.

        A start whose own branch leaves the limits inside its cell sends LM into a limit
        on the wrong branch; ranking those down keeps the branch that stays inside. Uses
        the Jacobian in the heading frame (see :func:`_arm_kernel_source`): joint 1 moves
        only the t row, joints 2..4 solve the 3x3 (u, z, phi) block by cross products."""
        pa = q[:, 1] + arm.pitch_offset
        pb = pa + q[:, 2]
        pt = pb + q[:, 3]
        ct = arm.tool * np.cos(pt)
        s4 = arm.tool * np.sin(pt)
        s3 = arm.forearm * np.sin(pb) + s4
        s2 = arm.upper_arm * np.sin(pa) + s3
        z3 = arm.forearm * np.cos(pb) + ct
        r = arm.upper_arm * np.cos(pa) + z3
        a = (-s2, -s3, -s4)  # rows of the 3x3 block: u, z, phi
        b = (r, z3, ct)
        # columns of the block's inverse: (b x c, c x a, a x b) / det with c = (1, 1, 1)
        bxc = (b[1] - b[2], b[2] - b[0], b[0] - b[1])
        cxa = (a[2] - a[1], a[0] - a[2], a[1] - a[0])
        axb = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        lo, hi = arm.limits[:, 0], arm.limits[:, 1]
        out = []
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            idet = np.abs(1.0 / (a[0] * bxc[0] + a[1] * bxc[1] + a[2] * bxc[2]))
            ir = 1.0 / np.abs(r)
            margin = [np.minimum(q[:, j] - lo[j], hi[j] - q[:, j]) for j in range(4)]
            du = [idet * np.abs(v) for v in bxc]
            dz = [idet * np.abs(v) for v in cxa]
            dp = [idet * np.abs(v) for v in axb]
            for cell, phi_cell in cells:
                near = np.maximum(0.0, 1.0 - margin[0] / (cell * ir))
                pen = near * near
                uext = cell * (1.0 + abs(arm.lateral_offset) * ir)
                for j in range(3):
                    reach = du[j] * uext + dz[j] * cell + dp[j] * phi_cell
                    near = np.maximum(0.0, 1.0 - margin[j + 1] / reach)
                    pen += near * near
                out.append(weight * np.nan_to_num(pen, nan=4.0, posinf=4.0))
        return out

    def _start(self, x: float, y: float, z: float, phi: float | None) -> Sequence[float]:
        """:meth:`nearest` without the tuple (the hot path of :func:`solve_arm`)."""
        if phi is None:
            ox, oy, oz, inv, nx, ny, nz, _, _ = self._p3
            i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                at = self._g3[(i * ny + j) * nz + k]
                if at >= 0:
                    return self._q[at:at + 4]
        else:
            ox, oy, oz, inv, nx, ny, nz, nphi, iphi = self._p4
            i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                if not -math.pi < phi <= math.pi:
                    phi = math.remainder(phi, TWO_PI)
                ip = int((phi + math.pi) * iphi)
                at = self._g4[((i * ny + j) * nz + k) * nphi + (ip if ip < nphi else nphi - 1)]
                if at >= 0:
                    return self._q[at:at + 4]
        coarse = self._grids[1] if phi is None else self._grids[3]
        key = coarse.key(x, y, z, phi)
        at = int(coarse.table[key, 0]) if key >= 0 else -1
        return self._q[at:at + 4] if at >= 0 else self.fallback

    def nearest(self, x: float, y: float, z: float, phi: float | None = None) -> tuple[float, ...]:
        """The first start for a target: the sample nearest the centre of its cell (phi:
        its pitch cell too)."""
        return tuple(self._start(x, y, z, phi))

    def candidates(
        self, x: float, y: float, z: float, phi: float | None = None, gap: float = 1.0,
        wide: bool = False,
    ) -> list[tuple[float, ...]]:
        """Every start kept for the target: its cell's samples, then the coarse cell's,
        without repeats (closer than ``gap`` rad in every joint to an earlier one).

        ``wide``: then also the samples of the 3^d coarse cells around the target, nearest
        (in task space) first - other branches for targets near a joint-limit boundary."""
        fine, coarse = self._grids[2:] if phi is not None else self._grids[:2]
        offsets: list[int] = []
        for g in (fine, coarse):
            key = g.key(x, y, z, phi)
            if key >= 0:
                offsets += [at for at in g.table[key].tolist() if at >= 0]
        if wide:
            offsets += self._around(coarse, x, y, z, phi)
        out: list[tuple[float, ...]] = []
        for at in offsets:
            c = tuple(self._q[at:at + 4])
            if all(max(abs(a - b) for a, b in zip(c, o, strict=True)) > gap for o in out):
                out.append(c)
        return out or [self.fallback]

    def _around(self, g: _Grid, x: float, y: float, z: float, phi: float | None) -> list[int]:
        """Sample offsets of the coarse cells around a target, nearest sample first."""
        ox, oy, oz, inv, nx, ny, nz, nphi, iphi = g.params
        ijk = [int((v - o) * inv) for v, o in ((x, ox), (y, oy), (z, oz))]
        axes = [np.clip(np.arange(c - 1, c + 2), 0, d - 1)
                for c, d in zip(ijk, (nx, ny, nz), strict=True)]
        key = (axes[0][:, None, None] * ny + axes[1][None, :, None]) * nz + axes[2][None, None, :]
        key = key.ravel()
        if nphi:
            ph = math.remainder(phi, TWO_PI)  # type: ignore[arg-type]
            ip = min(int((ph + math.pi) * iphi), nphi - 1)
            key = (key[:, None] * nphi + (np.arange(ip - 1, ip + 2) % nphi)[None, :]).ravel()
        at = np.unique(g.table[key].ravel())
        at = at[at >= 0]
        if not len(at):
            return []
        qs = np.frombuffer(self._q, dtype=np.float64).reshape(-1, 4)[at // 4]
        f = self._arm.fk(qs)
        d = np.sqrt((f[:, 0] - x) ** 2 + (f[:, 1] - y) ** 2 + (f[:, 2] - z) ** 2)
        if nphi:
            d += 10.0 * np.abs(np.remainder(f[:, 3] - phi + math.pi, TWO_PI) - math.pi)
        return at[np.argsort(d, kind="stable")].tolist()


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
    :func:`_arm_kernel_source`; the same steps as :func:`dls`), other masks run :func:`dls`.
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
    kern = kernels.get(pitch) or _arm_kernel(arm, pitch)
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
) -> IKResult:
    """:func:`dls` on the arm's residual for any mask (the path of unusual masks)."""
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
    return _restart_loop(_lm_attempt(residual, lim, lam, tol, max_iter), q, lim, tol, restarts,
                         rng, alts)


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
