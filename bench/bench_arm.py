"""Writing-arm simulation: speed against real time, drawing errors at the default speed,
servo step responses and homing, on the seed-003 arm (``thesis_rrrr``).

Run::

    taskset -c 0 python bench/bench_arm.py [--homing-seeds 10]

* drawing: the field, an X, an O and the erase pass at the default speed level; per job
  simulated seconds, wall seconds and their ratio (the target: well faster than real
  time), and the true tip's static (settled dwell samples) and dynamic (while drawing)
  error against the desired pose in mm;
* servo steps: a 10 deg step on each joint - settling time (2 %), overshoot, static error,
  peak torque against the limit;
* homing: from random power-on poses (+-15 deg), the residual belief error per joint.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from kinegym.envs.sim import strokes as S
from kinegym.envs.sim.arm import ArmSim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--arm", default="thesis_rrrr")
    ap.add_argument("--homing-seeds", type=int, default=10)
    args = ap.parse_args()

    sim = ArmSim(args.arm)
    lay = sim.layout
    print(f"arm {sim.arm.name}, servo tick {sim.dt * 1000:g} ms, default speed {sim.spec.speed():g} cm/s\n")
    print("| job | simulated s | wall s | x real time | static xy rms / max mm | dynamic xy rms / max mm |")
    print("|---|---|---|---|---|---|")
    jobs = [("field", S.field_strokes(lay)), ("X", S.x_strokes(lay, 0, 0)), ("O", S.o_strokes(lay, 4, 4)),
            ("erase", S.erase_strokes(lay, sim.spec))]
    tot_sim = tot_wall = 0.0
    for name, strokes in jobs:
        t0 = time.perf_counter()
        rec = sim.draw(strokes)
        wall = time.perf_counter() - t0
        tot_sim += rec.duration_s
        tot_wall += wall
        e = rec.errors_mm()
        print(f"| {name} | {rec.duration_s:.1f} | {wall:.2f} | {rec.duration_s / wall:.1f} | "
              f"{e['static_xy_rms']:.2f} / {e['static_xy_max']:.2f} | "
              f"{e['dynamic_xy_rms']:.2f} / {e['dynamic_xy_max']:.2f} |")
    print(f"| all | {tot_sim:.1f} | {tot_wall:.2f} | {tot_sim / tot_wall:.1f} | | |")
    print(f"\nink left after the erase pass: max density {sim.canvas.ink().max():.2e}\n")

    print("| joint | settling s (2 %) | overshoot | static error deg | peak torque / limit |")
    print("|---|---|---|---|---|")
    for j in range(4):
        s2 = ArmSim(args.arm)
        amp = math.radians(10.0) * (1 if s2.q_cmd[j] < s2.arm.limits[j].mean() else -1)
        _, _, tq, m = s2.step_response(j, amp)
        print(f"| q{j + 1} | {m.settling_s:.3f} | {m.overshoot:.1%} | {math.degrees(m.static_error):.3f} | "
              f"{np.abs(tq[:, j]).max() / s2.arm.max_torque[j]:.0%} |")

    res, start, dur = [], [], []
    for seed in range(args.homing_seeds):
        hs = ArmSim(args.arm, seed=seed, homing=True)
        rep = hs.homing_report
        res.append(np.degrees(np.abs(rep.residual)))
        start.append(np.degrees(np.abs(rep.start_error)))
        dur.append(rep.duration_s)
    res, start = np.array(res), np.array(start)
    print(f"\nhoming from {args.homing_seeds} random power-on poses: power-on offset error up to "
          f"{start.max(0).round(1).tolist()} deg per joint -> residual max {res.max(0).round(3).tolist()} deg; "
          f"{np.median(dur):.1f} s simulated (median)")


if __name__ == "__main__":
    main()
