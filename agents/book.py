"""Opening book: the exact value of every position with few stones, computed by the solver.

Early in a 5 x 5 four-in-a-row game the exact search takes seconds (from the empty board
about a minute); a few stones later it takes milliseconds. The book closes that gap: it
holds the game value of every legal position with at most ``max_stones`` stones, keyed by
:func:`kinegym.agents.solver.canonical_key` (so one entry serves all 8 symmetric copies), and
:func:`child_values` turns it into the value of every move of a position with fewer
stones. Nothing in it is typed in: :func:`build` computes it with :class:`Solver`, and
``python -m kinegym.agents.book --board 5 --k 4 --stones 4`` rebuilds the shipped file
(``agents/data/book_5x5x4.npz``); the tests re-solve a sample of entries.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

import numpy as np

from kinegym.agents.solver import GAMES, Solver, canonical_key
from kinegym.envs.game import EMPTY, Board, Game, InvalidPositionError

__all__ = ["BOOK_DIR", "SHIPPED", "MissingBookError", "book_path", "load", "child_values", "positions", "build",
           "save"]

BOOK_DIR = Path(__file__).resolve().parent / "data"
#: ``(rows, cols, k)`` of the games whose book ships with kinegym (in ``agents/data/``).
SHIPPED: frozenset[tuple[int, int, int]] = frozenset({(5, 5, 4)})


class MissingBookError(FileNotFoundError):
    """A book that ships with kinegym is not where it belongs: a broken install, not a choice.

    Without it the 5 x 5 solver would search each early move from scratch (about a minute),
    so this is raised instead of quietly playing on without the book."""


def book_path(game: Game) -> Path:
    """Where the book of ``game`` lives (whether or not it exists)."""
    return BOOK_DIR / f"book_{game.rows}x{game.cols}x{game.k}.npz"


@lru_cache(maxsize=8)
def load(game: Game) -> tuple[dict[int, int], int] | None:
    """``(values by canonical key, max_stones)`` of the shipped book; None for a game that has
    no book (see :data:`SHIPPED`); :class:`MissingBookError` when a shipped book is missing."""
    path = book_path(game)
    if not path.is_file():
        if (game.rows, game.cols, game.k) in SHIPPED:
            raise MissingBookError(
                f"the opening book of {game} ships with kinegym but {path} is missing: reinstall kinegym, or "
                f"rebuild it with python -m kinegym.agents.book --board {game.rows} --k {game.k} --stones 4")
        return None
    with np.load(path) as data:
        hi, lo = data["key_hi"].astype(object), data["key_lo"].astype(object)
        values = data["value"].astype(int).tolist()
        max_stones = int(data["max_stones"])
    keys = [(int(h) << 64) | int(l) for h, l in zip(hi, lo)]
    return dict(zip(keys, values)), max_stones


def child_values(board: Board) -> dict[int, int] | None:
    """Value of every legal move of ``board`` for the side playing it, from the book; None
    when the game has no book or the children have more stones than the book holds."""
    got = load(board.game)
    if got is None:
        return None
    book, max_stones = got
    if board.n_stones + 1 > max_stones:
        return None
    out = {}
    for c in board.legal_moves():
        child = board.play(c)
        if child.winner != EMPTY:
            out[c] = 1
        elif child.is_full:
            out[c] = 0
        else:
            v = book.get(canonical_key(child))
            if v is None:  # a book with holes is a broken book: say so, do not guess
                raise KeyError(f"book {book_path(board.game).name} lacks position {child}")
            out[c] = -v
    return out


def positions(game: Game, max_stones: int) -> list[list[Board]]:
    """One representative per symmetry class of every legal, unfinished position, by the
    number of stones (index 0 = the empty board)."""
    levels = [[game.empty()]]
    for _ in range(max_stones):
        seen: dict[int, Board] = {}
        for b in levels[-1]:
            for c in b.legal_moves():
                try:
                    child = b.play(c)
                except InvalidPositionError:  # pragma: no cover - play() only makes legal boards
                    continue
                if child.is_over:
                    continue
                key = canonical_key(child)
                if key not in seen:
                    seen[key] = child
        levels.append(list(seen.values()))
    return levels


def build(game: Game, max_stones: int, solver: Solver | None = None,
          progress: Callable[[int], None] | None = None) -> dict[int, int]:
    """Exact values of all positions with ``<= max_stones`` stones, deepest first (their
    searches fill the solver's table, which makes the shallower ones quick)."""
    solver = solver or Solver(game, max_entries=50_000_000)
    out: dict[int, int] = {}
    for level in reversed(positions(game, max_stones)):
        for b in level:
            out[canonical_key(b)] = solver.value(b)
            if progress is not None:
                progress(1)
    return out


def save(game: Game, values: dict[int, int], max_stones: int, path: Path | None = None) -> Path:
    """Write a book as compressed arrays (keys split in two uint64 halves)."""
    path = path or book_path(game)
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = sorted(values)
    mask = (1 << 64) - 1
    np.savez_compressed(
        path,
        key_hi=np.array([k >> 64 for k in keys], dtype=np.uint64),
        key_lo=np.array([k & mask for k in keys], dtype=np.uint64),
        value=np.array([values[k] for k in keys], dtype=np.int8),
        max_stones=np.int64(max_stones),
    )
    load.cache_clear()
    return path


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Rebuild an opening book with the exact solver.")
    ap.add_argument("--board", type=int, default=5)
    ap.add_argument("--k", type=int, default=4)
    ap.add_argument("--stones", type=int, default=4, help="book every position with at most this many stones")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    game = GAMES.get(f"{args.board}x{args.board}x{args.k}") or Game(args.board, args.board, args.k)
    levels = positions(game, args.stones)
    total = sum(len(lv) for lv in levels)
    print(f"{game}: {total} positions with <= {args.stones} stones (" + ", ".join(
        f"{i}: {len(lv)}" for i, lv in enumerate(levels)) + ")", flush=True)
    t0 = time.perf_counter()
    solver = Solver(game, max_entries=50_000_000)
    done = [0]

    def tick(n: int) -> None:  # a line per 2 % (agents may not import kinegym's progress bar)
        done[0] += n
        if done[0] % max(1, total // 50) == 0 or done[0] == total:
            print(f"  {done[0]}/{total} positions, {time.perf_counter() - t0:.0f} s, "
                  f"{solver.nodes} nodes, table {len(solver.table)}", flush=True)

    values = build(game, args.stones, solver, tick)
    path = save(game, values, args.stones, args.out)
    print(f"wrote {path} ({len(values)} positions, {time.perf_counter() - t0:.0f} s, "
          f"{solver.nodes} nodes, table {len(solver.table)})")


if __name__ == "__main__":
    main()
