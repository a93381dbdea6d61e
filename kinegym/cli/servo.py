"""``kinegym servo step`` and ``kinegym servo tune``: the writing arm's servo loops as the thesis
worked with them (seed 003, section 3.2) - step responses with their figures and a chart, and
the cascade's gains tuned against the simulated plant (:mod:`kinegym.envs.sim.servo_tune`).
Registered on the main parser by :func:`add_parsers`; conventions in :mod:`kinegym.cli.common`.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_OK, Parser, UsageError, add_json, emit, parse_floats, write_text_atomic

__all__ = ["add_parsers", "cmd_step", "cmd_tune"]


def _joint(text: str | int) -> int:
    try:
        j = int(text)
    except ValueError:
        j = 0
    if j not in (1, 2, 3, 4):
        raise UsageError(f"joint {text!r}; expected 1..4 (q1 base yaw .. q4 wrist)")
    return j - 1


def _describe(run: Any) -> dict[str, Any]:
    m = run.metrics
    return {"gains": {"kp_per_s": run.gains[0], "kv_ncm_s": run.gains[1], "ki_ncm": run.gains[2]},
            "settling_s": m.settling_s, "rise_s": m.rise_s, "overshoot": m.overshoot,
            "static_error_rad": m.static_error, "error_at_0_5_s_rad": run.error_at_half_s, "itae": run.itae,
            "peak_torque_ratio": run.peak_torque_ratio}


def _line(name: str, d: dict[str, Any]) -> str:
    g = d["gains"]
    return (f"{name:<8} kp {g['kp_per_s']:7.2f}  kv {g['kv_ncm_s']:7.2f}  ki {g['ki_ncm']:8.1f}  | settle "
            f"{d['settling_s']:5.3f} s  overshoot {100 * d['overshoot']:5.2f} %  static "
            f"{d['static_error_rad']:.5f} rad  at 0.5 s {d['error_at_0_5_s_rad']:.4f} rad  ITAE {d['itae']:.4f}  "
            f"torque {100 * d['peak_torque_ratio']:.0f} %")


def _step(arm: str, joint: int, deg: float, gains: Any = None, duration: float = 1.5) -> Any:
    from kinegym.envs.sim.servo_tune import step_run

    try:
        return step_run(arm, joint, math.radians(deg), gains, duration)
    except ValueError as err:
        raise UsageError(f"--deg {deg:g}: {err}") from None


def cmd_step(args: argparse.Namespace) -> int:
    from kinegym.envs.charts import line_chart
    from kinegym.envs.draw import save_rgb

    j = _joint(args.joint)
    if not (math.isfinite(args.deg) and args.deg != 0 and abs(args.deg) <= 180):
        raise UsageError(f"--deg {args.deg!r}; expected a step of 0 < |deg| <= 180")
    if not 0.2 <= args.duration <= 20:
        raise UsageError(f"--duration {args.duration!r}; expected 0.2..20 s")
    gains = None if args.gains is None else parse_floats(args.gains, 3, "--gains")
    if gains is not None and min(gains) <= 0:
        raise UsageError(f"--gains {args.gains!r}; expected three gains > 0 (KP,KV,KI)")
    run = _step(args.arm, j, args.deg, gains, args.duration)
    d = _describe(run)
    out = Path(args.out)
    t = run.t
    size = (720, 260)
    charts = [line_chart({"reference": (t, np.full_like(t, run.ref)), "position": (t, run.q)},
                         f"q{j + 1}: a {args.deg:g} deg step", "time (s)", "angle (rad)", size=size, markers=False),
              line_chart({"speed": (t, run.speed)}, "", "time (s)", "speed (rad/s)", size=size, markers=False),
              line_chart({"torque": (t, run.torque)}, "", "time (s)", "torque (N cm)", size=size, markers=False)]
    png = save_rgb(np.concatenate(charts, axis=0), out / f"servo_step_q{j + 1}.png")
    lines = [f"{args.arm}: q{j + 1} step of {args.deg:g} deg, {args.duration:g} s", _line("gains", d), f"plot: {png}"]
    emit(args, {"arm": args.arm, "joint": j + 1, "step_deg": args.deg, **d, "plot": str(png)}, "\n".join(lines))
    return EXIT_OK


def cmd_tune(args: argparse.Namespace) -> int:
    from kinegym.envs.sim.servo_tune import tune_joint, tuned_config
    from kinegym.progress import Progress

    if args.out and not args.out.lower().endswith((".yaml", ".yml")):
        raise UsageError(f"--out {args.out!r}: expected a .yaml file (what --arm reads back)")
    joints = [_joint(v) for v in args.joints.split(",") if v.strip()]
    if not joints or len(set(joints)) != len(joints):
        raise UsageError(f"--joints {args.joints!r}; expected distinct joints like 1,2,3")
    if not (math.isfinite(args.deg) and 0 < abs(args.deg) <= 90):
        raise UsageError(f"--deg {args.deg!r}; expected a step of 0 < |deg| <= 90")
    if not 4 <= args.evals <= 2000:
        raise UsageError(f"--evals {args.evals!r}; expected 4..2000 step responses per joint")
    signs = {}
    for j in joints:  # step away from the nearer limit; a step no way fits is a usage error before any search
        try:
            _step(args.arm, j, args.deg, duration=0.2)
            signs[j] = 1.0
        except UsageError:
            _step(args.arm, j, -args.deg, duration=0.2)
            signs[j] = -1.0
    results = []
    with Progress(len(joints) * args.evals, "servo tune", enabled=not args.json) as bar:
        for j in joints:
            results.append(tune_joint(args.arm, j, signs[j] * math.radians(args.deg), args.evals,
                                      progress=bar.update))
    lines = [f"{args.arm}: cascade gains tuned on {args.deg:g} deg steps (ITAE; overshoot <= 2 %, torque under the "
             "limit)"]
    rows = []
    for r in results:
        b, a = _describe(r.before), _describe(r.after)
        rows.append({"joint": r.joint + 1, "evaluations": r.evaluations, "before": b, "after": a})
        lines += [f"q{r.joint + 1} ({r.evaluations} step responses)", "  " + _line("YAML", b), "  " + _line("tuned", a)]
    out = None
    if args.out:
        out = str(write_text_atomic(args.out, tuned_config(args.arm, results)))
        lines.append(f"written: {out} (use it as --arm {out})")
    emit(args, {"arm": args.arm, "step_deg": args.deg, "joints": rows, "out": out}, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    """Add ``servo step`` and ``servo tune`` to the main parser's subcommands."""
    sv = sub.add_parser("servo", help="the writing arm's servo loops: step responses and tuning")
    ss = sv.add_subparsers(dest="which", required=True, parser_class=Parser)
    st = ss.add_parser("step", help="a step on one joint: settling, overshoot, static error; a chart")
    st.add_argument("--joint", default="1", help="joint 1..4 (q1 base yaw .. q4 wrist)")
    st.add_argument("--deg", type=float, default=57.3, help="step in deg (default 57.3 = the thesis's 1 rad)")
    st.add_argument("--duration", type=float, default=1.5, help="seconds to record after the step")
    st.add_argument("--gains", default=None, help="KP,KV,KI instead of the arm's (per s, N cm s, N cm)")
    st.add_argument("--arm", default="thesis_rrrr", help="arm config name or YAML path")
    st.add_argument("--out", default="kinegym-out", help="folder for the chart")
    add_json(st)
    st.set_defaults(func=cmd_step)
    tu = ss.add_parser("tune", help="tune each joint's cascade on the simulated plant; write the gains as YAML")
    tu.add_argument("--joints", default="1,2,3", help="joints to tune (default 1,2,3: the cascade drives)")
    tu.add_argument("--deg", type=float, default=10.0, help="tuning step in deg (default 10)")
    tu.add_argument("--evals", type=int, default=60, help="step responses per joint (default 60)")
    tu.add_argument("--arm", default="thesis_rrrr", help="arm config name or YAML path")
    tu.add_argument("--out", default=None, help="write the arm's YAML with the tuned gains here")
    add_json(tu)
    tu.set_defaults(func=cmd_tune)
