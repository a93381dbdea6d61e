"""The most probable board whose X and O counts a game can have.

Players take turns, so a board photographed in play holds as many X as O, or one more of
whoever began. The classifier calls each cell on its own; when its most probable call per
cell breaks that count (an X read empty beside its O, say), :func:`most_probable_board`
returns the board of highest probability that keeps it (the cells' probabilities taken as
independent: the sum of their log-probabilities, maximised by dynamic programming over the
running count difference, exact and linear in the cells). A board that already keeps the
count is returned as it was read.

Rules (:data:`COUNT_RULES`): ``"alternate"`` (either may begin: the counts differ by at most
one), ``"x-first"`` (X began: X - O is 0 or 1), ``"o-first"`` (O - X is 0 or 1), ``"any"`` (no
rule: every cell's own most probable call).
"""

from __future__ import annotations

import numpy as np

from .errors import VisionError

__all__ = ["COUNT_RULES", "count_rule", "most_probable_board", "keeps_count"]

#: the count rules and the X - O differences each allows (None: any)
COUNT_RULES: dict[str, tuple[int, ...] | None] = {"alternate": (-1, 0, 1), "x-first": (0, 1), "o-first": (-1, 0),
                                                  "any": None}
_STEP = np.array([0, 1, -1])  # empty, X, O: what each call adds to X - O


def count_rule(rule: str) -> tuple[int, ...] | None:
    """The X - O differences ``rule`` allows (None: any); :class:`VisionError` naming an unknown rule."""
    if rule not in COUNT_RULES:
        raise VisionError(f"counts={rule!r}; expected one of {', '.join(map(repr, COUNT_RULES))}")
    return COUNT_RULES[rule]


def keeps_count(cells: np.ndarray, rule: str = "alternate") -> bool:
    """Whether a board of calls (0 empty, 1 X, 2 O) has X and O counts the ``rule`` allows."""
    allowed = count_rule(rule)
    c = np.asarray(cells)
    return allowed is None or int((c == 1).sum() - (c == 2).sum()) in allowed


def most_probable_board(probs: np.ndarray, rule: str = "alternate") -> np.ndarray:
    """``(n, n)`` calls (0 empty, 1 X, 2 O) of highest joint probability among the boards the
    count ``rule`` allows, from ``probs`` ``(n, n, 3)`` (empty / X / O per cell; see the module
    docstring). The per-cell argmax when it keeps the count."""
    p = np.asarray(probs, np.float64)
    if p.ndim != 3 or p.shape[-1] != 3 or p.shape[0] != p.shape[1]:
        raise VisionError(f"probs of shape {p.shape}; expected (n, n, 3)")
    allowed = count_rule(rule)
    first = p.argmax(axis=-1)
    if allowed is None or keeps_count(first, rule):
        return first
    lp = np.log(np.clip(p.reshape(-1, 3), 1e-300, 1.0))
    m = len(lp)
    # best[d + m]: the best log-probability of the cells so far with X - O = d
    best = np.full(2 * m + 1, -np.inf)
    best[m] = 0.0
    came = np.zeros((m, 2 * m + 1), np.int64)
    for i in range(m):
        options = np.full((3, 2 * m + 1), -np.inf)
        options[0] = best + lp[i, 0]
        options[1, 1:] = best[:-1] + lp[i, 1]  # an X: one more
        options[2, :-1] = best[1:] + lp[i, 2]  # an O: one fewer
        came[i] = options.argmax(axis=0)
        best = options.max(axis=0)
    ends = np.array(allowed) + m
    d = int(ends[np.argmax(best[ends])])
    cells = np.empty(m, np.int64)
    for i in range(m - 1, -1, -1):
        cells[i] = came[i, d]
        d -= int(_STEP[cells[i]])
    return cells.reshape(p.shape[:2])
