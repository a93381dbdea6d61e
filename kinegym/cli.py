"""The ``kinegym`` command line: the main demo and the kinematics tools.

Conventions (user-facing contract): degrees at the command line, cm for lengths; ``--json``
prints one machine-readable object; exit code 0 = done, 2 = bad input (one line naming the
value), 3 = a well-formed question with no answer (unreachable target, ...), still valid
JSON with ``--json``.

Heavy modules (OpenCV drawing, later pymunk) are imported inside the commands, so
``kinegym --help`` is instant and ``import kinegym`` stays light.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

__all__ = ["main", "UsageError"]

EXIT_OK, EXIT_USAGE, EXIT_NO_ANSWER = 0, 2, 3


class UsageError(ValueError):
    """Bad command-line input; the message names the option and the value."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, no usage dump
        raise UsageError(f"{self.prog}: {message}")


# ---------------------------------------------------------------------------- parsing
def parse_floats(text: str, n: int, option: str) -> list[float]:
    """``"1,2,3"`` -> ``[1.0, 2.0, 3.0]`` with exactly ``n`` finite numbers."""
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        shape = ",".join("N" * 1 for _ in range(n))
        raise UsageError(f"{option} {text!r} is not {n} finite numbers like {shape}")
    return vals


def parse_triples(text: str, option: str, width: int = 2) -> np.ndarray:
    """``"a,b;c,d;e,f"`` -> a (3, width) array (one group per arm)."""
    groups = [g for g in text.split(";")]
    if len(groups) != 3:
        example = ";".join([",".join(["N"] * width)] * 3)
        raise UsageError(f"{option} {text!r} is not 3 groups like {example!r}")
    return np.array([parse_floats(g, width, option) for g in groups])


# ---------------------------------------------------------------------------- output
def _emit(args: argparse.Namespace, obj: dict[str, Any], text: str) -> None:
    if getattr(args, "json", False):
        print(json.dumps(obj))
    else:
        print(text)


def _round(x: Any, nd: int = 6) -> Any:
    if isinstance(x, np.ndarray):
        return np.round(x, nd).tolist()
    if isinstance(x, float):
        return round(x, nd)
    return x


# ---------------------------------------------------------------------------- commands
def cmd_ik_climber(args: argparse.Namespace) -> int:
    from kinematics.climber import hand_positions, inverse_program, wall_to_body

    holes = parse_triples(args.holes, "--holes")
    centre = parse_floats(args.center, 2, "--center")
    geom = _climber_geometry(args)
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
        _plot_climber(args.plot, holes, [*centre, heading], q, geom, None)
        lines.append(f"plot: {args.plot}")
    _emit(args, {"angles_deg": _round(qd), "centre_cm": centre, "heading_deg": args.heading,
                 "holes_cm": holes.tolist(), "roundtrip_error_cm": resid,
                 "plot": args.plot}, "\n".join(lines))
    return EXIT_OK


def cmd_fk_climber(args: argparse.Namespace) -> int:
    from kinematics.climber import body_to_wall, elbow_positions, hand_positions

    q = np.radians(parse_triples(args.angles, "--angles"))
    pose = parse_floats(args.pose, 3, "--pose")
    pose[2] = math.radians(pose[2])
    geom = _climber_geometry(args)
    hands = body_to_wall(hand_positions(q, geom), pose)
    elbows = body_to_wall(elbow_positions(q, geom), pose)
    lines = ["arm  hand x, y (cm)         elbow x, y (cm)"]
    for i in range(3):
        lines.append(f"{i + 1:>3}  ({hands[i, 0]:8.3f}, {hands[i, 1]:8.3f})   "
                     f"({elbows[i, 0]:8.3f}, {elbows[i, 1]:8.3f})")
    d = np.linalg.norm(hands - np.roll(hands, -1, axis=0), axis=1)
    lines.append(f"hand distances 1-2, 2-3, 3-1: {d[0]:.4f}, {d[1]:.4f}, {d[2]:.4f} cm")
    _emit(args, {"hands_cm": _round(hands), "elbows_cm": _round(elbows),
                 "hand_distances_cm": _round(d)}, "\n".join(lines))
    return EXIT_OK


def cmd_ik_arm(args: argparse.Namespace) -> int:
    from kinematics.writing_arm import BRANCHES, WritingArm

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
    _emit(args, {"arm": arm.name, "target": [x, y, z, args.phi],
                 "branches": [{"name": n, "reachable": bool(reachable[k]),
                               "in_limits": bool(inlim[k]),
                               "q_deg": _round(np.degrees(qs[k])) if reachable[k] else None}
                              for k, n in enumerate(BRANCHES)],
                 "q_deg": _round(np.degrees(q)), "servo_deg": _round(np.degrees(arm.to_servo(q))),
                 "fk_error_cm": err}, "\n".join(lines))
    return EXIT_OK


def cmd_fk_arm(args: argparse.Namespace) -> int:
    from kinematics.writing_arm import WritingArm

    arm = WritingArm.from_config(args.arm)
    q = np.radians(parse_floats(args.q, 4, "--q"))
    x, y, z, phi = arm.fk(q)
    _emit(args, {"arm": arm.name, "x_cm": x, "y_cm": y, "z_cm": z, "phi_deg": math.degrees(phi)},
          f"arm '{arm.name}': pen tip ({x:.4f}, {y:.4f}, {z:.4f}) cm, phi {math.degrees(phi):.4f} deg")
    return EXIT_OK


def cmd_demo(args: argparse.Namespace) -> int:
    from kinematics.climber import (
        ClimberGeometry,
        body_to_wall,
        hand_positions,
        inverse_program,
    )
    from kinematics.localization import HoleMap
    from kinematics.writing_arm import WritingArm

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    rows: list[tuple[str, str, str]] = []
    files: list[str] = []

    # 1. seed 000's inverse example, reproduced
    geom = ClimberGeometry.from_config("climber")
    seed_q = np.array([[-69.4851, 101.1454], [72.5795, 88.3680], [170.0409, 61.2544]])
    q = inverse_program([[20, 0], [0, 20], [0, 0]], [6.6289, 7.7378], 0.0, geom)
    dev = float(np.abs(np.degrees(q) - seed_q).max())
    rows.append(("seed 000 inverse example", f"max deviation from the printed angles {dev:.1e} deg",
                 "reproduced" if dev < 1e-3 else "MISMATCH"))

    # 2. the robot on the seed's wall: holes (4,3), (3,3), (3,2), centre inside the triangle
    wall = HoleMap.from_config("seed_4x4")
    held = [(4, 3), (3, 3), (3, 2)]
    holes = np.array([wall.position(h) for h in held])
    centre = holes.mean(axis=0)
    q_wall = inverse_program(holes, centre, 0.0, geom)
    hands = body_to_wall(hand_positions(q_wall, geom), [*centre, 0.0])
    resid = float(np.abs(hands - holes).max())
    rows.append(("climber IK -> FK on seed_4x4", f"holes {held}, centre ({centre[0]:.3f}, "
                 f"{centre[1]:.3f}) cm, hands land within {resid:.1e} cm", "ok" if resid < 1e-9 else "FAIL"))
    png = _plot_climber(out / "climber_on_seed_wall.png", holes, [*centre, 0.0], q_wall, geom, wall)
    files.append(str(png))

    # 3. localisation of seed 000's example angles on its wall
    from kinematics.localization import AmbiguousFixError, Localizer, NoiseModel

    angles = np.radians([[-24, 85], [78, 55], [-155, 103]])
    fix = Localizer(wall, geom, NoiseModel(tolerance=0.15)).localize(angles)
    try:
        Localizer(wall, geom, NoiseModel.from_degrees(0.289)).localize(angles)
        note = "unique also with the angles' 1-deg rounding as noise"
    except AmbiguousFixError as err:
        note = (f"with the angles' 1-deg rounding as noise: {err.count} triples fit, this one p="
                f"{err.candidates[0].likelihood:.2f}")
    rows.append(("localise seed 000's example", f"arms on {fix.ids}, centre ({fix.centre[0]:.2f}, "
                 f"{fix.centre[1]:.2f}) cm (seed printed the mirror (2,3),(3,3),(3,2)); {note}", "ok"))
    png = _plot_climber(out / "localised_seed_example.png", wall.xy[list(fix.holes)], fix.pose, angles, geom, wall)
    files.append(str(png))

    # 4. the writing arm: every IK branch of seed 002's task 6.4 points, FK round trip
    arm = WritingArm.from_config("pincher")
    pts = np.array([[12, 7, 5], [-10, 8, 10], [-13, -13, 4], [8, -12, 6], [15, 0, 7]], float)
    targets = np.concatenate([pts, np.full((5, 1), -math.pi / 2)], axis=1)
    qs, reach, inlim = arm.ik_all(targets)
    f = arm.fk(np.where(reach[..., None], qs, 0.0))
    err = float(np.max(np.where(reach, np.linalg.norm(f[..., :3] - targets[:, None, :3], axis=-1), 0)))
    rows.append(("Pincher IK, seed 002 task 6.4", f"{int(reach.sum())} branches for 5 targets, "
                 f"{int(inlim.sum())} in limits, FK error <= {err:.1e} cm", "ok" if err < 1e-9 else "FAIL"))

    secs = [time.perf_counter() - t_start]  # everything so far: milliseconds

    # 5. a climb on a generated wall by the gait planner
    t0 = time.perf_counter()
    climb = _demo_climb(out)
    rows.append(("HoleClimb-v0: planner climbs", climb["result"], "ok" if climb["success"] else "FAIL"))
    files += climb["files"]
    secs.append(time.perf_counter() - t0)

    # 6. one full game of the arm (solver) against the thesis player, drawn in pymunk and read by the camera
    t0 = time.perf_counter()
    game = _demo_game(out, args.quick)
    rows.append(("TicTacToeDraw-v0: arm vs thesis player", game["result"], game["status"]))
    files += game["files"]
    secs.append(time.perf_counter() - t0)

    elapsed = time.perf_counter() - t_start
    per_row = [secs[0] / (len(rows) - 2)] * (len(rows) - 2) + secs[1:]
    width = max(len(r[0]) for r in rows)
    lines = ["kinegym demo", ""] + [f"{a:<{width}}  {c:<10} {t:6.1f} s  {b}" for (a, b, c), t in zip(rows, per_row)]
    lines += ["", f"done in {elapsed:.1f} s; files in {out}/:"] + [f"  {Path(p).name}" for p in files]
    _emit(args, {"steps": [{"step": a, "result": b, "status": c, "seconds": t} for (a, b, c), t in zip(rows, per_row)],
                 "files": files, "seconds": elapsed}, "\n".join(lines))
    return EXIT_OK


def _demo_climb(out: Path) -> dict[str, Any]:
    """The gait planner climbing a generated wall; a GIF of the climb."""
    import gymnasium as gym

    import kinegym  # noqa: F401
    from agents.gait_planner import PlannerAgent
    from kinegym.cli_climb import save_gif

    env = gym.make("kinegym/HoleClimb-v0", render_mode="rgb_array")
    obs, info = env.reset(seed=1)
    agent = PlannerAgent()
    frames = [env.render()]
    done = False
    while not done:
        a = agent.act(env.unwrapped, obs)
        if a is None:
            break
        obs, r, term, trunc, info = env.step(a)
        frames.append(env.render())
        done = term or trunc
    gif = save_gif(frames, out / "climb.gif", env.unwrapped.metadata["render_fps"])
    from envs.draw import save_rgb

    png = save_rgb(frames[-1], out / "climb_final.png")
    env.close()
    return {"success": bool(info["is_success"]), "files": [str(gif), str(png)],
            "result": f"{info['wall']}: reached the goal in {info['moves']} moves (planner's route "
                      f"{info['planner_moves']})" if info["is_success"] else
                      f"stopped after {info['moves']} moves"}


def _demo_game(out: Path, quick: bool) -> dict[str, Any]:
    """The arm (solver) against the thesis player: homing, field, marks, readings, wipe."""
    import gymnasium as gym

    import kinegym  # noqa: F401
    from agents.minimax import StrongPlayer
    from envs.draw import save_rgb
    from envs.game import Board
    from kinegym.cli_climb import save_gif

    env = gym.make("kinegym/TicTacToeDraw-v0", opponent="thesis", homing=True, draw_physics=not quick,
                   render_mode="rgb_array")
    u = env.unwrapped
    frames: list[np.ndarray] = []
    u.on_frame, u.frame_every_s = frames.append, 2.0
    player = StrongPlayer(seed=0, deterministic=True)
    obs, info = env.reset(seed=0)
    homing = u.sim.homing_report
    reads = [info["read_ok"]]
    right = [info["read_board"] == info["true_board"]]
    done, moves = False, 0
    board_png = None
    while not done:
        a = player.choose(Board.from_cells(u.game, u.belief))
        before_erase = len(frames)
        obs, r, term, trunc, info = env.step(a)
        moves += 1
        reads.append(info["read_ok"])
        right.append(info["read_board"] == info["true_board"])
        frames.append(env.render())
        done = term or trunc
        if done and u._photo is not None:
            board_png = save_rgb(u._photo, out / "game_photo.png")  # the camera's last look before the wipe
            if before_erase < len(frames) - 1:
                save_rgb(frames[before_erase], out / "game_board.png")
    gif = save_gif(frames, out / "game.gif", 4) if frames else None
    files = [str(p) for p in (gif, board_png, out / "game_board.png") if p is not None and Path(p).is_file()]
    env.close()
    who = {"X": "the arm (X) wins", "O": "the thesis player (O) wins", "draw": "a draw"}[info["winner"]]
    hom = ""
    if homing is not None:
        hom = (f"; homed from {np.degrees(np.abs(homing.start_error[:3])).max():.1f} deg off to "
               f"{np.degrees(np.abs(homing.residual)).max():.2f} deg")
    result = (f"{who} after {moves} arm moves; {sum(right)}/{len(right)} readings equal the board, "
              f"{len(reads) - sum(reads)} flagged; {u.sim.time_s:.0f} s of arm motion simulated{hom}")
    return {"result": result, "files": files, "status": "ok" if info["winner"] != "O" and all(right) else "FAIL"}


def _wall(spec: str, args: argparse.Namespace) -> Any:
    """A wall from a config name/path, or ``grid:COLSxROWS`` generated with --spacing/--jitter/--seed."""
    from kinematics.localization import HoleMap

    if spec.startswith("grid:"):
        try:
            cols, rows = (int(v) for v in spec[5:].lower().split("x"))
        except ValueError:
            raise UsageError(f"--wall {spec!r} is not grid:COLSxROWS, e.g. grid:50x50") from None
        return HoleMap.grid(cols, rows, spacing=args.spacing, jitter=args.jitter, seed=args.seed)
    return HoleMap.from_config(spec)


def _noise(args: argparse.Namespace, geom: Any) -> Any:
    from kinematics.localization import NoiseModel

    if args.tolerance is not None:
        if not (math.isfinite(args.tolerance) and args.tolerance > 0):
            raise UsageError(f"--tolerance {args.tolerance!r} is not a length > 0 cm")
        return NoiseModel(tolerance=args.tolerance)
    sigma = math.degrees(geom.sensor_sigma) if args.sigma is None else args.sigma
    if not (math.isfinite(sigma) and sigma > 0):
        raise UsageError(f"--sigma {sigma!r} is not an angle > 0 deg")
    if not (math.isfinite(args.map_sigma) and args.map_sigma >= 0):
        raise UsageError(f"--map-sigma {args.map_sigma!r} is not a length >= 0 cm")
    return NoiseModel(sigma_angle=math.radians(sigma), sigma_map=args.map_sigma)


def cmd_localize(args: argparse.Namespace) -> int:
    from kinematics.localization import AmbiguousFixError, Localizer, NoFixError

    q = np.radians(parse_triples(args.angles, "--angles"))
    geom = _climber_geometry(args)
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
        _emit(args, {"error": "AmbiguousFixError", "count": err.count,
                     "candidates": [c.as_dict() for c in cands]}, "\n".join(lines))
        return EXIT_NO_ANSWER
    except NoFixError as err:
        best = err.best
        _emit(args, {"error": "NoFixError", "message": str(err), "best": best.as_dict() if best else None},
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
    _emit(args, fix.as_dict(), "\n".join(lines))
    return EXIT_OK


def _plot_localisation(path: str, wall: Any, q: np.ndarray, geom: Any, cands: Sequence[Any], title: str) -> None:
    from envs.draw import draw_climber, draw_wall, fit_canvas

    canvas = fit_canvas(wall.xy, margin=14.0, scale=max(2.0, min(9.0, 900 / max(1.0, float(np.ptp(wall.xy))))))
    draw_wall(canvas, wall, labels=len(wall) <= 400)
    for k, c in enumerate(cands):
        draw_climber(canvas, c.pose, q, geom, alpha=1.0 if k == 0 else 0.35, label=k == 0)
    canvas.caption([title] + [f"p={c.likelihood:.3f} {c.ids}" for c in cands])
    canvas.save(path)


def cmd_sensor_study(args: argparse.Namespace) -> int:
    from envs.draw import line_chart, save_rgb
    from kinegym.progress import Progress
    from kinematics.localization import sensor_study

    sigmas = [float(v) for v in parse_floats(args.sigmas, len(args.sigmas.split(",")), "--sigmas")]
    if any(s <= 0 for s in sigmas):
        raise UsageError(f"--sigmas {args.sigmas!r} must all be > 0 deg")
    if args.trials < 1 or args.walks < 0:
        raise UsageError(f"--trials {args.trials} / --walks {args.walks}: need trials >= 1, walks >= 0")
    geom = _climber_geometry(args)
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
    out.mkdir(parents=True, exist_ok=True)
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
    _emit(args, {"wall": wall.name, "holes": len(wall), "rows": rows, "plot": str(png)}, "\n".join(lines))
    return EXIT_OK


# ---------------------------------------------------------------------------- helpers
def _climber_geometry(args: argparse.Namespace) -> Any:
    from kinematics.climber import ClimberGeometry

    if args.link is None:
        return ClimberGeometry.from_config(args.robot)
    if not (math.isfinite(args.link) and args.link > 0):
        raise UsageError(f"--link {args.link!r} is not a length > 0 cm")
    return ClimberGeometry.uniform(args.link)


def _plot_climber(path: str | Path, holes: np.ndarray, pose: Sequence[float], q: np.ndarray,
                  geom: Any, wall: Any) -> Path:
    from envs.draw import draw_climber, draw_wall, fit_canvas

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


# ---------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="kinegym", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def common(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--json", action="store_true", help="print one JSON object")

    d = sub.add_parser("demo", help="the main job on built-in defaults (writes PNGs to --out)")
    d.add_argument("--out", default="kinegym-out", help="output folder (default: ./kinegym-out)")
    d.add_argument("--quick", action="store_true", help="the game with ideal strokes instead of the arm in pymunk")
    common(d)
    d.set_defaults(func=cmd_demo)

    def climber_opts(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--link", type=float, default=None,
                        help="all six link lengths in cm (default: from --robot)")
        sp.add_argument("--robot", default="climber",
                        help="robot config name or YAML path (default: climber)")

    ik = sub.add_parser("ik", help="inverse kinematics").add_subparsers(dest="which", required=True,
                                                                       parser_class=_Parser)
    ic = ik.add_parser("climber", help="three holes + wanted centre -> six joint angles (deg)")
    ic.add_argument("--holes", required=True, help='hole of arm 1, 2, 3 in cm: "X,Y;X,Y;X,Y"')
    ic.add_argument("--center", required=True, help="wanted body centre X,Y in cm")
    ic.add_argument("--heading", type=float, default=0.0, help="body heading in deg (default 0)")
    ic.add_argument("--branch", type=int, choices=(1, -1), default=1,
                    help="elbow branch: 1 = elbow angle 0..180 deg (seed), -1 = 180..360")
    ic.add_argument("--plot", default=None, help="write a PNG of the robot to this file")
    climber_opts(ic)
    common(ic)
    ic.set_defaults(func=cmd_ik_climber)

    ia = ik.add_parser("arm", help="pen pose -> joint angles of the writing arm (all branches)")
    ia.add_argument("--target", required=True, help="pen tip X,Y,Z in cm")
    ia.add_argument("--phi", type=float, default=-90.0,
                    help="pen pitch q2+q3+q4 in deg (default -90: pen down on the Pincher)")
    ia.add_argument("--current", default=None, help="current joint angles Q1,Q2,Q3,Q4 in deg")
    ia.add_argument("--arm", default="pincher", help="arm config name or YAML path")
    common(ia)
    ia.set_defaults(func=cmd_ik_arm)

    fk = sub.add_parser("fk", help="forward kinematics").add_subparsers(dest="which", required=True,
                                                                       parser_class=_Parser)
    fc = fk.add_parser("climber", help="six joint angles (deg) -> hands and elbows (cm)")
    fc.add_argument("--angles", required=True, help='shoulder,elbow per arm: "S1,E1;S2,E2;S3,E3"')
    fc.add_argument("--pose", default="0,0,0", help="body pose X,Y,HEADING (cm, cm, deg)")
    climber_opts(fc)
    common(fc)
    fc.set_defaults(func=cmd_fk_climber)

    fa = fk.add_parser("arm", help="joint angles (deg) -> pen tip (cm) and pitch (deg)")
    fa.add_argument("--q", required=True, help="Q1,Q2,Q3,Q4 in deg")
    fa.add_argument("--arm", default="pincher", help="arm config name or YAML path")
    common(fa)
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
    common(lo)
    lo.set_defaults(func=cmd_localize, map_default=0.05)

    ss = sub.add_parser("sensor-study", help="simulated grips per encoder noise level: what encoders are needed")
    ss.add_argument("--sigmas", default="0.1,0.25,0.5,1", help="encoder noise levels in deg")
    ss.add_argument("--trials", type=int, default=2000, help="grips per noise level")
    ss.add_argument("--walks", type=int, default=100, help="lost-start walks per noise level")
    ss.add_argument("--out", default="kinegym-out", help="folder for sensor_study.png")
    wall_opts(ss)
    climber_opts(ss)
    common(ss)
    ss.set_defaults(func=cmd_sensor_study, map_default=0.01)

    from kinegym import cli_arm, cli_climb, cli_game, cli_play, cli_train

    cli_game.add_parsers(sub, common)
    cli_climb.add_parsers(sub, common)
    cli_arm.add_parsers(sub, common)
    cli_play.add_parsers(sub, common)
    cli_train.add_parsers(sub, common)
    return p


def _glue_negative_values(argv: list[str]) -> list[str]:
    """``--angles -24,85;...`` -> ``--angles=-24,85;...`` (argparse would read an option)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else ""
        if tok.startswith("--") and "=" not in tok and len(nxt) > 1 and nxt[0] == "-" and (
            nxt[1].isdigit() or nxt[1] == "."
        ):
            out.append(f"{tok}={nxt}")
            i += 2
        else:
            out.append(tok)
            i += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code (also used by the ``kinegym`` script)."""
    from configs import ConfigError
    from envs.game import GameError
    from kinematics.errors import InvalidInputError, UnreachableError
    from vision.errors import NoBoardError, VisionError

    argv = _glue_negative_values(list(sys.argv[1:] if argv is None else argv))
    want_json = "--json" in argv
    handlers: list[tuple[type[BaseException], int]] = [
        (UsageError, EXIT_USAGE), (ConfigError, EXIT_USAGE), (InvalidInputError, EXIT_USAGE),
        (UnreachableError, EXIT_NO_ANSWER), (NoBoardError, EXIT_NO_ANSWER), (VisionError, EXIT_USAGE),
        (GameError, EXIT_USAGE),
    ]
    try:
        args = build_parser().parse_args(argv)
        if getattr(args, "map_sigma", 0) is None:
            args.map_sigma = args.map_default
        func: Callable[[argparse.Namespace], int] = args.func
        code = func(args)
        sys.stdout.flush()  # a closed pipe shows here, inside the handler below, not at exit
        return code
    except BrokenPipeError:  # the reader went away (``kinegym ... | head``): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 141  # 128 + SIGPIPE, as a shell reports it
    except tuple(h[0] for h in handlers) as exc:  # type: ignore[misc]
        code = next(c for t, c in handlers if isinstance(exc, t))
        if want_json:
            print(json.dumps({"error": type(exc).__name__, "message": str(exc),
                              **getattr(exc, "details", {})}))
        print(f"kinegym: {exc}" if not str(exc).startswith("kinegym") else str(exc), file=sys.stderr)
        return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
