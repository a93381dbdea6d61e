"""The writing arm's servo loops the way the thesis worked with them: step responses, and tuning.

Seed 003 (section 3.2) tuned each drive's cascade - an outer position P loop feeding an
inner speed PI loop - on step responses: settling time, overshoot, static error, and the
error half a second after a 1 rad step. :func:`step_run` runs one such step on the simulated
plant (:class:`~kinegym.envs.sim.arm.ArmSim`: rotor and link inertia, gravity, friction,
backlash, torque and speed limits). :func:`tune_joint` tunes one joint's three gains
``(kp, kv, ki)`` against that plant by minimising the ITAE of a step (the integral of time
times the absolute error, normalised by the step), with penalties for overshoot above 2 % and
for running into the torque limit - a pattern search in log space (each gain doubled or
halved, then by smaller factors), deterministic and free of derivatives, which a
discontinuous cost (saturation, stick-slip) needs. :func:`tuned_config` writes the gains into
a copy of the arm's YAML that the simulation reads.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml

import kinegym.configs as _configs

from .arm import ArmSim
from .arm_record import StepMetrics

__all__ = ["StepRun", "step_run", "TuneResult", "tune_joint", "tuned_config", "Gains"]

#: ``(kp per s, kv N cm s, ki N cm)`` of one joint's cascade, as in the arm YAML
Gains = tuple[float, float, float]


@dataclass
class StepRun:
    """One step response: time from the step (s), reference and true joint angle (rad), speed
    (rad/s), the joint's torque (N cm), the metrics, the error 0.5 s after the step (rad), the
    ITAE (s^2, error normalised by the step) and the peak torque over the servo's limit."""

    t: np.ndarray
    ref: float
    q: np.ndarray
    speed: np.ndarray
    torque: np.ndarray
    metrics: StepMetrics
    error_at_half_s: float
    itae: float
    peak_torque_ratio: float
    gains: Gains


def _gains(sim: ArmSim, joint: int) -> Gains:
    jp = sim.joints[joint]
    return (jp.kp, jp.kv, jp.ki)


def step_run(arm: str | Path, joint: int, amplitude: float, gains: Gains | None = None,
             duration_s: float = 1.5) -> StepRun:
    """A step of ``amplitude`` rad on ``joint`` (0..3) from the park pose, with the arm's gains or
    ``gains``; raises ``ValueError`` if the step leaves the joint limits."""
    sim = ArmSim(arm)
    if gains is not None:
        kp, kv, ki = (float(g) for g in gains)
        sim.joints[joint] = replace(sim.joints[joint], kp=kp, kv=kv, ki=ki)
    t, q, torque, m = sim.step_response(joint, amplitude, duration_s=duration_s)
    t = t - t[0]
    ref = float(sim.q_cmd[joint])
    err = np.abs(ref - q)
    k = min(len(t) - 1, int(np.searchsorted(t, 0.5)))
    f = t * err
    itae = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t))) / abs(amplitude)
    tau = torque[:, joint]
    return StepRun(t, ref, q, np.gradient(q, t), tau, m, float(err[k]), itae,
                   float(np.abs(tau).max() / sim.joints[joint].max_torque), _gains(sim, joint))


def _cost(run: StepRun) -> float:
    """ITAE, made worse by overshoot past 2 % and by a torque at (or beyond) 95 % of the limit."""
    over = max(0.0, run.metrics.overshoot - 0.02)
    sat = max(0.0, run.peak_torque_ratio - 0.95)
    return run.itae * (1.0 + 50.0 * over + 20.0 * sat)


@dataclass
class TuneResult:
    """The joint, the step it was tuned on, the arm's own gains and their run, the tuned gains
    and their run, and how many step responses the search simulated."""

    joint: int
    amplitude: float
    before: StepRun
    after: StepRun
    evaluations: int


def tune_joint(arm: str | Path, joint: int, amplitude: float = math.radians(10.0), max_evals: int = 60,
               progress: Callable[[], None] | None = None) -> TuneResult:
    """Tune ``joint``'s ``(kp, kv, ki)`` on a step of ``amplitude`` rad (see the module docstring)."""
    before = step_run(arm, joint, amplitude)
    x = np.log(np.asarray(before.gains, float))
    best, best_cost, evals = before, _cost(before), 1
    step = math.log(2.0)
    while step > math.log(1.05) and evals < max_evals:
        improved = False
        for i in range(3):
            for sign in (1.0, -1.0):
                if evals >= max_evals:
                    break
                trial = x.copy()
                trial[i] += sign * step
                run = step_run(arm, joint, amplitude, tuple(np.exp(trial)))  # type: ignore[arg-type]
                evals += 1
                if progress is not None:
                    progress()
                c = _cost(run)
                if c < best_cost:
                    x, best, best_cost, improved = trial, run, c, True
                    break
        if not improved:
            step *= 0.5
    return TuneResult(joint, amplitude, before, best, evals)


def tuned_config(arm: str | Path, results: Sequence[TuneResult]) -> str:
    """The arm's YAML with the tuned joints' gains replaced (what ``--arm FILE`` reads back)."""
    path = _configs.resolve("arms", arm)
    raw = _configs.load_yaml(path)
    joints = raw.setdefault("sim", {}).setdefault("joints", [{}, {}, {}, {}])
    for r in results:
        kp, kv, ki = r.after.gains
        joints[r.joint].update({"kp_per_s": round(kp, 4), "kv_ncm_s": round(kv, 4), "ki_ncm": round(ki, 4)})
    head = (f"# {raw.get('name', path.stem)} with servo gains tuned by `kinegym servo tune` (ITAE of a step,\n"
            f"# overshoot <= 2 %, torque under the limit) for joints "
            f"{', '.join(f'q{r.joint + 1}' for r in results)}; everything else as in {path.name}.\n")
    return head + yaml.safe_dump(raw, sort_keys=False, default_flow_style=None, width=110)
