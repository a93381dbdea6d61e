"""Why a real writing arm misses: an error model, and its calibration from measured points.

Seed 002 commanded its real Pincher to five points and measured where the pen went: 2.7 cm
off on average, always too low. It named the causes - frame misalignment, link-length
errors, servo resolution and backlash - but modelled none. :class:`ArmErrors` models them
on top of the ideal :class:`~kinegym.kinematics.writing_arm.WritingArm`:

* the base frame: offset ``base_offset_cm`` (x, y, z) and tilt ``base_tilt_deg`` (about x, then y,
  at the base point);
* link lengths: ``link_error_cm`` for the upper arm, forearm and tool;
* joint zeros: ``joint_offset_deg`` for q1..q4 (model joint angles, not servo angles);
* the pitch joints give way under gravity: ``compliance_deg_per_ncm`` (degrees per N cm of the
  gravity torque the joint holds; servo stiffness and link bending in one number) and
  ``backlash_deg`` (the gear play, taken up in the direction gravity pulls).

:func:`real_tip` is where the pen of such an arm goes when it is commanded to ``q``;
:func:`calibrate` estimates the parameters from commanded poses and measured tips (least
squares, Gauss-Newton with step control on a finite-difference Jacobian over the chosen
parameters); :func:`compensate` finds the command that puts the real pen on a target
through a calibrated model. Pure numpy; lengths cm, angles in degrees in the file and the
parameter names, radians inside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

import kinegym.configs as _configs

from .errors import InvalidInputError, as_array
from .writing_arm import WritingArm

__all__ = ["ArmErrors", "ARM_ERRORS_SCHEMA", "MEASUREMENTS_SCHEMA", "PARAMETERS", "real_tip", "gravity_torques",
           "calibrate", "Calibration", "compensate", "load_measurements"]

G = 9.81  # m/s^2: N per kg

#: name -> number of values, in the order of the parameter vector
PARAMETERS: dict[str, int] = {"base_offset_cm": 3, "base_tilt_deg": 2, "link_error_cm": 3, "joint_offset_deg": 4,
                              "compliance_deg_per_ncm": 1, "backlash_deg": 1}
#: name -> the slice of the parameter vector it occupies
_ENDS = np.cumsum(list(PARAMETERS.values()))
_SLICES: dict[str, slice] = {k: slice(int(e - n), int(e)) for (k, n), e in zip(PARAMETERS.items(), _ENDS)}


@dataclass(frozen=True)
class ArmErrors:
    """The ways a built arm differs from its drawing (see the module docstring); zero = ideal."""

    base_offset_cm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_tilt_deg: tuple[float, float] = (0.0, 0.0)
    link_error_cm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    joint_offset_deg: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    compliance_deg_per_ncm: float = 0.0
    backlash_deg: float = 0.0
    name: str = "ideal"
    description: str = field(default="", compare=False)

    def vector(self) -> np.ndarray:
        """The parameters as one vector, in :data:`PARAMETERS` order."""
        return np.concatenate([np.atleast_1d(np.asarray(getattr(self, k), float)) for k in PARAMETERS])

    @classmethod
    def from_vector(cls, v: Sequence[float], name: str = "fitted", description: str = "") -> ArmErrors:
        vals, i = {}, 0
        for k, n in PARAMETERS.items():
            part = [float(x) for x in v[i:i + n]]
            vals[k] = part[0] if n == 1 else tuple(part)
            i += n
        return cls(**vals, name=name, description=description)  # type: ignore[arg-type]

    @classmethod
    def from_config(cls, name_or_path: str | Path) -> ArmErrors:
        """``configs/arm_errors/<name>.yaml`` or a YAML path; raises ``configs.ConfigError``."""
        cfg = _configs.load("arm_errors", name_or_path, ARM_ERRORS_SCHEMA)
        return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in cfg.items()})

    def to_yaml(self) -> str:
        """The parameters as a YAML document :meth:`from_config` reads back."""
        lines = [f"name: {self.name}"] + ([f"description: {self.description!r}"] if self.description else [])
        for k in PARAMETERS:
            v = getattr(self, k)
            lines.append(f"{k}: {[round(x, 6) for x in v] if isinstance(v, tuple) else round(v, 6)}")
        return "\n".join(lines) + "\n"


_N = _configs.Number
ARM_ERRORS_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(default="errors"),
    "description": _configs.Text(default=""),
    "base_offset_cm": _configs.Vector(length=3, default=[0.0, 0.0, 0.0], item=_N(lo=-20.0, hi=20.0)),
    "base_tilt_deg": _configs.Vector(length=2, default=[0.0, 0.0], item=_N(lo=-30.0, hi=30.0),
                                     doc="about x, then y, at the base point"),
    "link_error_cm": _configs.Vector(length=3, default=[0.0, 0.0, 0.0], item=_N(lo=-5.0, hi=5.0),
                                     doc="upper arm, forearm, tool"),
    "joint_offset_deg": _configs.Vector(length=4, default=[0.0, 0.0, 0.0, 0.0], item=_N(lo=-45.0, hi=45.0)),
    "compliance_deg_per_ncm": _N(lo=0.0, hi=1.0, default=0.0, doc="joint give per N cm of gravity torque"),
    "backlash_deg": _N(lo=0.0, hi=20.0, default=0.0, doc="gear play, taken up along gravity"),
}

MEASUREMENTS_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(default="measurements"),
    "description": _configs.Text(default=""),
    "arm": _configs.Text(doc="the arm config the points were commanded on"),
    "phi_deg": _N(lo=-360.0, hi=360.0, default=-90.0, doc="pen pitch of every command"),
    "points": _configs.ListOf(item=_configs.Section(fields={
        "desired_cm": _configs.Vector(length=3),
        "measured_cm": _configs.Vector(length=3),
    }), min_len=1, doc="where the arm was sent and where its pen went"),
}


def load_measurements(name_or_path: str | Path) -> tuple[str, float, np.ndarray, np.ndarray]:
    """``configs/measurements/<name>.yaml``: ``(arm, phi rad, desired (N, 3), measured (N, 3))``."""
    cfg = _configs.load("measurements", name_or_path, MEASUREMENTS_SCHEMA)
    pts = cfg["points"]
    return (cfg["arm"], math.radians(cfg["phi_deg"]), np.array([p["desired_cm"] for p in pts]),
            np.array([p["measured_cm"] for p in pts]))


def gravity_torques(arm: WritingArm, q: object, lengths: Sequence[float] | None = None) -> np.ndarray:
    """Gravity torque (N cm) that joints q2, q3, q4 hold at ``q (..., 4)``: ``(..., 3)``, positive
    lifting. Each link's mass (``arm.mass``: upper arm, forearm, pen holder) sits at its middle."""
    qa = as_array("q", q, (4,))
    a, b, t = lengths if lengths is not None else (arm.upper_arm, arm.forearm, arm.tool)
    pa = qa[..., 1] + arm.pitch_offset
    pb, pt = pa + qa[..., 2], pa + qa[..., 2] + qa[..., 3]
    ma, mb, mt = arm.mass
    # horizontal positions (along the arm) of the joints and link middles, from the shoulder
    ea, wa = a * np.cos(pa), a * np.cos(pa) + b * np.cos(pb)
    ca, cb, ct = 0.5 * a * np.cos(pa), ea + 0.5 * b * np.cos(pb), wa + 0.5 * t * np.cos(pt)
    t2 = ma * ca + mb * cb + mt * ct
    t3 = mb * (cb - ea) + mt * (ct - ea)
    t4 = mt * (ct - wa)
    return -G * np.stack([t2, t3, t4], -1)  # gravity pulls down: a link out front is pulled to lower pitch


def _actual_joints(arm: WritingArm, e: ArmErrors, q: np.ndarray, lengths: Sequence[float]) -> np.ndarray:
    """Where the joints really are when commanded to ``q``: zero offsets, then the give of the
    pitch joints under the gravity torque they hold."""
    qr = q + np.radians(np.asarray(e.joint_offset_deg, float))
    if e.compliance_deg_per_ncm or e.backlash_deg:
        tau = gravity_torques(arm, qr, lengths)
        give = np.radians(e.compliance_deg_per_ncm) * tau + np.radians(0.5 * e.backlash_deg) * np.sign(tau)
        qr = qr.copy()
        qr[..., 1:] += give
    return qr


def real_tip(arm: WritingArm, errors: ArmErrors, q: object) -> np.ndarray:
    """The pen tip ``(..., 3)`` cm of the arm with ``errors`` when commanded to joint angles ``q``."""
    qa = as_array("q", q, (4,))
    lengths = (arm.upper_arm + errors.link_error_cm[0], arm.forearm + errors.link_error_cm[1],
               arm.tool + errors.link_error_cm[2])
    qr = _actual_joints(arm, errors, qa, lengths)
    built = replace(arm, upper_arm=lengths[0], forearm=lengths[1], tool=lengths[2])
    tip = built.fk(qr)[..., :3]
    rx, ry = np.radians(errors.base_tilt_deg)
    cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
    rot = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    base = np.array([arm.base_xy[0], arm.base_xy[1], 0.0])
    return base + (tip - base) @ rot.T + np.asarray(errors.base_offset_cm, float)


@dataclass
class Calibration:
    """What :func:`calibrate` found: the fitted model, which parameters it fitted, the RMS and
    per-point residual (cm) before (ideal model) and after, and the Gauss-Newton iterations."""

    errors: ArmErrors
    fitted: tuple[str, ...]
    residual_before_cm: np.ndarray
    residual_after_cm: np.ndarray
    iterations: int

    @property
    def rms_before_cm(self) -> float:
        return float(np.sqrt(np.mean(self.residual_before_cm ** 2)))

    @property
    def rms_after_cm(self) -> float:
        return float(np.sqrt(np.mean(self.residual_after_cm ** 2)))


def calibrate(arm: WritingArm, q_commanded: object, measured: object, fit: Sequence[str] = tuple(PARAMETERS),
              start: ArmErrors | None = None, max_iter: int = 50) -> Calibration:
    """Least-squares fit of the ``fit`` parameters so that :func:`real_tip` of the commanded
    poses ``(N, 4)`` meets the measured tips ``(N, 3)``; the others stay as in ``start``.

    Gauss-Newton on a central-difference Jacobian, each step halved until the sum of squares
    drops (a rank-deficient set of parameters - e.g. compliance and backlash from one pose -
    is solved in the least-norm sense by ``lstsq``)."""
    q = as_array("q_commanded", q_commanded, (4,)).reshape(-1, 4)
    meas = as_array("measured", measured, (3,)).reshape(-1, 3)
    if len(q) != len(meas):
        raise InvalidInputError(f"{len(q)} commanded poses but {len(meas)} measured points")
    unknown = [k for k in fit if k not in PARAMETERS]
    if unknown:
        raise InvalidInputError(f"fit={unknown!r} unknown; expected names from {list(PARAMETERS)}")
    start = start or ArmErrors()
    v0 = start.vector()
    idx = np.concatenate([np.arange(_SLICES[k].start, _SLICES[k].stop) for k in PARAMETERS if k in fit])

    nonneg = [_SLICES["compliance_deg_per_ncm"].start, _SLICES["backlash_deg"].start]

    def resid(v: np.ndarray) -> np.ndarray:
        try:
            return (real_tip(arm, ArmErrors.from_vector(v), q) - meas).ravel()
        except InvalidInputError:  # a link length <= 0: no arm at all
            return np.full(meas.size, np.inf)

    v = v0.copy()
    r = resid(v)
    before = np.linalg.norm((real_tip(arm, ArmErrors(), q) - meas), axis=1)
    it = 0
    while it < max_iter:
        it += 1
        jac = np.empty((r.size, idx.size))
        for c, i in enumerate(idx):
            h = 1e-4
            vp, vm = v.copy(), v.copy()
            vp[i] += h
            vm[i] -= h
            jac[:, c] = (resid(vp) - resid(vm)) / (2 * h)
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        cost, scale = r @ r, 1.0
        while scale > 1e-6:
            vn = v.copy()
            vn[idx] += scale * step
            vn[nonneg] = np.maximum(vn[nonneg], 0.0)  # a joint gives way under gravity, never against it
            rn = resid(vn)
            if rn @ rn < cost:
                break
            scale *= 0.5
        else:
            break
        v, r = vn, rn
        if np.abs(scale * step).max() < 1e-9:
            break
    fitted = ArmErrors.from_vector(v, name=f"{arm.name} calibrated",
                                   description=f"fitted to {len(q)} points: {', '.join(fit)}")
    after = np.linalg.norm(real_tip(arm, fitted, q) - meas, axis=1)
    return Calibration(fitted, tuple(fit), before, after, it)


def compensate(arm: WritingArm, errors: ArmErrors, target: Sequence[float], current: object | None = None,
               iterations: int = 20, tol: float = 1e-6) -> np.ndarray:
    """The command ``q`` whose real tip (through ``errors``) is the target ``(x, y, z, phi)``'s
    point: re-aim the ideal IK at ``target + (target - real tip)`` until the real tip is within
    ``tol`` cm. Raises the IK's ``UnreachableError`` / ``JointLimitError`` where no command fits."""
    goal = np.asarray(target, float)
    aim = goal.copy()
    q = arm.ik(aim, current=current)
    for _ in range(iterations):
        miss = goal[:3] - real_tip(arm, errors, q)
        if np.linalg.norm(miss) < tol:
            break
        aim[:3] += miss
        q = arm.ik(aim, current=q)
    return q
