"""The climber's servos in pymunk: a position loop with compliance, the load fed forward, stalls.

:class:`Servos` is the part of :class:`~kinegym.envs.sim.climber.PhysicsClimber` that turns
joint targets into torques each physics step. Every joint is a :class:`pymunk.SimpleMotor`
(a velocity motor) commanded ``feed-forward + gain x angle error`` (capped at the servo's
speed), whose torque cap grows with the position error up to the servo's limit: a stiff but
compliant servo (rigid motors fought each other in the closed chain three gripping arms
make). While a hand is free, the torques of the gait model's best load split
(:func:`~kinegym.envs.sim.gait.holding_torques`) are applied as a torque command and the
motor corrects round them within what the servo has left; a servo whose torque stays at its
limit for ``stall_s`` has stalled (:meth:`Servos._total_torque` gives the torque it applied).

Units: pymunk works in cm, kg, s, so a torque of 1 N cm is 100 kg cm^2 / s^2.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from kinegym.envs.sim.gait import holding_torques

__all__ = ["Servos", "FEEDFORWARD_HZ", "PymunkCalls", "pymunk_calls"]

#: How often the controller recomputes the load split it feeds forward (its statics take
#: about 100 us in Python; the configuration moves by a few hundredths of a cm between).
FEEDFORWARD_HZ = 60.0


class PymunkCalls(NamedTuple):
    """pymunk's public properties as plain calls (their getters and setters)."""

    angle: Callable[[Any], float]
    position: Callable[[Any], Any]
    angular_velocity: Callable[[Any], float]
    impulse: Callable[[Any], float]
    set_torque: Callable[[Any, float], None]
    set_rate: Callable[[Any, float], None]
    set_max_force: Callable[[Any, float], None]


@functools.cache
def pymunk_calls() -> PymunkCalls:
    """pymunk's properties that the servo loop reads and sets a few dozen times a physics
    step, as plain calls: ``obj.attr = v`` also passes through pymunk's typing mixin's
    ``__setattr__``. (pymunk is imported here, not with the module: the kinematic climber
    does not need it.)"""
    import pymunk

    body, con = pymunk.Body, pymunk.Constraint
    return PymunkCalls(body.angle.fget, body.position.fget, body.angular_velocity.fget, con.impulse.fget,
                       body.torque.fset, pymunk.SimpleMotor.rate.fset, con.max_force.fset)


class Servos:
    """The servo loop of :class:`~kinegym.envs.sim.climber.PhysicsClimber` (a mixin: it reads
    the robot's bodies, motors, targets and stance)."""

    model: Any
    body: Any
    upper: list[Any]
    lower: list[Any]
    motors: list[tuple[Any, Any]]
    targets: np.ndarray
    _prev_targets: np.ndarray | None
    dt: float
    _ff_arm: int | None
    _ff_w: float
    _ff_rate: float
    _ff: list[tuple[float, float]] | None
    _ff_made: tuple[object, float] | None
    _ff_raw: np.ndarray
    _ff_tick: int
    _ff_every: int
    holes: Any
    stance: tuple[int, int, int]
    pose: np.ndarray
    q: np.ndarray
    _tip: Any

    def _control(self) -> None:
        """Set every motor's rate and torque cap (and the fed-forward torques) for the next step.

        Runs every physics step, so it reads each body's angle once and sets pymunk's
        properties through their setters directly (the same C calls without pymunk's
        ``__setattr__`` hop); the arithmetic is the plain one, in the same order."""
        p = self.model.phys
        kp, vmax = p.servo_gain_per_s, math.radians(p.servo_speed_dps)
        ks = p.servo_stiffness_ncm_per_deg * 100.0 * 180.0 / math.pi  # kg cm^2 / s^2 per rad
        ts_max, te_max = p.shoulder_torque_ncm * 100.0, p.elbow_torque_ncm * 100.0
        ff = self._feedforward()
        w = self._ff_w * p.load_feedforward
        floor = p.servo_floor_share if ff is None else (1.0 - w) * p.servo_floor_share + w * p.feedforward_floor_share
        floor_s, floor_e = floor * ts_max, floor * te_max
        b = self.body
        targets = self.targets.tolist()
        prev = self._prev_targets.tolist() if self._prev_targets is not None else targets
        inv_dt = 1.0 / self.dt
        two_pi, pi, rem = 2 * math.pi, math.pi, math.remainder
        pm = pymunk_calls()
        angle, set_torque, set_rate, set_max_force = pm.angle, pm.set_torque, pm.set_rate, pm.set_max_force
        b_angle = angle(b)
        on_body = 0.0
        for k in range(3):
            up, lo = self.upper[k], self.lower[k]
            m_s, m_e = self.motors[k]
            up_angle = angle(up)
            s_now = up_angle - b_angle
            rel_now = angle(lo) - up_angle  # = pi - elbow
            s_t, e_t = targets[k]
            err_s = rem(s_t - s_now, two_pi)
            err_e = rem((pi - e_t) - rel_now, two_pi)
            # velocity feed-forward (the targets' own rate, consistent round the closed chain)
            # plus the position loop; SimpleMotor keeps a.w - b.w = rate
            ff_s = rem(s_t - prev[k][0], two_pi) * inv_dt
            ff_e = -rem(e_t - prev[k][1], two_pi) * inv_dt
            set_rate(m_s, -max(-vmax, min(vmax, ff_s + kp * err_s)))
            set_rate(m_e, -max(-vmax, min(vmax, ff_e + kp * err_e)))
            # the torque a servo may use grows with its position error, up to its limit: a
            # stiff but compliant servo. (Rigid velocity motors fight one another in the
            # closed chain that three gripping arms make: their internal torques drift to
            # the limit within a second even at rest.)
            cap_s, cap_e = min(ts_max, ks * abs(err_s) + floor_s), min(te_max, ks * abs(err_e) + floor_e)
            if ff is not None:
                # the fed-forward torque on the outer link (and its reaction), and the position
                # loop keeps to what the servo has left
                # (pymunk clears a body's torque after every step: it is set, not added to)
                t_s, t_e = ff[k][0] * 100.0, ff[k][1] * 100.0
                set_torque(up, t_s - t_e)
                set_torque(lo, t_e)
                on_body -= t_s
                cap_s, cap_e = min(cap_s, ts_max - abs(t_s)), min(cap_e, te_max - abs(t_e))
            set_max_force(m_s, cap_s)
            set_max_force(m_e, cap_e)
        if ff is not None:
            set_torque(b, on_body)
        self._prev_targets = self.targets

    def _feedforward(self) -> list[tuple[float, float]] | None:
        """Advance the feed-forward's ramp one step; the torques (N cm, clipped to each servo's
        limit) it commands now, or None. While a hand is free (from its gripper opening until
        it grips again) the holding servos are commanded the torques of the model's best load
        split (:func:`~kinegym.envs.sim.gait.holding_torques`) at the robot's present pose, as
        a controller that knows its statics would: compliant position servos alone share the
        load by their position errors, further from the best split the nearer a servo is to
        its limit. Ramped in as the gripper opens and out as a hand grips again."""
        p = self.model.phys
        if self._ff_arm is not None:
            self._ff_w = min(1.0, max(0.0, self._ff_w + self._ff_rate))
            if self._ff_w == 0.0 and self._ff_rate < 0.0:
                self._ff_arm = None
        if self._ff_arm is None or p.load_feedforward == 0.0:
            self._ff = None
            return None
        if self._ff_tick % self._ff_every == 0:  # the controller's statics, at FEEDFORWARD_HZ
            free = self._ff_arm
            hands = [tuple(self.holes.xy[h]) for h in self.stance]
            hands[free] = self._tip(free)
            pose = self.pose
            self._ff_raw = holding_torques(self.model, (float(pose[0]), float(pose[1]), float(pose[2])), hands,
                                           [(float(a), float(e)) for a, e in self.q], free)
        self._ff_tick += 1
        w, ls, le = self._ff_w * p.load_feedforward, p.shoulder_torque_ncm, p.elbow_torque_ncm
        made = self._ff_made
        if self._ff is None or made is None or made[0] is not self._ff_raw or made[1] != w:  # else as last step
            self._ff = [(min(ls, max(-ls, s * w)), min(le, max(-le, e * w))) for s, e in self._ff_raw.tolist()]
            self._ff_made = (self._ff_raw, w)
        return self._ff

    def _total_torque(self, k: int, n: int, fed: float) -> float:
        """|torque| servo ``n`` (0 shoulder, 1 elbow) of arm ``k`` applied in the last step: the
        fed-forward part plus its motor's impulse. A motor's impulse comes without its sign;
        a motor that could not keep its rate (at its cap) pushed towards it, which gives it."""
        m = self.motors[k][n]
        a, b = (self.body, self.upper[k]) if n == 0 else (self.upper[k], self.lower[k])
        pm = pymunk_calls()
        j = abs(pm.impulse(m)) / self.dt
        # the motor keeps a.w - b.w = rate and pushes b by +j when a.w - b.w ended above its rate
        return abs(fed + (j if (pm.angular_velocity(a) - pm.angular_velocity(b)) > m.rate else -j))
