"""Environment speed: HoleClimb-v0 in both modes against Gymnasium's LunarLander-v3 and
BipedalWalker-v3 in the same run (``pip install -e ".[bench]"`` for Box2D).

Run::

    taskset -c 0 python bench/bench_envs.py [--seconds 20]

* HoleClimb-v0, kinematic: env steps per second under random valid actions (each step
  judges all 3 K candidate moves for the mask and tracks the localiser), and gait moves
  per second of the kinematic climber itself (``KinematicClimber.move``, fresh judgements,
  no cache hits), along random walks on a 10 x 16 wall.
* HoleClimb-v0, physics: env steps (= gait moves) per second and physics steps per second.
* TicTacToeDraw-v0: agent moves per second (each: the arm's mark, the opponent's mark, a
  photo and a reading; resets with the field and game ends with the wipe included) with
  ``draw_physics=False`` (ideal strokes) and with the arm in pymunk; and over
  ``--ttt-games`` seeded games with the default camera (and a quarter as many with the
  hand-held ``hard`` camera), the share of steps whose board as read equals the true board.
* LunarLander-v3, BipedalWalker-v3: steps per second under random actions.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import kinegym  # noqa: F401
from kinegym.envs.climb_task import candidate_holes, start_stances
from kinegym.envs.sim.climber import KinematicClimber
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.kinematics.holes import HoleMap


def env_rate(env: gym.Env, seconds: float, masked: bool) -> tuple[float, int]:
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        if masked:
            m = info["action_mask"]
            a = int(rng.choice(np.flatnonzero(m))) if m.any() else 0
        else:
            a = env.action_space.sample()
        obs, r, term, trunc, info = env.step(a)
        n += 1
        if term or trunc:
            obs, info = env.reset()
    return n / (time.perf_counter() - t0), n


def gait_move_rate(seconds: float) -> tuple[float, int]:
    """Moves per second of ``KinematicClimber.move`` along recorded random walks (walks
    recorded first; then replayed with the judgement cache emptied before every move)."""
    model = ClimberModel.from_config()
    wall = HoleMap.grid(10, 16, 15.0, 1.0, missing=0.05, seed=3)
    kin = KinematicClimber(model)
    rng = np.random.default_rng(0)
    starts = start_stances(model, wall)
    walks = []
    for w in range(20):
        kin.reset(wall, starts[w % len(starts)])
        moves = []
        for _ in range(200):
            holes = candidate_holes(wall, kin.stance, 8, 40.0)
            mv = (int(rng.integers(3)), int(holes[int(rng.integers(len(holes)))]))
            kin.move(*mv)
            moves.append(mv)
        walks.append((starts[w % len(starts)], moves))
    n, ok, t0 = 0, 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for start, moves in walks:
            kin.reset(wall, start)
            for arm, hole in moves:
                kin._cache.clear()  # a fresh judgement every time: no cache hits
                ok += kin.move(arm, hole).ok
            n += len(moves)
    return n / (time.perf_counter() - t0), ok


def read_accuracy(games: int, camera: str = "default") -> None:
    """Share of TicTacToeDraw-v0 steps whose accepted reading equals the true board."""
    env = gym.make("kinegym/TicTacToeDraw-v0", draw_physics=False, opponent="thesis", erase=False, camera=camera)
    steps = right = flagged = tries = 0
    for g in range(games):
        rng = np.random.default_rng(g)
        obs, info = env.reset(seed=1000 + g)
        done = False
        while True:
            steps += 1
            right += info["read_board"] == info["true_board"]
            flagged += not info["read_ok"]
            tries += info["read_tries"]
            if done:
                break
            obs, r, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(info["action_mask"]))))
            done = term or trunc
    print(f"TicTacToeDraw-v0 reading, {games} games, {camera} camera: board as read == true board in "
          f"{right}/{steps} steps ({right / steps:.2%}); {flagged} flagged inconsistent (read_ok False); "
          f"{tries / steps:.3f} photos per reading\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="seconds per measurement")
    ap.add_argument("--ttt-games", type=int, default=200, help="games for the TicTacToeDraw reading figure")
    args = ap.parse_args()
    s = args.seconds
    read_accuracy(args.ttt_games)
    read_accuracy(max(1, args.ttt_games // 4), "hard")
    print("| environment | steps per second | notes |")
    print("|---|---|---|")
    rate, n = gait_move_rate(s)
    print(f"| climber kinematic gait moves (`KinematicClimber.move`) | {rate:,.0f} | fresh judgements, {n} ok |")
    rate, n = env_rate(gym.make("kinegym/HoleClimb-v0"), s, True)
    print(f"| HoleClimb-v0 kinematic | {rate:,.0f} | random valid actions, {n} steps |", flush=True)
    env = gym.make("kinegym/HoleClimb-v0", mode="physics")
    rng = np.random.default_rng(1)
    obs, info = env.reset(seed=1)
    steps = moves = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < 3 * s:
        before = env.unwrapped.sim.total_steps
        m = info["action_mask"]
        obs, r, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(m))) if m.any() else 0)
        steps += max(0, env.unwrapped.sim.total_steps - before)
        moves += 1
        if term or trunc:
            obs, info = env.reset()
    el = time.perf_counter() - t0
    print(f"| HoleClimb-v0 physics: gait moves | {moves / el:,.1f} | each a whole simulated motion |")
    print(f"| HoleClimb-v0 physics: pymunk steps | {steps / el:,.0f} | 240 Hz, {steps / max(moves, 1):.0f} "
          f"steps per move |", flush=True)
    for phys in (False, True):
        env = gym.make("kinegym/TicTacToeDraw-v0", draw_physics=phys, opponent="thesis")
        rng = np.random.default_rng(2)
        obs, info = env.reset(seed=2)
        moves, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < (3 if phys else 1) * s:
            obs, r, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(info["action_mask"]))))
            moves += 1
            if term or trunc:
                obs, info = env.reset()
        el = time.perf_counter() - t0
        what = "arm in pymunk (field, marks, wipe)" if phys else "ideal strokes"
        print(f"| TicTacToeDraw-v0, {what} | {moves / el:,.1f} | agent moves (each with the opponent's and a "
              "reading), resets and wipes included |", flush=True)
    for anchor in ("LunarLander-v3", "BipedalWalker-v3"):
        try:
            rate, n = env_rate(gym.make(anchor), s, False)
            print(f"| {anchor} | {rate:,.0f} | random actions |", flush=True)
        except (gym.error.DependencyNotInstalled, ImportError) as err:
            print(f"| {anchor} | - | not installed: {err} |")


if __name__ == "__main__":
    main()
