"""The climber's gait judged analytically: can this arm move to that hole, and how?

Seed 000 stopped at statics and named "equations for movements" as the next step; this is
the gait the seed sketches, as a feasibility model: shift the body with all three hands
gripping, release one arm, swing its hand to the new hole, grip. :func:`plan_move` returns a
:class:`MovePlan` (poses, joint angles, the static loads it checked) or the reason against
the move: reach and elbow limits along the shift and the swing, the static torques at the
four holding servos while one arm swings (:func:`swing_loads`: the 1-parameter family of
force splits between the two holding arms is searched for one within every servo's limit),
the free arm's own gravity torque and each gripper's holding force. The kinematic
simulation judges its moves here; the action masks and the route finder judge a stance's
moves all at once with its vectorised twin, :mod:`kinegym.envs.sim.gait_kernel`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinegym.envs.sim.climber_model import ClimberModel, G
from kinegym.kinematics.climber import arm_ik_one
from kinegym.kinematics.holes import HoleMap

__all__ = ["MovePlan", "GaitResult", "plan_move", "swing_loads", "holding_torques", "min_enclosing_circle", "rest_pose",
           "rest_joints", "PHASES", "SWING_CHECKS", "SHIFT_CHECKS", "HALF_TURN"]

#: The gait's phases, in order, that a failed move names: judged before trying (``plan``),
#: the body ``shift`` on the old holes, the ``swing``, ``reach``-ing into the new hole, the
#: ``grip``, coming to ``rest`` on the new holes.
PHASES = ("plan", "shift", "swing", "reach", "grip", "rest")
#: Points along a swing (besides its end) where :func:`plan_move` checks the statics.
SWING_CHECKS = 8
#: Segments of a body shift whose inner points :func:`plan_move` checks for clearance.
SHIFT_CHECKS = 8
#: A swing turning the hand more than this (rad) round its shoulder is a half turn (see ``_around``).
HALF_TURN = math.pi - 1e-9


def min_enclosing_circle(pts: Sequence[tuple[float, float]]) -> tuple[float, float, float]:
    """Smallest circle ``(cx, cy, r)`` around 1..4 points.

    If the circle on the farthest pair as diameter holds every point it is the answer;
    otherwise the answer passes through three points, and it is the smallest circumcircle
    of a triple that holds the rest.
    """
    n = len(pts)
    if n == 1:
        return pts[0][0], pts[0][1], 0.0
    far, fi, fj = -1.0, 0, 1
    for i in range(n):
        ax, ay = pts[i]
        for j in range(i + 1, n):
            d = (ax - pts[j][0]) ** 2 + (ay - pts[j][1]) ** 2
            if d > far:
                far, fi, fj = d, i, j
    cx, cy = 0.5 * (pts[fi][0] + pts[fj][0]), 0.5 * (pts[fi][1] + pts[fj][1])
    r2 = 0.25 * far * (1 + 1e-12) + 1e-12
    if all((px - cx) ** 2 + (py - cy) ** 2 <= r2 for px, py in pts):
        return cx, cy, 0.5 * math.sqrt(far)
    best = (cx, cy, math.inf)
    for i in range(n):
        ax, ay = pts[i]
        for j in range(i + 1, n):
            bx, by = pts[j]
            for k in range(j + 1, n):
                qx, qy = pts[k]
                d = 2 * (ax * (by - qy) + bx * (qy - ay) + qx * (ay - by))
                if abs(d) < 1e-12:
                    continue
                a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, qx * qx + qy * qy
                ux = (a2 * (by - qy) + b2 * (qy - ay) + c2 * (ay - by)) / d
                uy = (a2 * (qx - bx) + b2 * (ax - qx) + c2 * (bx - ax)) / d
                rr = (ax - ux) ** 2 + (ay - uy) ** 2
                if rr < best[2] ** 2:
                    lim = rr * (1 + 1e-12) + 1e-12
                    if all((px - ux) ** 2 + (py - uy) ** 2 <= lim for px, py in pts):
                        best = (ux, uy, math.sqrt(rr))
    return best


@dataclass
class MovePlan:
    """A feasible move: arm, new hole (map row), poses before and after the shift, the six
    joint angles after the move (rad), and the static load figures that were checked."""

    arm: int
    hole: int
    pose_from: tuple[float, float, float]  # the rest pose on the old stance (:func:`rest_pose`)
    pose_to: tuple[float, float, float]  # the swing pose: centre of the four holes' circle
    q_to: np.ndarray  # at pose_to, hands on the new stance
    torque_ratio: float  # worst servo torque over its limit during the swing (best split)
    grip_force_n: float  # largest holding force during the swing
    pose_end: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the rest pose on the new stance
    q_end: np.ndarray | None = None  # at pose_end
    turn: float = 0.0  # a half-turn swing's side: +1 counter-clockwise, -1 clockwise (0: the shorter way)


@dataclass
class GaitResult:
    """What one move did: ``outcome`` (one of :data:`OUTCOMES`), a human ``reason``, the
    stance and true pose after it, the physics steps and simulated seconds it took, and the
    ``phase`` of the gait a failure happened in (:data:`PHASES`; ``""`` when it went well)."""

    outcome: str
    reason: str
    stance: tuple[int, int, int]
    pose: np.ndarray
    steps: int = 0
    seconds: float = 0.0
    plan: MovePlan | None = None
    phase: str = ""

    @property
    def ok(self) -> bool:
        return self.outcome == "ok"


def swing_loads(model: ClimberModel, pose: tuple[float, float, float], hands: Sequence[tuple[float, float]],
                q: Sequence[tuple[float, float]], free: int, safety: float | None = None,
                hold: float | None = None) -> tuple[float, float]:
    """Static loads while arm ``free`` swings and the other two hold the body at ``pose``.

    Returns ``(worst torque ratio, largest gripper force in N)`` for the most favourable
    split of the body's weight between the two holding arms: each holding arm is a chain
    from a passive pivot at its hand, so the body's equilibrium leaves one free parameter
    (how much each arm pulls along the line between their hands); every servo's torque is
    affine in it, and the parameter is chosen to minimise the worst servo's torque over its
    limit (exact: the maximum of the affine ratios is minimised over the line). The free
    arm's own servos must hold its links against gravity in its pose at the new hole.

    With ``safety`` given, any split that keeps every servo within ``safety`` of its limit
    and every gripper within its holding force is taken instead of the best one (cheaper:
    one pass over intervals), and ``(inf, inf)`` means there is none. ``hold`` overrides the
    grippers' holding force (N).
    """
    p = model.phys
    st = _statics(model, pose, hands, q, free)
    norm = [(a0 / lim, b1 / lim) for a0, b1, lim in st.lines]
    if safety is None:
        t_best = _minimax_line(norm)
    else:
        t_best = _feasible_split(norm, st.grips, safety, p.holding_force_n if hold is None else hold)
        if t_best is None:
            return math.inf, math.inf
    ratio = max(abs(a0 + b1 * t_best) for a0, b1 in norm)
    grip = max(math.hypot(gx + dx * t_best, gy + dy * t_best) for gx, gy, dx, dy in st.grips)
    t_free = max(abs(st.free_torques[0]) / p.shoulder_torque_ncm, abs(st.free_torques[1]) / p.elbow_torque_ncm)
    return max(ratio, t_free), grip


def holding_torques(model: ClimberModel, pose: tuple[float, float, float], hands: Sequence[tuple[float, float]],
                    q: Sequence[tuple[float, float]], free: int) -> np.ndarray:
    """The servo torques of :func:`swing_loads`' best split, signed: ``(3, 2)`` N cm, row
    ``k`` = arm ``k``'s (shoulder, elbow), each the torque the servo applies to its outer
    link (shoulder: the upper link, elbow: the lower link), counter-clockwise positive;
    row ``free`` holds the free arm's own links against gravity. Not clipped to the servos'
    limits. :class:`~kinegym.envs.sim.climber.PhysicsClimber` feeds them forward while a
    hand is free."""
    st = _statics(model, pose, hands, q, free)
    t = _minimax_line([(a0 / lim, b1 / lim) for a0, b1, lim in st.lines])
    out = np.empty((3, 2))
    (a0s, b1s, _), (a0e, b1e, _), (b0s, c1s, _), (b0e, c1e, _) = st.lines
    out[st.held[0]] = a0s + b1s * t, a0e + b1e * t
    out[st.held[1]] = b0s + c1s * t, b0e + c1e * t
    out[free] = st.free_torques
    return out


@dataclass
class _Statics:
    """The two holding arms' servo torques as affine functions of the split ``t``."""

    held: tuple[int, int]  # the holding arms
    lines: list[tuple[float, float, float]]  # (a0, b1, limit) per servo: torque = a0 + b1 t (N cm)
    grips: list[tuple[float, float, float, float]]  # per holding hand: force (gx + dx t, gy + dy t) (N)
    free_torques: tuple[float, float]  # the free arm's servos against its own weight (N cm, signed)


def _statics(model: ClimberModel, pose: tuple[float, float, float], hands: Sequence[tuple[float, float]],
             q: Sequence[tuple[float, float]], free: int) -> _Statics:
    p = model.phys
    cx, cy, th = pose
    w_up, w_low, w_hand = p.upper_link_mass_kg * G, p.lower_link_mass_kg * G, p.hand_mass_kg * G
    offs = model.offsets(th)
    links = model._links  # type: ignore[attr-defined]
    pts = []
    for k in range(3):
        sx, sy = cx + offs[k][0], cy + offs[k][1]
        a1 = th + q[k][0]
        ex, ey = sx + links[k][0] * math.cos(a1), sy + links[k][0] * math.sin(a1)
        pts.append((sx, sy, ex, ey, hands[k][0], hands[k][1]))
    # (a moment of a weight w at horizontal offset dx is -w dx: gravity is along -y)
    # the free arm hangs from its shoulder: its weight and moment act on the body; its
    # servos hold it with the opposite torques
    sx, sy, ex, ey, hx, hy = pts[free]
    m_free = -w_up * 0.5 * (ex - sx) - w_low * (0.5 * (ex + hx) - sx) - w_hand * (hx - sx)
    m_free_e = -w_low * 0.5 * (hx - ex) - w_hand * (hx - ex)
    w_arm = w_up + w_low + w_hand
    w_body = p.body_mass_kg * G + w_arm  # the free arm's weight, hung at its shoulder
    a, b = (1, 2) if free == 0 else (0, 2) if free == 1 else (0, 1)
    # G_k: moment about the hand of the holding arm's own link weights
    sax, say, eax, eay, hax, hay = pts[a]
    sbx, sby, ebx, eby, hbx, hby = pts[b]
    ga = -w_up * (0.5 * (sax + eax) - hax) - w_low * 0.5 * (eax - hax)
    gb = -w_up * (0.5 * (sbx + ebx) - hbx) - w_low * 0.5 * (ebx - hbx)
    # F_k: the force arm k exerts on the body at its shoulder. Arm k about its hand (a
    # passive pivot): tau_s = (S - H) x F_k - G_k for its shoulder servo. The body:
    # F_a + F_b = (0, w_body), and its moments, with the shoulder torques substituted,
    # sum_k (C - H_k) x F_k = sum_k G_k + moment of the body's load about C
    m_load = -w_arm * (sx - cx) + m_free
    rhs = ga + gb + m_load - (cx - hbx) * w_body  # cross(u, F_a) after F_b = W - F_a
    ux, uy = hbx - hax, hby - hay
    uu = ux * ux + uy * uy
    fpx, fpy = -uy * rhs / uu, ux * rhs / uu
    # torques affine in t (F_a = F_p + t u): shoulder and elbow of both holding arms
    lines = []  # (a0, b1, limit) with torque = a0 + b1 t
    grips = []
    for (sxk, syk, exk, eyk, hxk, hyk), gk, f0x, f0y, dfx, dfy in (
            (pts[a], ga, fpx, fpy, ux, uy), (pts[b], gb, -fpx, w_body - fpy, -ux, -uy)):
        # the arm receives -F_k from the body at S
        dsx, dsy, dex, dey = sxk - hxk, syk - hyk, exk - hxk, eyk - hyk
        lines.append((dsx * f0y - dsy * f0x - gk, dsx * dfy - dsy * dfx, p.shoulder_torque_ncm))
        # elbow: the lower link about the hand; the upper link passes F_k + its weight to it
        lines.append((w_low * 0.5 * dex + dex * (f0y + w_up) - dey * f0x, dex * dfy - dey * dfx,
                      p.elbow_torque_ncm))
        grips.append((f0x, f0y + w_arm, dfx, dfy))
    return _Statics((a, b), lines, grips, (-m_free, -m_free_e))


def _feasible_split(lines: Sequence[tuple[float, float]], grips: Sequence[tuple[float, float, float, float]],
                    limit: float, hold: float) -> float | None:
    """A split ``t`` with every servo within ``limit`` of its torque (``|a + b t| <= limit``)
    and every gripper within ``hold`` N, or None: intervals intersected in one pass; the
    middle of what is left is returned."""
    lo, hi = -math.inf, math.inf
    for a, b in lines:
        if abs(b) < 1e-12:
            if abs(a) > limit:
                return None
            continue
        t1, t2 = (-limit - a) / b, (limit - a) / b
        if t1 > t2:
            t1, t2 = t2, t1
        lo, hi = max(lo, t1), min(hi, t2)
        if lo > hi:
            return None
    for gx, gy, dx, dy in grips:  # |(gx, gy) + t (dx, dy)| <= hold: a quadratic in t
        qa, qb, qc = dx * dx + dy * dy, gx * dx + gy * dy, gx * gx + gy * gy - hold * hold
        if qa < 1e-12:
            if qc > 0:
                return None
            continue
        disc = qb * qb - qa * qc
        if disc < 0:
            return None
        r = math.sqrt(disc)
        lo, hi = max(lo, (-qb - r) / qa), min(hi, (-qb + r) / qa)
        if lo > hi:
            return None
    if math.isinf(lo) and math.isinf(hi):
        return 0.0
    return hi if math.isinf(lo) else lo if math.isinf(hi) else 0.5 * (lo + hi)


def _minimax_line(lines: Sequence[tuple[float, float]]) -> float:
    """``t`` minimising ``max_j |a_j + b_j t|``: a convex piecewise-linear function of one
    variable, minimised by bisection on its slope (exact to 1e-9 of the breakpoints' span)."""
    brk = [-a / b for a, b in lines if abs(b) > 1e-12]
    if not brk:
        return 0.0
    lo, hi = min(brk) - 1.0, max(brk) + 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        # the slope of the maximum at mid: that of the largest term |a + b mid|, which rises
        # when its b has the sign of a + b mid (the physics' controller runs this at 60 Hz)
        best, rising = -1.0, False
        for a, b in lines:
            v = a + b * mid
            if v >= 0:
                if v > best:
                    best, rising = v, b > 0
            elif -v > best:
                best, rising = -v, b < 0
        if rising:
            hi = mid
        else:
            lo = mid
        if hi - lo < 1e-9 * (1.0 + abs(mid)):
            break
    return 0.5 * (lo + hi)


def rest_pose(model: ClimberModel, holes: HoleMap, stance: Sequence[int], heading: float = 0.0
              ) -> tuple[float, float, float] | str:
    """Where the body rests on ``stance`` between moves: the centre of the smallest circle
    round its three holes (each less its arm's shoulder offset), the pose with the most reach
    to spare. A reason (str) when that pose cannot hold the stance: a hole out of an arm's
    reach, or under the body (within ``body_radius_cm + reach_margin_cm``: three holes in a
    row put the middle one there)."""
    xy, offs, ids = holes.xy_list, model.offsets(heading), holes.id_list
    pts = [(xy[h][0] - offs[k][0], xy[h][1] - offs[k][1]) for k, h in enumerate(stance)]
    cx, cy, r = min_enclosing_circle(pts)
    inner, outer = model.reach
    clear = model.phys.body_radius_cm + model.phys.reach_margin_cm
    for k in range(3):
        d = math.hypot(pts[k][0] - cx, pts[k][1] - cy)
        if d > outer[k] or d < max(inner[k], clear):
            return (f"the robot cannot rest on holes {[ids[h] for h in stance]}: hole {ids[stance[k]]} would lie "
                    f"{d:.1f} cm from the body centre (arm {k + 1} holds {max(inner[k], clear):.1f}.."
                    f"{outer[k]:.1f} cm)")
    return cx, cy, heading


def _shift_clear(model: ClimberModel, a: tuple[float, float, float], b: tuple[float, float, float],
                 pts: Sequence[tuple[float, float]]) -> int | None:
    """Does the straight body shift from pose ``a`` to ``b`` keep every held hole (``pts``,
    each less its shoulder offset) out from under the body and within its arm's reach? The
    first arm (0..2) that fails, or None. (Reach is convex, so only the ends could break it;
    the body's clearance is not, so a shift may pass over a hole that both ends clear.)"""
    inner, outer = model.reach
    clear = model.phys.body_radius_cm + model.phys.reach_margin_cm
    for i in range(1, SHIFT_CHECKS):
        f = i / SHIFT_CHECKS
        x, y = a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
        for k in range(3):
            d = math.hypot(pts[k][0] - x, pts[k][1] - y)
            if d > outer[k] or d < max(inner[k], clear):
                return k
    return None


def plan_move(model: ClimberModel, holes: HoleMap, stance: Sequence[int], arm: int, hole: int,
              heading: float = 0.0, branch: int = 1, rest: tuple[float, float, float] | str | None = None
              ) -> MovePlan | tuple[str, str]:
    """Judge moving ``arm`` (0..2) from its hole to map row ``hole``: a :class:`MovePlan`, or
    ``(outcome, reason)`` with the outcome ``unreachable`` or ``torque_limit`` (or
    ``grip_lost`` when a gripper would have to hold more than it can).

    The move: from the rest pose on ``stance`` (:func:`rest_pose`; ``rest`` passes it in when
    the caller judges many moves from one stance) shift to the centre of the four holes'
    circle, swing, grip, shift to the rest pose on the new stance. Checked: reach and the
    body's clearance at every pose and along both shifts, elbow limits at the ends and along
    the swing, and the statics at the end of the swing and at :data:`SWING_CHECKS` points
    along it."""
    p = model.phys
    ids = holes.id_list
    if hole in stance:
        return "unreachable", f"hole {ids[hole]} is already held"
    xy = holes.xy_list
    offs = model.offsets(heading)
    s0, s1, s2 = stance
    pts = [(xy[s0][0] - offs[0][0], xy[s0][1] - offs[0][1]), (xy[s1][0] - offs[1][0], xy[s1][1] - offs[1][1]),
           (xy[s2][0] - offs[2][0], xy[s2][1] - offs[2][1]), (xy[hole][0] - offs[arm][0], xy[hole][1] - offs[arm][1])]
    inner, outer = model.reach
    span2 = (2 * max(outer)) ** 2
    for i in range(4):  # quick rejection: two holes further apart than two arms can span
        xi, yi = pts[i]
        for j in range(i + 1, 4):
            if (xi - pts[j][0]) ** 2 + (yi - pts[j][1]) ** 2 > span2:
                return "unreachable", (f"holes {ids[stance[i]]} and {ids[hole if j == 3 else stance[j]]} "
                                       f"are too far apart")
    cx, cy, r = min_enclosing_circle(pts)
    clear = p.body_radius_cm + p.reach_margin_cm  # no hole under the body itself
    for k in range(4):
        a = arm if k == 3 else k
        d = math.hypot(pts[k][0] - cx, pts[k][1] - cy)
        if d > outer[a] or d < max(inner[a], clear):
            return "unreachable", (f"no body pose reaches holes {[ids[h] for h in stance]} and {ids[hole]} at once "
                                   f"(they need {r:.1f} cm of reach, the arms have {min(outer):.1f}; a hole under "
                                   f"the body, within {clear:.1f} cm, cannot be held)")
    pose_to = (cx, cy, heading)
    new_stance = [s0, s1, s2]
    new_stance[arm] = hole
    # the gait rests on its three holes between moves: shift rest -> pose_to on the old
    # holes, swing, then pose_to -> the new rest on the new holes
    pose_from = rest_pose(model, holes, stance, heading) if rest is None else rest
    pose_end = rest_pose(model, holes, new_stance, heading)
    if isinstance(pose_from, str) or isinstance(pose_end, str):
        return "unreachable", pose_end if isinstance(pose_end, str) else pose_from
    new_pts = list(pts[:3])
    new_pts[arm] = pts[3]
    for a, b, held, st in ((pose_from, pose_to, pts[:3], stance), (pose_to, pose_end, new_pts, new_stance)):
        bad = _shift_clear(model, a, b, held)
        if bad is not None:
            return "unreachable", (f"the body would pass over hole {ids[st[bad]]} (or out of arm {bad + 1}'s reach) "
                                   f"while it shifts")
    q = []
    lo, hi = model.geom.elbow_limits
    c, s = math.cos(heading), math.sin(heading)
    links = model._links  # type: ignore[attr-defined]
    for k in range(3):
        hx, hy = xy[new_stance[k]]
        bx, by = hx - cx - offs[k][0], hy - cy - offs[k][1]  # wall-frame vector shoulder -> hand
        sk, ek = arm_ik_one(links[k][0], links[k][1], c * bx + s * by, -s * bx + c * by, branch)
        if not lo <= ek <= hi:
            return "unreachable", (f"arm {k + 1} would need an elbow of {math.degrees(ek):.0f} deg (limits "
                                   f"{math.degrees(lo):.0f}..{math.degrees(hi):.0f})")
        q.append((sk, ek))
    # the statics along the whole swing: the free hand sweeps round its shoulder from the old
    # hole to the new one (:func:`_around`, the path physics drives), its weight's moment on
    # the body changing as it goes; the end (f = 1) is the hand at its new hole
    hands = [xy[h] for h in new_stance]
    ax, ay = offs[arm]
    shoulder = (cx + ax, cy + ay)
    old = xy[stance[arm]]
    # a half turn is as short either way round: the side with the lighter statics is taken
    turns = (1.0, -1.0) if abs(_turn_angle(shoulder, old, hands[arm])) > HALF_TURN else (0.0,)
    best: tuple[float, float, float] | None = None
    failed: tuple[str, str] | None = None
    for turn in turns:
        got = _swing_statics(model, pose_to, hands, q, arm, shoulder, old, turn, branch)
        if isinstance(got[0], str):
            failed = failed or got  # type: ignore[assignment]
        elif best is None or got[0] < best[1]:
            best = (turn, got[0], got[1])  # type: ignore[assignment]
    if best is None:
        return failed  # type: ignore[return-value]
    turn, worst, grip = best
    q_end = rest_joints(model, holes, new_stance, pose_end, branch)
    return MovePlan(arm, hole, pose_from, pose_to, np.array(q), worst, grip, pose_end, q_end, turn)


def rest_joints(model: ClimberModel, holes: HoleMap, stance: Sequence[int], pose: tuple[float, float, float],
                branch: int = 1) -> np.ndarray:
    """The joint angles ``(3, 2)`` (rad) that hold ``stance`` with the body at ``pose`` (a
    move's end: ``pose`` its :func:`rest_pose`)."""
    xy, offs, links = holes.xy_list, model.offsets(pose[2]), model._links  # type: ignore[attr-defined]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    q = []
    for k in range(3):
        hx, hy = xy[stance[k]]
        bx, by = hx - pose[0] - offs[k][0], hy - pose[1] - offs[k][1]
        q.append(arm_ik_one(links[k][0], links[k][1], c * bx + s * by, -s * bx + c * by, branch))
    return np.array(q)


def _swing_statics(model: ClimberModel, pose_to: tuple[float, float, float], hands: list[tuple[float, float]],
                   q: list[tuple[float, float]], arm: int, shoulder: tuple[float, float], old: tuple[float, float],
                   turn: float, branch: int) -> tuple[float, float] | tuple[str, str]:
    """The statics along a whole swing of ``arm`` (``turn`` as :func:`_around` takes it):
    ``(worst torque ratio, largest grip force)``, or ``(outcome, reason)`` against it. The
    free hand sweeps round its shoulder from the old hole to the new one (the path physics
    drives), its weight's moment on the body changing as it goes; the end is the hand at
    its new hole."""
    p, links, heading = model.phys, model._links, pose_to[2]  # type: ignore[attr-defined]
    lo, hi = model.geom.elbow_limits
    c, s = math.cos(heading), math.sin(heading)
    worst, grip = 0.0, 0.0
    for i in (SWING_CHECKS, *range(SWING_CHECKS)):  # the end first: it rejects most
        f = i / SWING_CHECKS
        hand = hands[arm] if i == SWING_CHECKS else _around(shoulder, old, hands[arm], f, turn)
        hs, qs = list(hands), list(q)
        if i < SWING_CHECKS:
            bx, by = hand[0] - shoulder[0], hand[1] - shoulder[1]
            sk, ek = arm_ik_one(links[arm][0], links[arm][1], c * bx + s * by, -s * bx + c * by, branch)
            if not lo <= ek <= hi:
                return "unreachable", (f"arm {arm + 1} would need an elbow of {math.degrees(ek):.0f} deg on its "
                                       f"swing (limits {math.degrees(lo):.0f}..{math.degrees(hi):.0f})")
            hs[arm], qs[arm] = hand, (sk, ek)
        ratio, g = swing_loads(model, pose_to, hs, qs, arm, p.torque_safety)
        if ratio > p.torque_safety:
            where = "at its new hole" if i == SWING_CHECKS else f"{f:.0%} of the way along its swing"
            # which limit bites? without the grippers' limit, is there a split?
            if swing_loads(model, pose_to, hs, qs, arm, p.torque_safety, hold=math.inf)[0] > p.torque_safety:
                return "torque_limit", (f"no split of the body's weight between the two holding arms keeps every "
                                        f"servo within {p.torque_safety:.0%} of its torque with arm {arm + 1} "
                                        f"{where}")
            return "grip_lost", (f"a gripper would have to hold more than {p.holding_force_n:g} N with arm "
                                 f"{arm + 1} {where}")
        worst, grip = max(worst, ratio), max(grip, g)
    return worst, grip


def _turn_angle(centre: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """The shorter signed angle (rad) from ``a`` to ``b`` round ``centre``."""
    ta = math.atan2(a[1] - centre[1], a[0] - centre[0])
    return math.remainder(math.atan2(b[1] - centre[1], b[0] - centre[0]) - ta, 2 * math.pi)


def _around(centre: tuple[float, float], a: tuple[float, float], b: tuple[float, float], f: float,
            turn: float = 0.0) -> tuple[float, float]:
    """The point a share ``f`` of the way from ``a`` to ``b`` on the path that sweeps round
    ``centre`` (angle and radius interpolated), the shorter way round. A half turn (``a`` and
    ``b`` opposite about ``centre``: common, as the four holes' circle often has the moving
    hand's old and new holes as its diameter, and the shoulder then lies half-way between
    them) is as short either way: ``turn`` = +1 sweeps such a turn counter-clockwise, -1 clockwise
    (:func:`plan_move` takes the side with the lighter statics, and physics follows the
    plan; before, rounding noise chose the side)."""
    ax, ay, bx, by = a[0] - centre[0], a[1] - centre[1], b[0] - centre[0], b[1] - centre[1]
    ra, rb = math.hypot(ax, ay), math.hypot(bx, by)
    ta = math.atan2(ay, ax)
    dt = _turn_angle(centre, a, b)
    if turn and abs(dt) > HALF_TURN:
        dt = math.copysign(math.pi, turn)
    r, t = ra + f * (rb - ra), ta + f * dt
    return centre[0] + r * math.cos(t), centre[1] + r * math.sin(t)


def _path_length(centre: tuple[float, float], a: tuple[float, float], b: tuple[float, float],
                 turn: float = 0.0) -> float:
    pts = [_around(centre, a, b, i / 16, turn) for i in range(17)]
    return sum(math.hypot(pts[i + 1][0] - pts[i][0], pts[i + 1][1] - pts[i][1]) for i in range(16))
