"""Tic-tac-toe players: losses, move times, and the thesis player against the solver.

Run::

    taskset -c 0 python bench/bench_game.py [--games 1000] [--quick]

1. 3x3x3 solved from the empty board by a fresh solver (no book): median of 20 runs.
2. 5x5x4, the strong player (default budget and book) against random, the thesis player
   and itself, ``--games`` games with the strong player moving first and as many moving
   second: wins / draws / losses per side, and the strong player's move times (median,
   95th percentile, max). The strong player's solver table is kept across a match, as it
   is in a session of games.
3. The thesis player's results against the strong player (its loss rate).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from kinegym.agents.minimax import RandomPlayer, Solver, StrongPlayer, ThesisPlayer, play_game
from kinegym.envs.game import CLASSIC, THESIS, O, X


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--games", type=int, default=1000, help="games per side and opponent")
    ap.add_argument("--quick", action="store_true", help="50 games per side and opponent")
    ap.add_argument("--opponents", default="random,thesis,self", help="comma-separated subset of random,thesis,self")
    args = ap.parse_args()
    opponents = [o.strip() for o in args.opponents.split(",") if o.strip()]
    if not opponents or set(opponents) - {"random", "thesis", "self"}:
        ap.error(f"--opponents {args.opponents!r}; expected a comma-separated subset of random,thesis,self")
    games = 50 if args.quick else args.games

    ts = []
    for _ in range(20):
        t0 = time.perf_counter()
        v = Solver(CLASSIC).value(CLASSIC.empty())
        ts.append(time.perf_counter() - t0)
    print(f"3x3x3 from empty: value {v} (draw), fresh solver, median {np.median(ts) * 1e3:.2f} ms\n")

    print(f"5x5x4, {games} games per side and opponent (strong = StrongPlayer, budget 0.4 s, book)")
    print("| opponent | strong plays | strong wins | draws | strong losses | strong move median ms | p95 ms | max ms |")
    print("|---|---|---|---|---|---|---|---|")
    thesis_tally = {"games": 0, "losses": 0, "draws": 0}
    all_times: list[float] = []
    for opp_name in opponents:
        solver = Solver(THESIS)
        for strong_side in (X, O):
            wins = draws = losses = 0
            times: list[float] = []
            for i in range(games):
                strong = StrongPlayer(seed=10_000 + i, solver=solver)
                if opp_name == "random":
                    opp = RandomPlayer(seed=20_000 + i)
                elif opp_name == "thesis":
                    opp = ThesisPlayer(seed=30_000 + i)
                else:
                    opp = StrongPlayer(seed=40_000 + i, solver=solver)
                x, o = (strong, opp) if strong_side == X else (opp, strong)
                rec = play_game(THESIS, x, o)
                times += rec.seconds[0 if strong_side == X else 1::2]
                if rec.winner == strong_side:
                    wins += 1
                elif rec.winner == 0:
                    draws += 1
                else:
                    losses += 1
                if opp_name == "thesis":
                    thesis_tally["games"] += 1
                    thesis_tally["losses"] += rec.winner == strong_side
                    thesis_tally["draws"] += rec.winner == 0
            all_times += times
            t = np.asarray(times) * 1e3
            side = "X (first)" if strong_side == X else "O (second)"
            print(f"| {opp_name} | {side} | {wins} | {draws} | {losses} | {np.median(t):.1f} | "
                  f"{np.percentile(t, 95):.1f} | {t.max():.0f} |", flush=True)
    t = np.asarray(all_times) * 1e3
    print(f"\nstrong player over all {len(t)} moves: median {np.median(t):.1f} ms, p95 {np.percentile(t, 95):.1f} ms, "
          f"max {t.max():.0f} ms")
    g = thesis_tally["games"]
    if not g:
        return
    print(f"thesis player against the strong player: lost {thesis_tally['losses']} of {g} "
          f"({thesis_tally['losses'] / g:.1%}), drew {thesis_tally['draws']} ({thesis_tally['draws'] / g:.1%}), "
          f"won {g - thesis_tally['losses'] - thesis_tally['draws']}")


if __name__ == "__main__":
    main()
