"""Precision tests of the writing arm (seed 003 section 3.5, seed 002's error table) and the
charts that show a :class:`~envs.sim.arm.Recording`.

Tests, each run on a fresh :class:`~envs.sim.arm.ArmSim` from park:

* ``stairs small`` / ``stairs big`` - the pen pressed on the board steps along one axis
  (1 mm steps, then 10 mm steps), holding each step; along ``z`` the steps are in the air;
* ``parallel lines`` - two 10 cm lines 5 cm apart (thesis fig. 3.19);
* ``sine`` - a 10 cm sine wave of 4 cm peak to peak (thesis fig. 3.21).

Per test: the *static* error (settled samples of every hold) and the *dynamic* error
(samples while drawing) of the true tip against the desired pose, in mm, and the same for
the tip the arm believes it has (FK of its encoders). Charts: desired vs FK(encoders) vs
true tip per axis over time, and every servo's torque.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinegym.envs.charts import line_chart

from .arm import ArmSim, Recording
from .strokes import TOOL_PEN, Trajectory, _move, parallel_lines, sine_stroke

__all__ = ["PrecisionResult", "stairs", "run_precision", "axes_chart", "torque_chart", "AXES"]

AXES = ("x", "y", "z")


@dataclass
class PrecisionResult:
    """One precision test: its name, the recording and the error figures (mm)."""

    name: str
    axis: str
    recording: Recording
    errors: dict[str, float]
    believed_errors: dict[str, float]


def stairs(sim: ArmSim, axis: str, step_cm: float, steps: int, hold_s: float = 0.6,
           speed_cm_s: float | None = None) -> Trajectory:
    """From the commanded pose: go to the field centre, press the pen (or, along ``z``, stay
    ``lift_cm`` in the air), then ``steps`` steps of ``step_cm`` along ``axis``, holding each."""
    if axis not in AXES:
        raise ValueError(f"axis {axis!r}; expected one of {AXES}")
    spec, dt = sim.spec, sim.dt
    v = spec.speed() if speed_cm_s is None else speed_cm_s
    c = sim.layout.to_arm(sim.layout.field_centre)
    k = AXES.index(axis)
    z0 = spec.lift_cm if axis == "z" else -spec.press_cm
    start = np.array([c[0], c[1], z0, spec.pen_phi])
    if k < 2:  # centre the run on the field
        start[k] -= 0.5 * step_cm * steps
    cur = sim.pose_cmd()
    lift = np.array([start[0], start[1], spec.lift_cm, spec.pen_phi])
    parts = [_move(np.stack([cur, lift]), spec.travel_speed, spec.accel, dt),
             _move(np.stack([lift, start]), min(v, spec.travel_speed), spec.accel, dt)]
    tool = TOOL_PEN if axis != "z" else 0
    trajs = [Trajectory(dt, p, np.zeros(len(p), np.int8), np.full(len(p), -1, np.int16)) for p in parts if len(p)]
    n_hold = max(1, int(round(hold_s / dt)))
    p = start.copy()
    for i in range(steps + 1):
        if i:
            q = p.copy()
            q[k] += step_cm
            m = _move(np.stack([p, q]), v, spec.accel, dt)
            trajs.append(Trajectory(dt, m, np.full(len(m), tool, np.int8), np.zeros(len(m), np.int16)))
            p = q
        trajs.append(Trajectory(dt, np.repeat(p[None], n_hold, 0), np.full(n_hold, tool, np.int8),
                                np.zeros(n_hold, np.int16), np.ones(n_hold, bool)))
    up = p.copy()
    up[2] = max(p[2], spec.lift_cm)
    m = _move(np.stack([p, up, sim.park_pose]), spec.travel_speed, spec.accel, dt)
    trajs.append(Trajectory(dt, m, np.zeros(len(m), np.int8), np.full(len(m), -1, np.int16)))
    return Trajectory.concat(trajs)


def run_precision(arm: str = "thesis_rrrr", axes: Sequence[str] = ("x", "y"), speed_cm_s: float | None = None,
                  progress: object = None) -> list[PrecisionResult]:
    """Run the stairs along each of ``axes`` plus the parallel lines and the sine wave."""
    for a in axes:
        if a not in AXES:
            raise ValueError(f"axis {a!r}; expected one of {AXES}")
    out = []
    jobs: list[tuple[str, str]] = [(f"stairs small {a}", a) for a in axes] + [(f"stairs big {a}", a) for a in axes]
    jobs += [("parallel lines", "xy"), ("sine", "xy")]
    for name, axis in jobs:
        sim = ArmSim(arm)
        if name.startswith("stairs small"):
            rec = sim.run(stairs(sim, axis, 0.1, 5, speed_cm_s=speed_cm_s))
        elif name.startswith("stairs big"):
            rec = sim.run(stairs(sim, axis, 1.0, 3, speed_cm_s=speed_cm_s))
        elif name == "parallel lines":
            rec = sim.draw(parallel_lines(sim.layout.field_centre), speed_cm_s)
        else:
            rec = sim.draw([sine_stroke(sim.layout.field_centre)], speed_cm_s)
        out.append(PrecisionResult(name, axis, rec, rec.errors_mm(), rec.errors_mm(rec.fk_enc)))
        if callable(progress):
            progress()
    return out


def _window(rec: Recording) -> slice:
    """The samples worth plotting: from the first to the last sample with a tool meant down."""
    m = np.flatnonzero((rec.tool != 0) | rec.hold)
    if not len(m):
        return slice(0, len(rec))
    pad = int(0.3 / rec.dt)
    return slice(max(0, m[0] - pad), min(len(rec), m[-1] + pad))


def axes_chart(rec: Recording, title: str, axes: Sequence[str] = AXES, every: int = 5) -> np.ndarray:
    """Desired vs FK(encoders) vs true tip per axis over time (one panel per axis, stacked)."""
    w = _window(rec)
    t = rec.t[w][::every]
    panels = []
    fk = rec.fk_enc
    for ax in axes:
        k = AXES.index(ax)
        d, b, r = rec.desired[w, k][::every], fk[w, k][::every], rec.tip[w, k][::every]
        lo, hi = float(min(d.min(), r.min(), b.min())), float(max(d.max(), r.max(), b.max()))
        pad = max(0.05, 0.08 * (hi - lo))
        panels.append(line_chart({"desired": (t, d), "FK(encoders)": (t, b), "true tip": (t, r)},
                                 f"{title}: {ax}", "t (s)", f"{ax} (cm)", size=(820, 300),
                                 ylim=(lo - pad, hi + pad), markers=False))
    return np.vstack(panels)


def torque_chart(rec: Recording, title: str, every: int = 5) -> np.ndarray:
    """Every servo's torque (N cm) over time, with the limits in the legend."""
    t = rec.t[::every]
    series = {f"q{j + 1} (limit {rec.arm.max_torque[j]:g})": (t, rec.torque[::every, j]) for j in range(4)}
    tq = rec.torque
    lo, hi = float(tq.min()), float(tq.max())
    pad = max(1.0, 0.08 * (hi - lo))
    return line_chart(series, f"{title}: servo torques", "t (s)", "torque (N cm)", size=(820, 320),
                      ylim=(lo - pad, hi + pad), markers=False)
