"""A pygame window for the envs' ``render_mode="human"``, imported lazily.

pygame is an optional dependency (the ``human`` extra); ``rgb_array`` rendering never
needs it. A missing pygame raises :class:`gymnasium.error.DependencyNotInstalled` saying
what to install, instead of a bare ``ModuleNotFoundError`` from deep inside ``render()``.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from gymnasium.error import DependencyNotInstalled


class Window:
    """One lazily opened pygame window showing RGB frames at a fixed rate."""

    def __init__(self, caption: str, fps: float) -> None:
        self.caption = caption
        self.fps = fps
        self._screen: Any = None
        self._clock: Any = None

    def show(self, frame: np.ndarray) -> None:
        """Blit an (H, W, 3) uint8 frame, pump events and wait for the frame rate."""
        os.environ.setdefault("SDL_AUDIODRIVER", "dummy")  # video only: no ALSA errors on machines without sound
        try:
            import pygame
        except ImportError as exc:
            raise DependencyNotInstalled(
                'render_mode="human" needs pygame: pip install "kinegym[human]" '
                '(or use render_mode="rgb_array", which needs no display)') from exc
        if self._screen is None:
            pygame.display.init()  # not pygame.init(): no mixer, no audio device
            self._screen = pygame.display.set_mode(frame.shape[1::-1])
            pygame.display.set_caption(self.caption)
            self._clock = pygame.time.Clock()
        surf = pygame.surfarray.make_surface(np.ascontiguousarray(frame.transpose(1, 0, 2)))
        self._screen.blit(surf, (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self._clock.tick(self.fps)

    def close(self) -> None:
        if self._screen is not None:
            import pygame

            pygame.display.quit()
            pygame.quit()
            self._screen = None
