"""DH chains compiled into straight-line Python: the fast forward kinematics of
:class:`kinegym.kinematics.chains.DHChain`.

Each link's rotation and origin are written out as expressions with cos / sin of the joint
variables, constants folded (0, 1 and -1 entries of the transforms vanish), and the same
source runs on floats (one configuration, ~2 us for the Pincher) and on numpy arrays
(batches). The readable reference is :meth:`DHChain.fk_reference` (a product of
:func:`~kinegym.kinematics.chains.dh_matrix` transforms); ``tests/test_kernels.py`` pins the two.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["compile_dh"]


def _clean(c: float) -> float:
    """Snap cos/sin of multiples of 90 degrees to exact 0 / +-1 (enables constant folding)."""
    for exact in (0.0, 1.0, -1.0):
        if abs(c - exact) < 1e-12:
            return exact
    return c


class _Emitter:
    """Builds straight-line code from expression strings, folding 0 / 1 / -1 constants."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.n = 0

    @staticmethod
    def num(expr: str) -> float | None:
        try:
            return float(expr)
        except ValueError:
            return None

    def mul(self, c: float | str, e: str) -> str:
        if isinstance(c, str):
            ce = self.num(c)
            if ce is None:
                ee = self.num(e)
                if ee is not None:
                    return self.mul(ee, c)
                return f"{c}*{e}"
            c = ce
        if c == 0.0:
            return "0.0"
        ee = self.num(e)
        if ee is not None:
            return repr(c * ee)
        if c == 1.0:
            return e
        if c == -1.0:
            return f"(-{e})"
        return f"{c!r}*{e}"

    def add(self, *terms: str) -> str:
        const = 0.0
        live = []
        for t in terms:
            v = self.num(t)
            if v is None:
                live.append(t)
            else:
                const += v
        if const != 0.0 or not live:
            live.append(repr(const))
        return "(" + " + ".join(live) + ")" if len(live) > 1 else live[0]

    def bind(self, expr: str) -> str:
        if self.num(expr) is not None or expr.isidentifier():
            return expr
        self.n += 1
        name = f"t{self.n}"
        self.lines.append(f"    {name} = {expr}")
        return name


def compile_dh(links: Sequence[Any], base: np.ndarray, n_joints: int
               ) -> tuple[str, Callable[..., tuple], Callable[..., tuple]]:
    """The source of ``_fk(q0, q1, ...)`` for a DH tree and that function compiled twice: on
    ``math`` (floats) and on ``numpy`` (arrays, batched). It returns, per frame, the rotation
    row-major then the origin."""
    em = _Emitter()
    b = base
    # frame -1: rotation columns R[:, k] and origin p, as expression strings
    base_r = [[repr(_clean(float(b[r, c]))) for r in range(3)] for c in range(3)]
    base_p = [repr(float(b[r, 3])) for r in range(3)]
    frames: list[tuple[list[list[str]], list[str]]] = []
    outputs: list[str] = []
    for lk in links:
        cols, p = (base_r, base_p) if lk.parent == -1 else frames[lk.parent]  # type: ignore[index]
        r0, r1, r2 = cols
        ca, sa = _clean(math.cos(lk.alpha)), _clean(math.sin(lk.alpha))
        if lk.kind == "R":
            th = em.bind(em.add(em.mul(lk.scale, f"q{lk.joint}"), repr(lk.theta)))
            ct, st = em.bind(f"cos({th})"), em.bind(f"sin({th})")
            dd = repr(lk.d)
        else:
            ct, st = repr(_clean(math.cos(lk.theta))), repr(_clean(math.sin(lk.theta)))
            dd = (
                em.bind(em.add(em.mul(lk.scale, f"q{lk.joint}"), repr(lk.d)))
                if lk.kind == "P"
                else repr(lk.d)
            )
        c0 = [em.bind(em.add(em.mul(ct, r0[k]), em.mul(st, r1[k]))) for k in range(3)]
        w = [em.bind(em.add(em.mul(st, f"(-{r0[k]})" if em.num(r0[k]) is None
                                   else repr(-em.num(r0[k]))), em.mul(ct, r1[k])))
             for k in range(3)]
        c1 = [em.bind(em.add(em.mul(ca, w[k]), em.mul(sa, r2[k]))) for k in range(3)]
        c2 = [em.bind(em.add(em.mul(-sa, w[k]), em.mul(ca, r2[k]))) for k in range(3)]
        pn = [
            em.bind(em.add(p[k], em.mul(lk.a, c0[k]), em.mul(dd, r2[k]))) for k in range(3)
        ]
        frames.append(([c0, c1, c2], pn))
        # row-major R then p: r00 r01 r02 r10 ... p0 p1 p2
        outputs.append(
            "(" + ", ".join([frames[-1][0][c][r] for r in range(3) for c in range(3)]) + ", "
            + ", ".join(pn) + ")"
        )
    args = ", ".join(f"q{j}" for j in range(n_joints)) or "_unused=None"
    src = (
        f"def _fk({args}):\n"
        + "\n".join(em.lines)
        + ("\n" if em.lines else "")
        + "    return (" + ", ".join(outputs) + ",)\n"
    )
    namespace_math = {"cos": math.cos, "sin": math.sin}
    namespace_np = {"cos": np.cos, "sin": np.sin}
    exec(compile(src, "<dhchain>", "exec"), namespace_math)  # noqa: S102 - generated above
    exec(compile(src, "<dhchain>", "exec"), namespace_np)  # noqa: S102
    return src, namespace_math["_fk"], namespace_np["_fk"]
