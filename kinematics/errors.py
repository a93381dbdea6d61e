"""Named exceptions of the kinematics package, and the input checks that raise them.

Every error message names the offending value and says what would be valid, so a CLI can
print it as one line and a caller can catch the precise kind:

* :class:`InvalidInputError` - wrong shape, NaN/inf, wrong type (also a ``ValueError``);
* :class:`UnreachableError` - a well-formed target outside the workspace;
* :class:`JointLimitError` - reachable, but no solution respects the joint limits.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "KinematicsError",
    "InvalidInputError",
    "UnreachableError",
    "JointLimitError",
    "as_array",
]


class KinematicsError(Exception):
    """Base class of every error raised by :mod:`kinegym.kinematics`."""


class InvalidInputError(KinematicsError, ValueError):
    """An argument has the wrong shape, type, or holds NaN / infinity."""


class UnreachableError(KinematicsError, ValueError):
    """A target lies outside the reachable workspace.

    ``details`` holds machine-readable context (which arm, distance, reach interval).
    """

    def __init__(self, message: str, **details: Any) -> None:
        super().__init__(message)
        self.details = details


class JointLimitError(UnreachableError):
    """The target is reachable geometrically but every solution violates a joint limit."""


def _short(value: Any) -> str:
    text = np.array2string(np.asarray(value), precision=4, threshold=12) if isinstance(
        value, (np.ndarray, list, tuple)
    ) else repr(value)
    return text if len(text) < 200 else text[:197] + "..."


def as_array(name: str, value: Any, tail: tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a float64 array whose trailing dimensions are ``tail``.

    Leading (batch) dimensions are free. Raises :class:`InvalidInputError` naming ``name``,
    the value and the expected shape when the shape is wrong or a value is not finite.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"{name}={_short(value)} is not numeric; expected an array of shape (..., "
            f"{', '.join(map(str, tail))})"
        ) from exc
    if arr.ndim < len(tail) or (tail and arr.shape[arr.ndim - len(tail):] != tail):
        want = "(..., " + ", ".join(map(str, tail)) + ")" if tail else "a scalar or array"
        raise InvalidInputError(f"{name} has shape {arr.shape}; expected {want}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name}={_short(value)} holds NaN or infinity; expected finite values")
    return arr
