"""``kinegym demo``: the main job on built-in defaults.

It reproduces seed 000's inverse example, puts the climber on the seed's wall by IK and
checks it by FK, localises the seed's example angles, solves every IK branch of seed 002's
task 6.4, lets the gait planner climb a generated wall in HoleClimb-v0 and plays one full
game of the writing arm against the thesis player in TicTacToeDraw-v0; it prints what
happened, how long each part took and where the pictures are.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_OK, add_json, emit, out_dir
from kinegym.cli.kin import plot_climber

__all__ = ["add_parsers", "cmd_demo"]


def cmd_demo(args: argparse.Namespace) -> int:
    from kinegym.kinematics.climber import (
        ClimberGeometry,
        body_to_wall,
        hand_positions,
        inverse_program,
    )
    from kinegym.kinematics.holes import HoleMap
    from kinegym.kinematics.writing_arm import WritingArm

    out = out_dir(args.out)
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
    png = plot_climber(out / "climber_on_seed_wall.png", holes, [*centre, 0.0], q_wall, geom, wall)
    files.append(str(png))

    # 3. localisation of seed 000's example angles on its wall
    from kinegym.kinematics.localization import Localizer
    from kinegym.kinematics.pose_fit import AmbiguousFixError, NoiseModel

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
    png = plot_climber(out / "localised_seed_example.png", wall.xy[list(fix.holes)], fix.pose, angles, geom, wall)
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
    emit(args, {"steps": [{"step": a, "result": b, "status": c, "seconds": t} for (a, b, c), t in zip(rows, per_row)],
                 "files": files, "seconds": elapsed}, "\n".join(lines))
    return EXIT_OK


def _demo_climb(out: Path) -> dict[str, Any]:
    """The gait planner climbing a generated wall; a GIF of the climb."""
    import gymnasium as gym

    import kinegym  # noqa: F401
    from kinegym.agents.gait_planner import PlannerAgent
    from kinegym.agents.rollout import run_episode
    from kinegym.envs.draw import save_gif

    env = gym.make("kinegym/HoleClimb-v0", render_mode="rgb_array")
    ep = run_episode(env, PlannerAgent(), seed=1, frames=True)
    frames, info = ep.frames, ep.info
    gif = save_gif(frames, out / "climb.gif", env.unwrapped.metadata["render_fps"])
    from kinegym.envs.draw import save_rgb

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
    from kinegym.agents.minimax import StrongPlayer
    from kinegym.envs.draw import save_gif, save_rgb
    from kinegym.envs.game import Board

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
        if done and u.photo is not None:
            board_png = save_rgb(u.photo, out / "game_photo.png")  # the camera's last look before the wipe
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


def add_parsers(sub: Any) -> None:
    """Add ``demo`` to the main parser's subcommands."""
    d = sub.add_parser("demo", help="the main job on built-in defaults (writes PNGs to --out)")
    d.add_argument("--out", default="kinegym-out", help="output folder (default: ./kinegym-out)")
    d.add_argument("--quick", action="store_true", help="the game with ideal strokes instead of the arm in pymunk")
    add_json(d)
    d.set_defaults(func=cmd_demo)
