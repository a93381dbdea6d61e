"""``kinegym draw`` (the thesis's "operational GUI": draw one shape, plot desired vs real per
axis and the servo torques) and ``kinegym precision`` (stairs, parallel lines, a sine wave;
static and dynamic error table in mm).

Registered on the main parser by :func:`add_parsers`; conventions in :mod:`kinegym.cli.common`.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_OK, UsageError, add_json, emit

__all__ = ["add_parsers", "cmd_draw", "cmd_precision", "shape_strokes"]

SHAPES = ("x", "o", "sine", "lines", "field", "erase")


def _cell(text: str, n: int) -> tuple[int, int]:
    try:
        r, c = (int(v) for v in text.split(","))
    except ValueError:
        raise UsageError(f"--cell {text!r}; expected ROW,COL (0-based, row 0 at the top)") from None
    if not (0 <= r < n and 0 <= c < n):
        raise UsageError(f"--cell {text!r} is off the {n} x {n} field; rows and cols are 0..{n - 1}")
    return r, c


def shape_strokes(sim: Any, shape: str, size_cm: float | None, cell: tuple[int, int]) -> list[Any]:
    """The strokes of one ``kinegym draw`` shape on ``sim``'s board (size: see ``--size``)."""
    from kinegym.envs.sim import strokes as S

    lay = sim.layout
    if size_cm is not None and not (math.isfinite(size_cm) and 0 < size_cm <= 30):
        raise UsageError(f"--size {size_cm}; expected a size in 0..30 cm (the board)")
    if shape == "x":
        ratio = None if size_cm is None else size_cm / lay.cell
        if ratio is not None and not 0 < ratio <= 1:
            raise UsageError(f"--size {size_cm} cm: an X must fit its {lay.cell} cm cell")
        return S.x_strokes(lay, *cell, size_ratio=ratio)
    if shape == "o":
        r = None if size_cm is None else 0.5 * size_cm
        if r is not None and not r < 0.5 * lay.cell:
            raise UsageError(f"--size {size_cm} cm: an O must fit inside its {lay.cell} cm cell")
        return S.o_strokes(lay, *cell, radius_cm=r)
    if shape == "sine":
        return [S.sine_stroke(lay.field_centre, size_cm or 10.0)]
    if shape == "lines":
        return S.parallel_lines(lay.field_centre, size_cm or 10.0)
    if shape == "field":
        return S.field_strokes(lay if size_cm is None else lay.with_field(cell=size_cm / lay.n))
    return S.erase_strokes(lay, sim.spec)


def cmd_draw(args: argparse.Namespace) -> int:
    from kinegym.envs.draw import save_gif, save_rgb
    from kinegym.envs.sim.arm import ArmSim
    from kinegym.envs.sim.precision import axes_chart, torque_chart
    from kinegym.progress import Progress

    sim = ArmSim(args.arm, seed=args.seed, homing=args.homing)
    top = len(sim.spec.speed_levels) - 1
    if not 0 <= args.speed <= top:
        raise UsageError(f"--speed {args.speed}; expected a level 0..{top} ({list(sim.spec.speed_levels)} cm/s)")
    strokes = shape_strokes(sim, args.shape, args.size, _cell(args.cell, sim.layout.n))
    if args.shape == "erase":  # something to wipe: the field and a few marks
        from kinegym.envs.sim import strokes as S

        sim.draw(S.field_strokes(sim.layout) + S.x_strokes(sim.layout, 1, 1) + S.o_strokes(sim.layout, 3, 2))
    frames: list[np.ndarray] = []
    speed = sim.spec.speed(args.speed)
    traj = sim.plan(strokes, speed)
    t0 = time.perf_counter()
    with Progress(len(traj), f"draw {args.shape} ({traj.duration_s:.1f} s simulated)", enabled=not args.json) as bar:
        def progress(done: int, total: int) -> None:
            bar.update(done - bar.done)

        rec = sim.run(traj, progress=progress, on_frame=(lambda s: frames.append(s.render())) if args.gif else None,
                      frame_every_s=0.2)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    name = f"draw_{args.shape}"
    files = {"board": str(save_rgb(sim.render(status=[f"{args.shape} at {speed:g} cm/s"]), out / f"{name}.png")),
             "axes": str(save_rgb(axes_chart(rec, f"{args.shape} at {speed:g} cm/s"), out / f"{name}_axes.png")),
             "torques": str(save_rgb(torque_chart(rec, args.shape), out / f"{name}_torques.png"))}
    if args.gif:
        frames.append(sim.render())
        files["gif"] = str(save_gif(frames, args.gif, 10))
    err = rec.errors_mm()
    peak = rec.peak_torque_ratio
    ink = float(sim.canvas.ink().max())
    lines = [f"{sim.arm.name}: drew {args.shape} at level {args.speed:g} ({speed:g} cm/s) in {rec.duration_s:.1f} s "
             f"simulated, {wall:.1f} s wall ({rec.duration_s / wall:.1f}x real time)"]
    if sim.homing_report is not None:
        hr = sim.homing_report
        lines.append(f"homing: power-on offsets {np.degrees(hr.start_error).round(2).tolist()} deg -> residual "
                     f"{np.degrees(hr.residual).round(3).tolist()} deg in {hr.duration_s:.1f} s")
    for kind in ("static", "dynamic"):
        if f"{kind}_xy_rms" in err:
            lines.append(f"{kind:>8} error: xy rms {err[f'{kind}_xy_rms']:.2f} mm, max {err[f'{kind}_xy_max']:.2f} mm "
                         f"(x {err[f'{kind}_x_rms']:.2f}, y {err[f'{kind}_y_rms']:.2f}, z {err[f'{kind}_z_rms']:.2f})")
    lines.append("peak torque / limit: " + ", ".join(f"q{j + 1} {p:.0%}" for j, p in enumerate(peak)))
    if args.shape == "erase":
        lines.append(f"ink left on the board: max density {ink:.4f} (0 = clean)")
    lines += [f"{k}: {v}" for k, v in files.items()]
    emit(args, {"arm": sim.arm.name, "shape": args.shape, "speed_cm_s": speed, "simulated_s": rec.duration_s,
                 "wall_s": wall, "errors_mm": err, "peak_torque_ratio": peak.tolist(), "ink_left": ink,
                 "files": files}, "\n".join(lines))
    return EXIT_OK


def cmd_precision(args: argparse.Namespace) -> int:
    if args.errors is not None:  # the error model on a measured table, not the physics runs
        from kinegym.cli.calib import precision_with_errors

        args.arm_given = args.arm is not None
        return precision_with_errors(args)
    args.arm = args.arm or "thesis_rrrr"
    from kinegym.envs.draw import save_rgb
    from kinegym.envs.sim.arm import ArmSim
    from kinegym.envs.sim.precision import axes_chart, run_precision
    from kinegym.progress import Progress

    axes = ("x", "y", "z") if args.axis == "all" else (args.axis,)
    probe = ArmSim(args.arm)
    top = len(probe.spec.speed_levels) - 1
    if not 0 <= args.speed <= top:
        raise UsageError(f"--speed {args.speed}; expected a level 0..{top}")
    speed = probe.spec.speed(args.speed)
    out = Path(args.out)
    t0 = time.perf_counter()
    with Progress(2 * len(axes) + 2, "precision", enabled=not args.json) as bar:
        results = run_precision(args.arm, axes, speed, progress=bar.update)
    rows, files = [], []
    for r in results:
        e, b = r.errors, r.believed_errors
        rows.append({"test": r.name, "static_rms_mm": e.get("static_xy_rms" if r.axis != "z" else "static_z_rms"),
                     "static_max_mm": e.get("static_xy_max" if r.axis != "z" else "static_z_max"),
                     "dynamic_rms_mm": e.get("dynamic_xy_rms"),
                     "dynamic_max_mm": e.get("dynamic_xy_max"),
                     "believed_static_rms_mm": b.get("static_xy_rms" if r.axis != "z" else "static_z_rms"),
                     "believed_dynamic_rms_mm": b.get("dynamic_xy_rms"), "simulated_s": r.recording.duration_s})
        show = (r.axis,) if r.axis in ("x", "y", "z") else ("x", "y")
        png = out / f"precision_{r.name.replace(' ', '_')}.png"
        files.append(str(save_rgb(axes_chart(r.recording, r.name, show), png)))
    wall = time.perf_counter() - t0

    def f(v: float | None) -> str:
        return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f}"

    lines = [f"{probe.arm.name}: precision at {speed:g} cm/s ({wall:.1f} s wall); errors of the true tip vs the "
             "desired pose, mm (xy distance; z for the z stairs). 'believed': FK of the encoders vs desired.",
             f"{'test':<16} {'static rms':>10} {'static max':>10} {'dyn rms':>8} {'dyn max':>8} "
             f"{'believed static':>15} {'believed dyn':>12}"]
    for r in rows:
        lines.append(f"{r['test']:<16} {f(r['static_rms_mm']):>10} {f(r['static_max_mm']):>10} "
                     f"{f(r['dynamic_rms_mm']):>8} {f(r['dynamic_max_mm']):>8} {f(r['believed_static_rms_mm']):>15} "
                     f"{f(r['believed_dynamic_rms_mm']):>12}")
    lines += [f"plot: {p}" for p in files]
    emit(args, {"arm": probe.arm.name, "speed_cm_s": speed, "tests": rows, "files": files}, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    dr = sub.add_parser("draw", help="the writing arm draws one shape; plots desired vs real and the torques")
    dr.add_argument("--shape", default="x", choices=SHAPES)
    dr.add_argument("--size", type=float, default=None,
                    help="cm: X side, O diameter, sine / line length, field side (default: from the arm config)")
    dr.add_argument("--cell", default="2,2", help="ROW,COL of the X or O (0-based, row 0 at the top)")
    dr.add_argument("--speed", type=float, default=2, help="speed level 0..5 (thesis GUI; default 2 = 3 cm/s)")
    dr.add_argument("--arm", default="thesis_rrrr", help="arm config name or YAML path")
    dr.add_argument("--homing", action="store_true", help="power on with unknown encoder offsets and home first")
    dr.add_argument("--seed", type=int, default=0, help="seed of the power-on pose (with --homing)")
    dr.add_argument("--out", default="kinegym-out", help="folder for the PNGs")
    dr.add_argument("--gif", default=None, help="write the drawing as an animation (.gif, or .mp4 with kinegym[video])")
    add_json(dr)
    dr.set_defaults(func=cmd_draw)

    pr = sub.add_parser("precision", help="stairs, parallel lines and a sine: static and dynamic error in mm")
    pr.add_argument("--axis", default="all", choices=("x", "y", "z", "all"), help="axis of the stairs")
    pr.add_argument("--speed", type=float, default=2, help="speed level 0..5")
    pr.add_argument("--arm", default=None, help="arm config name or YAML path (default: thesis_rrrr)")
    pr.add_argument("--out", default="kinegym-out", help="folder for the PNGs")
    pr.add_argument("--errors", default=None,
                    help="error model (configs/arm_errors name or YAML, e.g. pincher_seed002): run --points "
                         "through it instead of the physics runs")
    pr.add_argument("--points", default="pincher_seed002",
                    help="with --errors: measured points (configs/measurements name or YAML)")
    add_json(pr)
    pr.set_defaults(func=cmd_precision)
