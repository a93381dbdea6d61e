"""Plain-Python Levenberg-Marquardt for small systems: what :func:`kinegym.kinematics.ik.dls` runs.

The same algorithm as the readable numpy reference :func:`kinegym.kinematics.ik._lm_reference`
(adaptive damping, an active set for joints on a limit, the stall rule), written for speed:
for the 4 x 4 systems of the arms, plain floats are many times faster than numpy's per-call
overhead, and systems up to 6 x 6 run on straight-line code generated once per size
(``prep(e, jac)`` returns the gradient ``g = J^T e`` and the data of the damped system;
``solve(data, dl)`` the step for the damping ``dl = lambda^2``). For m >= n the system is
the normal one, ``(J^T J + dl I) dq = J^T e``; for m < n the equivalent
``dq = J^T (J J^T + dl I)^-1 e`` (the push-through identity, seed 003's form), which is
smaller. ``tests/test_kernels.py`` pins it to the reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["solve_spd", "chol_lines", "dense_kernel", "lm_attempt", "DENSE_MAX"]

Residual = Callable[[list[float]], tuple[list[float], list[list[float]]]]


def solve_spd(a: list[list[float]], b: list[float]) -> list[float]:
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


# Straight-line kernels for small dense systems (generated once per size, like the DH
# chains of chains.py): ``prep(e, jac)`` returns the gradient ``g = J^T e`` and the data of
# the damped system; ``solve(data, dl)`` returns the step for the damping ``dl = lambda^2``.
# For m >= n the system is the normal one, ``(J^T J + dl I) dq = J^T e`` (n x n); for m < n
# it is the equivalent ``dq = J^T (J J^T + dl I)^-1 e`` (m x m, the push-through identity,
# seed 003's form), which is smaller. Cholesky as in :func:`solve_spd`.
DENSE_MAX = 6
_dense_kernels: dict[tuple[int, int], tuple[Callable, Callable]] = {}


def chol_lines(k: int, a: Callable[[int, int], str], b: Callable[[int], str]) -> list[str]:
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


def dense_kernel(m: int, n: int) -> tuple[Callable, Callable]:
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
    solve += ["    " + ln for ln in chol_lines(k, lambda i, j: f"a{i}_{j}", lambda i: rhs[i])]
    src = ("def prep(e, jac):\n" + "\n".join(prep) + "\n\n"
           "def solve(data, dl):\n" + "\n".join(solve + tail) + "\n")
    ns: dict[str, object] = {"sqrt": math.sqrt}
    exec(compile(src, f"<dls {m}x{n}>", "exec"), ns)  # noqa: S102 - generated above
    kern = (ns["prep"], ns["solve"])  # type: ignore[assignment]
    _dense_kernels[(m, n)] = kern  # type: ignore[assignment]
    return kern  # type: ignore[return-value]


def lm_attempt(
    residual: Residual, lim: list[tuple[float, float]], lam: float, tol: float, max_iter: int
) -> Callable[[list[float]], tuple[list[float], float, int, bool]]:
    """One LM descent from a start: ``attempt(q) -> (q, err2, iterations, stalled)``."""
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
        kern = dense_kernel(m, n) if m <= DENSE_MAX and n <= DENSE_MAX else None
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
                    step = solve_spd(a, gf)
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
