"""The one pygame window every kinegym GUI runs in, and the scripted driver tests use.

An *app* has ``size`` (width, height), ``handle(event) -> None``, ``update(dt) -> None``
(advance its simulation by at most ``dt`` seconds: work is done in slices between frames so
the window stays responsive), ``render() -> RGB array`` and ``done``. :func:`run` shows it
in a pygame window at ``fps``, turning pygame's mouse and keyboard events into
:class:`~kinegym.gui.widgets.Event`; ``script`` posts synthetic pygame events at given frames
(so a test drives the real event loop under ``SDL_VIDEODRIVER=dummy``) and ``screenshot``
saves the last frame. :func:`drive` runs an app without pygame at all (events straight in).
pygame is imported here only; a missing pygame is a :class:`GuiUnavailable` with the
install hint.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from kinegym.gui.widgets import Event

__all__ = ["App", "GuiUnavailable", "RunStats", "run", "drive", "pygame_or_hint"]


class GuiUnavailable(RuntimeError):
    """No GUI toolkit: the message says what to install."""


class App(Protocol):
    size: tuple[int, int]
    done: bool

    def handle(self, ev: Event) -> None: ...
    def update(self, dt: float) -> None: ...
    def render(self) -> np.ndarray: ...


@dataclass
class RunStats:
    """Frames shown, wall seconds, and the frame rate over the run."""

    frames: int = 0
    seconds: float = 0.0
    frame_ms: list[float] = field(default_factory=list)

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


def pygame_or_hint() -> Any:
    """``pygame`` (pygame-ce), or :class:`GuiUnavailable` naming the extra to install."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    os.environ.setdefault("SDL_AUDIODRIVER", "dummy")  # no sound: no ALSA errors on machines without audio
    try:
        import pygame
    except ImportError:
        raise GuiUnavailable('the kinegym windows need pygame-ce: pip install "kinegym[human]"') from None
    return pygame


_KEYS = {"space": "space", "return": "return", "enter": "return", "escape": "escape", "backspace": "backspace",
         "left": "left", "right": "right", "up": "up", "down": "down", "tab": "tab"}


def _to_event(pg: Any, ev: Any) -> Event | None:
    if ev.type == pg.QUIT:
        return Event("quit")
    if ev.type == pg.MOUSEBUTTONDOWN and ev.button == 1:
        return Event("down", tuple(ev.pos), buttons=True)
    if ev.type == pg.MOUSEBUTTONUP and ev.button == 1:
        return Event("up", tuple(ev.pos))
    if ev.type == pg.MOUSEMOTION:
        return Event("move", tuple(ev.pos), buttons=bool(ev.buttons[0]))
    if ev.type == pg.KEYDOWN:
        name = pg.key.name(ev.key)
        return Event("key", key=_KEYS.get(name, name))
    return None


def key_event(pg: Any, name: str) -> Any:
    """A pygame KEYDOWN event for the key ``name`` (for scripts)."""
    return pg.event.Event(pg.KEYDOWN, key=pg.key.key_code(name), mod=0, unicode="", scancode=0)


def mouse_events(pg: Any, kind: str, pos: tuple[int, int], held: bool = False) -> Any:
    """A pygame mouse event (``down``, ``up`` or ``move``) at ``pos`` (for scripts)."""
    if kind == "down":
        return pg.event.Event(pg.MOUSEBUTTONDOWN, pos=pos, button=1)
    if kind == "up":
        return pg.event.Event(pg.MOUSEBUTTONUP, pos=pos, button=1)
    return pg.event.Event(pg.MOUSEMOTION, pos=pos, rel=(0, 0), buttons=(1 if held else 0, 0, 0))


def run(app: App, fps: float = 30.0, title: str = "kinegym", script: Sequence[tuple[int, Any]] = (),
        max_frames: int | None = None, screenshot: str | Path | None = None) -> RunStats:
    """Show ``app`` until it is done (or ``max_frames``); ``script``: ``(frame, event-or-key-name)``
    pairs posted to pygame's queue at that frame (a ``str`` is a key press)."""
    pg = pygame_or_hint()
    pg.display.init()
    pg.font.init() if hasattr(pg, "font") else None
    screen = pg.display.set_mode(app.size)
    pg.display.set_caption(title)
    clock = pg.time.Clock()
    stats = RunStats()
    pending = sorted(script, key=lambda s: s[0])
    frame = None
    t0 = time.perf_counter()
    try:
        while not app.done and (max_frames is None or stats.frames < max_frames):
            f0 = time.perf_counter()
            while pending and pending[0][0] <= stats.frames:
                item = pending.pop(0)[1]
                pg.event.post(key_event(pg, item) if isinstance(item, str) else item)
            for raw in pg.event.get():
                ev = _to_event(pg, raw)
                if ev is not None:
                    app.handle(ev)
            app.update(1.0 / fps)
            frame = app.render()
            buf = np.ascontiguousarray(frame)
            screen.blit(pg.image.frombuffer(buf.data, (buf.shape[1], buf.shape[0]), "RGB"), (0, 0))
            pg.display.flip()
            stats.frame_ms.append(1000 * (time.perf_counter() - f0))
            stats.frames += 1
            clock.tick(fps)
    finally:
        stats.seconds = time.perf_counter() - t0
        pg.display.quit()
    if screenshot is not None and frame is not None:
        from kinegym.vision.image_io import write_image

        write_image(frame, screenshot)
    return stats


def drive(app: App, events: Sequence[Event], dt: float = 1.0 / 30.0, frames_after: int = 1) -> np.ndarray:
    """Feed ``events`` one per frame (updating between them), then ``frames_after`` more
    frames; returns the last frame. No window, no pygame."""
    for ev in events:
        app.handle(ev)
        app.update(dt)
    for _ in range(frames_after):
        app.update(dt)
    return app.render()
