"""The environments' named errors, and the one action check every env's ``step()`` runs.

Gymnasium's own envs ``assert`` that an action lies in the action space; kinegym's raise a
named error instead, saying which actions are valid, and refuse a ``step()`` once the
episode has ended (the caller must ``reset()``):

* :class:`InvalidActionError` (a ``ValueError``) - wrong type (a string, a float, a bool),
  out of range, or masked out by ``action_masks()``;
* :class:`ResetNeededError` (a ``RuntimeError``) - ``step()`` before the first ``reset()``
  or after ``terminated``/``truncated``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["InvalidActionError", "ResetNeededError", "NoRouteError", "check_action"]


class InvalidActionError(ValueError):
    """An action the env cannot take: ``action`` as given, ``valid`` the actions that are."""

    def __init__(self, message: str, action: Any, valid: list[int]) -> None:
        super().__init__(message)
        self.action, self.valid = action, valid


class ResetNeededError(RuntimeError):
    """``step()`` without a live episode: call ``reset()`` first."""


class NoRouteError(ValueError):
    """A wall on which no climb from the bottom to the top exists for the robot (too few or
    too far-apart holes for its reach): a task that cannot be posed."""


def _short(valid: list[int]) -> str:
    return str(valid) if len(valid) <= 24 else f"{valid[:24]}... ({len(valid)} actions)"


def check_action(action: Any, n: int, mask: np.ndarray | None = None) -> int:
    """``action`` as an ``int`` in ``0..n-1`` allowed by ``mask``, or :class:`InvalidActionError`.

    Accepted: Python ints, numpy integers and integer arrays of one element (what SB3's
    ``predict`` returns); refused: bools, floats, strings and anything else."""
    a = action
    if isinstance(a, np.ndarray) and a.size == 1 and np.issubdtype(a.dtype, np.integer):
        a = a.reshape(()).item()
    valid = list(range(n)) if mask is None else [int(i) for i in np.flatnonzero(mask)]
    if isinstance(a, (bool, np.bool_)) or not isinstance(a, (int, np.integer)):
        raise InvalidActionError(f"action {action!r} of type {type(action).__name__}; expected an integer in "
                                 f"0..{n - 1}, one of {_short(valid)}", action, valid)
    a = int(a)
    if not 0 <= a < n:
        raise InvalidActionError(f"action {a} is out of range; expected 0..{n - 1}, one of {_short(valid)}",
                                 action, valid)
    if mask is not None and not mask[a]:
        raise InvalidActionError(f"action {a} is masked out (action_masks()[{a}] is False); valid now: "
                                 f"{_short(valid)}", action, valid)
    return a
