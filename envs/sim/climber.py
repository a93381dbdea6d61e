"""The three-armed climber on a wall of holes: a gait model judged analytically and the same
robot in pymunk physics, behind one interface.

Seed 000 stopped at statics and named "equations for movements" as the next step; this
module moves the robot with the gait the seed sketches - move the centre, then one arm:

1. **shift** - with all three hands gripping, the body moves in a straight line to a new
   pose (inverse kinematics of all three arms along the way);
2. **release** the moving arm's gripper: it opens over ``grip_release_s``, its share of the
   load passing to the other two arms;
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
  (``max_force``), the model's best load split fed forward as torque while a hand is free,
  grippers as pivot joints that let go above their holding force, gravity along -y. A servo
  asked for more than it has sags; a hand that sags misses its hole.

Outcomes (:data:`OUTCOMES`): ``ok``, ``unreachable``, ``torque_limit``, ``missed_hole``,
``grip_lost``, ``fell`` (fewer than two grips). A failed move leaves the robot on its
previous holes where it can: a swing stops when a servo stalls or the body sags
``sag_abort_cm`` off its holds, and the swinging hand goes back and grips its hole the
moment it is within the capture radius; only a fall ends a climb. Encoders read the joint
angles with Gaussian noise (``sensor_sigma_deg``, what the localiser assumes too) and
quantisation from the robot's YAML; the robot never sees its true pose.

Units: cm, kg, s, radians in the API; forces in N and torques in N cm in the config.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from kinegym.envs.sim.climber_model import _G_CM, OUTCOMES, ClimberModel
from kinegym.envs.sim.climber_servos import FEEDFORWARD_HZ, Servos, pymunk_calls
from kinegym.envs.sim.gait import (
    GaitResult,
    MovePlan,
    _around,
    _path_length,
    min_enclosing_circle,
    plan_move,
    rest_joints,
    rest_pose,
)
from kinegym.kinematics.climber import arm_ik_one
from kinegym.kinematics.holes import HoleMap

__all__ = ["ClimberSim", "KinematicClimber", "PhysicsClimber", "OUTCOMES"]


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
        return np.array([self._ik_arm(pose, k, hands[k]) for k in range(3)])

    def _ik_arm(self, pose: Sequence[float], k: int, hand: Sequence[float]) -> tuple[float, float]:
        """Arm ``k``'s joint angles that put its hand at ``hand`` with the body at ``pose``."""
        g = self.model.geom
        cx, cy, th = pose
        c, s = math.cos(th), math.sin(th)
        sh0, sh1 = g.shoulders[k].tolist()
        ox, oy = c * sh0 - s * sh1, s * sh0 + c * sh1
        bx, by = hand[0] - cx - ox, hand[1] - cy - oy
        return arm_ik_one(float(g.l1[k]), float(g.l2[k]), c * bx + s * by, -s * bx + c * by, 1)


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

    def move(self, arm: int, hole: int, judged: bool = False) -> GaitResult:
        """Move ``arm`` to ``hole`` (map row). ``judged``: the caller's gait kernel
        (:func:`~kinegym.envs.sim.gait_kernel.feasible_moves`, heading 0, from this stance)
        already found the move feasible, so only where it ends is worked out - the swing's
        statics are not judged twice (the env's step: a third of its time) and the result
        carries no plan. The end pose and joints are :func:`plan_move`'s, bit for bit."""
        st = list(self.stance)
        st[arm] = hole
        new = (st[0], st[1], st[2])
        key = (self.stance, arm, hole)
        if judged and key not in self._cache and float(self.pose[2]) == 0.0:
            end = rest_pose(self.model, self.holes, new, 0.0)
            if not isinstance(end, str):
                self.stance, self.pose = new, np.array(end)
                self.q = rest_joints(self.model, self.holes, new, end)
                return GaitResult("ok", "moved", self.stance, self.pose.copy())
        plan = self.judge(arm, hole)
        if not isinstance(plan, MovePlan):
            return GaitResult(plan[0], plan[1], self.stance, self.pose.copy(), phase="plan")
        self.stance = new
        self.pose = np.array(plan.pose_end)
        self.q = plan.q_end.copy()  # type: ignore[union-attr]
        return GaitResult("ok", "moved", self.stance, self.pose.copy(), plan=plan)


# ------------------------------------------------------------------ physics (pymunk)
class PhysicsClimber(Servos, ClimberSim):
    """The climber in pymunk: the reference for :class:`KinematicClimber`.

    Bodies: the body (a disc), three upper and three lower links (rods; the hand's mass
    sits at the lower link's tip). Pivot joints at shoulders and elbows, each with a
    :class:`pymunk.SimpleMotor` whose rate comes from a position loop (gain
    ``servo_gain_per_s``, speed limit ``servo_speed_dps``) and whose ``max_force`` is the
    servo's torque limit (:class:`~kinegym.envs.sim.climber_servos.Servos`); while a hand is
    free the holding servos are also commanded the torques of the model's best load split
    (``load_feedforward``). A gripping hand is a pivot joint to the wall; it lets go when the
    force through it exceeds ``holding_force_n``. No collisions: the links move in parallel
    planes in front of the wall. Bit-identical from the same reset and moves.
    """

    def __init__(self, model: ClimberModel | None = None) -> None:
        self.model = model or ClimberModel.from_config()
        self.dt = 1.0 / self.model.phys.physics_hz
        self.total_steps = 0
        self.stalled = ""  # which servo stalled last

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
        # the load split fed forward while a hand is free: its arm, its weight (ramped), the
        # weight's change per step and the torques of the last step (N cm; None = none)
        self._ff_arm: int | None = None
        self._ff_w, self._ff_rate = 0.0, 0.0
        self._ff: list[tuple[float, float]] | None = None
        self._ff_made: tuple[object, float] | None = None  # the split and weight ``_ff`` was made of
        self._ff_tick, self._ff_every = 0, max(1, round(p.physics_hz / FEEDFORWARD_HZ))
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
        if self._ff_arm is not None:  # a hand grips again: the position loop takes the load back
            self._ff_rate = -self.dt / max(self.model.phys.grip_release_s, self.dt)

    def _release(self, k: int) -> None:
        j = self.grips[k]
        if j is not None:
            self.space.remove(j)
            self.grips[k] = None

    def _let_go(self, arm: int) -> tuple[str, str, str] | None:
        """Open arm ``arm``'s gripper as a real one opens, over ``grip_release_s``: the grip's
        force cap ramps from the force it carries down to zero while every servo holds its
        pose, so the hand's share of the load passes to the holding arms quasi-statically
        (removing the joint at once dropped it on them in one step, and the lightly damped
        body mode overshot past the servo limits). Then the joint goes. None once the hand is
        free; ``(outcome, reason, phase)`` if a holding servo stalls or the body sags on the
        way (the gripper closes again: the hand never left its hole) or a gripper lets go."""
        j = self.grips[arm]
        p = self.model.phys
        t_open = p.grip_release_s
        self._ff_arm, self._ff_rate = arm, self.dt / max(t_open, self.dt)  # feed the split forward as it opens
        self._ff_tick = 0
        if j is None or t_open <= 0.0:
            self._ff_w = 1.0
            self._release(arm)
            return None
        f0 = abs(j.impulse) / self.dt  # the force the grip carries now (below holding_force_n)

        def opening(t: float) -> None:
            j.max_force = f0 * max(0.0, 1.0 - t / t_open)

        lost = self._run(int(round(t_open / self.dt)), opening,
                         until=lambda: "sagged" if self._sagging(p.sag_abort_cm) else None)
        if lost in ("torque_limit", "sagged"):
            j.max_force = math.inf
            self._ff_rate = -self.dt / t_open
            self._run(int(0.3 / self.dt), lambda t: None, stall=False)
            what = self._gave_way(lost)
            return "torque_limit", f"{what} while arm {arm + 1}'s gripper opened; it closed again", "swing"
        if lost:
            return lost, f"a gripper let go while arm {arm + 1}'s gripper opened", "swing"
        self._release(arm)
        return None

    def _gave_way(self, lost: str) -> str:
        """What gave way, for a reason: the servo that stalled (``lost == "torque_limit"``) or
        the sag that stopped the motion (``"sagged"``)."""
        if lost == "torque_limit":
            return f"{self.stalled} stalled"
        return f"the body sagged {self.model.phys.sag_abort_cm:g} cm (a holding servo gave way)"

    # -- state ----------------------------------------------------------------------------
    @property
    def pose(self) -> np.ndarray:  # type: ignore[override]
        return np.array(self._pose_now())

    def _pose_now(self) -> tuple[float, float, float]:
        """:attr:`pose` as a tuple (read every physics step of a swing)."""
        pm = pymunk_calls()
        x, y = pm.position(self.body)
        return x, y, math.remainder(pm.angle(self.body), 2 * math.pi)

    @property
    def q(self) -> np.ndarray:  # type: ignore[override]
        b = self.body
        out = np.empty((3, 2))
        for k in range(3):
            a1, a2 = self.upper[k].angle, self.lower[k].angle
            out[k, 0] = math.remainder(a1 - b.angle, 2 * math.pi)
            out[k, 1] = math.remainder(math.pi - (a2 - a1), 2 * math.pi) % (2 * math.pi)
        return out

    # -- control loop: the servos are :class:`~kinegym.envs.sim.climber_servos.Servos`' ----------
    def _run(self, steps: int, schedule: object, stall: bool = True,
             until: Callable[[], str | None] | None = None) -> str | None:
        """Step ``steps`` times; ``schedule(t)`` updates the targets first. Returns
        ``"grip_lost"`` / ``"fell"`` if a gripper let go (and how many are left),
        ``"torque_limit"`` if a servo stayed at its torque limit for ``stall_s`` (a stalled
        servo: the move is stopped, as a servo's current limit would), what ``until()`` says
        once it says something (checked every step), else None."""
        p = self.model.phys
        hold = p.holding_force_n * 100.0
        dt = self.dt
        stall_steps = int(p.stall_s / dt)
        limits = [(p.shoulder_torque_ncm * 100.0 * dt * 0.995, p.elbow_torque_ncm * 100.0 * dt * 0.995)] * 3
        tops = (p.shoulder_torque_ncm * 100.0 * 0.995, p.elbow_torque_ncm * 100.0 * 0.995)
        stalled = [0] * 6
        impulse = pymunk_calls().impulse
        for i in range(steps):
            schedule(i * dt)  # type: ignore[operator]
            self._control()
            self.space.step(dt)
            self.total_steps += 1
            for k in range(3):
                j = self.grips[k]
                if j is not None and impulse(j) / dt > hold:
                    self._release(k)
                    return "fell" if sum(g is not None for g in self.grips) < 2 else "grip_lost"
            if until is not None and (said := until()):
                return said
            if stall:
                ff = self._ff
                for k in range(3):
                    for n in range(2):
                        if ff is None:
                            at_limit = abs(impulse(self.motors[k][n])) >= limits[k][n]
                        else:
                            fed = ff[k][n] * 100.0  # (cheap test first: the two could not reach the top)
                            at_limit = (abs(fed) + abs(impulse(self.motors[k][n])) / dt >= tops[n]
                                        and self._total_torque(k, n, fed) >= tops[n])
                        if at_limit:
                            stalled[2 * k + n] += 1
                            if stalled[2 * k + n] >= stall_steps:
                                self.stalled = f"arm {k + 1}'s {('shoulder', 'elbow')[n]} servo"
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

        def result(outcome: str, reason: str, phase: str = "") -> GaitResult:
            n = self.total_steps - steps0
            return GaitResult(outcome, reason, self.stance, self.pose, n, n * self.dt,
                              plan if isinstance(plan, MovePlan) else None, phase)

        if not isinstance(plan, MovePlan) and plan[0] == "unreachable":
            return result(*plan, "plan")  # no body pose exists: the robot does not try
        if self._hold() < 3:
            return result("fell", "the robot holds fewer than three holes", "plan")
        # the pose to shift to: the plan's, or (the planner expects the servos to fail)
        # the same minimal-circle pose, tried anyway - physics decides
        turn = 0.0  # a half turn's side: as planned, or the shorter way's noise-free default
        if isinstance(plan, MovePlan):
            target_pose, q_to, turn = plan.pose_to, plan.q_to, plan.turn
        else:
            xy = self.holes.xy
            st = list(self.stance)
            pts = [tuple(xy[h]) for h in st] + [tuple(xy[hole])]
            cx, cy, _ = min_enclosing_circle(pts)
            target_pose = (cx, cy, float(self.pose[2]))
            st[arm] = hole
            q_to = self._ik_all(target_pose, [tuple(xy[h]) for h in st])
        held = [tuple(self.holes.xy[h]) for h in self.stance]
        # 1. shift the body with all three hands gripping
        start = self.pose
        lost = self._shift(target_pose, held)
        if lost in ("torque_limit", None) and (lost or self._sagging(0.3)):
            # a servo stalled, or the servos cannot hold the shifted pose: go back
            back = self._shift(start, held, stall=False)
            if back:
                return result(back, "a gripper let go while the body shifted back", "shift")
            what = f"{self.stalled} stalled" if lost else "the servos could not hold the shifted pose (it sagged)"
            return result("torque_limit", f"{what} while the body shifted; it shifted back", "shift")
        if lost:
            return result(lost, "a gripper let go while the body shifted", "shift")
        # 2. release, 3. swing along a straight line in the wall frame, 4. grip
        old = held[arm]
        new = tuple(self.holes.xy[hole])
        lost = self._let_go(arm)
        if lost:
            return result(*lost)
        seg = _path_length(self._shoulder(target_pose, arm), old, new, turn)
        t_swing = max(0.2, seg / p.swing_speed_cm_s)
        n_swing = int(t_swing / self.dt)
        body_pose = target_pose

        shoulder = self._shoulder(body_pose, arm)
        holding = self._ik_all(body_pose, held)  # the holding arms' targets stay put through the swing

        def swing(t: float, a: tuple[float, float] = old, b: tuple[float, float] = new, back: bool = False) -> None:
            f = min(1.0, t / t_swing)
            f = f * f * (3 - 2 * f)
            targets = holding.copy()
            # the swinging arm aims from where the body really is (the robot knows it from
            # the holding arms' encoders): a sagging body does not throw the hand off
            targets[arm] = self._ik_arm(self._pose_now(), arm, _around(shoulder, a, b, f, -turn if back else turn))
            self.targets = targets

        lost = self._run(n_swing, swing, until=lambda: "sagged" if self._sagging(p.sag_abort_cm) else None)
        if lost in ("torque_limit", "sagged"):  # a servo stalled, or the body sags: the hand goes back to its hole
            what = self._gave_way(lost)
            return self._swing_back(arm, swing, n_swing, old, result, "torque_limit",
                                    f"{what} while arm {arm + 1} swung; the hand went back to its hole")
        if lost:
            return result(lost, f"a gripper let go while arm {arm + 1} swung", "swing")
        captured = self._wait_capture(arm, new, 0.6)
        if lost := (captured if isinstance(captured, str) else None):
            return result(lost, f"a gripper let go while arm {arm + 1} reached for its hole", "reach")
        if captured is True:
            self._grip(arm, hole)
            st = list(self.stance)
            st[arm] = hole
            self.stance = (st[0], st[1], st[2])
            self.targets = q_to.copy() if isinstance(plan, MovePlan) else self.targets
            lost = self._run(int(0.3 / self.dt), lambda t: None)
            if lost:
                return result(lost, "a gripper let go after the grip", "grip")
            # 5. come to rest on the new holes (the pose every move starts from)
            rest = plan.pose_end if isinstance(plan, MovePlan) else rest_pose(self.model, self.holes, self.stance,
                                                                               float(self.pose[2]))
            if isinstance(rest, str):
                return result("ok", "moved (stayed where it gripped: " + rest + ")")
            lost = self._shift(rest, [tuple(self.holes.xy[h]) for h in self.stance], stall=False)
            if lost:
                return result(lost, "a gripper let go while the body came to rest on its new holes", "rest")
            return result("ok", "moved")
        # missed: swing back to the old hole and grip it again
        return self._swing_back(arm, swing, n_swing, new, result, "missed_hole",
                                f"arm {arm + 1} did not reach hole {tuple(self.holes.ids[hole])} (the servos "
                                f"sagged); it went back to its hole")

    def _shift(self, to: Sequence[float], held: Sequence[tuple[float, float]], stall: bool = True) -> str | None:
        """Shift the body in a straight line to pose ``to`` with the hands on ``held`` (inverse
        kinematics of all three arms along the way), paced so that no joint is asked for more
        than ``shift_servo_share`` of the servo speed, then settle 0.3 s; what :meth:`_run` says."""
        p = self.model.phys
        start = self.pose
        dist = math.hypot(to[0] - start[0], to[1] - start[1])
        q0, q1 = self._ik_all(start, held), self._ik_all(to, held)
        turn = float(np.max(np.abs(np.remainder(q1 - q0 + math.pi, 2 * math.pi) - math.pi)))
        vmax = math.radians(p.servo_speed_dps) * p.shift_servo_share
        # a smoothstep's peak rate is 1.5x its mean
        t_shift = max(0.2, dist / p.shift_speed_cm_s, 1.5 * turn / vmax)

        def shift(t: float) -> None:
            f = min(1.0, t / t_shift)
            f = f * f * (3 - 2 * f)  # smooth start and stop
            pose = (start[0] + f * (to[0] - start[0]), start[1] + f * (to[1] - start[1]),
                    start[2] + f * math.remainder(to[2] - start[2], 2 * math.pi))
            self.targets = self._ik_all(pose, held)

        return self._run(int(t_shift / self.dt) + int(0.3 / self.dt), shift, stall=stall)

    def _swing_back(self, arm: int, swing: object, n_swing: int, frm: tuple[float, float], result: object,
                    outcome: str, reason: str) -> GaitResult:
        """Bring the swinging hand back to its old hole and grip it: ``outcome`` if that
        works, a fall if it does not."""
        old = tuple(self.holes.xy[self.stance[arm]])
        phase = "reach" if outcome == "missed_hole" else "swing"
        # the hand grips as soon as it is back, not when the path ends
        lost = self._run(n_swing, lambda t: swing(t, frm, old, True), stall=False,  # type: ignore[operator]
                         until=lambda: "home" if self._at_hole(arm, old) else None)
        lost = None if lost == "home" else lost
        if lost:
            return result(lost, f"{reason}; a gripper let go on the way", phase)  # type: ignore[operator]
        back = self._wait_capture(arm, old, 0.6)
        if back is True:
            self._grip(arm, self.stance[arm])
            self._run(int(0.3 / self.dt), lambda t: None, stall=False)
            return result(outcome, reason, phase)  # type: ignore[operator]
        return result("fell", f"{reason}, but could not find it", phase)  # type: ignore[operator]

    def _shoulder(self, pose: Sequence[float], k: int) -> tuple[float, float]:
        g = self.model.geom
        c, s = math.cos(pose[2]), math.sin(pose[2])
        return (pose[0] + c * g.shoulders[k, 0] - s * g.shoulders[k, 1],
                pose[1] + s * g.shoulders[k, 0] + c * g.shoulders[k, 1])

    def _sagging(self, tolerance_cm: float) -> bool:
        """Is the body more than ``tolerance_cm`` from where the servo targets put it?
        (Checked every step of a swing: the body's pose is read once.)"""
        b = self.body
        pm = pymunk_calls()
        px, py = pm.position(b)
        angle = pm.angle(b)
        ca, sa = math.cos(angle), math.sin(angle)
        g = self.model.geom
        targets = self.targets.tolist()
        xy = self.holes.xy
        for k in range(3):
            if self.grips[k] is None:
                continue
            # forward kinematics of the targets from the hand back to the shoulder
            s_t, e_t = targets[k]
            ang = angle + s_t
            sh0, sh1 = g.shoulders[k].tolist()
            sx = px + ca * sh0 - sa * sh1
            sy = py + sa * sh0 + ca * sh1
            l1, l2 = float(g.l1[k]), float(g.l2[k])
            hx = sx + l1 * math.cos(ang) + l2 * math.cos(ang - e_t + math.pi)
            hy = sy + l1 * math.sin(ang) + l2 * math.sin(ang - e_t + math.pi)
            tx, ty = xy[self.stance[k]].tolist()
            if math.hypot(hx - tx, hy - ty) > tolerance_cm:
                return True
        return False

    def _at_hole(self, arm: int, hole_xy: tuple[float, float]) -> bool:
        """Is arm ``arm``'s hand within the capture radius of ``hole_xy``?"""
        tx, ty = self._tip(arm)
        return math.hypot(tx - hole_xy[0], ty - hole_xy[1]) <= self.model.phys.capture_radius_cm

    def _wait_capture(self, arm: int, hole_xy: tuple[float, float], seconds: float) -> bool | str:
        """Let the hand settle up to ``seconds``; True once it is within the capture radius,
        ``"fell"`` / ``"grip_lost"`` if a gripper let go meanwhile."""
        if self._at_hole(arm, hole_xy):
            return True
        said = self._run(int(seconds / self.dt), lambda t: None, stall=False,
                         until=lambda: "home" if self._at_hole(arm, hole_xy) else None)
        return True if said == "home" else said or False
