"""The 4-DOF writing arm: base yaw and three pitch joints, closed-form IK with every branch.

One model covers both seed arms (geometry from ``configs/arms/*.yaml``):

* ``pincher`` - the PhantomX Pincher of seed 002 (lab 6): base 10 cm, riser 4.5 cm,
  links 10.7 / 10.5 cm, pen 9.5 cm;
* ``thesis_rrrr`` - the RRRR arm of seed 003: zero pose hanging straight down, the pen
  offset sideways by ``l_f`` from the plane of the links.

Model (lengths in cm, angles in radians)::

    yaw   = q1 + yaw_offset                     u = (cos yaw, sin yaw), v = (sin yaw, -cos yaw)
    psi_A = q2 + pitch_offset,  psi_B = psi_A + q3,  psi_T = psi_B + q4   (from the horizontal)
    r     = A cos psi_A + B cos psi_B + T cos psi_T
    (x, y) = base_xy + r u + lateral_offset v
    z     = shoulder_height + A sin psi_A + B sin psi_B + T sin psi_T
    psi_W = psi_T if r >= 0 else pi - psi_T     (the pen's pitch in the world, see below)
    phi   = psi_W - pitch_offset

The pen pose is a world-frame quantity, as seed 002 defines it: ``phi`` is the pitch of the
tool in the vertical plane through the base axis and the target, measured from the
*outward* horizontal (away from the base axis), less the arm's own zero ``pitch_offset``.
An arm facing its target (``r >= 0``) has ``phi = q2 + q3 + q4``; one reaching back over its
base (``r < 0``) points the pen the other way round, ``phi = pi - (q2 + q3 + q4) - 2
pitch_offset``. For the Pincher ``phi = -pi/2`` points the pen straight down and ``phi = 0``
horizontally outward; for the RRRR arm (pitch offset -90 deg) ``phi = 0`` is down, as in the
thesis (eq. 3.25). (With the RRRR arm's sideways pen offset the pen lies in the links'
vertical plane, parallel to the plane through the base axis; ``phi`` is its pitch there.)

Inverse kinematics (:meth:`WritingArm.ik_all`) returns four branches: the arm facing the
target or reaching back over its base (yaw + pi, ``r < 0``), each with the elbow on
either side. Every branch reproduces the tip ``(x, y, z)`` and the world pen pitch ``phi``
through :meth:`WritingArm.fk` (checked by round-trip tests, also against the wrist-to-tip
direction). :meth:`WritingArm.ik` picks the branch inside the joint
limits nearest the current pose (seed 002's ``findOptimalSolution``, with its errors
fixed: seed 002's branch row 3 flips the signs of ``q3``/``q4`` and misses its target).

Servo convention: a real arm's servos may count from another zero and in the other
direction: ``servo = sign * q + offset`` (Pincher: signs ``(+1, -1, -1, -1)``, offsets
``(90, 90, 0, 0)`` deg - exactly seed 002's ``[t1 + pi/2, -t2 + pi/2, -t3, -t4]``);
joint limits are given in servo angles, as on the hardware (Pincher: +-150 deg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import kinegym.configs as _configs

from ._kernels.arm_closed_form import ik_fast_function
from .chains import DHChain, DHLink, PoEChain
from .errors import InvalidInputError, JointLimitError, UnreachableError, as_array

__all__ = ["WritingArm", "ARM_SCHEMA", "BRANCHES"]

TWO_PI = 2.0 * math.pi
#: Branch order of :meth:`WritingArm.ik_all`: (reach, sign of q3).
BRANCHES: tuple[str, ...] = ("front, q3<=0", "front, q3>=0", "back, q3<=0", "back, q3>=0")

ARM_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(doc="short name of the arm"),
    "description": _configs.Text(default=""),
    "base_xy_cm": _configs.Vector(length=2, default=[0.0, 0.0], doc="base axis position"),
    "base_height_cm": _configs.Number(lo=0.0, doc="height of the base top"),
    "shoulder_riser_cm": _configs.Number(lo=0.0, default=0.0, doc="base top to shoulder axis"),
    "upper_arm_cm": _configs.Number(lo=0.0, lo_open=True, doc="shoulder to elbow"),
    "forearm_cm": _configs.Number(lo=0.0, lo_open=True, doc="elbow to wrist"),
    "tool_cm": _configs.Number(lo=0.0, doc="wrist to pen tip"),
    "lateral_offset_cm": _configs.Number(default=0.0, doc="pen plane offset from the base axis"),
    "yaw_offset_deg": _configs.Number(lo=-360.0, hi=360.0, default=0.0),
    "pitch_offset_deg": _configs.Number(lo=-360.0, hi=360.0, default=0.0),
    "servo_sign": _configs.Vector(length=4, default=[1, 1, 1, 1],
                                  item=_configs.Number(lo=-1, hi=1, integer=True)),
    "servo_offset_deg": _configs.Vector(length=4, default=[0.0, 0.0, 0.0, 0.0],
                                        item=_configs.Number(lo=-360.0, hi=360.0)),
    "servo_limits_deg": _configs.Matrix(rows=4, cols=2, item=_configs.Number(lo=-720.0, hi=720.0),
                                        doc="per joint [low, high] in servo degrees"),
    "mass_kg": _configs.Vector(length=3, default=[0.12, 0.10, 0.05],
                               item=_configs.Number(lo=0.0, lo_open=True),
                               doc="upper arm, forearm, pen holder (used by the simulation)"),
    "max_torque_ncm": _configs.Vector(length=4, default=[150.0, 150.0, 150.0, 150.0],
                                      item=_configs.Number(lo=0.0, lo_open=True)),
    "sim": _configs.Opaque(default={}, doc="servo loops, pen, sponge, board: validated by kinegym.envs.sim.arm_config"),
}



# ik_all works on 14 rows of joint values: per reach (front, back) q1, then q2, q3, q4 of
# each elbow sign; _ROW_OF_OUT maps the 16 (branch, joint) outputs to their rows.
_ROW_JOINT = np.array([0, 1, 2, 3, 1, 2, 3] * 2)
_ROW_OF_OUT = np.array([7 * (k // 2) + (0 if j == 0 else 1 + 3 * (k % 2) + j - 1)
                        for k in range(4) for j in range(4)])
_IK_CHUNK = 8192  # targets per pass of ik_all: its temporaries stay in the CPU cache


def _wrap(a: float) -> float:
    """Angle to (-pi, pi]."""
    return a - TWO_PI * math.floor((a + math.pi) / TWO_PI)


@dataclass(frozen=True)
class WritingArm:
    """Geometry and kinematics of a yaw + three-pitch writing arm (cm, radians).

    Build one with :meth:`from_config` (``"pincher"``, ``"thesis_rrrr"`` or a YAML path)
    or directly. ``limits`` are model-space joint limits, shape (4, 2).
    """

    name: str
    base_xy: tuple[float, float]
    shoulder_height: float
    upper_arm: float
    forearm: float
    tool: float
    lateral_offset: float = 0.0
    yaw_offset: float = 0.0
    pitch_offset: float = 0.0
    limits: np.ndarray = field(default_factory=lambda: np.tile([-math.pi, math.pi], (4, 1)))
    servo_sign: tuple[int, int, int, int] = (1, 1, 1, 1)
    servo_offset: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    mass: tuple[float, float, float] = (0.12, 0.10, 0.05)
    max_torque: tuple[float, float, float, float] = (150.0, 150.0, 150.0, 150.0)

    def __post_init__(self) -> None:
        lim = as_array("limits", self.limits, (4, 2))
        if lim.shape != (4, 2) or np.any(lim[:, 0] >= lim[:, 1]):
            raise InvalidInputError(f"limits={lim.tolist()}; expected 4 rows of [low < high] (rad)")
        object.__setattr__(self, "limits", lim)
        for key in ("upper_arm", "forearm"):
            if not getattr(self, key) > 0:
                raise InvalidInputError(f"{key}={getattr(self, key)!r}; expected a length > 0 cm")
        if self.tool < 0:
            raise InvalidInputError(f"tool={self.tool!r}; expected a length >= 0 cm")
        # scalar copies for the microsecond path
        object.__setattr__(self, "_lim", [tuple(map(float, r)) for r in lim])
        # generated numeric-IK kernels of this geometry (filled lazily by kinematics.ik)
        object.__setattr__(self, "_kernels", {})
        # per row of ik_all's 14 joint rows: the joint's lower limit and upper limit + 1e-9
        object.__setattr__(self, "_row_lo", lim[_ROW_JOINT, 0][:, None].copy())
        object.__setattr__(self, "_row_hi_tol", (lim[_ROW_JOINT, 1] + 1e-9)[:, None])

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_config(cls, name_or_path: str | Path = "pincher") -> WritingArm:
        """Load ``configs/arms/<name>.yaml`` or a YAML file; raises ``configs.ConfigError``."""
        cfg = _configs.load("arms", name_or_path, ARM_SCHEMA)
        return cls.from_dict(cfg, str(_configs.resolve("arms", name_or_path)))

    @classmethod
    def from_dict(cls, cfg: dict, source: str = "<config>") -> WritingArm:
        """From an arm config already validated against :data:`ARM_SCHEMA` (``source`` names
        the file in errors): what a caller that also needs the ``sim:`` section uses, so that
        the file is read once."""
        src = source
        sign = [int(s) for s in cfg["servo_sign"]]
        for i, s in enumerate(sign):
            if s not in (-1, 1):
                raise _configs.ConfigError(src, f"servo_sign[{i}]", s, "+1 or -1")
        offset = np.radians(cfg["servo_offset_deg"])
        servo_lim = np.radians(np.asarray(cfg["servo_limits_deg"], dtype=float))
        for i, (lo, hi) in enumerate(servo_lim):
            if lo >= hi:
                raise _configs.ConfigError(
                    src, f"servo_limits_deg[{i}]", cfg["servo_limits_deg"][i], "[low, high] with low < high"
                )
        # servo = s q + o  ->  q = (servo - o) / s ; a negative sign swaps the interval ends
        q_lim = np.sort((servo_lim - offset[:, None]) * np.asarray(sign, float)[:, None], axis=1)
        return cls(
            name=cfg["name"],
            base_xy=(cfg["base_xy_cm"][0], cfg["base_xy_cm"][1]),
            shoulder_height=cfg["base_height_cm"] + cfg["shoulder_riser_cm"],
            upper_arm=cfg["upper_arm_cm"],
            forearm=cfg["forearm_cm"],
            tool=cfg["tool_cm"],
            lateral_offset=cfg["lateral_offset_cm"],
            yaw_offset=math.radians(cfg["yaw_offset_deg"]),
            pitch_offset=math.radians(cfg["pitch_offset_deg"]),
            limits=q_lim,
            servo_sign=tuple(sign),  # type: ignore[arg-type]
            servo_offset=tuple(float(o) for o in offset),  # type: ignore[arg-type]
            mass=tuple(cfg["mass_kg"]),  # type: ignore[arg-type]
            max_torque=tuple(cfg["max_torque_ncm"]),  # type: ignore[arg-type]
        )

    # ------------------------------------------------------------------ conventions
    def to_servo(self, q: object) -> np.ndarray:
        """Model joint angles -> servo angles (rad), batched."""
        qa = as_array("q", q, (4,))
        return qa * np.asarray(self.servo_sign, float) + np.asarray(self.servo_offset)

    def from_servo(self, servo: object) -> np.ndarray:
        """Servo angles (rad) -> model joint angles, batched."""
        sa = as_array("servo", servo, (4,))
        return (sa - np.asarray(self.servo_offset)) * np.asarray(self.servo_sign, float)

    def within_limits(self, q: object, tol: float = 1e-9) -> np.ndarray:
        """Boolean (...,) : every joint inside its limits (model space)."""
        qa = as_array("q", q, (4,))
        return np.all((qa >= self.limits[:, 0] - tol) & (qa <= self.limits[:, 1] + tol), axis=-1)

    # ------------------------------------------------------------------ forward kinematics
    def fk(self, q: object) -> np.ndarray:
        """Pen tip and pitch ``(..., 4)`` = ``(x, y, z, phi)`` in cm / rad; ``phi`` in (-pi, pi]."""
        qa = as_array("q", q, (4,))
        q1, q2, q3, q4 = np.moveaxis(qa, -1, 0)
        pa = q2 + self.pitch_offset
        pb = pa + q3
        pt = pb + q4
        r = self.upper_arm * np.cos(pa) + self.forearm * np.cos(pb) + self.tool * np.cos(pt)
        z = (self.shoulder_height + self.upper_arm * np.sin(pa) + self.forearm * np.sin(pb)
             + self.tool * np.sin(pt))
        yaw = q1 + self.yaw_offset
        c, s = np.cos(yaw), np.sin(yaw)
        lf = self.lateral_offset
        x = self.base_xy[0] + r * c + lf * s
        y = self.base_xy[1] + r * s - lf * c
        rel = q2 + q3 + q4
        rel = np.where(r >= 0, rel, (np.pi - 2 * self.pitch_offset) - rel)  # world pitch: see the module docstring
        phi = np.mod(rel + np.pi, TWO_PI) - np.pi
        phi = np.where(phi == -np.pi, np.pi, phi)
        return np.stack([x, y, z, phi], axis=-1)

    def fk_one(self, q1: float, q2: float, q3: float, q4: float) -> tuple[float, float, float, float]:
        """Scalar :meth:`fk` for one configuration (plain floats; the fast path)."""
        pa = q2 + self.pitch_offset
        pb = pa + q3
        pt = pb + q4
        a, b, t = self.upper_arm, self.forearm, self.tool
        r = a * math.cos(pa) + b * math.cos(pb) + t * math.cos(pt)
        z = self.shoulder_height + a * math.sin(pa) + b * math.sin(pb) + t * math.sin(pt)
        yaw = q1 + self.yaw_offset
        c, s = math.cos(yaw), math.sin(yaw)
        lf = self.lateral_offset
        rel = q2 + q3 + q4 if r >= 0 else (math.pi - 2 * self.pitch_offset) - (q2 + q3 + q4)
        return (self.base_xy[0] + r * c + lf * s, self.base_xy[1] + r * s - lf * c, z, _wrap(rel))

    def joint_positions(self, q: object) -> np.ndarray:
        """World positions of base, shoulder, elbow, wrist and pen tip: ``(..., 5, 3)``."""
        qa = as_array("q", q, (4,))
        q1, q2, q3, q4 = np.moveaxis(qa, -1, 0)
        yaw = q1 + self.yaw_offset
        u = np.stack([np.cos(yaw), np.sin(yaw)], -1)
        v = np.stack([np.sin(yaw), -np.cos(yaw)], -1)
        pa = q2 + self.pitch_offset
        angles = np.stack([pa, pa + q3, pa + q3 + q4], -1)
        lengths = np.array([self.upper_arm, self.forearm, self.tool])
        r = np.concatenate([np.zeros(qa.shape[:-1] + (1,)),
                            np.cumsum(lengths * np.cos(angles), -1)], -1)
        z = self.shoulder_height + np.concatenate(
            [np.zeros(qa.shape[:-1] + (1,)), np.cumsum(lengths * np.sin(angles), -1)], -1)
        xy = (np.asarray(self.base_xy) + self.lateral_offset * v)[..., None, :] + r[..., None] * u[..., None, :]
        pts = np.concatenate([xy, z[..., None]], -1)
        base = np.concatenate([np.broadcast_to(np.asarray(self.base_xy, float), qa.shape[:-1] + (2,)),
                               np.zeros(qa.shape[:-1] + (1,))], -1)
        return np.concatenate([base[..., None, :], pts], -2)

    def pen_direction(self, q: object) -> np.ndarray:
        """Unit vector from wrist to pen tip, world frame, ``(..., 3)``."""
        qa = as_array("q", q, (4,))
        yaw = qa[..., 0] + self.yaw_offset
        pt = qa[..., 1] + qa[..., 2] + qa[..., 3] + self.pitch_offset
        return np.stack([np.cos(pt) * np.cos(yaw), np.cos(pt) * np.sin(yaw), np.sin(pt)], -1)

    def jacobian(self, q: object) -> np.ndarray:
        """Analytic Jacobian of ``(x, y, z, phi)`` w.r.t. ``q``: ``(..., 4, 4)``."""
        qa = as_array("q", q, (4,))
        q1, q2, q3, q4 = np.moveaxis(qa, -1, 0)
        pa = q2 + self.pitch_offset
        pb, pt = pa + q3, pa + q3 + q4
        a, b, t = self.upper_arm, self.forearm, self.tool
        st, sb, sa = t * np.sin(pt), b * np.sin(pb), a * np.sin(pa)
        ct, cb, ca = t * np.cos(pt), b * np.cos(pb), a * np.cos(pa)
        r = ca + cb + ct
        dr = np.stack([-(sa + sb + st), -(sb + st), -st], -1)  # d r / d(q2, q3, q4)
        dz = np.stack([ca + cb + ct, cb + ct, ct], -1)
        yaw = q1 + self.yaw_offset
        c, s = np.cos(yaw), np.sin(yaw)
        lf = self.lateral_offset
        jac = np.zeros(qa.shape[:-1] + (4, 4))
        jac[..., 0, 0] = -r * s + lf * c
        jac[..., 1, 0] = r * c + lf * s
        jac[..., 0, 1:] = dr * c[..., None]
        jac[..., 1, 1:] = dr * s[..., None]
        jac[..., 2, 1:] = dz
        jac[..., 3, 1:] = np.where(r >= 0, 1.0, -1.0)[..., None]  # world pitch turns round when reaching back
        return jac

    def task_one(self, q: list[float]) -> tuple[list[float], list[list[float]]]:
        """Scalar ``(x, y, z, phi)`` and its 4x4 Jacobian (rows) for the numeric solvers."""
        q1, q2, q3, q4 = q
        pa = q2 + self.pitch_offset
        pb = pa + q3
        pt = pb + q4
        a, b, t = self.upper_arm, self.forearm, self.tool
        ca, cb, ct = a * math.cos(pa), b * math.cos(pb), t * math.cos(pt)
        sa, sb, st = a * math.sin(pa), b * math.sin(pb), t * math.sin(pt)
        r = ca + cb + ct
        yaw = q1 + self.yaw_offset
        c, s = math.cos(yaw), math.sin(yaw)
        lf = self.lateral_offset
        d2, d3, d4 = -(sa + sb + st), -(sb + st), -st
        sign = 1.0 if r >= 0 else -1.0  # world pitch: the pen turns round when the arm reaches back
        rel = q2 + q3 + q4 if r >= 0 else (math.pi - 2 * self.pitch_offset) - (q2 + q3 + q4)
        f = [self.base_xy[0] + r * c + lf * s, self.base_xy[1] + r * s - lf * c,
             self.shoulder_height + sa + sb + st, rel]
        jac = [
            [-r * s + lf * c, d2 * c, d3 * c, d4 * c],
            [r * c + lf * s, d2 * s, d3 * s, d4 * s],
            [0.0, ca + cb + ct, cb + ct, ct],
            [0.0, sign, sign, sign],
        ]
        return f, jac

    # ------------------------------------------------------------------ chains
    def dh_chain(self) -> DHChain:
        """The same arm as a standard DH chain (tool frame: x along the pen)."""
        base = np.eye(4)
        base[:2, 3] = self.base_xy
        return DHChain(
            [
                DHLink(d=self.shoulder_height, theta=self.yaw_offset, alpha=math.pi / 2, joint=0,
                       name="yaw"),
                DHLink(d=self.lateral_offset, theta=self.pitch_offset, a=self.upper_arm, joint=1,
                       name="upper_arm"),
                DHLink(a=self.forearm, joint=2, name="forearm"),
                DHLink(a=self.tool, joint=3, name="pen"),
            ],
            base=base,
        )

    def poe_chain(self) -> PoEChain:
        """The same arm as screw axes and a home pose, written from the geometry at q = 0."""
        yo, po = self.yaw_offset, self.pitch_offset
        u = np.array([math.cos(yo), math.sin(yo), 0.0])
        v = np.array([math.sin(yo), -math.cos(yo), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        heading = math.cos(po) * u + math.sin(po) * up  # every link points this way at q = 0
        base = np.array([self.base_xy[0], self.base_xy[1], 0.0])
        j2 = base + self.shoulder_height * up + self.lateral_offset * v
        j3 = j2 + self.upper_arm * heading
        j4 = j3 + self.forearm * heading
        tip = j4 + self.tool * heading

        def revolute(w: np.ndarray, point: np.ndarray) -> np.ndarray:
            return np.concatenate([w, -np.cross(w, point)])

        screws = np.stack([revolute(up, base), revolute(v, j2), revolute(v, j3), revolute(v, j4)])
        home = np.eye(4)
        home[:3, 0], home[:3, 2] = heading, v
        home[:3, 1] = np.cross(v, heading)
        home[:3, 3] = tip
        return PoEChain(screws=screws, home=home)

    # ------------------------------------------------------------------ inverse kinematics
    def ik_all(self, target: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All four closed-form branches for targets ``(..., 4)`` = ``(x, y, z, phi)``.

        Returns:
            q: ``(..., 4 branches, 4 joints)``, each joint wrapped into its limit interval
               when a representative exists (NaN where the branch is unreachable);
            reachable: ``(..., 4)`` the branch exists geometrically;
            in_limits: ``(..., 4)`` it also respects every joint limit.
        Branch order: :data:`BRANCHES`.

        Speed (the same floating-point operations as the plain formulas, bit for bit):
        one ``arctan2(zw, rw)`` and one ``sin``/``cos``/``arctan2`` of the elbow per reach
        serve both elbow signs (``sin``, ``arctan2`` odd, ``cos`` even); the 14 distinct
        joint rows (``q1`` is shared by both elbows) are computed as contiguous rows, in
        chunks that stay in cache, wrapped with ``fmod`` (what ``np.mod`` computes, without
        its slow loop), and transposed into the output once.
        """
        t = as_array("target", target, (4,))
        lead = t.shape[:-1]
        flat = t.reshape(-1, 4)
        n = flat.shape[0]
        out = np.empty((n, 4, 4))
        ok = np.empty((n, 4), dtype=bool)
        inl = np.empty((n, 4), dtype=bool)
        step = _IK_CHUNK
        for s in range(0, n, step):
            e = min(s + step, n)
            self._ik_chunk(flat[s:e], out[s:e], ok[s:e], inl[s:e])
        return out.reshape(lead + (4, 4)), ok.reshape(lead + (4,)), inl.reshape(lead + (4,))

    def _ik_chunk(self, t: np.ndarray, out: np.ndarray, ok: np.ndarray, inl: np.ndarray) -> None:
        """:meth:`ik_all` on ``t`` (m, 4) into ``out`` (m, 4, 4), ``ok`` and ``inl`` (m, 4)."""
        m = t.shape[0]
        tc = np.ascontiguousarray(t.T)
        x, y, z, phi = tc
        bx, by = self.base_xy
        dx = x - bx
        dy = y - by
        lf = self.lateral_offset
        rho2 = dx * dx
        rho2 += dy * dy
        rho2 -= lf * lf
        rho = np.sqrt(np.maximum(rho2, 0.0))
        psi_t = phi + self.pitch_offset
        a, b, tl = self.upper_arm, self.forearm, self.tool
        bearing = np.arctan2(dy, dx)
        zw = z - self.shoulder_height
        zw -= tl * np.sin(psi_t)
        tc_ = tl * np.cos(psi_t)
        zz = zw * zw
        aa, bb, ab2 = a * a, b * b, 2 * a * b
        rho_ok = rho2 >= 0
        # rows of the 14 distinct joint values: per reach q1, then (q2, q3, q4) per elbow
        rows = np.empty((14, m))
        unreachable = []
        for reach in (0, 1):
            r = rho if reach == 0 else -rho
            # reaching back, the same world pitch is pi - psi_t in the arm's plane (cos flips, sin stays)
            psi_arm = psi_t if reach == 0 else np.pi - psi_t
            base = 7 * reach
            yaw = rows[base]
            np.arctan2(lf, r, out=yaw)
            yaw += bearing
            rw = r - tc_ if reach == 0 else r + tc_
            cos3 = rw * rw
            cos3 += zz
            cos3 -= aa
            cos3 -= bb
            cos3 /= ab2
            valid = np.abs(cos3) <= 1 + 1e-12
            valid &= rho_ok
            ok[:, 2 * reach] = valid
            ok[:, 2 * reach + 1] = valid
            if not valid.all():
                unreachable.append((reach, ~valid))
            q3m = np.arccos(np.clip(cos3, -1.0, 1.0, out=cos3), out=cos3)
            yaw -= self.yaw_offset
            at = np.arctan2(b * np.sin(q3m), a + b * np.cos(q3m))
            base_ang = np.arctan2(zw, rw)
            for elbow in (0, 1):
                # elbow 0: q3 = -q3m, psi_a = base_ang - atan2(-S, C) = base_ang + at
                psi_a = base_ang + at if elbow == 0 else base_ang - at
                k = base + 1 + 3 * elbow
                np.subtract(psi_a, self.pitch_offset, out=rows[k])
                if elbow == 0:
                    np.negative(q3m, out=rows[k + 1])
                else:
                    rows[k + 1] = q3m
                d = np.subtract(psi_arm, psi_a, out=rows[k + 2])
                d -= rows[k + 1]
        # wrap each joint into [lo, lo + 2 pi) as lo + np.mod(v - lo, 2 pi) (np.mod is
        # fmod plus 2 pi where the remainder is negative, -0.0 -> +0.0), then back to the
        # raw value where no representative fits the limits
        lo = self._row_lo
        hi = self._row_hi_tol
        d = rows - lo
        w = np.fmod(d, TWO_PI, out=d)
        w += TWO_PI * (w < 0)
        w += lo
        # a value within 1e-9 below lo + 2 pi means lo (the limit hit exactly)
        close = np.abs(w - TWO_PI - lo) < 1e-9 if (w > lo + (TWO_PI - 1e-8)).any() else None
        if close is not None:
            np.copyto(w, np.broadcast_to(lo, w.shape), where=close)
        # (rows are finite for every existing branch: the inputs are finite)
        outside = w > hi
        np.copyto(w, rows, where=outside)
        # rows -> (m, branch, joint): one transposing copy
        o = out.reshape(m, 16)
        o[:] = w[_ROW_OF_OUT].T
        for reach, bad in unreachable:  # NaN for every joint of a branch that does not exist
            o[bad, 8 * reach:8 * reach + 8] = np.nan
        np.logical_not(outside[_ROW_OF_OUT].reshape(4, 4, m).any(axis=1).T, out=inl)
        inl &= ok

    def _branches_one(self, x: float, y: float, z: float, phi: float) -> list[tuple[float, ...] | None]:
        """Scalar :meth:`ik_all` without limit handling: four raw branches or None."""
        dx, dy = x - self.base_xy[0], y - self.base_xy[1]
        lf = self.lateral_offset
        rho2 = dx * dx + dy * dy - lf * lf
        if rho2 < 0:
            return [None, None, None, None]
        rho = math.sqrt(rho2)
        psi_t = phi + self.pitch_offset
        a, b, tl = self.upper_arm, self.forearm, self.tool
        bearing = math.atan2(dy, dx)
        ct, st = math.cos(psi_t), math.sin(psi_t)
        zw = z - self.shoulder_height - tl * st
        twoab = 2 * a * b
        base2 = zw * zw - a * a - b * b
        out: list[tuple[float, ...] | None] = []
        # reaching back, the same world pitch is pi - psi_t in the arm's plane (cos flips, sin stays)
        for r, tc, psi_arm in ((rho, tl * ct, psi_t), (-rho, -tl * ct, math.pi - psi_t)):
            rw = r - tc
            c3 = (rw * rw + base2) / twoab
            if c3 > 1.0 or c3 < -1.0:
                if abs(c3) > 1 + 1e-12:
                    out += [None, None]
                    continue
                c3 = max(-1.0, min(1.0, c3))
            q1 = bearing + math.atan2(lf, r) - self.yaw_offset
            s3 = math.sqrt(1.0 - c3 * c3)
            base_ang = math.atan2(zw, rw)
            k_c = a + b * c3
            ks = b * s3
            for q3, k_s in ((-math.acos(c3), -ks), (math.acos(c3), ks)):
                psi_a = base_ang - math.atan2(k_s, k_c)
                out.append((q1, psi_a - self.pitch_offset, q3, psi_arm - psi_a - q3))
        return out

    def ik_fast(
        self, x: float, y: float, z: float, phi: float, current: tuple[float, ...] | None = None
    ) -> tuple[float, float, float, float] | None:
        """:meth:`ik` for plain floats, without input checks: a tuple, or None if impossible.

        The microsecond path for control loops and benchmarks (no numpy on the way). It runs
        a function generated for this geometry (constants folded, branches computed lazily:
        without ``current`` it stops at the first in-limit branch), installed on the
        instance on first use so that later calls reach it directly.
        """
        fn = self.__dict__.get("_ik_fast_fn")
        if fn is None:
            fn = ik_fast_function(self)
            object.__setattr__(self, "_ik_fast_fn", fn)
            object.__setattr__(self, "ik_fast", fn)
        return fn(x, y, z, phi, current)

    def __getstate__(self) -> dict:
        # generated functions do not pickle: drop them, they are rebuilt on demand
        state = {k: v for k, v in self.__dict__.items() if k not in ("ik_fast", "_ik_fast_fn")}
        state["_kernels"] = {}
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    def ik(
        self,
        target: object,
        current: object | None = None,
        branch: int | None = None,
    ) -> np.ndarray:
        """Joint angles reaching ``target = (x, y, z, phi)`` inside the joint limits.

        Picks the in-limit branch nearest ``current`` (sum of absolute joint differences,
        seed 002's rule); without ``current``, the first in-limit branch of
        :data:`BRANCHES`. ``branch`` forces one branch.

        Raises:
            InvalidInputError: target not 4 finite numbers (or branch not 0..3).
            UnreachableError: no branch reaches the point (message gives the reach).
            JointLimitError: reachable, but every branch violates a limit.
        """
        t = as_array("target", target, (4,))
        if t.shape != (4,):
            raise InvalidInputError(f"target has shape {t.shape}; expected (4,) - use ik_all for batches")
        cur = None if current is None else as_array("current", current, (4,))
        if cur is not None and cur.shape != (4,):
            raise InvalidInputError(f"current has shape {cur.shape}; expected (4,)")
        if branch is not None and branch not in range(4):
            raise InvalidInputError(f"branch={branch!r}; expected 0..3 ({', '.join(BRANCHES)})")
        raw = self._branches_one(*map(float, t))
        best, best_cost, reachable = None, math.inf, False
        for k, qb in enumerate(raw):
            if qb is None or (branch is not None and k != branch):
                continue
            reachable = True
            qw = []
            for qi, (lo, hi) in zip(qb, self._lim):  # type: ignore[attr-defined]
                w = lo + (qi - lo) % TWO_PI
                if w > hi + 1e-9:
                    if abs(w - TWO_PI - lo) < 1e-9:
                        w = lo
                    else:
                        break
                qw.append(w)
            else:
                if cur is None:
                    return np.array(qw)
                cost = sum(abs(a - b) for a, b in zip(qw, cur))
                if cost < best_cost:
                    best, best_cost = qw, cost
        if best is not None:
            return np.array(best)
        x, y, z, phi = map(float, t)
        if not reachable:
            reach = self.upper_arm + self.forearm
            raise UnreachableError(
                f"target (x={x:.4g}, y={y:.4g}, z={z:.4g} cm, phi={math.degrees(phi):.4g} deg) is out "
                f"of reach of arm '{self.name}': the wrist point must lie within "
                f"{abs(self.upper_arm - self.forearm):.4g}..{reach:.4g} cm of the shoulder",
                target=[x, y, z, phi],
            )
        raise JointLimitError(
            f"target (x={x:.4g}, y={y:.4g}, z={z:.4g} cm, phi={math.degrees(phi):.4g} deg) is "
            f"reachable by arm '{self.name}' only outside its joint limits "
            f"{np.degrees(self.limits).round(1).tolist()} deg",
            target=[x, y, z, phi],
        )
