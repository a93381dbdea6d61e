"""A small widget layer for kinegym's windows: buttons, sliders, choices and labels drawn with
OpenCV into the app's RGB frame, fed with toolkit-neutral :class:`Event` objects.

The apps draw their whole frame as a numpy array (the same pictures the CLI saves), so a
screenshot is just the frame, tests need no display, and pygame (see
:mod:`kinegym.gui.window`) only shows frames and turns its events into :class:`Event`.
Every widget has a keyboard shortcut (``key``), shown in its label.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["Event", "Widget", "Button", "Slider", "Choice", "Label", "Panel", "text"]

Colour = tuple[int, int, int]
_INK: Colour = (30, 30, 30)
_FACE: Colour = (232, 232, 226)
_ACCENT: Colour = (31, 119, 180)
_ON: Colour = (190, 215, 240)


@dataclass(frozen=True)
class Event:
    """``kind``: ``"down"``, ``"up"``, ``"move"`` (``pos`` in frame pixels, ``buttons`` held),
    ``"key"`` (``key``: a name like ``"space"``, ``"return"``, ``"escape"``, ``"a"``, ``"1"``,
    ``"left"``) or ``"quit"``."""

    kind: str
    pos: tuple[int, int] = (0, 0)
    key: str = ""
    buttons: bool = False


def text(img: np.ndarray, s: str, at: tuple[int, int], size: float = 0.45, colour: Colour = _INK,
         bold: bool = False) -> None:
    """Anti-aliased text at pixel ``at`` (baseline left)."""
    cv2.putText(img, s, at, cv2.FONT_HERSHEY_SIMPLEX, size, colour, 2 if bold else 1, cv2.LINE_AA)


@dataclass
class Widget:
    """A rectangle ``(x, y, w, h)`` in frame pixels with a ``label`` and a shortcut ``key``."""

    rect: tuple[int, int, int, int]
    label: str
    key: str = ""

    def hit(self, pos: tuple[int, int]) -> bool:
        x, y, w, h = self.rect
        return x <= pos[0] < x + w and y <= pos[1] < y + h

    def handle(self, ev: Event) -> bool:  # pragma: no cover - overridden
        return False

    def draw(self, img: np.ndarray) -> None:  # pragma: no cover - overridden
        pass

    def caption(self) -> str:
        return f"{self.label} [{self.key}]" if self.key else self.label


@dataclass
class Button(Widget):
    """Calls ``on_press`` on a click or its key; ``active`` draws it pressed (a toggle's state)."""

    on_press: Callable[[], None] = lambda: None
    active: bool = False
    enabled: bool = True

    def handle(self, ev: Event) -> bool:
        if not self.enabled:
            return False
        if (ev.kind == "down" and self.hit(ev.pos)) or (ev.kind == "key" and self.key and ev.key == self.key):
            self.on_press()
            return True
        return False

    def draw(self, img: np.ndarray) -> None:
        x, y, w, h = self.rect
        cv2.rectangle(img, (x, y), (x + w - 1, y + h - 1), _ON if self.active else _FACE, -1)
        cv2.rectangle(img, (x, y), (x + w - 1, y + h - 1), _ACCENT if self.enabled else (170, 170, 170), 1)
        text(img, self.caption(), (x + 6, y + h // 2 + 5), 0.42, _INK if self.enabled else (150, 150, 150))


@dataclass
class Slider(Widget):
    """A value in ``[lo, hi]`` set by dragging, or stepped by its keys (``key`` down, ``key_up``
    up, by ``step``); ``on_change`` gets the new value."""

    lo: float = 0.0
    hi: float = 1.0
    value: float = 0.0
    step: float = 0.1
    key_up: str = ""
    unit: str = ""
    on_change: Callable[[float], None] = lambda v: None
    dragging: bool = field(default=False, repr=False)

    def set(self, v: float) -> None:
        v = float(min(self.hi, max(self.lo, v)))
        if v != self.value:
            self.value = v
            self.on_change(v)

    def _track(self) -> tuple[int, int, int]:
        x, y, w, h = self.rect
        return x + 8, x + w - 8, y + h - 10

    def handle(self, ev: Event) -> bool:
        x0, x1, _ = self._track()
        if ev.kind == "down" and self.hit(ev.pos):
            self.dragging = True
        elif ev.kind == "up":
            was, self.dragging = self.dragging, False
            return was
        elif ev.kind == "key" and ev.key in (self.key, self.key_up) and ev.key:
            self.set(self.value + (self.step if ev.key == self.key_up else -self.step))
            return True
        if self.dragging and ev.kind in ("down", "move"):
            t = (ev.pos[0] - x0) / max(1, x1 - x0)
            raw = self.lo + t * (self.hi - self.lo)
            self.set(round(raw / self.step) * self.step)
            return True
        return False

    def draw(self, img: np.ndarray) -> None:
        x, y, w, h = self.rect
        x0, x1, ty = self._track()
        keys = f" [{self.key}/{self.key_up}]" if self.key else ""
        text(img, f"{self.label}: {self.value:g} {self.unit}{keys}", (x + 4, y + 14), 0.42)
        cv2.line(img, (x0, ty), (x1, ty), (150, 150, 150), 2, cv2.LINE_AA)
        u = int(round(x0 + (self.value - self.lo) / max(1e-12, self.hi - self.lo) * (x1 - x0)))
        cv2.circle(img, (u, ty), 6, _ACCENT, -1, cv2.LINE_AA)


@dataclass
class Choice(Widget):
    """One of ``options``: click an option, or press its shortcut (``keys``, one per option)."""

    options: Sequence[str] = ()
    keys: Sequence[str] = ()
    index: int = 0
    on_change: Callable[[str], None] = lambda s: None

    def _cells(self) -> list[tuple[int, int, int, int]]:
        x, y, w, h = self.rect
        n = max(1, len(self.options))
        cw = w // n
        return [(x + i * cw, y + 18, cw - 2, h - 18) for i in range(n)]

    def select(self, i: int) -> None:
        if i != self.index:
            self.index = i
            self.on_change(self.options[i])

    @property
    def value(self) -> str:
        return self.options[self.index]

    def handle(self, ev: Event) -> bool:
        if ev.kind == "down":
            for i, (x, y, w, h) in enumerate(self._cells()):
                if x <= ev.pos[0] < x + w and y <= ev.pos[1] < y + h:
                    self.select(i)
                    return True
        if ev.kind == "key" and ev.key in self.keys:
            self.select(list(self.keys).index(ev.key))
            return True
        return False

    def draw(self, img: np.ndarray) -> None:
        x, y, _, _ = self.rect
        text(img, self.label, (x + 4, y + 13), 0.42)
        for i, (cx, cy, w, h) in enumerate(self._cells()):
            on = i == self.index
            cv2.rectangle(img, (cx, cy), (cx + w - 1, cy + h - 1), _ON if on else _FACE, -1)
            cv2.rectangle(img, (cx, cy), (cx + w - 1, cy + h - 1), _ACCENT, 2 if on else 1)
            k = f" [{self.keys[i]}]" if i < len(self.keys) else ""
            text(img, f"{self.options[i]}{k}", (cx + 4, cy + h // 2 + 5), 0.38)


@dataclass
class Label(Widget):
    """Text lines; ``lines`` is set by the app each frame."""

    lines: Sequence[str] = ()
    size: float = 0.42

    def handle(self, ev: Event) -> bool:
        return False

    def draw(self, img: np.ndarray) -> None:
        x, y, _, _ = self.rect
        if self.label:
            text(img, self.label, (x + 4, y + 14), 0.5, colour=_ACCENT)
            y += 18
        for i, s in enumerate(self.lines):
            text(img, s, (x + 4, y + 14 + 17 * i), self.size)


@dataclass
class Panel:
    """The widgets of one app: events go to the first widget that takes them."""

    widgets: list[Widget] = field(default_factory=list)

    def add(self, w: Widget) -> Widget:
        self.widgets.append(w)
        return w

    def handle(self, ev: Event) -> bool:
        return any(w.handle(ev) for w in self.widgets)

    def draw(self, img: np.ndarray) -> None:
        for w in self.widgets:
            w.draw(img)
