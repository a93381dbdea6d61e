"""The fused Levenberg-Marquardt descent of :func:`kinegym.kinematics.ik.solve_arm`, generated per arm.

For the writing arm's two task masks (position; position + pitch) one Python function per
arm and mask is generated with the residual, the analytic Jacobian and the damped solve
fused and the arm's constants folded (~1 us per LM iteration). It takes the same steps as
:func:`kinegym.kinematics.ik.dls` on the arm's residual; ``tests/test_kernels.py`` pins it
to the readable reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from .lm import solve_spd

if TYPE_CHECKING:
    from ..writing_arm import WritingArm

__all__ = ["arm_kernel", "arm_kernel_source"]

TWO_PI = 2.0 * math.pi


def arm_kernel_source(arm: WritingArm, pitch: bool) -> str:
    """Source of the fused LM descent of :func:`solve_arm` for one arm and mask.

    The same algorithm as :func:`dls` (damping, active set, stall rule), with the arm's
    analytic Jacobian folded in. The task error is taken in the frame of the arm's current
    heading, ``u = (cos yaw, sin yaw)``, ``t = (-sin yaw, cos yaw)`` (a rotation of the x, y
    rows: ``J^T J``, ``J^T e`` and hence every LM step are unchanged). There the Jacobian is
    sparse::

        t row: [r,  0,   0,   0 ]        r  = A cos psiA + B cos psiB + T cos psiT
        u row: [lf, -S2, -S3, -S4]       S2 = A sin psiA + S3, S3 = B sin psiB + S4, S4 = T sin psiT
        z row: [0,  r,   z3,  ct]        z3 = B cos psiB + ct, ct = T cos psiT
        phi  : [0,  1,   1,   1 ]        (position + pitch only; reaching back, r < 0: -[0, 1, 1, 1])

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
                # world pitch: reaching back (r < 0) the joint sum must meet pi - gp - 2 pitch_offset
                # (its Jacobian row is -[0, 1, 1, 1]; J^T J is the same, J^T e flips with the error)
                f"{o}ep = remainder((gp if {o}r >= 0.0 else gb) - ({q2} + {q3} + {q4}), {TWO_PI!r})",
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
        f"    gb = {math.pi - 2 * PO!r} - gp",
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


def arm_kernel(arm: WritingArm, pitch: bool) -> Callable[..., tuple]:
    """The compiled fused LM descent for ``arm`` (cached on the arm)."""
    cache = arm._kernels  # type: ignore[attr-defined]
    kern = cache.get(pitch)
    if kern is None:
        ns: dict[str, object] = {
            "cos": math.cos, "sin": math.sin, "remainder": math.remainder,
            "solve_spd": solve_spd,
            "LO": tuple(float(v) for v in arm.limits[:, 0]),
            "HI": tuple(float(v) for v in arm.limits[:, 1]),
        }
        src = arm_kernel_source(arm, pitch)
        exec(compile(src, f"<solve_arm {arm.name} {'pitch' if pitch else 'position'}>", "exec"), ns)  # noqa: S102
        kern = cache[pitch] = ns["attempt"]
    return kern  # type: ignore[return-value]
