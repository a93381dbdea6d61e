"""The reader's errors, importable without OpenCV (the CLI maps them to exit codes)."""

from __future__ import annotations

__all__ = ["VisionError", "NoBoardError"]


class VisionError(ValueError):
    """Bad input to the reader (not an image, wrong size argument, ...)."""


class NoBoardError(VisionError):
    """No tic-tac-toe grid could be found in the image; ``reason`` says what was missing."""

    def __init__(self, reason: str) -> None:
        super().__init__(f"no board found: {reason}")
        self.reason = reason
