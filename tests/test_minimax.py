"""Players: the exact solver against brute force, the strong player never losing, the thesis
player against a naive re-implementation of the seed's rule, the opening book re-solved."""

import math
import random
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from kinegym.agents import book
from kinegym.agents.minimax import (
    RandomPlayer,
    Solver,
    StrongPlayer,
    ThesisPlayer,
    canonical_key,
    play_game,
    play_match,
    tables,
)
from kinegym.envs.game import CLASSIC, EMPTY, THESIS, Board, Game, O, X

SMALL = [CLASSIC, Game(4, 4, 3), Game(4, 4, 4), Game(3, 4, 3)]


@cache
def _value(game: Game, x: int, o: int) -> int:
    b = Board(game, x, o)
    if b.winner != EMPTY:
        return -1  # the previous mover completed a line
    if b.is_full:
        return 0
    return max(-_value(game, c.x, c.o) for c in (b.play(m) for m in b.legal_moves()))


def brute_force(board: Board) -> int:
    """Plain minimax, no pruning, no table, no symmetry: the value for the side to move."""
    return _value(board.game, board.x, board.o)


def random_positions(game: Game, n: int, stones: tuple[int, int], seed: int) -> list[Board]:
    rng = random.Random(seed)
    out = []
    while len(out) < n:
        b = game.empty()
        for _ in range(rng.randint(*stones)):
            if b.is_over:
                break
            b = b.play(rng.choice(b.legal_moves()))
        if not b.is_over:
            out.append(b)
    return out


def test_classic_from_empty_is_a_draw() -> None:
    assert Solver(CLASSIC).value(CLASSIC.empty()) == 0


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("XX.|OO.|...", 1),  # X completes the top row
        ("XO.|...|...", 1),  # O answered a corner with an adjacent edge: X wins
        ("X..|.O.|..X", 0),  # O must take an edge, then it holds
        ("X..|...|...", 0),  # O to move: the centre holds
        ("XX.|O..|...", -1),  # O to move must block the top row, and then X forks
        ("X.O|...|...", 1),  # O took the far corner of X's row: X wins
    ],
)
def test_known_values(text: str, value: int) -> None:
    b = Board.parse(text)
    assert Solver(CLASSIC).value(b) == value == brute_force(b)


@pytest.mark.parametrize("game", SMALL, ids=str)
def test_solver_agrees_with_brute_force(game: Game) -> None:
    lo = max(0, game.n_cells - 9)
    solver = Solver(game)  # one table for all positions: reuse must not change values
    for b in random_positions(game, 30, (lo, game.n_cells - 1), seed=game.n_cells):
        assert solver.value(b) == brute_force(b), str(b)


def test_null_window_bounds_are_correct() -> None:
    solver = Solver(Game(4, 4, 3))
    for b in random_positions(Game(4, 4, 3), 40, (6, 12), seed=3):
        v = brute_force(b)
        for alpha in (-1, 0):
            got = solver.bounded(b, alpha, alpha + 1)
            assert (got <= alpha) == (v <= alpha) and (got >= alpha + 1) == (v >= alpha + 1)


def test_canonical_key_is_the_same_for_all_symmetric_copies() -> None:
    t = tables(THESIS)
    for b in random_positions(THESIS, 20, (1, 12), seed=5):
        keys = set()
        for perm in t.perms:
            x = sum(1 << perm[c] for c in range(25) if b.x >> c & 1)
            o = sum(1 << perm[c] for c in range(25) if b.o >> c & 1)
            keys.add(canonical_key(Board(THESIS, x, o)))
        assert len(keys) == 1
    assert canonical_key(THESIS.parse("X....|.....|.....|.....|.....")) != canonical_key(
        THESIS.parse(".....|.....|..X..|.....|....."))


def test_strong_player_never_loses_any_classic_position() -> None:
    """Every reachable 3x3x3 position that is not already lost: the chosen move keeps it."""
    seen: set[tuple[int, int]] = set()
    frontier = [CLASSIC.empty()]
    player = StrongPlayer(seed=1, time_budget_s=None)
    checked = 0
    while frontier:
        b = frontier.pop()
        if (b.x, b.o) in seen or b.is_over:
            continue
        seen.add((b.x, b.o))
        frontier.extend(b.play(m) for m in b.legal_moves())
        v = brute_force(b)
        if v < 0:
            continue
        move = player.choose(b)
        assert -brute_force(b.play(move)) == v, f"{b}: move {move} gives up the value {v}"
        checked += 1
    assert checked > 2000


def test_strong_player_keeps_the_value_on_handed_5x5_positions() -> None:
    """Positions from random play, 6-12 stones: an independent solver checks the chosen move."""
    player = StrongPlayer(seed=2, time_budget_s=None)
    judge = Solver(THESIS)
    for b in random_positions(THESIS, 12, (7, 12), seed=11):
        v = judge.value(b)
        if v < 0:
            continue
        move = player.choose(b)
        assert judge.child_value(b, move) == v, f"{b}: move {move}"


@pytest.fixture(scope="module")
def shared_solver() -> Solver:
    return Solver(THESIS)


@pytest.mark.parametrize("opponent", ["random", "thesis"])
def test_strong_player_does_not_lose_5x5_games(opponent: str, shared_solver: Solver) -> None:
    for i in range(3):
        strong = StrongPlayer(seed=i, solver=shared_solver)
        other = RandomPlayer(seed=i) if opponent == "random" else ThesisPlayer(seed=i)
        assert play_game(THESIS, strong, other).winner != O
        strong = StrongPlayer(seed=100 + i, solver=shared_solver)
        assert play_game(THESIS, other, strong).winner != X


def test_strong_player_wins_a_won_position_and_blocks() -> None:
    player = StrongPlayer(seed=0)
    assert player.choose(Board.parse("XX.|OO.|...")) == 2
    b = THESIS.parse("XXX..|OO...|.....|.....|O....")  # X to move and wins at (0, 3)
    assert player.choose(b) == 3
    b = THESIS.parse("OOO..|XX...|X....|.....|.....")  # X to move: must block (0, 3)
    assert player.choose(b) == 3


def _naive_thesis_scores(board: Board) -> dict[int, float]:
    """Seed 003's rule written plainly: three plies, +-inf for a win on the way, at the
    leaves lines without an opponent stone minus lines without one of the player's."""
    g = board.game
    me = board.to_move

    def evaluate(b: Board) -> float:
        mine = b.stones(me)
        theirs = b.stones(O if me == X else X)
        return sum(1 for ln in g.lines if not ln & theirs) - sum(1 for ln in g.lines if not ln & mine)

    def value(b: Board, ply: int) -> float:
        if b.winner != EMPTY:
            return math.inf if b.winner == me else -math.inf
        if ply == 3 or b.is_full:
            return evaluate(b)
        vals = [value(b.play(m), ply + 1) for m in b.legal_moves()]
        return max(vals) if b.to_move == me else min(vals)

    return {m: value(board.play(m), 1) for m in board.legal_moves()}


def test_thesis_player_is_the_seed_rule() -> None:
    for b in random_positions(Game(4, 4, 3), 12, (2, 9), seed=4) + random_positions(THESIS, 3, (14, 18), seed=9):
        assert ThesisPlayer(seed=0).scores(b) == _naive_thesis_scores(b), str(b)


def test_thesis_player_takes_a_win_and_is_reproducible() -> None:
    b = THESIS.parse("XXX..|OO...|.....|.....|O....")
    assert ThesisPlayer(seed=3).choose(b) == 3
    a = play_game(THESIS, ThesisPlayer(seed=5), RandomPlayer(seed=6))
    c = play_game(THESIS, ThesisPlayer(seed=5), RandomPlayer(seed=6))
    assert a.moves == c.moves


def test_matches_replay_with_their_seed() -> None:
    a = play_match(CLASSIC, "solver", "random", 6, seed=4)
    b = play_match(CLASSIC, "solver", "random", 6, seed=4)
    assert (a.x_wins, a.o_wins, a.draws) == (b.x_wins, b.o_wins, b.draws)
    assert a.o_wins == 0


def test_heuristic_fallback_when_the_budget_is_tiny() -> None:
    b = THESIS.parse(".....|.....|..X..|.....|.....")
    player = StrongPlayer(seed=0, time_budget_s=0.01, book=False, hard_limit_s=0.01)
    move = player.choose(b)
    assert b.is_legal(move) and player.last is not None
    assert player.last.source == "heuristic" and not player.last.exact


def test_a_missing_shipped_book_is_a_loud_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A wheel without the 5x5 book must not quietly play on at a minute a move."""
    from kinegym.cli import main

    monkeypatch.setattr(book, "BOOK_DIR", tmp_path)
    book.load.cache_clear()
    try:
        with pytest.raises(book.MissingBookError, match="book_5x5x4.npz"):
            book.load(THESIS)
        with pytest.raises(book.MissingBookError):
            StrongPlayer(seed=0).choose(THESIS.empty())
        assert main(["solve", ".....|.....|.....|.....|....."]) == 1
        assert "reinstall kinegym" in capsys.readouterr().err
        assert book.load(CLASSIC) is None  # 3x3 has no book and needs none
    finally:
        monkeypatch.undo()
        book.load.cache_clear()
    assert book.load(THESIS) is not None


def test_book_is_consistent_and_its_deepest_entries_resolve() -> None:
    """Every entry with fewer stones than the book's depth must equal the negamax of its
    children's entries (a check of all of them without any search); a sample of the
    deepest entries is re-solved from scratch."""
    got = book.load(THESIS)
    assert got is not None, "the shipped 5x5x4 book is missing: python -m kinegym.agents.book"
    values, max_stones = got
    levels = book.positions(THESIS, max_stones)
    assert sum(len(lv) for lv in levels) == len(values)
    for level in levels[:-1]:
        for b in level:
            kids = book.child_values(b)
            assert kids is not None and max(kids.values()) == values[canonical_key(b)], str(b)
    assert values[canonical_key(THESIS.empty())] == 0  # 5x5, four in a row: a draw
    rng = np.random.default_rng(0)
    solver = Solver(THESIS)
    deepest = levels[-1]
    for i in rng.choice(len(deepest), 2, replace=False):
        b = deepest[int(i)]
        assert values[canonical_key(b)] == solver.value(b), str(b)


def test_deterministic_strong_player_repeats_itself_under_any_load() -> None:
    """Budgets counted in nodes: a seeded player makes the same moves, however slow the
    machine (a tiny budget forces the timed-out path, which wall time would make random)."""
    from kinegym.agents.minimax import RandomPlayer, StrongPlayer
    from kinegym.envs.game import THESIS

    sources: set[str] = set()

    def game(seed: int) -> list[int]:
        sp = StrongPlayer(seed=seed, deterministic=True, time_budget_s=0.01, hard_limit_s=0.02)
        rp = RandomPlayer(seed=seed)
        b, moves = THESIS.empty(), []
        while not b.is_over:
            c = (sp if b.to_move == 1 else rp).choose(b)
            if b.to_move == 1:
                sources.add(sp.last.source)
            moves.append(c)
            b = b.play(c)
        return moves

    assert game(3) == game(3)
    assert "heuristic" in sources  # the budget really ran out
    assert game(3) != game(4)


def test_win_probe_out_of_time_still_proves_a_move_that_keeps_a_draw() -> None:
    """Off the book, the player first asks "can I force a win?" with half its budget; out of
    time it plays a move it proves keeps at least a draw (value a lower bound, exact False).
    The move is checked against the exact value of the position after it."""
    from kinegym.agents.minimax import RandomPlayer

    checked = 0
    for seed in range(12):
        rp, b = RandomPlayer(seed=seed), THESIS.empty()
        for _ in range(6):
            b = b.play(rp.choose(b))
        if b.is_over:
            continue
        sp = StrongPlayer(seed=0, deterministic=True, time_budget_s=0.002, hard_limit_s=30)
        move = sp.choose(b)
        if sp.last.source != "search" or sp.last.exact:
            continue
        assert sp.last.value == 0 and b.is_legal(move)
        assert -Solver(THESIS).value(b.play(move)) >= 0, str(b)
        checked += 1
        if checked == 3:
            break
    assert checked == 3


def test_a_lost_position_is_reported_lost() -> None:
    b = CLASSIC.parse("XX.|.O.|X.O")  # O to move; X threatens the top row and the left column
    a = StrongPlayer(seed=0).analyse(b)
    assert a.value == -1 and a.exact and sorted(a.best_moves) == sorted(b.legal_moves())
