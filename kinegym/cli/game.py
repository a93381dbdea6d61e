"""Command-line tools for the tic-tac-toe brain and eyes: ``solve``, ``match``, ``read-board``.

Registered on the main parser by :func:`add_parsers`; conventions in :mod:`kinegym.cli.common`
(``--json``, exit codes 0 / 2 / 3).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_NO_ANSWER, EXIT_OK, UsageError, add_json, emit, parse_floats
from kinegym.vision.counts import COUNT_RULES  # numpy only: the parser names the rules

__all__ = ["add_parsers", "cmd_solve", "cmd_match", "cmd_read_board"]

_VALUE = {1: "win", 0: "draw", -1: "loss"}


def _game(board: int, k: int | None) -> Any:
    from kinegym.envs.game import Game

    return Game(board, board, k if k is not None else (3 if board == 3 else 4))


def cmd_solve(args: argparse.Namespace) -> int:
    from kinegym.agents.minimax import SearchTimeout, StrongPlayer
    from kinegym.envs.game import Board

    b = Board.parse(args.board, k=args.k)
    g = b.game
    mover = "X" if b.to_move == 1 else "O"
    if b.is_over:
        emit(args, {"game": str(g), "board": str(b), "result": b.result(), "best_moves": []},
              f"{g}: the game is over ({b.result()}); no move to make")
        return EXIT_NO_ANSWER
    if not (0 < args.time_limit <= 86_400):
        raise UsageError(f"--time-limit {args.time_limit!r}; expected 0 < seconds <= 86400")
    player = StrongPlayer(seed=0, time_budget_s=None, book=not args.no_book)
    t0 = time.perf_counter()
    try:
        a = player.analyse(b, all_best=True, limit_s=args.time_limit)
    except SearchTimeout:
        secs = time.perf_counter() - t0
        emit(args, {"game": str(g), "board": str(b), "to_move": mover, "value": None, "outcome": "unknown",
                    "best_moves": [], "seconds": secs, "time_limit_s": args.time_limit},
             f"{g}, {mover} to move: unknown within the budget ({args.time_limit:g} s; --time-limit to allow more)")
        return EXIT_NO_ANSWER
    secs = time.perf_counter() - t0
    cells = [list(g.rc(c)) for c in sorted(a.best_moves)]
    text = [b.pretty(), "",
            f"{g}, {mover} to move: {_VALUE[a.value]} for {mover} with best play "
            f"({a.source}, {a.nodes} positions, {secs:.3f} s)",
            "best moves (row, col): " + ", ".join(f"({r}, {c})" for r, c in cells)]
    emit(args, {"game": str(g), "board": str(b), "to_move": mover, "value": a.value, "outcome": _VALUE[a.value],
                 "best_moves": cells, "source": a.source, "nodes": a.nodes, "seconds": secs}, "\n".join(text))
    return EXIT_OK


def cmd_match(args: argparse.Namespace) -> int:
    from kinegym.agents.minimax import PLAYERS, play_match
    from kinegym.progress import Progress

    for side, name in (("--x", args.x), ("--o", args.o)):
        if name not in PLAYERS:
            raise UsageError(f"{side} {name!r} is not a player; expected one of: {', '.join(PLAYERS)}")
    if args.games < 1:
        raise UsageError(f"--games {args.games} must be >= 1")
    game = _game(args.board, args.k)
    t0 = time.perf_counter()
    with Progress(args.games, f"{args.x} vs {args.o}", enabled=not args.json) as bar:
        res = play_match(game, args.x, args.o, args.games, seed=args.seed, progress=bar.update)
    secs = time.perf_counter() - t0

    def stats(xs: list[float]) -> dict[str, float]:
        a = np.asarray(xs) if xs else np.zeros(1)
        return {"median_s": float(np.median(a)), "p95_s": float(np.percentile(a, 95)), "max_s": float(a.max())}

    sx, so = stats(res.x_seconds), stats(res.o_seconds)
    lines = [f"{game}: {res.games} games, X = {args.x}, O = {args.o} (seed {args.seed}, {secs:.1f} s)",
             f"  X wins {res.x_wins} ({res.x_wins / res.games:.1%}), O wins {res.o_wins} "
             f"({res.o_wins / res.games:.1%}), draws {res.draws} ({res.draws / res.games:.1%})",
             f"  move time X: median {sx['median_s'] * 1e3:.1f} ms, p95 {sx['p95_s'] * 1e3:.1f} ms, "
             f"max {sx['max_s'] * 1e3:.0f} ms",
             f"  move time O: median {so['median_s'] * 1e3:.1f} ms, p95 {so['p95_s'] * 1e3:.1f} ms, "
             f"max {so['max_s'] * 1e3:.0f} ms"]
    emit(args, {"game": str(game), "x": args.x, "o": args.o, "games": res.games, "x_wins": res.x_wins,
                 "o_wins": res.o_wins, "draws": res.draws, "x_move_time": sx, "o_move_time": so,
                 "seconds": secs}, "\n".join(lines))
    return EXIT_OK


def cmd_read_board(args: argparse.Namespace) -> int:
    from kinegym.vision.board_reader import BoardReader, NoBoardError, debug_image
    from kinegym.vision.image_io import read_image
    from kinegym.vision.reading import UNSURE_GRID

    accept = None if args.accept is None else parse_floats(args.accept, 1, "--accept")[0]
    if accept is not None and not 0.0 <= accept <= 1.0:
        raise UsageError(f"--accept {args.accept!r}: expected a probability in 0..1 (0: the first grid found, "
                         "1: every grid hypothesis)")
    path = Path(args.image)
    rgb = read_image(path)
    reader = BoardReader(size=args.size, counts=args.counts, accept=accept)
    trace: dict[str, object] = {}
    t0 = time.perf_counter()
    try:
        r = reader.read(rgb, trace)
    except NoBoardError as err:
        if args.debug:
            _save(debug_image(rgb, None, trace, str(err)), args.debug)
        emit(args, {"error": "NoBoardError", "message": str(err), "debug": args.debug},
              f"kinegym: {err}" + (f"\ndebug picture: {args.debug}" if args.debug else ""))
        return EXIT_NO_ANSWER
    ms = (time.perf_counter() - t0) * 1e3
    if args.debug:
        _save(debug_image(rgb, r, trace), args.debug)
    rows = r.text().split("|")
    tried = [(str(k), float(p)) for k, p in trace["hypotheses"]]  # type: ignore[attr-defined]
    kind = trace["kind"]
    judged = "" if r.grid_confidence is None else (f"; grid confidence {r.grid_confidence:.2f} ({kind}, "
                                                   f"{len(tried)} grid{'s' * (len(tried) != 1)} tried)")
    text = [f"{r.n} x {r.n} board in {path.name} ({ms:.1f} ms; grid fit {r.grid_error_px:.2f} px over "
            f"{r.grid_points} crossings{judged}; lowest cell confidence {r.confidence.min():.2f})"]
    if r.unsure:
        text.append(f"unsure grid: the reader gives this grid {r.grid_confidence:.2f}, under {UNSURE_GRID} (readings "
                    "that unsure were almost never right); look at --debug, or take another photo")
    text += ["  " + " ".join(row) for row in rows]
    text.append(f"text form: {r.text()}")
    changed = [list(rc) for rc in trace.get("count_changed", [])]  # type: ignore[attr-defined]
    if changed:
        text.append(f"count rule ({args.counts}): called otherwise than their own most probable call: "
                    + ", ".join(f"row {rc[0]} column {rc[1]}" for rc in changed) + " (--counts any reads each alone)")
    if args.debug:
        text.append(f"debug picture: {args.debug}")
    emit(args, {"size": r.n, "board": r.text(), "cells": r.cells.tolist(),
                 "confidence": np.round(r.confidence, 4).tolist(), "corners_px": np.round(r.corners(), 2).tolist(),
                 "grid_error_px": r.grid_error_px, "grid_confidence": r.grid_confidence, "unsure": r.unsure,
                 "frame": list(r.frame), "ms": ms, "debug": args.debug,
                 "count_changed": changed, "grid_kind": kind, "grids_tried": [{"kind": k, "p": p} for k, p in tried]},
          "\n".join(text))
    return EXIT_OK


def _save(rgb: np.ndarray, path: str) -> None:
    from kinegym.envs.draw import save_rgb

    save_rgb(rgb, path)


def add_parsers(sub: Any) -> None:
    """Add ``solve``, ``match`` and ``read-board`` to the main parser's subcommands."""
    so = sub.add_parser("solve", help="game value and best moves of a tic-tac-toe position")
    so.add_argument("board", help='rows joined by |, e.g. "X..|.O.|..." (3x3) or 5 rows of 5 for 5x5')
    so.add_argument("--k", type=int, default=None, help="stones in a row to win (default 3 on 3x3, else 4)")
    so.add_argument("--no-book", action="store_true", help="search from scratch, without the opening book")
    so.add_argument("--time-limit", type=float, default=20.0,
                    help="seconds for an exact answer, else 'unknown' with exit 3 (default 20)")
    add_json(so)
    so.set_defaults(func=cmd_solve)

    ma = sub.add_parser("match", help="play two players against each other and tally the results")
    ma.add_argument("--x", default="solver", help="player moving first: solver, thesis or random")
    ma.add_argument("--o", default="thesis", help="player moving second: solver, thesis or random")
    ma.add_argument("--games", type=int, default=20, help="number of games (default 20)")
    ma.add_argument("--board", type=int, default=5, choices=(3, 4, 5, 6), help="board size (default 5)")
    ma.add_argument("--k", type=int, default=None, help="stones in a row to win (default 3 on 3x3, else 4)")
    ma.add_argument("--seed", type=int, default=0, help="seed of the players' tie-breaking")
    add_json(ma)
    ma.set_defaults(func=cmd_match)

    rb = sub.add_parser("read-board", help="read a tic-tac-toe board from a photo (X, O or empty per cell)")
    rb.add_argument("image", help="image file (PNG, JPEG, ...)")
    rb.add_argument("--size", type=int, choices=(3, 5), default=None, help="board size (default: decide)")
    rb.add_argument("--counts", choices=tuple(COUNT_RULES), default="alternate",
                    help="X and O counts the board may have: players took turns (default), X or O began, or any "
                         "(each cell's own most probable call)")
    rb.add_argument("--accept", default=None, metavar="P",
                    help="take the first grid hypothesis at least this probable, 0..1: lower reads faster and less "
                         "often right (default: the shipped arbiter's level, 0.94)")
    rb.add_argument("--debug", default=None, help="write a PNG showing the found grid and each cell's call")
    add_json(rb)
    rb.set_defaults(func=cmd_read_board)
