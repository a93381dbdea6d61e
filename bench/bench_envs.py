"""Environment speed: HoleClimb-v0 in both modes against Gymnasium's LunarLander-v3 and
BipedalWalker-v3 in the same run (``pip install -e ".[bench]"`` for Box2D).

Run::

    taskset -c 0 python bench/bench_envs.py [--seconds 20] [--climb-only]

* HoleClimb-v0, kinematic: env steps per second under random valid actions (each step
  judges all 3 K candidate moves for the mask and tracks the localiser), and gait moves
  per second of the kinematic climber itself (``KinematicClimber.move``, fresh judgements,
  no cache hits), along random walks on a 10 x 16 wall.
* Climber action masks per second: the 24 moves from one stance judged by the vectorised
  kernel and by the scalar reference, over the same 200 stances (their answers compared).
* HoleClimb-v0, physics: env steps (= gait moves) per second and physics steps per second.
* TicTacToeDraw-v0: agent moves per second (each: the arm's mark, the opponent's mark, a
  photo and a reading; resets with the field and game ends with the wipe included) with
  ``draw_physics=False`` (ideal strokes) and with the arm in pymunk; and over
  ``--ttt-games`` seeded games with the default camera (and a quarter as many with the
  hand-held ``hard`` camera), the share of steps whose board as read equals the true board.
* LunarLander-v3, BipedalWalker-v3: steps per second under random actions.

``--budget`` instead: where a HoleClimb-v0 kinematic step's time goes, part by part (the same
random valid actions, resets included), against issue 17's budget for a step - BipedalWalker-v3's
time per step divided by 2.5 - both timed in the same run.
"""

from __future__ import annotations

import argparse
import functools
import math
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import kinegym  # noqa: F401
from kinegym.envs.climb_task import candidate_holes, start_stances
from kinegym.envs.sim.climber import KinematicClimber
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move, rest_pose
from kinegym.envs.sim.gait_kernel import feasible_moves
from kinegym.kinematics.holes import HoleMap


def env_rate(env: gym.Env, seconds: float, masked: bool, start: Callable[[], object] | None = None
             ) -> tuple[float, int]:
    """Steps per second of ``env`` under random (valid, with ``masked``) actions, resets included;
    ``start`` is called when the clock starts (after the first reset)."""
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    if start is not None:
        start()
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


def mask_rates(seconds: float) -> tuple[float, float, int]:
    """Action masks per second (the 3 K = 24 moves from one stance judged), by the vectorised
    kernel (``gait_kernel.feasible_moves``) and by 24 calls of the scalar reference
    (``gait.plan_move``), over the same stances; and how many single judgements disagreed."""
    model = ClimberModel.from_config()
    wall = HoleMap.grid(10, 16, 15.0, 1.0, missing=0.05, seed=3)
    rng = np.random.default_rng(0)
    starts = start_stances(model, wall)
    jobs = []
    while len(jobs) < 200:
        st = list(starts[int(rng.integers(len(starts)))])
        for _ in range(int(rng.integers(0, 6))):
            near = candidate_holes(wall, st, 8, 40.0)
            st[int(rng.integers(3))] = near[int(rng.integers(len(near)))]
        if len(set(st)) == 3:
            cand = candidate_holes(wall, st, 8, 40.0)
            jobs.append((tuple(st), np.repeat(np.arange(3), len(cand)), np.tile(cand, 3)))
    rates, answers = [], []
    for kernel in (True, False):
        n, t0, got = 0, time.perf_counter(), []
        while time.perf_counter() - t0 < seconds / 2:
            for st, arms, targets in jobs:
                if kernel:
                    got.append(feasible_moves(model, wall, st, arms, targets))
                else:
                    rest = rest_pose(model, wall, st)
                    got.append(np.array([isinstance(plan_move(model, wall, st, int(a), int(h), rest=rest), MovePlan)
                                         for a, h in zip(arms, targets)]))
            n += len(jobs)
        rates.append(n / (time.perf_counter() - t0))
        answers.append(np.concatenate(got[:len(jobs)]))
    return rates[0], rates[1], int((answers[0] != answers[1]).sum())


def step_parts(seconds: float, env_id: str = "kinegym/HoleClimb-v0", warm: float = 0.0, **kwargs: Any
               ) -> tuple[float, int, list[tuple[str, float]]]:
    """Where a HoleClimb kinematic step's time goes, each part timed where the env calls it over
    random valid actions with resets (after ``warm`` seconds of them untimed: a wall pool's tasks
    made and their stances judged): the steps/s (with the timers), the steps, and the parts
    (name, us per step; resets spread over the steps; the parts add up to the whole)."""
    from kinegym.envs import climb_robot

    env = gym.make(env_id, **kwargs)
    if warm > 0:
        env_rate(env, warm, True)
    u = env.unwrapped
    spent: dict[tuple[str, str], float] = {}
    within = ["step"]  # whether a part runs inside a step or a reset

    def timed(name: str, fn: Callable[..., Any], phase: str | None = None) -> Callable[..., Any]:
        @functools.wraps(fn)  # (the env checker reads reset's signature)
        def run(*a: Any, **k: Any) -> Any:
            outer = within[0]
            within[0] = phase or outer
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                key = (within[0], name)
                spent[key] = spent.get(key, 0.0) + time.perf_counter() - t
                within[0] = outer
        return run

    kernel = climb_robot.feasible_moves
    climb_robot.feasible_moves = timed("kernel", kernel)  # the gait kernel inside the mask (bench only)
    try:
        for obj, name, label in ((u.robot, "options", "mask"), (u.robot, "move", "move"),
                                 (u.robot, "relocalise", "localiser"), (u, "_obs", "observation"),
                                 (u, "_info", "info"), (u.task, "new_episode", "new wall")):
            setattr(obj, name, timed(label, getattr(obj, name)))
        u.step, u.reset = timed("env", u.step, "step"), timed("env", u.reset, "reset")
        env.step, env.reset = timed("wrapped", env.step, "step"), timed("wrapped", env.reset, "reset")
        rate, n = env_rate(env, seconds, True, spent.clear)  # the first reset lies outside the clock
    finally:
        climb_robot.feasible_moves = kernel
    us = {k: 1e6 * v / n for k, v in spent.items()}  # per env step, resets spread over the steps

    def part(phase: str, *names: str) -> float:
        return sum(us.get((phase, k), 0.0) for k in names)

    inside = part("step", "mask", "move", "localiser", "observation", "info")
    rows = [("the gait kernel judging a new stance's 24 moves", part("step", "kernel")),
            ("the rest of the mask (candidate holes, stance cache, failed moves)",
             part("step", "mask") - part("step", "kernel")),
            ("the move (kinematic climber, judged by the mask)", part("step", "move")),
            ("the localiser tracking the encoders", part("step", "localiser")),
            ("the observation", part("step", "observation")), ("the info dict", part("step", "info")),
            ("the rest of step() (reward, visit counts, checks)", part("step", "env") - inside),
            ("Gymnasium's wrappers (order enforcing, checker)", part("step", "wrapped") - part("step", "env")),
            ("resets: a new wall, proved climbable by the planner", part("reset", "new wall")),
            ("resets: the rest (hanging the robot, first mask and fix)",
             part("reset", "wrapped") - part("reset", "new wall"))]
    return rate, n, rows


def step_budget(seconds: float) -> None:
    """Print :func:`step_parts` of HoleClimb-v0 (fresh walls) and of the training config's env
    (its id, a pool of 20 walls made and judged first: the steady state of training on a pool)
    against issue 17's budget, 2.5x BipedalWalker-v3's steps/s timed in the same run (without
    Box2D, the parts alone)."""
    runs = [("HoleClimb-v0, a fresh wall every reset", step_parts(seconds)),
            ("HoleClimbMemoryHints-v0, wall_pool=20 (made and judged first)",
             step_parts(seconds, "kinegym/HoleClimbMemoryHints-v0", warm=2 * seconds, wall_pool=20))]
    try:
        bip = env_rate(gym.make("BipedalWalker-v3"), seconds, False)[0]
        print(f"BipedalWalker-v3: {bip:,.0f} steps/s ({1e6 / bip:.0f} us a step); issue 17's budget (2.5x "
              f"BipedalWalker-v3): {1e6 / (2.5 * bip):.0f} us a step\n")
    except (gym.error.DependencyNotInstalled, ImportError) as err:
        print(f"BipedalWalker-v3 not installed ({err}): no budget\n")
        bip = math.nan
    budget = 1e6 / (2.5 * bip)
    print("| part of a step, us per step (x the budget) | " + " | ".join(name for name, _ in runs) + " |")
    print("|---|" + "---|" * len(runs))
    for i, (part, _) in enumerate(runs[0][1][2]):
        print(f"| {part} | " + " | ".join(f"{r[2][i][1]:.1f} ({r[2][i][1] / budget:.2f})" for _, r in runs) + " |")
    totals = [sum(v for _, v in r[2]) for _, r in runs]
    print("| **a whole step** | " + " | ".join(f"**{t:.1f} ({t / budget:.2f})**" for t in totals) + " |")
    print("| steps/s with the timers (steps timed) | " + " | ".join(f"{r[0]:,.0f} ({r[1]})" for _, r in runs) + " |")


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
    ap.add_argument("--climb-only", action="store_true", help="only the climber and the two anchors")
    ap.add_argument("--budget", action="store_true", help="only where a HoleClimb-v0 step's time goes")
    args = ap.parse_args()
    s = args.seconds
    if args.budget:
        step_budget(s)
        return
    if not args.climb_only:
        read_accuracy(args.ttt_games)
        read_accuracy(max(1, args.ttt_games // 4), "hard")
    print("| environment | steps per second | notes |")
    print("|---|---|---|")
    kern, ref, differ = mask_rates(s)
    print(f"| climber action masks, vectorised kernel | {kern:,.0f} | 24 moves judged per mask; scalar reference "
          f"{ref:,.0f} masks/s ({kern / ref:.2f}x); {differ} judgements differ |")
    rate, n = gait_move_rate(s)
    print(f"| climber kinematic gait moves (`KinematicClimber.move`) | {rate:,.0f} | fresh judgements, {n} ok |")
    climb, n = env_rate(gym.make("kinegym/HoleClimb-v0"), s, True)
    print(f"| HoleClimb-v0 kinematic | {climb:,.0f} | random valid actions, {n} steps, resets included |", flush=True)
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
    for phys in (() if args.climb_only else (False, True)):
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
            print(f"| {anchor} | {rate:,.0f} | random actions; HoleClimb-v0 kinematic runs at {climb / rate:.2f}x |",
                  flush=True)
        except (gym.error.DependencyNotInstalled, ImportError) as err:
            print(f"| {anchor} | - | not installed: {err} |")


if __name__ == "__main__":
    main()
