"""What the arm simulation reports: a :class:`Recording` of a motion (desired and real pose per
axis, joint angles, torques, ink), step-response metrics, and the homing report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinegym.kinematics.writing_arm import WritingArm

from .strokes import TOOL_NONE

__all__ = ["Recording", "HomingReport", "StepMetrics", "step_metrics"]


@dataclass(frozen=True)
class HomingReport:
    """What homing found: per joint the offset set (rad), the true power-on offset error it
    removed, reversals made and time taken; ``residual`` is the encoder belief's error after
    homing (rad, per joint; backlash and quantisation remain)."""

    offsets: np.ndarray
    start_error: np.ndarray
    residual: np.ndarray
    reversals: tuple[int, ...]
    duration_s: float


@dataclass(frozen=True)
class StepMetrics:
    """Step response of one joint: settling time (s, into +-``band`` of the step), overshoot
    (fraction of the step), static error (rad, mean over the last 10 %), rise time 10-90 %."""

    settling_s: float
    overshoot: float
    static_error: float
    rise_s: float


def step_metrics(t: np.ndarray, y: np.ndarray, start: float, target: float, band: float = 0.02) -> StepMetrics:
    """Settling time, overshoot, static error and rise time of a response ``y(t)`` to a
    step from ``start`` to ``target``; ``band`` is the settling band as a fraction of the step
    (2 % by default). Settling time is ``inf`` if the response never stays in the band."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    step = target - start
    if step == 0 or len(t) != len(y) or len(t) < 10:
        raise ValueError(f"step_metrics: need a non-zero step and >= 10 matching samples (step {step}, {len(t)})")
    e = (y - target) / step  # 0 at the target, -1 at the start
    outside = np.flatnonzero(np.abs(e) > band)
    if not len(outside):
        settle = 0.0
    elif outside[-1] == len(t) - 1:
        settle = math.inf
    else:
        settle = float(t[outside[-1] + 1] - t[0])
    frac = 1.0 + e  # 0 at start, 1 at target
    overshoot = float(max(0.0, frac.max() - 1.0))
    tail = max(1, len(t) // 10)
    static = float(np.mean(y[-tail:]) - target)
    i10 = np.flatnonzero(frac >= 0.1)
    i90 = np.flatnonzero(frac >= 0.9)
    rise = float(t[i90[0]] - t[i10[0]]) if len(i10) and len(i90) else math.inf
    return StepMetrics(settle, overshoot, static, rise)


@dataclass
class Recording:
    """One run, sampled at every servo tick.

    ``desired`` the wanted pen pose (arm frame x, y, z cm, phi rad), ``q_ref`` the IK'd joint
    targets, ``q_enc`` the joint angles the arm believes (encoders + offsets), ``q_true`` the
    links' true angles, ``torque`` the servo torques (N cm), ``tip`` the true pen pose,
    ``contact`` the board's push on the tool (N), ``tool``/``stroke``/``hold`` from the
    trajectory. :attr:`fk_enc` is the tip where the arm believes it is.
    """

    arm: WritingArm
    dt: float
    desired: np.ndarray
    q_ref: np.ndarray
    q_enc: np.ndarray
    q_true: np.ndarray
    torque: np.ndarray
    tip: np.ndarray
    contact: np.ndarray
    tool: np.ndarray
    stroke: np.ndarray
    hold: np.ndarray

    def __len__(self) -> int:
        return len(self.desired)

    @property
    def duration_s(self) -> float:
        return len(self.desired) * self.dt

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.desired)) * self.dt

    @property
    def fk_enc(self) -> np.ndarray:
        return self.arm.fk(self.q_enc)

    @property
    def fk_ref(self) -> np.ndarray:
        return self.arm.fk(self.q_ref)

    def drawing(self) -> np.ndarray:
        """Mask of samples where a tool was meant to touch and the pose was moving."""
        return (self.tool != TOOL_NONE) & ~self.hold

    def static_samples(self) -> np.ndarray:
        """Mask of the last third of every hold (dwell): the settled samples."""
        out = np.zeros(len(self.hold), bool)
        h = np.concatenate([[False], self.hold, [False]]).astype(np.int8)
        starts, ends = np.flatnonzero(np.diff(h) == 1), np.flatnonzero(np.diff(h) == -1)
        for a, b in zip(starts, ends):
            out[a + 2 * (b - a) // 3:b] = True
        return out

    def errors_mm(self, tip: np.ndarray | None = None) -> dict[str, float]:
        """Static and dynamic error of the true tip (or ``tip``, e.g. :attr:`fk_enc`) against
        the desired pose, in mm: board-plane distance (``xy``) and per axis; ``*_rms`` and
        ``*_max`` over the settled hold samples (static) and the drawing samples (dynamic)."""
        out: dict[str, float] = {}
        d = ((self.tip if tip is None else tip)[:, :3] - self.desired[:, :3]) * 10.0
        for kind, m in (("static", self.static_samples()), ("dynamic", self.drawing())):
            if not m.any():
                continue
            dx = d[m]
            xy = np.hypot(dx[:, 0], dx[:, 1])
            out[f"{kind}_xy_rms"] = float(np.sqrt(np.mean(xy * xy)))
            out[f"{kind}_xy_max"] = float(xy.max())
            for i, ax in enumerate("xyz"):
                out[f"{kind}_{ax}_rms"] = float(np.sqrt(np.mean(dx[:, i] ** 2)))
                out[f"{kind}_{ax}_max"] = float(np.abs(dx[:, i]).max())
        return out

    @property
    def peak_torque_ratio(self) -> np.ndarray:
        """Per joint: the largest |torque| over the servo's limit."""
        lim = np.asarray(self.arm.max_torque, float)
        return np.abs(self.torque).max(axis=0) / lim if len(self.torque) else np.zeros(4)
