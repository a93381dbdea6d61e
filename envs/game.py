"""(m, n, k) game rules - tic-tac-toe and the seed thesis's 5 x 5 four-in-a-row - on bitboards.

A :class:`Game` is a board of ``rows x cols`` cells where ``k`` in a row (across, down or
diagonally) wins; :data:`CLASSIC` is 3 x 3 x 3 and :data:`THESIS` is seed 003's
5 x 5 x 4. A :class:`Board` is an immutable position: two Python ``int`` bitmasks, one per
player, with cell ``r * cols + c`` at bit ``r * cols + c`` (row 0 is the top row, as the
text form reads). X always moves first, so whose turn it is follows from the counts.

Every winning line is precomputed as a bitmask, and the lines through each cell as a
tuple, so ``winner`` after a move is a handful of integer ``&`` tests - cheap enough for
search. The text form is one string per row joined by ``|`` (``"X..|.O.|..."``); ``.``,
``-``, ``_`` or a space mark an empty cell.

Bad input never passes silently: a wrong size, an unknown character, an occupied or
out-of-range cell, a move after the game is over, or an impossible position (both
players with ``k`` in a row, O ahead of X, X two ahead, play continued after a win)
raises a :class:`GameError` subclass naming the value and what would be valid.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property

__all__ = [
    "Game",
    "Board",
    "CLASSIC",
    "THESIS",
    "GameError",
    "IllegalMoveError",
    "InvalidPositionError",
    "X",
    "O",
    "EMPTY",
]

#: Cell contents as small ints (also the values of :meth:`Board.cells`).
EMPTY, X, O = 0, 1, 2
_SYMBOL = {EMPTY: ".", X: "X", O: "O"}
_EMPTY_CHARS = frozenset(".-_ ")


class GameError(ValueError):
    """Base class of the game-rule errors: a bad board, move or position."""


class IllegalMoveError(GameError):
    """A move that the rules do not allow (occupied cell, off the board, game over)."""


class InvalidPositionError(GameError):
    """A position that no legal game reaches (wrong counts, two winners, play after a win)."""


@dataclass(frozen=True)
class Game:
    """An (m, n, k) game: ``rows x cols`` cells, ``k`` in a row wins.

    Attributes:
        rows: number of rows (>= 1).
        cols: number of columns (>= 1).
        k: stones in a row needed to win (1 <= k <= max(rows, cols)).
    """

    rows: int
    cols: int
    k: int
    lines: tuple[int, ...] = field(init=False, repr=False, compare=False)
    lines_through: tuple[tuple[int, ...], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("rows", "cols", "k"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                raise GameError(f"{name}={v!r}; expected a positive integer")
        if self.rows * self.cols > 64:
            raise GameError(f"board {self.rows}x{self.cols} has {self.rows * self.cols} cells; at most 64 supported")
        if self.k > max(self.rows, self.cols):
            raise GameError(f"k={self.k} on a {self.rows}x{self.cols} board: nobody could ever win; "
                            f"expected 1 <= k <= {max(self.rows, self.cols)}")
        lines = []
        for r in range(self.rows):
            for c in range(self.cols):
                for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
                    er, ec = r + dr * (self.k - 1), c + dc * (self.k - 1)
                    if 0 <= er < self.rows and 0 <= ec < self.cols:
                        mask = 0
                        for i in range(self.k):
                            mask |= 1 << ((r + dr * i) * self.cols + c + dc * i)
                        lines.append(mask)
        lines = sorted(set(lines))
        through = tuple(tuple(m for m in lines if m >> cell & 1) for cell in range(self.rows * self.cols))
        object.__setattr__(self, "lines", tuple(lines))
        object.__setattr__(self, "lines_through", through)

    @property
    def n_cells(self) -> int:
        return self.rows * self.cols

    @property
    def full(self) -> int:
        """Bitmask of every cell."""
        return (1 << self.n_cells) - 1

    def cell(self, row: int, col: int) -> int:
        """Cell index of ``(row, col)`` (row 0 at the top)."""
        if not (0 <= row < self.rows and 0 <= col < self.cols):
            raise IllegalMoveError(f"cell (row {row}, col {col}) is off the {self.rows}x{self.cols} board")
        return row * self.cols + col

    def rc(self, cell: int) -> tuple[int, int]:
        """``(row, col)`` of a cell index."""
        return divmod(cell, self.cols)

    def empty(self) -> Board:
        """The empty board of this game."""
        return Board(self, 0, 0)

    def parse(self, text: str) -> Board:
        """A board of this game from its text form (see :meth:`Board.parse`)."""
        return Board.parse(text, k=self.k, game=self)

    def __str__(self) -> str:
        return f"{self.rows}x{self.cols}x{self.k}"


#: Classic tic-tac-toe: 3 x 3, three in a row.
CLASSIC = Game(3, 3, 3)
#: Seed 003's game: 5 x 5, four in a row.
THESIS = Game(5, 5, 4)


def _popcount(v: int) -> int:
    return bin(v).count("1")


def _has_line(game: Game, bits: int) -> bool:
    return any(bits & m == m for m in game.lines)


@dataclass(frozen=True)
class Board:
    """An immutable position: bitmasks ``x`` and ``o`` of the cells each player holds.

    Build one with :meth:`Game.empty`, :meth:`parse` or :meth:`play`; the constructor
    checks that the position can arise in a legal game.
    """

    game: Game
    x: int
    o: int

    def __post_init__(self) -> None:
        g = self.game
        if not isinstance(self.x, int) or not isinstance(self.o, int):
            raise InvalidPositionError(f"bitmasks x={self.x!r}, o={self.o!r}; expected ints")
        if self.x < 0 or self.o < 0 or (self.x | self.o) > g.full:
            raise InvalidPositionError(f"bitmasks x={self.x:#x}, o={self.o:#x} fall off the {g} board")
        if self.x & self.o:
            raise InvalidPositionError(f"cells {self._cells_of(self.x & self.o)} hold both X and O")
        nx, no = _popcount(self.x), _popcount(self.o)
        if not (nx == no or nx == no + 1):
            raise InvalidPositionError(f"{nx} X and {no} O on the board: X moves first, so X must have as many "
                                       f"as O or one more")
        xw, ow = _has_line(g, self.x), _has_line(g, self.o)
        if xw and ow:
            raise InvalidPositionError(f"both X and O have {g.k} in a row:\n{self.pretty()}")
        if xw and nx == no:
            raise InvalidPositionError(f"O moved after X had already won:\n{self.pretty()}")
        if ow and nx > no:
            raise InvalidPositionError(f"X moved after O had already won:\n{self.pretty()}")

    # ------------------------------------------------------------ construction
    @classmethod
    def parse(cls, text: str, k: int | None = None, game: Game | None = None) -> Board:
        """A board from ``"X..|.O.|..."`` (rows top to bottom, joined by ``|`` or newlines).

        Args:
            text: one string per row; ``X``/``O`` (any case) for stones, ``.``, ``-``,
                ``_`` or space for empty. Rows must all have the same length.
            k: stones in a row to win; default 3 on 3 x 3 boards, 4 on bigger ones
                (the seed's 5 x 5 four-in-a-row).
            game: the game to check the text against (overrides ``k``).
        """
        if not isinstance(text, str):
            raise GameError(f"board text {text!r} is not a string; expected rows like 'X..|.O.|...'")
        rows = [r for r in text.replace("\n", "|").split("|")]
        if rows and rows[-1] == "" and len(rows) > 1:
            rows = rows[:-1]
        if not rows or any(len(r) != len(rows[0]) for r in rows) or not rows[0]:
            lens = [len(r) for r in rows]
            raise GameError(f"board text {text!r} has rows of lengths {lens}; expected equal, non-empty rows "
                            f"joined by '|'")
        if game is None:
            kk = k if k is not None else (3 if max(len(rows), len(rows[0])) <= 3 else 4)
            game = Game(len(rows), len(rows[0]), kk)
        elif (game.rows, game.cols) != (len(rows), len(rows[0])):
            raise GameError(f"board text {text!r} is {len(rows)}x{len(rows[0])}; expected {game.rows}x{game.cols}")
        x = o = 0
        for r, row in enumerate(rows):
            for c, ch in enumerate(row):
                bit = 1 << (r * game.cols + c)
                if ch in "xX":
                    x |= bit
                elif ch in "oO0":
                    o |= bit
                elif ch not in _EMPTY_CHARS:
                    raise GameError(f"board text {text!r}: character {ch!r} at row {r}, col {c}; expected X, O or .")
        return cls(game, x, o)

    @classmethod
    def from_cells(cls, game: Game, cells: object) -> Board:
        """A board from a ``rows x cols`` nested sequence / array of 0 (empty), 1 (X), 2 (O)."""
        flat = []
        try:
            grid = [list(row) for row in cells]  # type: ignore[attr-defined]
        except TypeError as err:
            raise GameError(f"cells {cells!r}: expected a {game.rows}x{game.cols} grid of 0/1/2") from err
        if len(grid) != game.rows or any(len(r) != game.cols for r in grid):
            raise GameError(f"cells have shape {[len(r) for r in grid]}; expected {game.rows}x{game.cols}")
        for row in grid:
            for v in row:
                if int(v) not in (EMPTY, X, O) or int(v) != v:
                    raise GameError(f"cell value {v!r}; expected 0 (empty), 1 (X) or 2 (O)")
                flat.append(int(v))
        x = sum(1 << i for i, v in enumerate(flat) if v == X)
        o = sum(1 << i for i, v in enumerate(flat) if v == O)
        return cls(game, x, o)

    # ------------------------------------------------------------ state
    @property
    def occupied(self) -> int:
        return self.x | self.o

    @property
    def n_stones(self) -> int:
        return _popcount(self.x | self.o)

    @property
    def to_move(self) -> int:
        """:data:`X` or :data:`O`: whose turn it is (meaningful while the game is not over)."""
        return X if _popcount(self.x) == _popcount(self.o) else O

    def stones(self, player: int) -> int:
        """Bitmask of ``player``'s stones."""
        return self.x if player == X else self.o

    @cached_property
    def winner(self) -> int:
        """:data:`X`, :data:`O`, or :data:`EMPTY` when nobody has ``k`` in a row."""
        if _has_line(self.game, self.x):
            return X
        if _has_line(self.game, self.o):
            return O
        return EMPTY

    @property
    def is_full(self) -> bool:
        return self.occupied == self.game.full

    @property
    def is_over(self) -> bool:
        return self.winner != EMPTY or self.is_full

    def result(self) -> str:
        """``"X wins"``, ``"O wins"``, ``"draw"`` or ``"in play"``."""
        if self.winner:
            return f"{_SYMBOL[self.winner]} wins"
        return "draw" if self.is_full else "in play"

    def legal_moves(self) -> list[int]:
        """Empty cells in index order; none once the game is over."""
        if self.is_over:
            return []
        free = self.game.full & ~self.occupied
        return [i for i in range(self.game.n_cells) if free >> i & 1]

    def is_legal(self, cell: int) -> bool:
        return (isinstance(cell, int) and 0 <= cell < self.game.n_cells and not (self.occupied >> cell & 1)
                and not self.is_over)

    def play(self, cell: int) -> Board:
        """The board after the player to move takes ``cell``."""
        g = self.game
        if isinstance(cell, bool) or not isinstance(cell, int) or not 0 <= cell < g.n_cells:
            raise IllegalMoveError(f"move {cell!r}; expected a cell index 0..{g.n_cells - 1} on the {g} board")
        if self.is_over:
            raise IllegalMoveError(f"move {cell} after the game is over ({self.result()})")
        if self.occupied >> cell & 1:
            r, c = g.rc(cell)
            raise IllegalMoveError(f"move {cell} (row {r}, col {c}) is taken; free cells: {self.legal_moves()}")
        if self.to_move == X:
            return Board(g, self.x | 1 << cell, self.o)
        return Board(g, self.x, self.o | 1 << cell)

    def cells(self) -> list[list[int]]:
        """Rows of 0 (empty), 1 (X), 2 (O)."""
        g = self.game
        return [[X if self.x >> (r * g.cols + c) & 1 else O if self.o >> (r * g.cols + c) & 1 else EMPTY
                 for c in range(g.cols)] for r in range(g.rows)]

    def _cells_of(self, mask: int) -> list[tuple[int, int]]:
        return [self.game.rc(i) for i in range(self.game.n_cells) if mask >> i & 1]

    def __iter__(self) -> Iterator[int]:
        for row in self.cells():
            yield from row

    # ------------------------------------------------------------ text
    def __str__(self) -> str:
        return "|".join("".join(_SYMBOL[v] for v in row) for row in self.cells())

    def pretty(self) -> str:
        """Multi-line picture with row and column numbers."""
        g = self.game
        head = "   " + " ".join(str(c) for c in range(g.cols))
        body = [f"{r:>2} " + " ".join(_SYMBOL[v] for v in row) for r, row in enumerate(self.cells())]
        return "\n".join([head, *body])

    def __repr__(self) -> str:
        return f"Board({self.game}, {str(self)!r})"
