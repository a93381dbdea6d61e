"""The writing arm's closed-form IK for one target, generated per arm: :meth:`WritingArm.ik_fast`.

Straight-line Python with the arm's constants folded, for callers that solve one target at
a time in a loop (the arm simulation's stroke following). The reference is
:meth:`kinegym.kinematics.writing_arm.WritingArm.ik` (same branches, same choice nearest
``current``, same limit wrapping); ``tests/test_kernels.py`` pins the two equal.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..writing_arm import WritingArm

__all__ = ["ik_fast_function"]

TWO_PI = 2.0 * math.pi


def ik_fast_function(arm: WritingArm) -> Callable[..., tuple[float, float, float, float] | None]:
    """Generate :meth:`WritingArm.ik_fast` for one geometry.

    The same floating-point operations as :meth:`WritingArm._branches_one` followed by the
    limit wrapping of the original ``ik_fast``, in the same order (results are identical
    bit for bit); constants are folded, ``q1`` is wrapped once per reach (it is shared by
    both elbows), and each branch is computed only when the ones before it did not fit.
    """
    a, b, tl = float(arm.upper_arm), float(arm.forearm), float(arm.tool)
    lf = float(arm.lateral_offset)
    lim = arm._lim  # type: ignore[attr-defined]

    def wrap(v: str, j: int, ind: str, fail: str) -> list[str]:
        lo, hi = lim[j]
        return [
            f"{ind}w{j} = {lo!r} + ({v} - {lo!r}) % {TWO_PI!r}",
            f"{ind}if w{j} > {hi + 1e-9!r}:",
            f"{ind}    if w{j} - {TWO_PI!r} - {lo!r} > -1e-9:",
            f"{ind}        w{j} = {lo!r}",
            f"{ind}    else:",
            f"{ind}        {fail}",
        ]

    def branch(sign: str, ind: str) -> list[str]:
        lines = [
            f"{ind}while True:",
            f"{ind}    psi_a = base_ang - atan2({sign}ks, k_c)",
            f"{ind}    q3 = {sign}ac",
            *wrap(f"(psi_a - {float(arm.pitch_offset)!r})", 1, ind + "    ", "break"),
            *wrap("q3", 2, ind + "    ", "break"),
            *wrap("(psi_arm - psi_a - q3)", 3, ind + "    ", "break"),
            f"{ind}    if current is None:",
            f"{ind}        return (w0, w1, w2, w3)",
            f"{ind}    cost = abs(w0 - cur0) + abs(w1 - cur1) + abs(w2 - cur2) + abs(w3 - cur3)",
            f"{ind}    if cost < best_cost:",
            f"{ind}        best, best_cost = (w0, w1, w2, w3), cost",
            f"{ind}    break",
        ]
        return lines

    src = [
        "def ik_fast(x, y, z, phi, current=None):",
        f"    dx = x - {float(arm.base_xy[0])!r}",
        f"    dy = y - {float(arm.base_xy[1])!r}",
        f"    rho2 = dx * dx + dy * dy - {lf * lf!r}",
        "    if rho2 < 0:",
        "        return None",
        "    rho = sqrt(rho2)",
        f"    psi_t = phi + {float(arm.pitch_offset)!r}",
        "    bearing = atan2(dy, dx)",
        "    ct, st = cos(psi_t), sin(psi_t)",
        f"    zw = z - {float(arm.shoulder_height)!r} - {tl!r} * st",
        f"    base2 = zw * zw - {a * a!r} - {b * b!r}",
        "    best, best_cost = None, inf",
        "    if current is not None:",
        "        cur0, cur1, cur2, cur3 = current[0], current[1], current[2], current[3]",
        f"    for r, tc, psi_arm in ((rho, {tl!r} * ct, psi_t), (-rho, -{tl!r} * ct, {math.pi!r} - psi_t)):",
        "        rw = r - tc",
        f"        c3 = (rw * rw + base2) / {2 * a * b!r}",
        "        if c3 > 1.0 or c3 < -1.0:",
        "            if abs(c3) > 1 + 1e-12:",
        "                continue",
        "            c3 = max(-1.0, min(1.0, c3))",
        *wrap(f"(bearing + atan2({lf!r}, r) - {float(arm.yaw_offset)!r})", 0, "        ",
              "continue"),
        "        s3 = sqrt(1.0 - c3 * c3)",
        "        base_ang = atan2(zw, rw)",
        f"        k_c = {a!r} + {b!r} * c3",
        f"        ks = {b!r} * s3",
        "        ac = acos(c3)",
        *branch("-", "        "),
        *branch("", "        "),
        "    return best",
    ]
    ns: dict[str, object] = {"sqrt": math.sqrt, "atan2": math.atan2, "cos": math.cos,
                             "sin": math.sin, "acos": math.acos, "inf": math.inf}
    exec(compile("\n".join(src) + "\n", f"<ik_fast {arm.name}>", "exec"), ns)  # noqa: S102
    return ns["ik_fast"]  # type: ignore[return-value]
