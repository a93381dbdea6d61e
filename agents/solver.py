"""The exact solver of (m, n, k) games and the per-game tables it works on.

:class:`Solver` is a negamax over the game values win / draw / loss with alpha-beta, a
transposition table keyed on the board reduced by its symmetries (8 on a square board),
immediate-win and forced-block detection, cut-offs from lines that are dead for one side,
and move ordering by line potential. :func:`canonical_key` names a position up to those
symmetries (the opening book's key). Values are from the point of view of the side to move:
``+1`` it can force a win, ``0`` draw with best play on both sides, ``-1`` it loses.

The players built on it (and on :mod:`kinegym.agents.book`) live in
:mod:`kinegym.agents.minimax`; this module depends on the game rules only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

from kinegym.envs.game import CLASSIC, EMPTY, THESIS, Board, Game, X

__all__ = ["Solver", "SearchTimeout", "GAMES", "canonical_key", "tables", "potential", "WIN", "DRAW", "LOSS"]

WIN, DRAW, LOSS = 1, 0, -1
#: Line-potential weights by the number of own stones in a line still open for its owner.
_POTENTIAL = (1, 4, 16, 64, 256, 1024, 4096, 16384, 65536)


class SearchTimeout(RuntimeError):
    """The exact search ran past its deadline (raised inside :class:`Solver`)."""


# ------------------------------------------------------------------ per-game tables
@dataclass(frozen=True)
class _Tables:
    """Precomputed masks of one game: lines, their cells, symmetries, move bits."""

    game: Game
    lines: tuple[tuple[int, tuple[int, ...]], ...]
    lines_through: tuple[tuple[int, ...], ...]
    line_ids_through: tuple[int, ...]  # per cell: bitmask over line indices
    perms: tuple[tuple[int, ...], ...]  # symmetry s maps cell c to perms[s][c]
    move_bits: tuple[tuple[int, ...], ...]  # move_bits[c][s] = 1 << perms[s][c]
    centrality: tuple[int, ...]  # static tie-break: number of lines through the cell

    def encode(self, mask: int) -> list[int]:
        """``mask`` under every symmetry (the running keys of the solver)."""
        out = []
        for p in self.perms:
            v = 0
            m = mask
            while m:
                b = m & -m
                v |= 1 << p[b.bit_length() - 1]
                m ^= b
            out.append(v)
        return out


def _symmetries(rows: int, cols: int) -> list[tuple[int, ...]]:
    maps: list[Callable[[int, int], tuple[int, int]]] = [
        lambda r, c: (r, c),
        lambda r, c: (r, cols - 1 - c),
        lambda r, c: (rows - 1 - r, c),
        lambda r, c: (rows - 1 - r, cols - 1 - c),
    ]
    if rows == cols:
        maps += [
            lambda r, c: (c, r),
            lambda r, c: (cols - 1 - c, r),
            lambda r, c: (c, rows - 1 - r),
            lambda r, c: (cols - 1 - c, rows - 1 - r),
        ]
    perms = []
    for f in maps:
        perm = []
        for i in range(rows * cols):
            r, c = f(*divmod(i, cols))
            perm.append(r * cols + c)
        perms.append(tuple(perm))
    return perms


@lru_cache(maxsize=16)
def tables(game: Game) -> _Tables:
    """The (cached) precomputed tables of ``game``."""
    n = game.n_cells
    lines = tuple((m, tuple(c for c in range(n) if m >> c & 1)) for m in game.lines)
    ids = [0] * n
    for i, (_, cells) in enumerate(lines):
        for c in cells:
            ids[c] |= 1 << i
    perms = _symmetries(game.rows, game.cols)
    move_bits = tuple(tuple(1 << p[c] for p in perms) for c in range(n))
    return _Tables(game, lines, game.lines_through, tuple(ids), tuple(perms), move_bits,
                   tuple(len(t) for t in game.lines_through))


def canonical_key(board: Board) -> int:
    """The board's key reduced by its symmetries: ``min_s (mover_s << 64 | other_s)``.

    Equal for every rotation / reflection of a position; the mover's stones come first,
    so the key also says whose turn it is.
    """
    t = tables(board.game)
    me, op = _sides(board)
    return min((a << 64) | b for a, b in zip(t.encode(me), t.encode(op)))


def _sides(board: Board) -> tuple[int, int]:
    """``(stones of the side to move, stones of the other side)``."""
    return (board.x, board.o) if board.to_move == X else (board.o, board.x)


# ------------------------------------------------------------------ exact solver
class Solver:
    """Exact negamax over win / draw / loss for one game, with a symmetric transposition table.

    The table survives between calls (positions of one game share most of their trees), and
    is cleared when it holds more than ``max_entries`` positions (about 100 bytes each).
    ``nodes`` counts the positions visited since construction.
    """

    def __init__(self, game: Game, max_entries: int = 2_000_000) -> None:
        self.game = game
        self.t = tables(game)
        self.max_entries = int(max_entries)
        # key -> (lo + 1) * 3 + (hi + 1) + 9 * (best move in the key's frame + 1, or 0)
        self.table: dict[int, int] = {}
        self.nodes = 0
        self._deadline = math.inf
        #: what deadlines are measured on: wall time, or a node count (StrongPlayer(deterministic=True))
        self.clock: Callable[[], float] = time.perf_counter
        self._w = _POTENTIAL[: game.k + 1]
        # hot-path constants as plain attributes
        self._full, self._n, self._need = game.full, game.n_cells, game.k - 1
        self._lines, self._move_bits = self.t.lines, self.t.move_bits
        self._masks = tuple(m for m, _ in self.t.lines)
        self._cells = tuple(range(game.n_cells))
        self._perms = self.t.perms
        self._inverse = tuple(tuple(sorted(range(game.n_cells), key=p.__getitem__)) for p in self.t.perms)

    # -- public ------------------------------------------------------------------
    def value(self, board: Board, deadline: float | None = None) -> int:
        """Exact value of ``board`` for the side to move (raises :class:`SearchTimeout`)."""
        return self.bounded(board, LOSS, WIN, deadline)

    def bounded(self, board: Board, alpha: int, beta: int, deadline: float | None = None) -> int:
        """Fail-soft alpha-beta value: exact inside ``(alpha, beta)``, a bound outside."""
        if board.winner != EMPTY:  # the side to move has lost already
            return LOSS
        if board.is_full:
            return DRAW
        if len(self.table) > self.max_entries:
            self.table.clear()
        self._deadline = math.inf if deadline is None else deadline
        me, op = _sides(board)
        return self._negamax(me, op, self.t.encode(me), self.t.encode(op), alpha, beta)

    def table_move(self, board: Board) -> int | None:
        """The best move the transposition table holds for ``board`` (from the last search
        that reached it: after a search proved a win, the winning move), or None."""
        me, op = _sides(board)
        emes, eops = self.t.encode(me), self.t.encode(op)
        keys = [(a << 64) | b for a, b in zip(emes, eops)]
        key = min(keys)
        code = self.table.get(key)
        if code is None or code < 9:
            return None
        return self._inverse[keys.index(key)][code // 9 - 1]

    def child_value(self, board: Board, cell: int, deadline: float | None = None) -> int:
        """Exact value of playing ``cell`` in ``board``, for the side playing it."""
        return -self.value(board.play(cell), deadline)

    # -- search ------------------------------------------------------------------
    def _negamax(self, me: int, op: int, emes: list[int], eops: list[int], alpha: int, beta: int) -> int:
        self.nodes += 1
        if not self.nodes & 1023 and self.clock() > self._deadline:
            raise SearchTimeout("exact search ran past its deadline")
        occ = me | op
        if occ == self._full:
            return DRAW
        need = self._need
        mywin = opwin = 0
        mylive = oplive = False
        for line in self._masks:
            a, b = line & me, line & op
            if b:
                if a:
                    continue
                oplive = True
                if b.bit_count() == need:
                    opwin |= line ^ b
            else:
                mylive = True
                if a.bit_count() == need:
                    mywin |= line ^ a
                if not a:
                    oplive = True
        if mywin:
            return WIN
        # a side with no open line cannot win: that bounds the value before any search
        lo = LOSS if oplive else DRAW
        hi = WIN if mylive else DRAW
        if lo == hi or lo >= beta or hi <= alpha:
            return lo if lo >= beta or lo == hi else hi
        keys = [(a << 64) | b for a, b in zip(emes, eops)]
        key = min(keys)
        table = self.table
        code = table.get(key)
        tt_move = -1
        if code is not None:
            tlo, thi = code % 9 // 3 - 1, code % 3 - 1
            if tlo > lo:
                lo = tlo
            if thi < hi:
                hi = thi
            if lo == hi or lo >= beta or hi <= alpha:
                return lo if lo >= beta or lo == hi else hi
            if code >= 9:  # best move found last time, stored in the canonical frame
                tt_move = self._inverse[keys.index(key)][code // 9 - 1]
        if lo > alpha:
            alpha = lo
        if hi < beta:
            beta = hi
        a0, b0 = alpha, beta
        mb = self._move_bits
        best, best_move = LOSS - 1, -1
        if opwin:
            if opwin & (opwin - 1):  # two cells to block: lost
                table[key] = 0
                return LOSS
            moves: Sequence[int] = (opwin.bit_length() - 1,)
        elif tt_move >= 0:
            # try last time's best move before paying for move ordering: often it cuts
            c = best_move = tt_move
            best = -self._negamax(op, me | 1 << c, eops, [e | b for e, b in zip(emes, mb[c])], -beta, -alpha)
            if best > alpha:
                alpha = best
            moves = () if alpha >= beta else [m for m in self._ordered(me, op, occ) if m != tt_move]
        else:
            moves = self._ordered(me, op, occ)
            if not moves:
                return DRAW
        for c in moves:
            v = -self._negamax(op, me | 1 << c, eops, [e | b for e, b in zip(emes, mb[c])], -beta, -alpha)
            if v > best:
                best, best_move = v, c
                if v > alpha:
                    alpha = v
                    if alpha >= beta:
                        break
        if best <= a0:
            hi = best
        elif best >= b0:
            lo = best
        else:
            lo = hi = best
        table[key] = (lo + 1) * 3 + hi + 1 + 9 * (self._perms[keys.index(key)][best_move] + 1)
        return best

    def _ordered(self, me: int, op: int, occ: int) -> list[int]:
        """Empty cells on a line still open for someone, by line potential (best first)."""
        w = self._w
        score = [0] * self._n
        for line, cells in self._lines:
            a, b = line & me, line & op
            if b:
                if a:
                    continue
                v = w[b.bit_count()]
            else:
                v = w[a.bit_count()] + (0 if a else w[0])
            for c in cells:
                score[c] += v
        moves = [c for c in self._cells if not occ >> c & 1 and score[c]]
        moves.sort(key=score.__getitem__, reverse=True)
        return moves


def potential(t: _Tables, w: Sequence[int], me: int, op: int) -> list[int]:
    """Per cell: sum over the lines through it that are open for a side of ``w[stones]``
    of that side - how much a stone there makes or blocks (0 on dead cells)."""
    score = [0] * t.game.n_cells
    for line, cells in t.lines:
        a, b = line & me, line & op
        if a and b:
            continue
        v = 0 if b else w[a.bit_count()]
        if not a:
            v += w[b.bit_count()]
        for c in cells:
            score[c] += v
    return score


GAMES = {"3x3x3": CLASSIC, "5x5x4": THESIS}
