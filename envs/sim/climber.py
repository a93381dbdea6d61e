"""The three-armed climber on a wall of holes: a gait model judged analytically and the same
robot in pymunk physics, behind one interface.

Seed 000 stopped at statics and named "equations for movements" as the next step; this
module moves the robot with the gait the seed sketches - move the centre, then one arm:

1. **shift** - with all three hands gripping, the body moves in a straight line to a new
   pose (inverse kinematics of all three arms along the way);
2. **release** the moving arm's gripper;
3. **swing** its hand in a straight line to the new hole (the other two arms hold the body);
4. **grip** when the hand is within the capture radius of the hole.

The new pose is the centre of the smallest circle around the four holes involved (the
three held now and the new one, each shifted by its arm's shoulder offset): of all poses
it keeps the largest margin to every arm's reach, and since the set of poses that reach
all three current holes is convex, the straight shift stays inside it. A move is possible
only if that circle fits within the arms' reach - which is why the seed's robot (10 cm
links, 20 cm of reach) cannot climb the seed's own wall (holes 20 cm apart) with this
gait: it can only shuffle inside its first 2 x 2 block of holes (see the README).

Two implementations share :class:`ClimberSim`'s interface (``reset``, ``move``,
``encoders``, ``pose``, ``stance``, ``q``):

* :class:`KinematicClimber` judges a move analytically - reach and elbow limits along the
  shift and the swing, the static torques at the four holding servos while one arm swings
  (the 1-parameter family of force splits between the two holding arms is searched for one
  within every servo's limit), the free arm's own gravity torque, and the holding force of
  each gripper. Microseconds per move: for planning and training.
* :class:`PhysicsClimber` (pymunk) is the reference: body, six links and three hands with
  masses and inertias, servos as velocity motors under a position loop with torque limits
  (``max_force``), grippers as pivot joints that let go above their holding force, gravity
  along -y. A servo asked for more than it has sags; a hand that sags misses its hole.

Outcomes (:data:`OUTCOMES`): ``ok``, ``unreachable``, ``torque_limit``, ``missed_hole``,
``grip_lost``, ``fell`` (fewer than two grips). A failed move leaves the robot on its
previous holes where it can (the swinging hand goes back to its hole); only a fall ends a
climb. Encoders read the joint angles with Gaussian noise (``sensor_sigma_deg``, what the
localiser assumes too) and quantisation from the robot's YAML; the robot never sees its
true pose.

Units: cm, kg, s, radians in the API; forces in N and torques in N cm in the config.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import kinegym.configs as _configs
from kinegym.kinematics.climber import CLIMBER_SCHEMA, ClimberGeometry
from kinegym.kinematics.holes import HoleMap

__all__ = [
    "OUTCOMES",
    "ClimberPhysics",
    "ClimberModel",
    "MovePlan",
    "GaitResult",
    "ClimberSim",
    "KinematicClimber",
    "PhysicsClimber",
    "plan_move",
    "min_enclosing_circle",
    "candidate_holes",
    "start_stances",
    "hop_counts",
    "stance_hops",
]

#: Move outcomes, in the order the observation encodes them.
OUTCOMES = ("ok", "unreachable", "torque_limit", "missed_hole", "grip_lost", "fell")
G = 9.81  # m/s^2: weights in N from masses in kg
_G_CM = 981.0  # cm/s^2 for pymunk (cm, kg, s)


@dataclass(frozen=True)
class ClimberPhysics:
    """Masses, servos, grippers and encoders of the climber (``physics:`` in its YAML)."""

    body_mass_kg: float = 0.6
    upper_link_mass_kg: float = 0.08
    lower_link_mass_kg: float = 0.06
    hand_mass_kg: float = 0.06
    body_radius_cm: float = 5.0
    shoulder_torque_ncm: float = 200.0
    elbow_torque_ncm: float = 200.0
    servo_gain_per_s: float = 12.0
    servo_stiffness_ncm_per_deg: float = 40.0
    servo_speed_dps: float = 90.0
    capture_radius_cm: float = 0.8
    holding_force_n: float = 40.0
    reach_margin_cm: float = 0.5
    torque_safety: float = 0.85
    stall_s: float = 0.5
    shift_speed_cm_s: float = 4.0
    swing_speed_cm_s: float = 8.0
    encoder_step_deg: float = 0.05
    physics_hz: float = 240.0


@dataclass(frozen=True)
class ClimberModel:
    """Geometry (:class:`ClimberGeometry`) and physics (:class:`ClimberPhysics`) of one robot."""

    geom: ClimberGeometry = field(default_factory=ClimberGeometry)
    phys: ClimberPhysics = field(default_factory=ClimberPhysics)

    @classmethod
    def from_config(cls, name_or_path: str | Path = "climber") -> ClimberModel:
        """``configs/robots/<name>.yaml``: geometry as for the kinematics, masses and servos
        from its ``physics:`` section (defaults where absent)."""
        cfg = _configs.load("robots", name_or_path, CLIMBER_SCHEMA)
        phys = ClimberPhysics(**(cfg.get("physics") or {}))
        return cls(ClimberGeometry.from_config(name_or_path), phys)

    def __post_init__(self) -> None:
        g, m = self.geom, self.phys.reach_margin_cm
        object.__setattr__(self, "_reach", ([float(abs(g.l1[i] - g.l2[i])) + m for i in range(3)],
                                            [float(g.l1[i] + g.l2[i]) - m for i in range(3)]))
        object.__setattr__(self, "_links", [(float(g.l1[i]), float(g.l2[i])) for i in range(3)])
        object.__setattr__(self, "_offsets", [(float(g.shoulders[i, 0]), float(g.shoulders[i, 1])) for i in range(3)])

    @property
    def reach(self) -> tuple[list[float], list[float]]:
        """Per arm: inner and outer reach (cm) less the safety margin."""
        return self._reach  # type: ignore[attr-defined]

    def offsets(self, heading: float) -> list[tuple[float, float]]:
        """Shoulder offsets in the wall frame for a body ``heading`` (cm)."""
        if heading == 0.0:
            return self._offsets  # type: ignore[attr-defined]
        c, s = math.cos(heading), math.sin(heading)
        return [(c * ox - s * oy, s * ox + c * oy) for ox, oy in self._offsets]  # type: ignore[attr-defined]


# ------------------------------------------------------------------ geometry (scalar, fast)
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


def _ik(l1: float, l2: float, dx: float, dy: float, branch: int) -> tuple[float, float]:
    """Two-link IK in the body frame (shoulder at the origin): ``(s, e)`` (seed convention)."""
    d = math.hypot(dx, dy)
    ce = max(-1.0, min(1.0, (l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2)))
    e = math.acos(ce)
    ca = max(-1.0, min(1.0, (l1 * l1 + d * d - l2 * l2) / (2 * l1 * max(d, 1e-12))))
    s = math.atan2(dy, dx) - branch * math.acos(ca)
    if branch < 0:
        e = 2 * math.pi - e
    return math.remainder(s, 2 * math.pi), e


@dataclass
class MovePlan:
    """A feasible move: arm, new hole (map row), poses before and after the shift, the six
    joint angles after the move (rad), and the static load figures that were checked."""

    arm: int
    hole: int
    pose_from: tuple[float, float, float]
    pose_to: tuple[float, float, float]
    q_to: np.ndarray
    torque_ratio: float  # worst servo torque over its limit during the swing (best split)
    grip_force_n: float  # largest holding force during the swing


@dataclass
class GaitResult:
    """What one move did: ``outcome`` (one of :data:`OUTCOMES`), a human ``reason``, the
    stance and true pose after it, the physics steps and simulated seconds it took."""

    outcome: str
    reason: str
    stance: tuple[int, int, int]
    pose: np.ndarray
    steps: int = 0
    seconds: float = 0.0
    plan: MovePlan | None = None

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
    # the free arm hangs from its shoulder: its weight and moment act on the body
    sx, sy, ex, ey, hx, hy = pts[free]
    m_free = -w_up * 0.5 * (ex - sx) - w_low * (0.5 * (ex + hx) - sx) - w_hand * (hx - sx)
    t_free_s = abs(m_free) / p.shoulder_torque_ncm
    t_free_e = abs(-w_low * 0.5 * (hx - ex) - w_hand * (hx - ex)) / p.elbow_torque_ncm
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
    norm = [(a0 / lim, b1 / lim) for a0, b1, lim in lines]
    if safety is None:
        t_best = _minimax_line(norm)
    else:
        t_best = _feasible_split(norm, grips, safety, p.holding_force_n if hold is None else hold)
        if t_best is None:
            return math.inf, math.inf
    ratio = max(abs(a0 + b1 * t_best) for a0, b1 in norm)
    grip = max(math.hypot(gx + dx * t_best, gy + dy * t_best) for gx, gy, dx, dy in grips)
    return max(ratio, t_free_s, t_free_e), grip


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
        # the slope of the maximum at mid: that of the largest term
        best, slope = -1.0, 0.0
        for a, b in lines:
            v = a + b * mid
            if abs(v) > best:
                best, slope = abs(v), b if v >= 0 else -b
        if slope > 0:
            hi = mid
        else:
            lo = mid
        if hi - lo < 1e-9 * (1.0 + abs(mid)):
            break
    return 0.5 * (lo + hi)


def plan_move(model: ClimberModel, holes: HoleMap, stance: Sequence[int], arm: int, hole: int,
              heading: float = 0.0, branch: int = 1) -> MovePlan | tuple[str, str]:
    """Judge moving ``arm`` (0..2) from its hole to map row ``hole``: a :class:`MovePlan`, or
    ``(outcome, reason)`` with the outcome ``unreachable`` or ``torque_limit`` (or
    ``grip_lost`` when a gripper would have to hold more than it can)."""
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
    q = []
    lo, hi = model.geom.elbow_limits
    c, s = math.cos(heading), math.sin(heading)
    links = model._links  # type: ignore[attr-defined]
    for k in range(3):
        hx, hy = xy[new_stance[k]]
        bx, by = hx - cx - offs[k][0], hy - cy - offs[k][1]  # wall-frame vector shoulder -> hand
        sk, ek = _ik(links[k][0], links[k][1], c * bx + s * by, -s * bx + c * by, branch)
        if not lo <= ek <= hi:
            return "unreachable", (f"arm {k + 1} would need an elbow of {math.degrees(ek):.0f} deg (limits "
                                   f"{math.degrees(lo):.0f}..{math.degrees(hi):.0f})")
        q.append((sk, ek))
    hands = [xy[h] for h in new_stance]
    ratio, grip = swing_loads(model, pose_to, hands, q, arm, p.torque_safety)
    if ratio > p.torque_safety:
        # which limit bites? without the grippers' limit, is there a split?
        if swing_loads(model, pose_to, hands, q, arm, p.torque_safety, hold=math.inf)[0] > p.torque_safety:
            return "torque_limit", (f"no split of the body's weight between the two holding arms keeps every "
                                    f"servo within {p.torque_safety:.0%} of its torque while arm {arm + 1} swings")
        return "grip_lost", f"a gripper would have to hold more than {p.holding_force_n:g} N while arm {arm + 1} swings"
    return MovePlan(arm, hole, (0.0, 0.0, heading), pose_to, np.array(q), ratio, grip)


def _around(centre: tuple[float, float], a: tuple[float, float], b: tuple[float, float], f: float
            ) -> tuple[float, float]:
    """The point a share ``f`` of the way from ``a`` to ``b`` on the path that sweeps round
    ``centre`` (angle and radius interpolated): a swinging hand never passes over the body."""
    ax, ay, bx, by = a[0] - centre[0], a[1] - centre[1], b[0] - centre[0], b[1] - centre[1]
    ra, rb = math.hypot(ax, ay), math.hypot(bx, by)
    ta = math.atan2(ay, ax)
    dt = math.remainder(math.atan2(by, bx) - ta, 2 * math.pi)
    r, t = ra + f * (rb - ra), ta + f * dt
    return centre[0] + r * math.cos(t), centre[1] + r * math.sin(t)


def _path_length(centre: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    pts = [_around(centre, a, b, i / 16) for i in range(17)]
    return sum(math.hypot(pts[i + 1][0] - pts[i][0], pts[i + 1][1] - pts[i][1]) for i in range(16))


# ------------------------------------------------------------------ the interface
class ClimberSim:
    """What both climbers offer. ``stance`` holds the map row held by each arm; ``pose`` is
    the true body pose ``(x, y, heading)``; ``q`` the true joint angles ``(3, 2)``."""

    model: ClimberModel
    holes: HoleMap
    stance: tuple[int, int, int]
    pose: np.ndarray
    q: np.ndarray

    def reset(self, holes: HoleMap, stance: Sequence[int], heading: float = 0.0) -> None:
        raise NotImplementedError

    def move(self, arm: int, hole: int) -> GaitResult:
        raise NotImplementedError

    def encoders(self, rng: np.random.Generator) -> np.ndarray:
        """The six joint angles as the encoders read them (rad): noise and quantisation."""
        p = self.model.phys
        q = self.q.copy()
        if self.model.geom.sensor_sigma > 0:
            q = q + rng.normal(0.0, self.model.geom.sensor_sigma, (3, 2))
        if p.encoder_step_deg:
            step = math.radians(p.encoder_step_deg)
            q = np.round(q / step) * step
        return q

    def _start_pose(self, holes: HoleMap, stance: Sequence[int], heading: float) -> tuple[float, float, float]:
        g = self.model.geom
        c, s = math.cos(heading), math.sin(heading)
        pts = [(float(holes.xy[stance[k], 0]) - (c * g.shoulders[k, 0] - s * g.shoulders[k, 1]),
                float(holes.xy[stance[k], 1]) - (s * g.shoulders[k, 0] + c * g.shoulders[k, 1])) for k in range(3)]
        cx, cy, r = min_enclosing_circle(pts)
        if r > min(self.model.reach[1]):
            ids = [tuple(holes.ids[h]) for h in stance]
            raise ValueError(f"stance {ids} needs {r:.1f} cm of reach; the arms have {min(self.model.reach[1]):.1f}")
        return cx, cy, heading

    def _ik_all(self, pose: Sequence[float], hands: Sequence[tuple[float, float]]) -> np.ndarray:
        g = self.model.geom
        cx, cy, th = pose
        c, s = math.cos(th), math.sin(th)
        out = []
        for k in range(3):
            ox, oy = c * g.shoulders[k, 0] - s * g.shoulders[k, 1], s * g.shoulders[k, 0] + c * g.shoulders[k, 1]
            bx, by = hands[k][0] - cx - ox, hands[k][1] - cy - oy
            out.append(_ik(float(g.l1[k]), float(g.l2[k]), c * bx + s * by, -s * bx + c * by, 1))
        return np.array(out)


class KinematicClimber(ClimberSim):
    """The gait judged analytically (see :func:`plan_move`); moves are instantaneous."""

    def __init__(self, model: ClimberModel | None = None) -> None:
        self.model = model or ClimberModel.from_config()
        self._cache: dict[tuple[tuple[int, int, int], int, int], MovePlan | tuple[str, str]] = {}

    def reset(self, holes: HoleMap, stance: Sequence[int], heading: float = 0.0) -> None:
        if getattr(self, "holes", None) is not holes:
            self._cache = {}
        self.holes = holes
        self.stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        self.pose = np.array(self._start_pose(holes, self.stance, heading))
        self.q = self._ik_all(self.pose, [tuple(holes.xy[h]) for h in self.stance])

    def judge(self, arm: int, hole: int) -> MovePlan | tuple[str, str]:
        """The plan (or the reason against it) for moving ``arm`` to ``hole`` from the
        current stance; cached per wall."""
        key = (self.stance, arm, hole)
        got = self._cache.get(key)
        if got is None:
            got = plan_move(self.model, self.holes, self.stance, arm, hole, float(self.pose[2]))
            self._cache[key] = got
        return got

    def move(self, arm: int, hole: int) -> GaitResult:
        plan = self.judge(arm, hole)
        if not isinstance(plan, MovePlan):
            return GaitResult(plan[0], plan[1], self.stance, self.pose.copy())
        st = list(self.stance)
        st[arm] = hole
        self.stance = (st[0], st[1], st[2])
        self.pose = np.array(plan.pose_to)
        self.q = plan.q_to.copy()
        return GaitResult("ok", "moved", self.stance, self.pose.copy(), plan=plan)


# ------------------------------------------------------------------ physics (pymunk)
class PhysicsClimber(ClimberSim):
    """The climber in pymunk: the reference for :class:`KinematicClimber`.

    Bodies: the body (a disc), three upper and three lower links (rods; the hand's mass
    sits at the lower link's tip). Pivot joints at shoulders and elbows, each with a
    :class:`pymunk.SimpleMotor` whose rate comes from a position loop (gain
    ``servo_gain_per_s``, speed limit ``servo_speed_dps``) and whose ``max_force`` is the
    servo's torque limit. A gripping hand is a pivot joint to the wall; it lets go when the
    force through it exceeds ``holding_force_n``. No collisions: the links move in parallel
    planes in front of the wall. Bit-identical from the same reset and moves.
    """

    def __init__(self, model: ClimberModel | None = None) -> None:
        self.model = model or ClimberModel.from_config()
        self.dt = 1.0 / self.model.phys.physics_hz
        self.total_steps = 0

    # -- construction ------------------------------------------------------------------
    def reset(self, holes: HoleMap, stance: Sequence[int], heading: float = 0.0) -> None:
        import pymunk

        self.holes = holes
        self.stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        g, p = self.model.geom, self.model.phys
        pose = self._start_pose(holes, self.stance, heading)
        hands = [tuple(holes.xy[h]) for h in self.stance]
        q = self._ik_all(pose, hands)
        space = pymunk.Space()
        space.gravity = (0.0, -_G_CM)
        space.iterations = 30
        self.space = space
        r = p.body_radius_cm
        body = pymunk.Body(p.body_mass_kg, 0.5 * p.body_mass_kg * r * r)
        body.position, body.angle = (pose[0], pose[1]), pose[2]
        space.add(body)
        self.body = body
        self.upper, self.lower, self.motors, self.grips = [], [], [], [None, None, None]
        cx, cy, th = pose
        c, s = math.cos(th), math.sin(th)
        for k in range(3):
            l1, l2 = float(g.l1[k]), float(g.l2[k])
            sx = cx + c * g.shoulders[k, 0] - s * g.shoulders[k, 1]
            sy = cy + s * g.shoulders[k, 0] + c * g.shoulders[k, 1]
            a1 = th + q[k, 0]
            a2 = a1 - q[k, 1] + math.pi
            ex, ey = sx + l1 * math.cos(a1), sy + l1 * math.sin(a1)
            mu, ml, mh = p.upper_link_mass_kg, p.lower_link_mass_kg, p.hand_mass_kg
            up = pymunk.Body(mu, mu * l1 * l1 / 12.0)
            up.position, up.angle = (sx + 0.5 * l1 * math.cos(a1), sy + 0.5 * l1 * math.sin(a1)), a1
            # lower link + hand: centre of mass moves toward the tip
            m_lo = ml + mh
            xc = (ml * 0.5 * l2 + mh * l2) / m_lo
            inertia = ml * l2 * l2 / 12.0 + ml * (0.5 * l2 - xc) ** 2 + mh * (l2 - xc) ** 2
            lo = pymunk.Body(m_lo, max(inertia, 1e-6))
            lo.position, lo.angle = (ex + xc * math.cos(a2), ey + xc * math.sin(a2)), a2
            space.add(up, lo)
            up.l, lo.l, lo.xc = l1, l2, xc
            j_s = pymunk.PivotJoint(body, up, (sx, sy))
            j_e = pymunk.PivotJoint(up, lo, (ex, ey))
            m_s = pymunk.SimpleMotor(body, up, 0.0)
            m_e = pymunk.SimpleMotor(up, lo, 0.0)
            m_s.max_force = p.shoulder_torque_ncm * 100.0  # N cm -> kg cm^2 / s^2
            m_e.max_force = p.elbow_torque_ncm * 100.0
            for j in (j_s, j_e):
                j.collide_bodies = False
            space.add(j_s, j_e, m_s, m_e)
            self.upper.append(up)
            self.lower.append(lo)
            self.motors.append((m_s, m_e))
            self._grip(k, self.stance[k])
        self.targets = q.copy()
        self._prev_targets: np.ndarray | None = None
        self.total_steps = 0
        # settle on the start holes
        self._run(int(0.5 / self.dt), lambda t: None)

    def _tip(self, k: int) -> tuple[float, float]:
        lo = self.lower[k]
        d = lo.l - lo.xc
        return (lo.position.x + d * math.cos(lo.angle), lo.position.y + d * math.sin(lo.angle))

    def _grip(self, k: int, hole: int) -> None:
        import pymunk

        lo = self.lower[k]
        j = pymunk.PivotJoint(lo, self.space.static_body, (lo.l - lo.xc, 0.0), tuple(self.holes.xy[hole]))
        j.collide_bodies = False
        self.space.add(j)
        self.grips[k] = j

    def _release(self, k: int) -> None:
        j = self.grips[k]
        if j is not None:
            self.space.remove(j)
            self.grips[k] = None

    # -- state ----------------------------------------------------------------------------
    @property
    def pose(self) -> np.ndarray:  # type: ignore[override]
        b = self.body
        return np.array([b.position.x, b.position.y, math.remainder(b.angle, 2 * math.pi)])

    @property
    def q(self) -> np.ndarray:  # type: ignore[override]
        b = self.body
        out = np.empty((3, 2))
        for k in range(3):
            a1, a2 = self.upper[k].angle, self.lower[k].angle
            out[k, 0] = math.remainder(a1 - b.angle, 2 * math.pi)
            out[k, 1] = math.remainder(math.pi - (a2 - a1), 2 * math.pi) % (2 * math.pi)
        return out

    # -- control loop -------------------------------------------------------------------------
    def _control(self) -> None:
        p = self.model.phys
        kp, vmax = p.servo_gain_per_s, math.radians(p.servo_speed_dps)
        ks = p.servo_stiffness_ncm_per_deg * 100.0 * 180.0 / math.pi  # kg cm^2 / s^2 per rad
        ts_max, te_max = p.shoulder_torque_ncm * 100.0, p.elbow_torque_ncm * 100.0
        floor_s, floor_e = 0.15 * ts_max, 0.15 * te_max
        b = self.body
        prev = self._prev_targets if self._prev_targets is not None else self.targets
        inv_dt = 1.0 / self.dt
        for k in range(3):
            up, lo = self.upper[k], self.lower[k]
            m_s, m_e = self.motors[k]
            s_now = up.angle - b.angle
            rel_now = lo.angle - up.angle  # = pi - elbow
            s_t, e_t = self.targets[k]
            err_s = math.remainder(s_t - s_now, 2 * math.pi)
            err_e = math.remainder((math.pi - e_t) - rel_now, 2 * math.pi)
            # velocity feed-forward (the targets' own rate, consistent round the closed chain)
            # plus the position loop; SimpleMotor keeps a.w - b.w = rate
            ff_s = math.remainder(s_t - prev[k][0], 2 * math.pi) * inv_dt
            ff_e = -math.remainder(e_t - prev[k][1], 2 * math.pi) * inv_dt
            m_s.rate = -max(-vmax, min(vmax, ff_s + kp * err_s))
            m_e.rate = -max(-vmax, min(vmax, ff_e + kp * err_e))
            # the torque a servo may use grows with its position error, up to its limit: a
            # stiff but compliant servo. (Rigid velocity motors fight one another in the
            # closed chain that three gripping arms make: their internal torques drift to
            # the limit within a second even at rest.)
            m_s.max_force = min(ts_max, ks * abs(err_s) + floor_s)
            m_e.max_force = min(te_max, ks * abs(err_e) + floor_e)
        self._prev_targets = self.targets

    def _run(self, steps: int, schedule: object, stall: bool = True) -> str | None:
        """Step ``steps`` times; ``schedule(t)`` updates the targets first. Returns
        ``"grip_lost"`` / ``"fell"`` if a gripper let go (and how many are left),
        ``"torque_limit"`` if a servo stayed at its torque limit for ``stall_s`` (a stalled
        servo: the move is stopped, as a servo's current limit would), else None."""
        p = self.model.phys
        hold = p.holding_force_n * 100.0
        dt = self.dt
        stall_steps = int(p.stall_s / dt)
        limits = [(p.shoulder_torque_ncm * 100.0 * dt * 0.995, p.elbow_torque_ncm * 100.0 * dt * 0.995)] * 3
        stalled = [0] * 6
        for i in range(steps):
            schedule(i * dt)  # type: ignore[operator]
            self._control()
            self.space.step(dt)
            self.total_steps += 1
            for k in range(3):
                j = self.grips[k]
                if j is not None and j.impulse / dt > hold:
                    self._release(k)
                    return "fell" if sum(g is not None for g in self.grips) < 2 else "grip_lost"
            if stall:
                for k in range(3):
                    for n in range(2):
                        if abs(self.motors[k][n].impulse) >= limits[k][n]:
                            stalled[2 * k + n] += 1
                            if stalled[2 * k + n] >= stall_steps:
                                return "torque_limit"
                        else:
                            stalled[2 * k + n] = 0
        return None

    def _hold(self) -> int:
        return sum(g is not None for g in self.grips)

    def move(self, arm: int, hole: int) -> GaitResult:
        p = self.model.phys
        steps0 = self.total_steps
        plan = plan_move(self.model, self.holes, self.stance, arm, hole, float(self.pose[2]))

        def result(outcome: str, reason: str) -> GaitResult:
            n = self.total_steps - steps0
            return GaitResult(outcome, reason, self.stance, self.pose, n, n * self.dt,
                              plan if isinstance(plan, MovePlan) else None)

        if not isinstance(plan, MovePlan) and plan[0] == "unreachable":
            return result(*plan)  # no body pose exists: the robot does not try
        if self._hold() < 3:
            return result("fell", "the robot holds fewer than three holes")
        # the pose to shift to: the plan's, or (the planner expects the servos to fail)
        # the same minimal-circle pose, tried anyway - physics decides
        if isinstance(plan, MovePlan):
            target_pose, q_to = plan.pose_to, plan.q_to
        else:
            xy = self.holes.xy
            st = list(self.stance)
            pts = [tuple(xy[h]) for h in st] + [tuple(xy[hole])]
            cx, cy, _ = min_enclosing_circle(pts)
            target_pose = (cx, cy, float(self.pose[2]))
            st[arm] = hole
            q_to = self._ik_all(target_pose, [tuple(xy[h]) for h in st])
        start = self.pose
        held = [tuple(self.holes.xy[h]) for h in self.stance]
        # 1. shift the body with all three hands gripping
        dist = math.hypot(target_pose[0] - start[0], target_pose[1] - start[1])
        t_shift = max(0.2, dist / p.shift_speed_cm_s)
        n_shift = int(t_shift / self.dt)

        def shift(t: float) -> None:
            f = min(1.0, t / t_shift)
            f = f * f * (3 - 2 * f)  # smooth start and stop
            pose = (start[0] + f * (target_pose[0] - start[0]), start[1] + f * (target_pose[1] - start[1]),
                    start[2] + f * math.remainder(target_pose[2] - start[2], 2 * math.pi))
            self.targets = self._ik_all(pose, held)

        lost = self._run(n_shift + int(0.3 / self.dt), shift)
        if lost in ("torque_limit", None) and (lost or self._sagging(0.3)):
            # a servo stalled, or the servos cannot hold the shifted pose: go back
            back = self._run(n_shift + int(0.3 / self.dt), lambda t: setattr(
                self, "targets", self._ik_all(start, held)), stall=False)
            if back:
                return result(back, "a gripper let go while the body shifted back")
            return result("torque_limit", "a servo stalled while the body shifted; it shifted back")
        if lost:
            return result(lost, "a gripper let go while the body shifted")
        # 2. release, 3. swing along a straight line in the wall frame, 4. grip
        old = held[arm]
        new = tuple(self.holes.xy[hole])
        self._release(arm)
        seg = _path_length(self._shoulder(target_pose, arm), old, new)
        t_swing = max(0.2, seg / p.swing_speed_cm_s)
        n_swing = int(t_swing / self.dt)
        body_pose = target_pose

        shoulder = self._shoulder(body_pose, arm)

        def swing(t: float, a: tuple[float, float] = old, b: tuple[float, float] = new) -> None:
            f = min(1.0, t / t_swing)
            f = f * f * (3 - 2 * f)
            hs = list(held)
            hs[arm] = _around(shoulder, a, b, f)
            targets = self._ik_all(body_pose, hs)
            # the swinging arm aims from where the body really is (the robot knows it from
            # the holding arms' encoders): a sagging body does not throw the hand off
            targets[arm] = self._ik_all(self.pose, hs)[arm]
            self.targets = targets

        lost = self._run(n_swing, swing)
        if lost == "torque_limit":  # a servo stalled: the hand goes back to its hole
            return self._swing_back(arm, swing, n_swing, old, result, "torque_limit",
                                    f"a servo stalled while arm {arm + 1} swung; the hand went back to its hole")
        if lost:
            return result(lost, f"a gripper let go while arm {arm + 1} swung")
        captured = self._wait_capture(arm, new, 0.6)
        if lost := (captured if isinstance(captured, str) else None):
            return result(lost, f"a gripper let go while arm {arm + 1} reached for its hole")
        if captured is True:
            self._grip(arm, hole)
            st = list(self.stance)
            st[arm] = hole
            self.stance = (st[0], st[1], st[2])
            self.targets = q_to.copy() if isinstance(plan, MovePlan) else self.targets
            lost = self._run(int(0.3 / self.dt), lambda t: None)
            if lost:
                return result(lost, "a gripper let go after the grip")
            return result("ok", "moved")
        # missed: swing back to the old hole and grip it again
        return self._swing_back(arm, swing, n_swing, new, result, "missed_hole",
                                f"arm {arm + 1} did not reach hole {tuple(self.holes.ids[hole])} (the servos "
                                f"sagged); it went back to its hole")

    def _swing_back(self, arm: int, swing: object, n_swing: int, frm: tuple[float, float], result: object,
                    outcome: str, reason: str) -> GaitResult:
        """Bring the swinging hand back to its old hole and grip it: ``outcome`` if that
        works, a fall if it does not."""
        old = tuple(self.holes.xy[self.stance[arm]])
        lost = self._run(n_swing, lambda t: swing(t, frm, old), stall=False)  # type: ignore[operator]
        if lost:
            return result(lost, f"{reason}; a gripper let go on the way")  # type: ignore[operator]
        back = self._wait_capture(arm, old, 0.6)
        if back is True:
            self._grip(arm, self.stance[arm])
            self._run(int(0.3 / self.dt), lambda t: None, stall=False)
            return result(outcome, reason)  # type: ignore[operator]
        return result("fell", f"{reason}, but could not find it")  # type: ignore[operator]

    def _shoulder(self, pose: Sequence[float], k: int) -> tuple[float, float]:
        g = self.model.geom
        c, s = math.cos(pose[2]), math.sin(pose[2])
        return (pose[0] + c * g.shoulders[k, 0] - s * g.shoulders[k, 1],
                pose[1] + s * g.shoulders[k, 0] + c * g.shoulders[k, 1])

    def _sagging(self, tolerance_cm: float) -> bool:
        """Is the body more than ``tolerance_cm`` from where the servo targets put it?"""
        p = self.body.position
        g = self.model.geom
        b = self.body
        for k in range(3):
            if self.grips[k] is None:
                continue
            # forward kinematics of the targets from the hand back to the shoulder
            s_t, e_t = self.targets[k]
            ang = b.angle + s_t
            sx = p.x + math.cos(b.angle) * g.shoulders[k, 0] - math.sin(b.angle) * g.shoulders[k, 1]
            sy = p.y + math.sin(b.angle) * g.shoulders[k, 0] + math.cos(b.angle) * g.shoulders[k, 1]
            hx = sx + g.l1[k] * math.cos(ang) + g.l2[k] * math.cos(ang - e_t + math.pi)
            hy = sy + g.l1[k] * math.sin(ang) + g.l2[k] * math.sin(ang - e_t + math.pi)
            tx, ty = self.holes.xy[self.stance[k]]
            if math.hypot(hx - tx, hy - ty) > tolerance_cm:
                return True
        return False

    def _wait_capture(self, arm: int, hole_xy: tuple[float, float], seconds: float) -> bool | str:
        """Let the hand settle up to ``seconds``; True once it is within the capture radius."""
        cap = self.model.phys.capture_radius_cm
        hold = self.model.phys.holding_force_n * 100.0
        for _ in range(int(seconds / self.dt)):
            tx, ty = self._tip(arm)
            if math.hypot(tx - hole_xy[0], ty - hole_xy[1]) <= cap:
                return True
            self._control()
            self.space.step(self.dt)
            self.total_steps += 1
            for k in range(3):
                j = self.grips[k]
                if j is not None and j.impulse / self.dt > hold:
                    self._release(k)
                    return "fell" if self._hold() < 2 else "grip_lost"
        tx, ty = self._tip(arm)
        return math.hypot(tx - hole_xy[0], ty - hole_xy[1]) <= cap



def candidate_holes(holes: HoleMap, stance: Sequence[int], k: int, radius: float) -> list[int]:
    """The ``k`` holes nearest the centroid of the held holes (within ``radius`` cm) that the
    stance does not hold, nearest first (ties by row): the moves an agent may choose from.
    A function of the stance alone, so a planner and the environment offer the same moves."""
    xy = holes.xy_list
    cx = (xy[stance[0]][0] + xy[stance[1]][0] + xy[stance[2]][0]) / 3.0
    cy = (xy[stance[0]][1] + xy[stance[1]][1] + xy[stance[2]][1]) / 3.0
    near = [h for h in holes.within((cx, cy), radius).tolist() if h not in stance]
    near.sort(key=lambda h: ((xy[h][0] - cx) ** 2 + (xy[h][1] - cy) ** 2, h))
    return near[:k]


def hop_counts(holes: HoleMap, goal: int, span: float) -> list[int]:
    """Per hole: hops to hole ``goal`` through holes at most ``span`` cm apart (breadth-first;
    ``1 << 20`` where no chain of such hops reaches the goal)."""
    far = 1 << 20
    got = [far] * len(holes)
    got[goal] = 0
    frontier = [goal]
    while frontier:
        nxt = []
        for h in frontier:
            for j in holes.within(holes.xy[h], span).tolist():
                if got[j] == far:
                    got[j] = got[h] + 1
                    nxt.append(j)
        frontier = nxt
    return got


def stance_hops(hops: Sequence[int], stance: Sequence[int]) -> int:
    """A lower bound on the moves from ``stance`` until an arm holds the goal, from
    :func:`hop_counts` with ``span`` = one arm span (twice the reach). A move changes one
    arm's hole, and its old and new holes both lie within the move's circle (radius at most
    the reach), so one move lowers one arm's hop count by at most one; at the end one arm
    holds the goal (0 hops) and the others lie within one span of it (at most 1 hop): so at
    least ``sum_k max(0, hops_k - 1)`` moves, plus one if no arm holds the goal yet."""
    hs = [hops[h] for h in stance]
    return sum(max(0, v - 1) for v in hs) + (0 if min(hs) == 0 else 1)


def start_stances(model: ClimberModel, holes: HoleMap, rows: float = 1.5) -> list[tuple[int, int, int]]:
    """Stances near the bottom of the wall the robot can rest in (its three holes fit in its
    reach), lowest first: the holes within ``rows`` spacings of the lowest hole."""
    xy = holes.xy
    y0 = float(xy[:, 1].min())
    low = [i for i in range(len(holes)) if xy[i, 1] <= y0 + rows * holes.spacing]
    reach = min(model.reach[1])
    clear = model.phys.body_radius_cm + model.phys.reach_margin_cm
    out = []
    for st in itertools.permutations(low, 3):
        pts = [tuple(xy[h]) for h in st]
        cx, cy, r = min_enclosing_circle(pts)
        if r <= reach and all(math.hypot(px - cx, py - cy) >= clear for px, py in pts):
            out.append((st[0], st[1], st[2]))
    out.sort(key=lambda s: (sum(xy[h, 1] for h in s), s))
    return out
