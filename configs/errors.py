"""The configuration error every loader raises (kept apart so :mod:`kinegym.configs.io` can use it)."""

from __future__ import annotations

from typing import Any

__all__ = ["ConfigError"]


class ConfigError(ValueError):
    """A configuration is missing, malformed or holds a bad value.

    Attributes ``source`` (file), ``key`` (dotted path), ``value`` and ``expected`` say
    exactly what is wrong; ``str(err)`` is one line naming all four.
    """

    def __init__(self, source: str, key: str, value: Any, expected: str) -> None:
        self.source, self.key, self.value, self.expected = source, key, value, expected
        where = f"{source}: {key}" if key else source
        super().__init__(f"{where}: {value!r} is not valid; expected {expected}")
