"""``kinegym ik``, ``kinegym fk``, ``kinegym localize`` and ``kinegym sensor-study``: the
climber's and the writing arm's kinematics, and localisation on a map of holes.

Registered on the main parser by :func:`add_parsers`; conventions in :mod:`kinegym.cli.common`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import (
    EXIT_NO_ANSWER,
    EXIT_OK,
    Parser,
    UsageError,
    add_json,
    emit,
    out_dir,
    parse_floats,
    parse_triples,
    rnd,
)

__all__ = ["add_parsers", "climber_geometry", "plot_climber"]


def cmd_ik_climber(args: argparse.Namespace) -> int:
    from kinegym.kinematics.climber import hand_positions, inverse_program, wall_to_body

    holes = parse_triples(args.holes, "--holes")
    centre = parse_floats(args.center, 2, "--center")
    geom = climber_geometry(args)
    heading = math.radians(args.heading)
    q = inverse_program(holes, centre, heading, geom, branch=args.branch)
    hands = hand_positions(q, geom)
    resid = float(np.abs(hands - wall_to_body(holes, [*centre, heading])).max())
    qd = np.degrees(q)
    lines = [f"climber IK: centre ({centre[0]:g}, {centre[1]:g}) cm, heading {args.heading:g} deg,"
             f" links {geom.l1[0]:g}/{geom.l2[0]:g} cm",
             "arm  hole (cm)            shoulder (deg)  elbow (deg)"]
    for i in range(3):
        lines.append(f"{i + 1:>3}  ({holes[i, 0]:8.3f}, {holes[i, 1]:8.3f})  {qd[i, 0]:14.4f}  "
                     f"{qd[i, 1]:11.4f}")
    lines.append(f"round trip (FK of these angles vs holes): {resid:.2e} cm")
    if args.plot:
        plot_climber(args.plot, holes, [*centre, heading], q, geom, None)
        lines.append(f"plot: {args.plot}")
    emit(args, {"angles_deg": rnd(qd), "centre_cm": centre, "heading_deg": args.heading,
                 "holes_cm": holes.tolist(), "roundtrip_error_cm": resid,
                 "plot": args.plot}, "\n".join(lines))
    return EXIT_OK


def cmd_fk_climber(args: argparse.Namespace) -> int:
    from kinegym.kinematics.climber import body_to_wall, elbow_positions, hand_positions

    q = np.radians(parse_triples(args.angles, "--angles"))
    pose = parse_floats(args.pose, 3, "--pose")
    pose[2] = math.radians(pose[2])
    geom = climber_geometry(args)
    hands = body_to_wall(hand_positions(q, geom), pose)
    elbows = body_to_wall(elbow_positions(q, geom), pose)
    lines = ["arm  hand x, y (cm)         elbow x, y (cm)"]
    for i in range(3):
        lines.append(f"{i + 1:>3}  ({hands[i, 0]:8.3f}, {hands[i, 1]:8.3f})   "
                     f"({elbows[i, 0]:8.3f}, {elbows[i, 1]:8.3f})")
    d = np.linalg.norm(hands - np.roll(hands, -1, axis=0), axis=1)
    lines.append(f"hand distances 1-2, 2-3, 3-1: {d[0]:.4f}, {d[1]:.4f}, {d[2]:.4f} cm")
    emit(args, {"hands_cm": rnd(hands), "elbows_cm": rnd(elbows),
                 "hand_distances_cm": rnd(d)}, "\n".join(lines))
    return EXIT_OK


def cmd_ik_arm(args: argparse.Namespace) -> int:
    from kinegym.kinematics.writing_arm import BRANCHES, WritingArm

    arm = WritingArm.from_config(args.arm)
    x, y, z = parse_floats(args.target, 3, "--target")
    target = [x, y, z, math.radians(args.phi)]
    qs, reachable, inlim = arm.ik_all(target)
    cur = None if args.current is None else np.radians(parse_floats(args.current, 4, "--current"))
    q = arm.ik(target, current=cur)  # raises Unreachable/JointLimit -> exit 3
    lines = [f"arm '{arm.name}': target ({x:g}, {y:g}, {z:g}) cm, phi {args.phi:g} deg",
             "branch          q1       q2       q3       q4 (deg)   in limits"]
    for k, name in enumerate(BRANCHES):
        if reachable[k]:
            qd = np.degrees(qs[k])
            lines.append(f"{name:<13} {qd[0]:8.3f} {qd[1]:8.3f} {qd[2]:8.3f} {qd[3]:8.3f}   "
                         f"{'yes' if inlim[k] else 'no'}")
        else:
            lines.append(f"{name:<13}   unreachable")
    err = float(np.linalg.norm(arm.fk(q)[:3] - target[:3]))
    lines.append(f"chosen: {np.degrees(q).round(4).tolist()} deg"
                 f"{' (nearest --current)' if cur is not None else ''}; FK error {err:.1e} cm")
    lines.append(f"servo angles: {np.degrees(arm.to_servo(q)).round(4).tolist()} deg")
    emit(args, {"arm": arm.name, "target": [x, y, z, args.phi],
                 "branches": [{"name": n, "reachable": bool(reachable[k]),
                               "in_limits": bool(inlim[k]),
                               "q_deg": rnd(np.degrees(qs[k])) if reachable[k] else None}
                              for k, n in enumerate(BRANCHES)],
                 "q_deg": rnd(np.degrees(q)), "servo_deg": rnd(np.degrees(arm.to_servo(q))),
                 "fk_error_cm": err}, "\n".join(lines))
    return EXIT_OK


def cmd_fk_arm(args: argparse.Namespace) -> int:
    from kinegym.kinematics.writing_arm import WritingArm

    arm = WritingArm.from_config(args.arm)
    q = np.radians(parse_floats(args.q, 4, "--q"))
    x, y, z, phi = arm.fk(q)
    emit(args, {"arm": arm.name, "x_cm": x, "y_cm": y, "z_cm": z, "phi_deg": math.degrees(phi)},
          f"arm '{arm.name}': pen tip ({x:.4f}, {y:.4f}, {z:.4f}) cm, phi {math.degrees(phi):.4f} deg")
    return EXIT_OK


def _wall(spec: str, args: argparse.Namespace) -> Any:
    """A wall from a config name/path, or ``grid:COLSxROWS`` generated with --spacing/--jitter/--seed."""
    from kinegym.kinematics.holes import HoleMap

    if spec.startswith("grid:"):
        try:
            cols, rows = (int(v) for v in spec[5:].lower().split("x"))
        except ValueError:
            raise UsageError(f"--wall {spec!r} is not grid:COLSxROWS, e.g. grid:50x50") from None
        if not (2 <= cols <= 1000 and 2 <= rows <= 1000 and cols * rows <= 250_000):
            raise UsageError(f"--wall {spec!r}: expected 2..1000 columns and rows, at most 250,000 holes")
        if not (math.isfinite(args.spacing) and 1 <= args.spacing <= 1000):
            raise UsageError(f"--spacing {args.spacing!r}; expected 1..1000 cm")
        if not (math.isfinite(args.jitter) and 0 <= args.jitter < args.spacing / 2):
            raise UsageError(f"--jitter {args.jitter!r}; expected 0 <= jitter < spacing / 2 cm")
        return HoleMap.grid(cols, rows, spacing=args.spacing, jitter=args.jitter, seed=args.seed)
    return HoleMap.from_config(spec)


def _noise(args: argparse.Namespace, geom: Any) -> Any:
    from kinegym.kinematics.pose_fit import NoiseModel

    if args.tolerance is not None:
        if not (math.isfinite(args.tolerance) and 0.001 <= args.tolerance <= 20):
            raise UsageError(f"--tolerance {args.tolerance!r}; expected a length in 0.001..20 cm")
        return NoiseModel(tolerance=args.tolerance)
    sigma = math.degrees(geom.sensor_sigma) if args.sigma is None else args.sigma
    if not (math.isfinite(sigma) and 0.001 <= sigma <= 10):
        raise UsageError(f"--sigma {sigma!r}; expected an angle in 0.001..10 deg (beyond it no grip tells holes "
                         "apart)")
    if not (math.isfinite(args.map_sigma) and 0 <= args.map_sigma <= 5):
        raise UsageError(f"--map-sigma {args.map_sigma!r}; expected a length in 0..5 cm")
    return NoiseModel(sigma_angle=math.radians(sigma), sigma_map=args.map_sigma)


def cmd_localize(args: argparse.Namespace) -> int:
    from kinegym.kinematics.localization import Localizer
    from kinegym.kinematics.pose_fit import AmbiguousFixError, NoFixError

    q = np.radians(parse_triples(args.angles, "--angles"))
    geom = climber_geometry(args)
    wall = _wall(args.wall, args)
    noise = _noise(args, geom)
    loc = Localizer(wall, geom, noise)
    gate = (f"tolerance {noise.tolerance:g} cm" if noise.tolerance is not None else
            f"sigma {math.degrees(noise.sigma_angle):g} deg, map {noise.sigma_map:g} cm, "
            f"chi2 <= {noise.chi2_limit:.3g}")
    try:
        fix = loc.localize(q)
    except AmbiguousFixError as err:
        cands = err.candidates[:10]
        lines = [f"ambiguous on '{wall.name}' ({gate}): {err.count} hole triples fit; most likely:"]
        lines += [f"  p={c.likelihood:.4f}  arms 1,2,3 on {c.ids}  centre ({c.pose[0]:.3f}, {c.pose[1]:.3f}) cm"
                  for c in cands]
        if args.plot:
            _plot_localisation(args.plot, wall, q, geom, cands[:3], f"ambiguous: {err.count} candidates")
            lines.append(f"plot: {args.plot}")
        emit(args, {"error": "AmbiguousFixError", "count": err.count,
                     "candidates": [c.as_dict() for c in cands]}, "\n".join(lines))
        return EXIT_NO_ANSWER
    except NoFixError as err:
        best = err.best
        emit(args, {"error": "NoFixError", "message": str(err), "best": best.as_dict() if best else None},
              f"no fix on '{wall.name}' ({gate}): {err}")
        return EXIT_NO_ANSWER
    std = np.sqrt(np.diag(fix.covariance))
    lines = [f"fix on '{wall.name}' ({gate})"]
    for i in range(3):
        lines.append(f"  arm {i + 1}: hole {fix.ids[i]}  residual {fix.best.residual_cm[i]:.4f} cm")
    lines.append(f"  centre ({fix.centre[0]:.4f}, {fix.centre[1]:.4f}) cm +- ({std[0]:.3f}, {std[1]:.3f}), "
                 f"heading {math.degrees(fix.heading):.3f} +- {math.degrees(std[2]):.3f} deg, chi2 {fix.best.chi2:.3g}")
    if fix.runner_up is not None:
        lines.append(f"  runner-up {fix.runner_up.ids} chi2 {fix.runner_up.chi2:.3g}")
    if args.plot:
        _plot_localisation(args.plot, wall, q, geom, [fix.best], "fix")
        lines.append(f"plot: {args.plot}")
    emit(args, fix.as_dict(), "\n".join(lines))
    return EXIT_OK


def _plot_localisation(path: str, wall: Any, q: np.ndarray, geom: Any, cands: Sequence[Any], title: str) -> None:
    from kinegym.envs.draw import draw_climber, draw_wall, fit_canvas

    canvas = fit_canvas(wall.xy, margin=14.0, scale=max(2.0, min(9.0, 900 / max(1.0, float(np.ptp(wall.xy))))))
    draw_wall(canvas, wall, labels=len(wall) <= 400)
    for k, c in enumerate(cands):
        draw_climber(canvas, c.pose, q, geom, alpha=1.0 if k == 0 else 0.35, label=k == 0)
    canvas.caption([title] + [f"p={c.likelihood:.3f} {c.ids}" for c in cands])
    canvas.save(path)


def cmd_sensor_study(args: argparse.Namespace) -> int:
    from kinegym.envs.charts import line_chart
    from kinegym.envs.draw import save_rgb
    from kinegym.kinematics.sensor_study import sensor_study
    from kinegym.progress import Progress

    sigmas = [float(v) for v in parse_floats(args.sigmas, len(args.sigmas.split(",")), "--sigmas")]
    if not (1 <= len(sigmas) <= 20 and all(0.001 <= s <= 10 for s in sigmas)):
        raise UsageError(f"--sigmas {args.sigmas!r}: expected 1..20 angles in 0.001..10 deg")
    if not (1 <= args.trials <= 1_000_000 and 0 <= args.walks <= 100_000):
        raise UsageError(f"--trials {args.trials} / --walks {args.walks}: expected trials 1..1000000, walks "
                         "0..100000")
    geom = climber_geometry(args)
    wall = _wall(args.wall, args)
    out = Path(args.out)
    with Progress(len(sigmas) * (args.trials + args.walks), "sensor study", enabled=not args.json) as bar:
        rows = sensor_study(wall, [math.radians(s) for s in sigmas], geom, args.trials, args.walks,
                            map_sigma=args.map_sigma, seed=args.seed, progress=bar.update)
    head = (f"{'sigma':>6} {'correct':>8} {'ambig':>7} {'none':>6} {'wrong':>7} {'kept':>7} "
            f"{'err med':>8} {'err p99':>8} {'grips':>6} {'<=3':>6} {'track':>7}")
    lines = [f"sensor study on '{wall.name}' ({len(wall)} holes): {args.trials} grips and {args.walks} walks per sigma",
             head]
    for r in rows:
        lines.append(f"{r['sigma_deg']:6.3g} {r['correct']:8.2%} {r['ambiguous']:7.2%} {r['none']:6.2%} "
                     f"{r['wrong']:7.3%} {r['true_kept']:7.2%} {r['centre_err_median_cm']:8.4f} "
                     f"{r['centre_err_p99_cm']:8.4f} {r['grips_needed_median']:6.3g} {r['lost_within_3']:6.1%} "
                     f"{r['track_correct']:7.2%}")
    lines.append("(sigma in deg; err = centre error at the true holes in cm; grips = median grips from a lost start)")
    out_dir(out)
    xs = [r["sigma_deg"] for r in rows]
    chart = line_chart({"unique & correct (1 grip)": (xs, [r["correct"] for r in rows]),
                        "ambiguous (1 grip)": (xs, [r["ambiguous"] for r in rows]),
                        "wrong (1 grip)": (xs, [r["wrong"] for r in rows]),
                        "lost start: localised <= 3 grips": (xs, [r["lost_within_3"] for r in rows]),
                        "tracking correct": (xs, [r["track_correct"] for r in rows])},
                       f"Localisation on '{wall.name}' vs encoder noise", "encoder sigma (deg)", "share",
                       log_x=True, ylim=(0.0, 1.0))
    png = save_rgb(chart, out / "sensor_study.png")
    lines.append(f"plot: {png}")
    emit(args, {"wall": wall.name, "holes": len(wall), "rows": rows, "plot": str(png)}, "\n".join(lines))
    return EXIT_OK


def climber_geometry(args: argparse.Namespace) -> Any:
    from kinegym.kinematics.climber import ClimberGeometry

    if args.link is None:
        return ClimberGeometry.from_config(args.robot)
    if not (math.isfinite(args.link) and 0 < args.link <= 10_000):
        raise UsageError(f"--link {args.link!r} is not a length in 0..10000 cm")
    return ClimberGeometry.uniform(args.link)


def plot_climber(path: str | Path, holes: np.ndarray, pose: Sequence[float], q: np.ndarray,
                  geom: Any, wall: Any) -> Path:
    from kinegym.envs.draw import draw_climber, draw_wall, fit_canvas

    pts = holes if wall is None else np.concatenate([wall.xy, holes])
    canvas = fit_canvas(pts, margin=14.0, scale=9.0)
    if wall is not None:
        draw_wall(canvas, wall)
    for h in holes:
        canvas.circle(h, 1.0, (90, 90, 90), fill=False, width=0.3)
    draw_climber(canvas, pose, q, geom)
    qd = np.degrees(q)
    canvas.caption([f"centre ({pose[0]:.2f}, {pose[1]:.2f}) cm, heading {math.degrees(pose[2]):.1f} deg"]
                   + [f"arm {i + 1}: shoulder {qd[i, 0]:.2f}, elbow {qd[i, 1]:.2f} deg" for i in range(3)])
    return canvas.save(path)


def add_parsers(sub: Any) -> None:
    """Add ``ik``, ``fk``, ``localize`` and ``sensor-study`` to the main parser's subcommands."""
    def climber_opts(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--link", type=float, default=None,
                        help="all six link lengths in cm (default: from --robot)")
        sp.add_argument("--robot", default="climber",
                        help="robot config name or YAML path (default: climber)")

    ik = sub.add_parser("ik", help="inverse kinematics").add_subparsers(dest="which", required=True,
                                                                       parser_class=Parser)
    ic = ik.add_parser("climber", help="three holes + wanted centre -> six joint angles (deg)")
    ic.add_argument("--holes", required=True, help='hole of arm 1, 2, 3 in cm: "X,Y;X,Y;X,Y"')
    ic.add_argument("--center", required=True, help="wanted body centre X,Y in cm")
    ic.add_argument("--heading", type=float, default=0.0, help="body heading in deg (default 0)")
    ic.add_argument("--branch", type=int, choices=(1, -1), default=1,
                    help="elbow branch: 1 = elbow angle 0..180 deg (seed), -1 = 180..360")
    ic.add_argument("--plot", default=None, help="write a PNG of the robot to this file")
    climber_opts(ic)
    add_json(ic)
    ic.set_defaults(func=cmd_ik_climber)

    ia = ik.add_parser("arm", help="pen pose -> joint angles of the writing arm (all branches)")
    ia.add_argument("--target", required=True, help="pen tip X,Y,Z in cm")
    ia.add_argument("--phi", type=float, default=-90.0,
                    help="pen pitch in deg from the outward horizontal, world frame, less the arm's zero "
                         "(default -90: pen down on the Pincher)")
    ia.add_argument("--current", default=None, help="current joint angles Q1,Q2,Q3,Q4 in deg")
    ia.add_argument("--arm", default="pincher", help="arm config name or YAML path")
    add_json(ia)
    ia.set_defaults(func=cmd_ik_arm)

    fk = sub.add_parser("fk", help="forward kinematics").add_subparsers(dest="which", required=True,
                                                                       parser_class=Parser)
    fc = fk.add_parser("climber", help="six joint angles (deg) -> hands and elbows (cm)")
    fc.add_argument("--angles", required=True, help='shoulder,elbow per arm: "S1,E1;S2,E2;S3,E3"')
    fc.add_argument("--pose", default="0,0,0", help="body pose X,Y,HEADING (cm, cm, deg)")
    climber_opts(fc)
    add_json(fc)
    fc.set_defaults(func=cmd_fk_climber)

    fa = fk.add_parser("arm", help="joint angles (deg) -> pen tip (cm) and pitch (deg)")
    fa.add_argument("--q", required=True, help="Q1,Q2,Q3,Q4 in deg")
    fa.add_argument("--arm", default="pincher", help="arm config name or YAML path")
    add_json(fa)
    fa.set_defaults(func=cmd_fk_arm)

    def wall_opts(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--wall", default="seed_4x4",
                        help="wall config name, YAML path, or grid:COLSxROWS (default seed_4x4)")
        sp.add_argument("--spacing", type=float, default=20.0, help="grid: hole spacing in cm")
        sp.add_argument("--jitter", type=float, default=0.5, help="grid: +- jitter per coordinate in cm")
        sp.add_argument("--seed", type=int, default=0, help="grid and simulation seed")
        sp.add_argument("--map-sigma", type=float, default=None,
                        help="1-sigma error of the mapped hole positions in cm")

    lo = sub.add_parser("localize", help="which holes the climber holds, and where it is, from six angles")
    lo.add_argument("--angles", required=True, help='measured shoulder,elbow per arm in deg: "S1,E1;S2,E2;S3,E3"')
    g = lo.add_mutually_exclusive_group()
    g.add_argument("--sigma", type=float, default=None, help="encoder noise, 1 sigma in deg (default: robot config)")
    g.add_argument("--tolerance", type=float, default=None, help="seed mode: fixed distance tolerance in cm")
    lo.add_argument("--plot", default=None, help="PNG of the map with the robot at the fix")
    wall_opts(lo)
    climber_opts(lo)
    add_json(lo)
    lo.set_defaults(func=cmd_localize, map_default=0.05)

    ss = sub.add_parser("sensor-study", help="simulated grips per encoder noise level: what encoders are needed")
    ss.add_argument("--sigmas", default="0.1,0.25,0.5,1", help="encoder noise levels in deg")
    ss.add_argument("--trials", type=int, default=2000, help="grips per noise level")
    ss.add_argument("--walks", type=int, default=100, help="lost-start walks per noise level")
    ss.add_argument("--out", default="kinegym-out", help="folder for sensor_study.png")
    wall_opts(ss)
    climber_opts(ss)
    add_json(ss)
    ss.set_defaults(func=cmd_sensor_study, map_default=0.01)
