"""The arm's two planar projections in one pymunk space (see :mod:`kinegym.envs.sim.arm`).

The yaw plane (the top view: one body turning about the base axis with the arm's inertia
about it at the current reach) and the reach plane (upper arm, forearm and pen holder as
rods under gravity), each servo a rotor with reflected inertia and friction geared to its
link through a backlash joint, with hard stops beyond the soft limits. Only the bodies and
joints live here; :class:`~kinegym.envs.sim.arm.ArmSim` runs the servo loops on them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pymunk

from kinegym.kinematics.writing_arm import WritingArm

from .arm_config import JointParams

__all__ = ["ArmPhysics"]

_NCM = 100.0  # 1 N cm in pymunk units (kg cm^2 / s^2)
_G = 981.0  # cm / s^2
_STOP_MARGIN = math.radians(3.0)  # hard stops beyond the soft joint limits
_ROTOR_MASS = 1e-3  # kg: rotors are carried by their parent link; their mass is negligible


class ArmPhysics:
    """The pymunk space: yaw plane and reach plane (see the module docstring)."""

    def __init__(self, arm: WritingArm, joints: list[JointParams], base_inertia: float, q0: Sequence[float],
                 motor_offset: Sequence[float]) -> None:
        self.arm = arm
        space = pymunk.Space()
        space.gravity = (0.0, -_G)
        space.iterations = 20
        self.space = space
        static = space.static_body
        a, b, t = arm.upper_arm, arm.forearm, arm.tool
        lengths = (a, b, t)
        masses = arm.mass
        self.lengths, self.masses = lengths, masses
        self.base_inertia = base_inertia
        q1, q2, q3, q4 = (float(v) for v in q0)
        # --- reach plane: x = horizontal reach r, y = height z
        shoulder = (0.0, arm.shoulder_height)
        psi = [q2 + arm.pitch_offset]
        psi.append(psi[0] + q3)
        psi.append(psi[1] + q4)
        links, pivots = [], []
        p = shoulder
        for L, m, ang in zip(lengths, masses, psi):
            body = pymunk.Body(m, m * L * L / 12.0)
            c, s = math.cos(ang), math.sin(ang)
            body.position = (p[0] + 0.5 * L * c, p[1] + 0.5 * L * s)
            body.angle = ang
            links.append(body)
            pivots.append(p)
            p = (p[0] + L * c, p[1] + L * s)
        # --- yaw plane: a body turning about a pivot far from the reach plane's bodies
        yaw_centre = (10_000.0, 0.0)
        yaw = pymunk.Body(1.0, 1.0)
        yaw.position = yaw_centre
        yaw.angle = q1
        self.yaw, self.links = yaw, links
        space.add(yaw, *links)
        space.add(pymunk.PivotJoint(static, yaw, yaw_centre))
        parents = [static, static, links[0], links[1]]
        children = [yaw, links[0], links[1], links[2]]
        anchors = [yaw_centre, *pivots]
        space.add(pymunk.PivotJoint(static, links[0], pivots[0]),
                  pymunk.PivotJoint(links[0], links[1], pivots[1]),
                  pymunk.PivotJoint(links[1], links[2], pivots[2]))
        zero = [0.0, arm.pitch_offset, 0.0, 0.0]  # child angle - parent angle = q + zero
        self.zero = zero
        self.parents, self.children, self.rotors = parents, children, []
        for j, jp in enumerate(joints):
            rotor = pymunk.Body(_ROTOR_MASS, jp.rotor_inertia)
            rotor.position = anchors[j]
            # the motor starts turned by motor_offset relative to its link inside the play
            rotor.angle = children[j].angle - motor_offset[j]
            space.add(rotor)
            space.add(pymunk.PivotJoint(parents[j], rotor, anchors[j]))
            space.add(pymunk.RotaryLimitJoint(rotor, children[j], -0.5 * jp.backlash, 0.5 * jp.backlash))
            space.add(pymunk.RotaryLimitJoint(parents[j], children[j], jp.lo + zero[j] - _STOP_MARGIN,
                                              jp.hi + zero[j] + _STOP_MARGIN))
            if jp.friction > 0:
                fr = pymunk.SimpleMotor(parents[j], rotor, 0.0)
                fr.max_force = jp.friction * _NCM
                space.add(fr)
            self.rotors.append(rotor)
        self.update_yaw_inertia()

    # ------------------------------------------------------------------ state
    def q_true(self) -> list[float]:
        c, p, z = self.children, self.parents, self.zero
        return [c[j].angle - p[j].angle - z[j] for j in range(4)]

    def q_motor(self) -> list[float]:
        r, p, z = self.rotors, self.parents, self.zero
        return [r[j].angle - p[j].angle - z[j] for j in range(4)]

    def tip_plane(self) -> tuple[float, float, float, float, float]:
        """Reach-plane tip (r, z), its velocity (vr, vz) and the tool's angle from horizontal."""
        tool = self.links[2]
        local = (0.5 * self.lengths[2], 0.0)
        p = tool.local_to_world(local)
        v = tool.velocity_at_local_point(local)
        return p.x, p.y, v.x, v.y, tool.angle

    def update_yaw_inertia(self) -> None:
        """The yaw body's moment: turntable + every link about the base axis at this reach."""
        lf2 = self.arm.lateral_offset ** 2
        J = self.base_inertia
        for body, L, m in zip(self.links, self.lengths, self.masses):
            r = body.position.x
            c = math.cos(body.angle)
            J += m * (r * r + lf2 + L * L * c * c / 12.0)
        self.yaw.moment = J
