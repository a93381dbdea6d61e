"""Tic-tac-toe players for (m, n, k) games: the seed thesis's 3-ply player, a solver that
never loses, and a random player - plus matches between them.

Players share one small interface (:class:`Player`): ``choose(board) -> cell``. Every
player that has choices to break takes a ``seed`` and draws from its own
``random.Random``, so a match between seeded players replays move for move.

* :class:`ThesisPlayer` - seed 003's algorithm, kept as the baseline it is: minimax three
  plies deep (its move, the opponent's, its move) with the static evaluation "lines still
  open for me minus lines still open for the opponent" and +-infinity for a win found on
  the way. Alpha-beta inside the tree does not change its choice; ties between equally
  scored moves are broken at random (the thesis took the first in scan order).
* :class:`StrongPlayer` - an exact solver. :class:`Solver` is a negamax over the game
  values win / draw / loss with alpha-beta, a transposition table keyed on the board
  reduced by its symmetries (8 on a square board), immediate-win and forced-block
  detection, cut-offs from lines that are dead for one side, and move ordering by line
  potential. The player consults an opening book (:mod:`kinegym.agents.book`: exact values of
  every position with few stones, computed by this solver) where search alone is too slow.
  After that it asks, with half its time budget, whether it can force a win; unanswered in
  time it plays for a draw, which it proves move by move (that proof may run on to a hard
  limit: never losing comes first). Only past the hard limit does an iterative-deepening
  heuristic search decide (reported as ``source="heuristic"``, ``exact=False``).
  Among the moves of the best value it samples by line potential (a softmax, seeded), so
  it plays sharply against weak players and still varies its games.
* :class:`RandomPlayer` - uniform over the legal moves.

Values are from the point of view of the side to move: ``+1`` it can force a win, ``0``
draw with best play on both sides, ``-1`` it loses against best play.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from kinegym.agents import book as _book
from kinegym.agents.solver import (
    _POTENTIAL,
    DRAW,
    GAMES,
    LOSS,
    WIN,
    SearchTimeout,
    Solver,
    _sides,
    _Tables,
    canonical_key,
    potential,
    tables,
)
from kinegym.envs.game import Board, Game, GameError, O, X

__all__ = [
    "Player",
    "RandomPlayer",
    "ThesisPlayer",
    "StrongPlayer",
    "Solver",
    "Analysis",
    "SearchTimeout",
    "GameRecord",
    "MatchResult",
    "PLAYERS",
    "make_player",
    "play_game",
    "play_match",
    "GAMES",
    "canonical_key",
    "tables",
    "potential",
]

class Player(Protocol):
    """Anything that picks a move: ``choose(board)`` returns a legal cell index."""

    name: str

    def choose(self, board: Board) -> int: ...


# ------------------------------------------------------------------ players
@dataclass
class Analysis:
    """What :meth:`StrongPlayer.analyse` found: the value for the side to move, the moves
    that achieve it (all of them when ``complete``), whether the value is proven
    (``exact``), where it came from (``"book"``, ``"search"``, ``"heuristic"``), nodes
    searched and seconds taken."""

    value: int
    best_moves: list[int]
    exact: bool
    source: str
    nodes: int = 0
    seconds: float = 0.0
    complete: bool = True
    move_values: dict[int, int] = field(default_factory=dict)


class RandomPlayer:
    """Uniformly random legal moves from a seeded generator."""

    name = "random"

    def __init__(self, seed: int | None = None) -> None:
        self.rng = random.Random(seed)

    def choose(self, board: Board) -> int:
        moves = board.legal_moves()
        if not moves:
            raise GameError(f"no legal move: the game is over ({board.result()})")
        return self.rng.choice(moves)


class ThesisPlayer:
    """Seed 003's player: 3-ply minimax, evaluation = open lines mine minus open lines theirs.

    A win found at any of the three plies scores +-infinity (its own win at ply 1 or 3,
    the opponent's at ply 2). Equal root scores are broken at random from ``seed``.
    """

    name = "thesis"

    def __init__(self, seed: int | None = None, plies: int = 3) -> None:
        if plies < 1:
            raise ValueError(f"plies={plies}; expected >= 1")
        self.rng = random.Random(seed)
        self.plies = plies

    def scores(self, board: Board) -> dict[int, float]:
        """Minimax score of every legal move (from the mover's point of view)."""
        if board.is_over:
            raise GameError(f"no legal move: the game is over ({board.result()})")
        t = tables(board.game)
        me, op = _sides(board)
        lines = board.game.lines
        all_lines = (1 << len(lines)) - 1
        touched_me = touched_op = 0
        ids = t.line_ids_through
        for c in range(board.game.n_cells):
            if me >> c & 1:
                touched_me |= ids[c]
            elif op >> c & 1:
                touched_op |= ids[c]
        out = {}
        for c in board.legal_moves():
            out[c] = self._value(board.game, t, me | 1 << c, op, touched_me | ids[c], touched_op, c,
                                 1, True, -math.inf, math.inf, all_lines)
        return out

    def _value(self, g: Game, t: _Tables, me: int, op: int, tme: int, top: int, last: int, ply: int,
               my_move_made: bool, alpha: float, beta: float, all_lines: int) -> float:
        """Score after ``ply`` moves; ``my_move_made``: the last stone was the thesis player's."""
        mover = me if my_move_made else op
        if any(line & mover == line for line in g.lines_through[last]):
            return math.inf if my_move_made else -math.inf
        occ = me | op
        if ply == self.plies or occ == g.full:
            # lines still open for me (no opponent stone) minus lines open for the opponent
            return (all_lines & ~top).bit_count() - (all_lines & ~tme).bit_count()
        ids = t.line_ids_through
        maximise = not my_move_made  # the thesis player moves next
        best = -math.inf if maximise else math.inf
        for c in range(g.n_cells):
            if occ >> c & 1:
                continue
            if maximise:
                v = self._value(g, t, me | 1 << c, op, tme | ids[c], top, c, ply + 1, True, alpha, beta, all_lines)
                if v > best:
                    best = v
                    alpha = max(alpha, v)
            else:
                v = self._value(g, t, me, op | 1 << c, tme, top | ids[c], c, ply + 1, False, alpha, beta, all_lines)
                if v < best:
                    best = v
                    beta = min(beta, v)
            if alpha >= beta:
                break
        return best

    def choose(self, board: Board) -> int:
        scores = self.scores(board)
        top = max(scores.values())
        return self.rng.choice([c for c, v in scores.items() if v == top])


class StrongPlayer:
    """A player that never loses a position that is not already lost.

    Args:
        seed: seeds the choice among the moves of the best value.
        time_budget_s: seconds per move the search aims at; ``None`` = unbounded (exact
            values). Half of it goes to "can I force a win?"; unanswered, the player proves
            a move that keeps a draw (``Analysis.exact`` False: the value is a lower bound).
            That proof may run on to ``hard_limit_s`` (never losing comes first); only then
            does an iterative-deepening heuristic search over the moves not proven to lose
            decide (``source="heuristic"``).
        book: use the opening book where one exists for the game.
        temperature: softmax temperature over line potential when choosing among the moves
            of the best value (0 = always the highest potential, ties at random).
        solver: share a :class:`Solver` (its table) between players of one game.
        hard_limit_s: the most seconds the exact search may take for one move.
        deterministic: measure the budget in search nodes (``node_seconds`` of "time" each)
            instead of on the wall clock, so that a seeded player makes the same moves on
            any machine and under any load (the envs' opponents use this).
        node_seconds: the time one node stands for in deterministic mode (about this
            machine's speed, so the budgets keep their meaning).
    """

    name = "solver"

    def __init__(self, seed: int | None = None, time_budget_s: float | None = 0.4, book: bool = True,
                 temperature: float = 0.5, solver: Solver | None = None, hard_limit_s: float = 30.0,
                 deterministic: bool = False, node_seconds: float = 1e-5) -> None:
        if time_budget_s is not None and not time_budget_s > 0:
            raise ValueError(f"time_budget_s={time_budget_s!r}; expected a positive number of seconds or None")
        if temperature < 0:
            raise ValueError(f"temperature={temperature!r}; expected >= 0")
        self.rng = random.Random(seed)
        self.time_budget_s = time_budget_s
        self.use_book = book
        self.temperature = float(temperature)
        self.hard_limit_s = float(hard_limit_s)
        self.deterministic = bool(deterministic)
        self.node_seconds = float(node_seconds)
        self._extra_nodes = 0  # heuristic-search nodes (deterministic clock)
        self._solvers: dict[Game, Solver] = {}
        if solver is not None:
            self._solvers[solver.game] = solver
        self.last: Analysis | None = None

    def solver(self, game: Game) -> Solver:
        if game not in self._solvers:
            self._solvers[game] = Solver(game)
        return self._solvers[game]

    # -- choosing ------------------------------------------------------------------
    def choose(self, board: Board) -> int:
        a = self.analyse(board, all_best=False)
        self.last = a
        return a.best_moves[0]

    def _sample_order(self, board: Board, moves: Sequence[int]) -> list[int]:
        """``moves`` in a random order where higher line potential tends to come first: the
        Gumbel-max trick, so that the first feasible move is a softmax sample."""
        t = tables(board.game)
        me, op = _sides(board)
        score = potential(t, _POTENTIAL[: board.game.k + 1], me, op)
        top = max((score[c] for c in moves), default=1) or 1
        keyed = []
        for c in moves:
            logit = score[c] / top
            if self.temperature > 0:
                logit = logit / self.temperature - math.log(-math.log(self.rng.random() or 1e-300))
            else:
                logit += self.rng.random() * 1e-9
            keyed.append((logit, c))
        keyed.sort(reverse=True)
        return [c for _, c in keyed]

    def analyse(self, board: Board, all_best: bool = True, limit_s: float | None = None) -> Analysis:
        """Value of ``board`` for the side to move and the moves that keep it.

        ``all_best=False`` (what :meth:`choose` uses) stops at the first best move in the
        sampled order; ``best_moves[0]`` is then the chosen move. ``limit_s``: an exact answer
        within that many wall-clock seconds or :class:`SearchTimeout` (no heuristic guess).
        """
        if limit_s is not None and not (isinstance(limit_s, (int, float)) and limit_s > 0):
            raise ValueError(f"limit_s={limit_s!r}; expected a positive number of seconds or None")
        if board.is_over:
            raise GameError(f"no legal move: the game is over ({board.result()})")
        wall0 = time.perf_counter()
        solver = self.solver(board.game)
        if self.deterministic and limit_s is None:
            ns = self.node_seconds
            solver.clock = lambda: (solver.nodes + self._extra_nodes) * ns
        else:
            solver.clock = time.perf_counter
        t0 = solver.clock()
        n0 = solver.nodes
        moves = board.legal_moves()
        order = self._sample_order(board, moves)

        def done(a: Analysis) -> Analysis:
            a.seconds, a.nodes = time.perf_counter() - wall0, solver.nodes - n0
            return a

        # immediate wins and forced blocks need no search
        me, op = _sides(board)
        wins = [c for c in order if _completes(board.game, me, c)]
        if wins:
            return done(Analysis(WIN, wins if all_best else wins[:1], True, "search", complete=all_best))
        if self.use_book:

            vals = _book.child_values(board)
            if vals is not None:
                best = max(vals.values())
                bm = [c for c in order if vals[c] == best]
                return done(Analysis(best, bm, True, "book", move_values=vals))
        # never losing comes first: the search that proves a move keeps the value may run on
        # to ``hard_limit_s``; only past that does the heuristic search decide. Whether the
        # side to move can *win* is asked with half the budget: unanswered in time, a draw is
        # what it plays for (the value is then a lower bound, ``exact=False``)
        deadline = None if self.time_budget_s is None else t0 + max(self.time_budget_s, self.hard_limit_s)
        if limit_s is not None:
            deadline = t0 + limit_s
        try:
            root = self._book_value(board) if self.use_book else None
            exact = root is not None
            if root is None:
                quick = None if self.time_budget_s is None else t0 + 0.5 * self.time_budget_s
                if limit_s is not None:
                    quick = deadline
                try:
                    root = WIN if solver.bounded(board, DRAW, WIN, quick) >= WIN else DRAW
                    exact = True  # a win, or at most a draw (the loop below tells draw from loss)
                except SearchTimeout:
                    if limit_s is not None:
                        raise
                    root = DRAW
            if not all_best and root > LOSS:
                # one null-window search "value >= root?" in the solver's own move order: its
                # cut-off move keeps the value, and is tried first below (testing the sampled
                # order move by move pays for refuting every weaker move before it)
                if solver.bounded(board, root - 1, root, deadline) < root:
                    root, exact = LOSS, True  # (only after an unanswered win probe: lost after all)
                first = solver.table_move(board)
                if first is not None and first in order:
                    order = [first] + [c for c in order if c != first]
            best_moves, values = [], {}
            for c in order:
                v = -solver.bounded(board.play(c), -root, -root + 1, deadline)  # is this move >= root?
                if v >= root:
                    best_moves.append(c)
                    values[c] = root
                    if not all_best:
                        break
                else:
                    values[c] = v  # an upper bound below root
            if not best_moves:  # no move keeps a draw: the position was lost already
                return done(Analysis(LOSS, list(order if all_best else order[:1]), True, "search",
                                     complete=all_best, move_values={c: LOSS for c in order}))
            return done(Analysis(root, best_moves, exact, "search", complete=all_best, move_values=values))
        except SearchTimeout:
            if limit_s is not None:
                raise
            move = self._fallback(board, order, solver, t0)
            return done(Analysis(DRAW, [move], False, "heuristic", complete=False))

    @staticmethod
    def _book_value(board: Board) -> int | None:
        """The position's own value from the book, if it holds it."""

        got = _book.load(board.game)
        if got is None or board.n_stones > got[1]:
            return None
        return got[0].get(canonical_key(board))

    def _fallback(self, board: Board, order: list[int], solver: Solver, t0: float) -> int:
        """Out of time: drop moves the table already proves losing, then deepen a heuristic
        alpha-beta search over the rest for a quarter of the budget more."""
        keep = []
        for c in order:
            code = solver.table.get(canonical_key(board.play(c)))
            if code is None or code % 9 // 3 - 1 < WIN:  # not proven a win for the opponent
                keep.append(c)
        keep = keep or order
        budget = self.time_budget_s or 0.1
        search = _HeuristicSearch(board.game, solver.clock() + budget)
        if self.deterministic:
            ns = self.node_seconds
            search.clock = lambda: (solver.nodes + self._extra_nodes + search.nodes) * ns
        try:
            return search.best(board, keep)
        finally:
            self._extra_nodes += search.nodes


class _HeuristicSearch:
    """Iterative-deepening alpha-beta with a line-potential evaluation (used only when the
    exact search runs out of time)."""

    BIG = 10**9

    def __init__(self, game: Game, deadline: float) -> None:
        self.t = tables(game)
        self.game = game
        self.deadline = deadline
        self.w = _POTENTIAL[: game.k + 1]
        self.nodes = 0
        self.clock: Callable[[], float] = time.perf_counter

    def best(self, board: Board, moves: list[int]) -> int:
        me, op = _sides(board)
        choice = moves[0]
        depth = 1
        try:
            while depth <= self.game.n_cells - board.n_stones:
                scored = []
                alpha = -self.BIG - 1
                for c in moves:
                    v = -self._search(op, me | 1 << c, c, depth - 1, -self.BIG - 1, -alpha)
                    scored.append((v, c))
                    alpha = max(alpha, v)
                scored.sort(key=lambda vc: -vc[0])
                moves = [c for _, c in scored]  # best first: better ordering next depth
                choice = moves[0]
                depth += 1
        except SearchTimeout:
            pass
        return choice

    def _search(self, me: int, op: int, last: int, depth: int, alpha: int, beta: int) -> int:
        self.nodes += 1
        if self.clock() > self.deadline:
            raise SearchTimeout("heuristic search ran past its deadline")
        g = self.game
        if any(line & op == line for line in g.lines_through[last]):
            return -self.BIG
        occ = me | op
        if occ == g.full:
            return 0
        if depth == 0:
            s = 0
            for line, _ in self.t.lines:
                if not line & op:
                    s += self.w[(line & me).bit_count()]
                if not line & me:
                    s -= self.w[(line & op).bit_count()]
            return s
        score = potential(self.t, self.w, me, op)
        moves = sorted((c for c in range(g.n_cells) if not occ >> c & 1), key=score.__getitem__, reverse=True)
        best = -self.BIG - 1
        for c in moves:
            v = -self._search(op, me | 1 << c, c, depth - 1, -beta, -alpha)
            if v > best:
                best = v
                alpha = max(alpha, v)
                if alpha >= beta:
                    break
        return best


def _completes(game: Game, stones: int, cell: int) -> bool:
    s = stones | 1 << cell
    return any(line & s == line for line in game.lines_through[cell])


# ------------------------------------------------------------------ matches
PLAYERS: dict[str, Callable[[int | None], Player]] = {
    "solver": lambda seed: StrongPlayer(seed=seed),
    "thesis": lambda seed: ThesisPlayer(seed=seed),
    "random": lambda seed: RandomPlayer(seed=seed),
}


def make_player(name: str, seed: int | None = None) -> Player:
    """A player by name: ``"solver"`` (strong), ``"thesis"`` or ``"random"``."""
    try:
        return PLAYERS[name](seed)
    except KeyError:
        raise ValueError(f"player {name!r}; expected one of: {', '.join(PLAYERS)}") from None


@dataclass
class GameRecord:
    """One finished game: the moves (cell indices), the final board, who won (``X``, ``O``
    or ``EMPTY`` for a draw) and each move's thinking time in seconds."""

    moves: list[int]
    board: Board
    winner: int
    seconds: list[float]


def play_game(game: Game, x: Player, o: Player, start: Board | None = None) -> GameRecord:
    """Play ``x`` against ``o`` from ``start`` (default: the empty board) to the end."""
    board = start if start is not None else game.empty()
    moves, secs = [], []
    while not board.is_over:
        player = x if board.to_move == X else o
        t0 = time.perf_counter()
        cell = player.choose(board)
        secs.append(time.perf_counter() - t0)
        board = board.play(cell)
        moves.append(cell)
    return GameRecord(moves, board, board.winner, secs)


@dataclass
class MatchResult:
    """Tally of a match: wins of X, wins of O, draws, and every move time per side (s)."""

    x_name: str
    o_name: str
    x_wins: int = 0
    o_wins: int = 0
    draws: int = 0
    x_seconds: list[float] = field(default_factory=list)
    o_seconds: list[float] = field(default_factory=list)

    @property
    def games(self) -> int:
        return self.x_wins + self.o_wins + self.draws


def play_match(game: Game, x_name: str, o_name: str, games: int, seed: int = 0,
               progress: Callable[[int], None] | None = None,
               factory: Callable[[str, int], Player] = make_player) -> MatchResult:
    """``games`` games of ``x_name`` (moving first) against ``o_name``; game ``i`` seeds the
    players with ``seed * 1_000_003 + 2 i`` and ``... + 2 i + 1``, so a match replays.

    Strong players keep their solver's table across the games of the match.
    """
    res = MatchResult(x_name, o_name)
    px, po = factory(x_name, seed * 1_000_003), factory(o_name, seed * 1_000_003 + 1)
    for i in range(games):
        for p, s in ((px, 2 * i), (po, 2 * i + 1)):
            if hasattr(p, "rng"):
                p.rng.seed(seed * 1_000_003 + s)
        rec = play_game(game, px, po)
        for b_idx, secs in enumerate(rec.seconds):
            (res.x_seconds if b_idx % 2 == 0 else res.o_seconds).append(secs)
        if rec.winner == X:
            res.x_wins += 1
        elif rec.winner == O:
            res.o_wins += 1
        else:
            res.draws += 1
        if progress is not None:
            progress(1)
    return res


#: The built-in games by name (``--board 5 --k 4`` at the CLI).
