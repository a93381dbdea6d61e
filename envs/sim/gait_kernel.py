"""Many moves judged at once: the vectorised twin of :func:`~kinegym.envs.sim.gait.plan_move`.

:func:`feasible_moves` answers, for a batch of ``(arm, hole)`` moves from one stance, the one
question the action masks and the route finder ask: would :func:`plan_move` return a
:class:`~kinegym.envs.sim.gait.MovePlan`? It runs the same checks with the same formulas, in
the same floating-point order, over numpy arrays instead of one move at a time: the quick
span rejection, the smallest circle round the four holes (the swing pose) and round the new
three (the new rest pose), reach and body clearance at both and along both shifts, elbow
limits at the swing pose and along the swing, and the statics (the best split of the body's
weight between the two holding arms, every servo and gripper within its limit) at the end
of the swing and at :data:`~kinegym.envs.sim.gait.SWING_CHECKS` points along it.
A half-turn swing is judged on both sides, as :func:`plan_move` judges it (feasible if
either side is).

``gait.py`` stays the readable reference (it also says *why* a move fails and returns the
plan); ``tests/test_gait_kernel.py`` pins this kernel's answers equal to it on thousands of
moves over generated walls, robots and headings. The two can only part on a move whose
margin is within a few units in the last place of a double (numpy's and Python's ``hypot``,
``atan2`` and ``cos`` may round differently there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import combinations

import numpy as np

from kinegym.envs.sim.climber_model import ClimberModel, G
from kinegym.envs.sim.gait import HALF_TURN, SHIFT_CHECKS, SWING_CHECKS, rest_pose
from kinegym.kinematics.holes import HoleMap

__all__ = ["feasible_moves", "enclosing_circles"]

_TWO_PI = 2.0 * math.pi


def _remainder(x: np.ndarray) -> np.ndarray:
    """``math.remainder(x, 2 pi)`` for ``|x| <= 4 pi`` (exact there: ``x -/+ 2 pi`` is exact
    for ``pi <= |x| <= 4 pi``, Sterbenz)."""
    return x - _TWO_PI * np.round(x / _TWO_PI)


def enclosing_circles(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`~kinegym.envs.sim.gait.min_enclosing_circle` of each of ``N`` point sets
    ``(N, n, 2)``, ``n`` 2..4: centres ``cx, cy`` and radii ``r`` (``inf`` where no circle
    was found), computed as the scalar version does (a repeated point changes nothing)."""
    n = pts.shape[1]
    x, y = pts[..., 0], pts[..., 1]
    pi, pj = (np.array(v, dtype=np.intp) for v in zip(*combinations(range(n), 2)))
    far2 = (x[:, pi] - x[:, pj]) ** 2 + (y[:, pi] - y[:, pj]) ** 2
    pick = np.argmax(far2, axis=1)  # the first of the farthest pairs, as the scalar loop keeps it
    rows = np.arange(len(pick))
    far = far2[rows, pick]
    fi, fj = pi[pick], pj[pick]
    cx, cy = 0.5 * (x[rows, fi] + x[rows, fj]), 0.5 * (y[rows, fi] + y[rows, fj])
    r2 = 0.25 * far * (1 + 1e-12) + 1e-12
    inside = np.all((x - cx[:, None]) ** 2 + (y - cy[:, None]) ** 2 <= r2[:, None], axis=1)
    r = 0.5 * np.sqrt(far)
    if inside.all() or n < 3:
        return cx, cy, np.where(inside, r, math.inf)
    # the rest: the smallest circle through three points that holds every point
    out = np.flatnonzero(~inside)
    tri = np.array(list(combinations(range(n), 3)), dtype=np.intp)  # (triples, 3)
    X, Y = x[out][:, tri], y[out][:, tri]  # (m, triples, 3)
    ax, bx, qx, ay, by, qy = X[..., 0], X[..., 1], X[..., 2], Y[..., 0], Y[..., 1], Y[..., 2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = 2 * (ax * (by - qy) + bx * (qy - ay) + qx * (ay - by))
        a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, qx * qx + qy * qy
        ux = (a2 * (by - qy) + b2 * (qy - ay) + c2 * (ay - by)) / d
        uy = (a2 * (qx - bx) + b2 * (ax - qx) + c2 * (bx - ax)) / d
        rr = (ax - ux) ** 2 + (ay - uy) ** 2
        lim = rr * (1 + 1e-12) + 1e-12
        holds = np.all((x[out][:, None, :] - ux[..., None]) ** 2 + (y[out][:, None, :] - uy[..., None]) ** 2
                       <= lim[..., None], axis=2) & (np.abs(d) >= 1e-12)
    # in the scalar loop's order: a triple replaces the best when its circle is smaller (four
    # points on one circle tie up to rounding, and this keeps the scalar version's pick)
    bx_, by_, br = cx[out], cy[out], np.full(len(out), math.inf)
    for t in range(len(tri)):
        take = holds[:, t] & (rr[:, t] < br ** 2)
        bx_ = np.where(take, ux[:, t], bx_)
        by_ = np.where(take, uy[:, t], by_)
        br = np.where(take, np.sqrt(rr[:, t]), br)
    cx, cy = cx.copy(), cy.copy()
    cx[out], cy[out], r[out] = bx_, by_, br
    return cx, cy, r


def _ik(l1: np.ndarray | float, l2: np.ndarray | float, dx: np.ndarray, dy: np.ndarray, branch: int
        ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~kinegym.kinematics.climber.arm_ik_one` over arrays."""
    d = np.hypot(dx, dy)
    e = np.arccos(np.clip((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0))
    ca = np.clip((l1 * l1 + d * d - l2 * l2) / (2 * l1 * np.maximum(d, 1e-12)), -1.0, 1.0)
    s = np.arctan2(dy, dx) - branch * np.arccos(ca)
    if branch < 0:
        e = 2 * math.pi - e
    return _remainder(s), e


def feasible_moves(model: ClimberModel, holes: HoleMap, stance: Sequence[int], arms: Sequence[int] | np.ndarray,
                   targets: Sequence[int] | np.ndarray, heading: float = 0.0, branch: int = 1,
                   rest: tuple[float, float, float] | str | None = None) -> np.ndarray:
    """For each move ``(arms[i], targets[i])`` from ``stance``: would :func:`plan_move` (same
    ``heading``, ``branch`` and ``rest``) return a plan? A ``(N,)`` bool array."""
    arm = np.asarray(arms, dtype=np.intp).reshape(-1)
    tgt = np.asarray(targets, dtype=np.intp).reshape(-1)
    if arm.shape != tgt.shape:
        raise ValueError(f"arms {arm.shape} and targets {tgt.shape} differ in length")
    out = np.zeros(len(arm), dtype=bool)
    st = np.array([int(stance[0]), int(stance[1]), int(stance[2])], dtype=np.intp)
    pose_from = rest_pose(model, holes, stance, heading) if rest is None else rest
    if len(arm) == 0 or isinstance(pose_from, str):
        return out
    xy, offs = holes.xy, np.array(model.offsets(heading))
    idx = np.flatnonzero((tgt != st[0]) & (tgt != st[1]) & (tgt != st[2]))
    a = arm[idx]
    n = len(idx)
    if n == 0:
        return out
    # rows 0..n-1: the four holes at the swing; rows n..2n-1: the new three (the moved one twice)
    pts = np.empty((2 * n, 4, 2))
    pts[:n, :3] = xy[st] - offs
    pts[:n, 3] = xy[tgt[idx]] - offs[a]
    pts[n:, :3] = pts[:n, :3]
    pts[n + np.arange(n), a] = pts[:n, 3]
    pts[n:, 3] = pts[n:, 2]
    x, y = pts[..., 0], pts[..., 1]
    span2 = (2 * max(model.reach[1])) ** 2  # two holes further apart than two arms can span
    keep = np.all(((x[:n, :, None] - x[:n, None, :]) ** 2 + (y[:n, :, None] - y[:n, None, :]) ** 2
                   <= span2).reshape(n, -1), axis=1)
    # reach and body clearance at the swing pose and at the new rest pose (circle centres)
    cx, cy, _ = enclosing_circles(pts)
    inner, outer = np.asarray(model.reach[0]), np.asarray(model.reach[1])
    clear = model.phys.body_radius_cm + model.phys.reach_margin_cm
    which = np.empty((2 * n, 4), dtype=np.intp)
    which[:, :3] = (0, 1, 2)
    which[:n, 3], which[n:, 3] = a, 2
    ok = _within(np.hypot(x - cx[:, None], y - cy[:, None]), outer[which], np.maximum(inner[which], clear))
    keep &= ok[:n].all(axis=1) & ok[n:].all(axis=1)
    # both shifts (rest -> swing pose on the old holes, swing pose -> new rest on the new holes)
    # keep every held hole clear of the body and within reach at SHIFT_CHECKS - 1 inner points
    f = (np.arange(1, SHIFT_CHECKS) / SHIFT_CHECKS)[None, :]
    x0 = np.concatenate([np.full(n, float(pose_from[0])), cx[:n]])[:, None]
    y0 = np.concatenate([np.full(n, float(pose_from[1])), cy[:n]])[:, None]
    x1 = np.concatenate([cx[:n], cx[n:]])[:, None]
    y1 = np.concatenate([cy[:n], cy[n:]])[:, None]
    px, py = x0 + f * (x1 - x0), y0 + f * (y1 - y0)  # (2n, checks)
    d = np.hypot(x[:, None, :3] - px[..., None], y[:, None, :3] - py[..., None])
    ok = np.all(_within(d, outer[:3], np.maximum(inner[:3], clear)).reshape(2 * n, -1), axis=1)
    keep &= ok[:n] & ok[n:]
    idx, a, cx, cy = idx[keep], a[keep], cx[:n][keep], cy[:n][keep]
    n = len(idx)
    if n == 0:
        return out
    rows = np.arange(n)
    new_st = np.broadcast_to(st, (n, 3)).copy()
    new_st[rows, a] = tgt[idx]
    hands = xy[new_st]  # (n, 3, 2)
    # the swing: the free hand sweeps round its shoulder from its old hole to the new one
    sh_x, sh_y = cx + offs[a, 0], cy + offs[a, 1]
    ox, oy = xy[st[a], 0] - sh_x, xy[st[a], 1] - sh_y
    nx, ny = hands[rows, a, 0] - sh_x, hands[rows, a, 1] - sh_y
    ra, rb = np.hypot(ox, oy), np.hypot(nx, ny)
    ta = np.arctan2(oy, ox)
    dt = _remainder(np.arctan2(ny, nx) - ta)
    # a half turn is as short either way round: both sides are judged (one row each), and the
    # move is feasible if either is (plan_move then takes the lighter one)
    half = np.flatnonzero(np.abs(dt) > HALF_TURN)
    dt[half] = math.pi
    owner = np.concatenate([np.arange(n), half])
    dt = np.concatenate([dt, np.full(len(half), -math.pi)])
    idx, a, cx, cy, sh_x, sh_y, ra, rb, ta, hands = (v[owner] for v in (idx, a, cx, cy, sh_x, sh_y, ra, rb, ta,
                                                                         hands))
    n = len(owner)
    rows = np.arange(n)
    fs = (np.arange(SWING_CHECKS) / SWING_CHECKS)[None, :]
    r, t = ra[:, None] + fs * (rb - ra)[:, None], ta[:, None] + fs * dt[:, None]
    swing_x, swing_y = sh_x[:, None] + r * np.cos(t), sh_y[:, None] + r * np.sin(t)  # (n, checks)
    # joint angles: the three arms at the swing pose, then the free arm along its swing
    c, s = math.cos(heading), math.sin(heading)
    l1, l2 = model.geom.l1, model.geom.l2
    bx = np.concatenate([hands[..., 0] - cx[:, None] - offs[:, 0], swing_x - sh_x[:, None]], axis=1)
    by = np.concatenate([hands[..., 1] - cy[:, None] - offs[:, 1], swing_y - sh_y[:, None]], axis=1)
    ik_arm = np.concatenate([np.broadcast_to([0, 1, 2], (n, 3)), np.broadcast_to(a[:, None], (n, SWING_CHECKS))],
                            axis=1)
    qs, qe = _ik(l1[ik_arm], l2[ik_arm], c * bx + s * by, -s * bx + c * by, branch)
    lo, hi = model.geom.elbow_limits
    keep = np.all((qe >= lo) & (qe <= hi), axis=1)
    # the statics at every swing point and at its end: one row each
    m = SWING_CHECKS + 1
    H = np.repeat(hands[:, None], m, axis=1)  # (n, m, 3, 2)
    Q = np.repeat(qs[:, None, :3], m, axis=1)  # (n, m, 3)
    H[rows, :SWING_CHECKS, a, 0], H[rows, :SWING_CHECKS, a, 1] = swing_x, swing_y
    Q[rows, :SWING_CHECKS, a] = qs[:, 3:]
    ok = _statics_ok(model, np.repeat(cx, m), np.repeat(cy, m), heading, H.reshape(-1, 3, 2), Q.reshape(-1, 3),
                     np.repeat(a, m))
    keep &= np.all(ok.reshape(n, m), axis=1)
    out[idx[keep]] = True
    return out


def _within(d: np.ndarray, outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """Distances within reach and clear of the body (``inner <= d <= outer``)."""
    return (d <= outer) & (d >= inner)


_HOLDING = np.array([[1, 2], [0, 2], [0, 1]], dtype=np.intp)  # free arm -> the two holding arms
_SIGN = np.array([1.0, -1.0])


def _statics_ok(model: ClimberModel, cx: np.ndarray, cy: np.ndarray, th: float, hands: np.ndarray, qsh: np.ndarray,
                free: np.ndarray) -> np.ndarray:
    """:func:`~kinegym.envs.sim.gait.swing_loads` with ``safety = torque_safety``, over rows:
    does a split keep every servo and gripper within its limit, with the free arm's own
    servos within it too? Columns 0 and 1 of the ``(rows, 2)`` arrays are the two holding
    arms (``a`` and ``b`` of the scalar version); arm ``b`` takes the body's weight less
    what ``a`` takes, so its force is ``(0, w_body) - F_a``."""
    p = model.phys
    safety, hold = p.torque_safety, p.holding_force_n
    w_up, w_low, w_hand = p.upper_link_mass_kg * G, p.lower_link_mass_kg * G, p.hand_mass_kg * G
    offs = np.array(model.offsets(th))
    l1 = model.geom.l1
    rows = np.arange(len(cx))
    # the free arm hangs from its shoulder
    fsx = cx + offs[free, 0]
    fex = fsx + l1[free] * np.cos(th + qsh[rows, free])
    fhx = hands[rows, free, 0]
    m_free = -w_up * 0.5 * (fex - fsx) - w_low * (0.5 * (fex + fhx) - fsx) - w_hand * (fhx - fsx)
    t_free = np.maximum(np.abs(m_free) / p.shoulder_torque_ncm,
                        np.abs(-w_low * 0.5 * (fhx - fex) - w_hand * (fhx - fex)) / p.elbow_torque_ncm)
    w_arm = w_up + w_low + w_hand
    w_body = p.body_mass_kg * G + w_arm
    ab = _HOLDING[free]  # (N, 2)
    r2 = rows[:, None]
    Sx, Sy = cx[:, None] + offs[ab, 0], cy[:, None] + offs[ab, 1]
    a1 = th + qsh[r2, ab]
    Ex, Ey = Sx + l1[ab] * np.cos(a1), Sy + l1[ab] * np.sin(a1)
    Hx, Hy = hands[r2, ab, 0], hands[r2, ab, 1]
    Gk = -w_up * (0.5 * (Sx + Ex) - Hx) - w_low * 0.5 * (Ex - Hx)
    m_load = -w_arm * (fsx - cx) + m_free
    rhs = Gk[:, 0] + Gk[:, 1] + m_load - (cx - Hx[:, 1]) * w_body
    ux, uy = Hx[:, 1] - Hx[:, 0], Hy[:, 1] - Hy[:, 0]
    uu = ux * ux + uy * uy
    fpx, fpy = -uy * rhs / uu, ux * rhs / uu
    F0x, F0y = fpx[:, None] * _SIGN, np.array([0.0, w_body]) + fpy[:, None] * _SIGN
    DFx, DFy = ux[:, None] * _SIGN, uy[:, None] * _SIGN
    dsx, dsy, dex, dey = Sx - Hx, Sy - Hy, Ex - Hx, Ey - Hy
    A = np.concatenate([(dsx * F0y - dsy * F0x - Gk) / p.shoulder_torque_ncm,
                        (w_low * 0.5 * dex + dex * (F0y + w_up) - dey * F0x) / p.elbow_torque_ncm], axis=1)
    B = np.concatenate([(dsx * DFy - dsy * DFx) / p.shoulder_torque_ncm,
                        (dex * DFy - dey * DFx) / p.elbow_torque_ncm], axis=1)
    gx, gy = F0x, F0y + w_arm  # the grippers' forces, affine in the split t too
    with np.errstate(divide="ignore", invalid="ignore"):
        # each servo |A + B t| <= safety and each gripper |(gx, gy) + t (dx, dy)| <= hold
        # bounds t to an interval (a flat one holds everywhere or nowhere)
        qa, qb, qc = DFx * DFx + DFy * DFy, gx * DFx + gy * DFy, gx * gx + gy * gy - hold * hold
        disc = qb * qb - qa * qc
        rt = np.sqrt(np.maximum(disc, 0.0))
        flat = np.concatenate([np.abs(B) < 1e-12, qa < 1e-12], axis=1)
        fits = np.concatenate([np.abs(A) <= safety, qc <= 0], axis=1)
        ok = np.all(np.where(flat, fits, np.concatenate([np.ones_like(A, dtype=bool), disc >= 0], axis=1)), axis=1)
        t1 = np.concatenate([(-safety - A) / B, (-qb - rt) / qa], axis=1)
        t2 = np.concatenate([(safety - A) / B, (-qb + rt) / qa], axis=1)
        lo = np.max(np.where(flat, -math.inf, np.minimum(t1, t2)), axis=1)
        hi = np.min(np.where(flat, math.inf, np.maximum(t1, t2)), axis=1)
        lo_inf, hi_inf = np.isinf(lo), np.isinf(hi)
        t = np.where(lo_inf & hi_inf, 0.0, np.where(lo_inf, hi, np.where(hi_inf, lo, 0.5 * (lo + hi))))
        ratio = np.max(np.abs(A + B * t[:, None]), axis=1)
    return ok & (lo <= hi) & (np.maximum(ratio, t_free) <= safety)
