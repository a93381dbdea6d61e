"""One climbing episode, played by any agent: the single episode loop behind evaluation,
``kinegym climb`` and the demo.

An agent is anything with ``act(env, obs) -> action | None`` (:class:`~kinegym.agents.gait_planner.PlannerAgent`,
:class:`~kinegym.agents.policies.MaskedPolicyAgent`); it is handed the unwrapped env, so a
masked policy predicts with the env's own ``action_masks()``. ``None`` ends the episode
early (the planner proves it cannot get on from here).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

__all__ = ["Agent", "Episode", "run_episode"]


class Agent(Protocol):
    """What :func:`run_episode` drives."""

    def act(self, env: Any, obs: Any = None) -> int | None: ...


@dataclass
class Episode:
    """What one episode came to: success, moves, falls, return, the agent's thinking time per
    step (s), the last ``info``, when asked for the rendered frames, and each step's reward."""

    success: bool
    moves: int
    falls: int
    ret: float
    think_s: list[float]
    info: dict[str, Any]
    seconds: float
    frames: list[np.ndarray] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)


def run_episode(env: Any, agent: Agent, seed: int | None = None, frames: bool = False,
                on_step: Callable[[], None] | None = None) -> Episode:
    """Reset ``env`` with ``seed`` and let ``agent`` act until the episode ends; ``frames``
    collects ``env.render()`` after the reset and every step; ``on_step`` is called after each step."""
    tic = time.perf_counter()
    obs, info = env.reset(seed=seed)
    shots = [env.render()] if frames else []
    done, falls, think, rewards = False, 0, [], []
    while not done:
        t0 = time.perf_counter()
        a = agent.act(env.unwrapped, obs)
        think.append(time.perf_counter() - t0)
        if a is None:
            break
        obs, r, term, trunc, info = env.step(a)
        rewards.append(float(r))
        falls += info["outcome"] == "fell"
        done = term or trunc
        if frames:
            shots.append(env.render())
        if on_step is not None:
            on_step()
    return Episode(bool(info["is_success"]), int(info["moves"]), falls, sum(rewards), think, info,
                   time.perf_counter() - tic, shots, rewards)
