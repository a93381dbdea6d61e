"""A dependency-free progress bar for long CLI jobs (stderr; redraws only on a terminal)."""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """``with Progress(total, "study") as bar: ... bar.update()``.

    On a terminal it redraws one line at most ten times a second; in a log (CI) it prints a
    line at every quarter, so long jobs never look hung and logs stay short.
    """

    def __init__(self, total: int, desc: str = "", stream: TextIO | None = None, enabled: bool = True) -> None:
        self.total, self.desc = max(int(total), 1), desc
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.done = 0
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._t0 = time.perf_counter()
        self._last_draw = 0.0
        self._last_quarter = -1

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        if self.enabled and et is None:
            self._draw(final=True)
            if self._tty:
                self.stream.write("\n")
            self.stream.flush()

    def update(self, n: int = 1) -> None:
        self.done = min(self.total, self.done + n)
        if not self.enabled:
            return
        now = time.perf_counter()
        if self._tty and now - self._last_draw >= 0.1:
            self._last_draw = now
            self._draw()
        elif not self._tty and self.done * 4 // self.total > self._last_quarter and self.done < self.total:
            self._draw()

    def _draw(self, final: bool = False) -> None:
        frac = self.done / self.total
        elapsed = time.perf_counter() - self._t0
        eta = elapsed / frac - elapsed if frac > 0 else 0.0
        width = 28
        bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
        line = f"{self.desc} [{bar}] {self.done}/{self.total} {elapsed:5.1f}s"
        if not final and frac >= 0.05:  # an eta from the first few steps would be noise
            line += f" eta {eta:4.0f}s"
        if self._tty:
            self.stream.write("\r" + line)
        else:
            self._last_quarter = self.done * 4 // self.total
            self.stream.write(line + "\n")
        self.stream.flush()
