"""The climber's physics as a reference: the planner's climbs in pymunk, and how often the
gait model's verdict on a move agrees with physics.

Run::

    python bench/bench_climber.py [--walls 200] [--moves 2000]

* **Planner in physics**: :class:`~kinegym.agents.gait_planner.PlannerAgent` climbs
  ``--walls`` held-out generated walls (``reset(seed=1_000_000 + i)``, the seeds the
  evaluation uses) in ``HoleClimb-v0`` with ``mode="physics"`` and, as the anchor, in
  kinematic mode: success, falls (each with the reason physics gave), and the moves made
  over the moves of the plan the wall was accepted with.
* **Agreement**: :func:`kinegym.envs.sim.agreement.agreement` on ``--moves`` random moves:
  the confusion matrix of the model's verdict against the physics outcome.

Targets (issue 17): planner >= 98 % in physics, falls <= 0.5 %, moves <= 1.15x the plan;
agreement >= 99 %, "kinematic ok, physics fails" <= 0.5 %.
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium as gym

import kinegym  # noqa: F401
from kinegym.agents.gait_planner import PlannerAgent
from kinegym.agents.rollout import run_episode
from kinegym.envs.sim.agreement import agreement


def planner_climbs(mode: str, walls: int) -> dict[str, object]:
    env = gym.make("kinegym/HoleClimb-v0", mode=mode)
    ok = falls = moves = planned = 0
    failures: list[str] = []
    t0 = time.perf_counter()
    for i in range(walls):
        ep = run_episode(env, PlannerAgent(), seed=1_000_000 + i)
        ok += ep.success
        falls += ep.falls
        moves += ep.moves
        planned += ep.info["planner_moves"]
        if not ep.success:
            failures.append(f"wall {i}: {ep.info['outcome']} after {ep.moves} moves - {ep.info['reason']}")
        if (i + 1) % 20 == 0:
            print(f"  {mode}: {i + 1}/{walls} walls, {ok} climbed", file=sys.stderr, flush=True)
    return {"ok": ok, "falls": falls, "moves": moves, "planned": planned, "failures": failures,
            "seconds": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walls", type=int, default=200, help="held-out walls per mode")
    ap.add_argument("--moves", type=int, default=2000, help="random moves for the agreement matrix")
    args = ap.parse_args()
    print("| planner on held-out walls | climbed | falls | moves / planned | wall time |")
    print("|---|---|---|---|---|")
    for mode in ("kinematic", "physics"):
        r = planner_climbs(mode, args.walls)
        print(f"| {mode} | {r['ok']}/{args.walls} ({100 * r['ok'] / args.walls:.1f} %) | {r['falls']} | "
              f"{r['moves'] / max(r['planned'], 1):.3f} ({r['moves']} / {r['planned']}) | {r['seconds']:.0f} s |",
              flush=True)
        for line in r["failures"]:
            print(f"  - {line}")
    print()
    t0 = time.perf_counter()
    got = agreement(moves=args.moves, seed=0)
    print(got.table())
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
