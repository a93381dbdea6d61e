"""(m, n, k) game rules: lines, text form, legality, results, named errors."""

import pytest

from kinegym.envs.game import (
    CLASSIC,
    EMPTY,
    THESIS,
    Board,
    Game,
    GameError,
    IllegalMoveError,
    InvalidPositionError,
    O,
    X,
)


def test_line_counts_of_the_presets() -> None:
    assert len(CLASSIC.lines) == 8  # 3 rows, 3 columns, 2 diagonals
    # 5x5, four in a row: 2 per row and column (20), 4 + 4 diagonals of length 4 or 5
    assert len(THESIS.lines) == 28
    assert all(bin(m).count("1") == 4 for m in THESIS.lines)


def test_text_round_trip_and_turns() -> None:
    b = Board.parse("X..|.O.|...")
    assert str(b) == "X..|.O.|..." and b.game == CLASSIC and b.to_move == X
    assert Board.parse(str(THESIS.empty())).game == THESIS
    b2 = b.play(b.game.cell(2, 2))
    assert str(b2) == "X..|.O.|..X" and b2.to_move == O
    assert Board.parse("x..|.0.|-_ ").cells() == [[X, 0, 0], [0, O, 0], [0, 0, 0]]
    assert Board.from_cells(CLASSIC, b2.cells()) == b2


def test_results() -> None:
    assert Board.parse("XXX|OO.|...").result() == "X wins"
    assert Board.parse("XOX|XOO|OXX").result() == "draw"
    assert Board.parse("XOX|XOO|OX.").result() == "in play"
    assert THESIS.parse("X....|.X...|..X..|...X.|OOO..").winner == X  # four on the diagonal
    assert THESIS.parse("XXX..|.....|.....|X....|OOOO.").winner == O
    assert THESIS.parse("XXX..|.....|.....|.....|OOO..").winner == EMPTY  # three is not enough


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("X..|.O", "rows of lengths"),
        ("X..|.Q.|...", "character 'Q'"),
        ("XX.|...|...", "X must have as many"),
        ("O..|...|...", "X must have as many"),
        ("XXX|OOO|...", "both X and O"),
        ("XXX|OO.|O..", "O moved after X had already won"),
    ],
)
def test_bad_text_names_the_problem(text: str, needle: str) -> None:
    with pytest.raises(GameError, match=needle):
        Board.parse(text)


def test_impossible_positions_are_invalid_position_errors() -> None:
    with pytest.raises(InvalidPositionError):
        Board.parse("XXX|OOO|...")
    with pytest.raises(InvalidPositionError):
        Board(CLASSIC, 0b11, 0b11)


def test_illegal_moves() -> None:
    b = Board.parse("X..|...|...")
    with pytest.raises(IllegalMoveError, match="taken"):
        b.play(0)
    with pytest.raises(IllegalMoveError, match="0..8"):
        b.play(9)
    with pytest.raises(IllegalMoveError, match="game is over"):
        Board.parse("XXX|OO.|...").play(8)
    assert Board.parse("XXX|OO.|...").legal_moves() == []


def test_bad_games() -> None:
    with pytest.raises(GameError, match="nobody could ever win"):
        Game(3, 3, 4)
    with pytest.raises(GameError, match="positive integer"):
        Game(0, 3, 3)
    with pytest.raises(GameError, match="at most 64"):
        Game(9, 9, 5)


def test_empty_constant_and_cells() -> None:
    assert EMPTY == 0 and THESIS.empty().n_stones == 0
    assert THESIS.rc(THESIS.cell(3, 4)) == (3, 4)
