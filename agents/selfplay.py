"""Self-play on the drawn 3 x 3 game: MaskablePPO learns both sides by playing a frozen copy of itself.

The two-player game is :mod:`kinegym.envs.tictactoe_aec`; its single-agent view
(``kinegym/TicTacToeDraw3x3-v0``) takes any ``Board -> cell`` callable as the person. Here
that callable is the learner's own policy, frozen every ``swap_every`` steps (the usual SB3
self-play recipe): two envs, one where the learner holds X and one where it holds O, so one
network plays both sides. Observations are the board as the camera reads it; the opponent
looks at the real board, from its own side (planes: its marks, then the other's).
Strokes are drawn ideally (``draw_physics=False``) and photographed by the ``ideal`` camera for
speed (about 45 ms a step, most of it the camera and the reader: this is the drawn game, not a
board in memory).

Run it (about 5 minutes on one core)::

    kinegym selfplay --timesteps 6000 --out runs/selfplay

It prints the learner's results against the random player and the thesis's 3-ply player
before and after training (masked, deterministic) and saves ``selfplay_model.zip``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["FrozenOpponent", "SelfPlayResult", "selfplay", "score"]

ENV_ID = "kinegym/TicTacToeDraw3x3-v0"
FAST = {"draw_physics": False, "erase": False, "camera": "ideal"}  # ideal strokes, a plain camera: speed


class FrozenOpponent:
    """A ``Board -> cell`` player from a policy snapshot (:meth:`freeze` refreshes it): it looks
    at the real board from its own side and picks among the free cells."""

    def __init__(self, model: Any, seed: int = 0) -> None:
        self.policy: Any = None
        self.rng = np.random.default_rng(seed)
        self.freeze(model)

    def freeze(self, model: Any) -> None:
        self.policy = copy.deepcopy(model.policy).eval()

    def __call__(self, board: Any) -> int:
        from kinegym.envs.game import EMPTY

        cells = np.asarray(board.cells())
        me = board.to_move
        obs = np.stack([cells == me, (cells != me) & (cells != EMPTY)], axis=-1).astype(np.int8)
        mask = (cells == EMPTY).ravel()
        action, _ = self.policy.predict(obs, deterministic=False, action_masks=mask)
        return int(action)


@dataclass(frozen=True)
class SelfPlayResult:
    """Win / draw / loss shares of the learner before and after training, per opponent and side."""

    before: dict[str, tuple[float, float, float]]
    after: dict[str, tuple[float, float, float]]
    model_path: Path | None


def _env(symbol: str, opponent: Any) -> Any:
    import gymnasium as gym
    from stable_baselines3.common.monitor import Monitor

    return Monitor(gym.make(ENV_ID, **FAST, agent_symbol=symbol, opponent=opponent))


def score(model: Any, opponent: str, games: int, seed: int = 0) -> dict[str, tuple[float, float, float]]:
    """The model's (win, draw, loss) shares against ``opponent`` ("random", "thesis", "strong"),
    ``games`` games on each side, masked and deterministic (SB3-contrib's evaluation)."""
    from sb3_contrib.common.maskable.evaluation import evaluate_policy

    out = {}
    for symbol in ("X", "O"):
        env = _env(symbol, opponent)
        env.reset(seed=seed)
        rewards, _ = evaluate_policy(model, env, n_eval_episodes=games, deterministic=True, return_episode_rewards=True,
                                     use_masking=True)
        r = np.asarray(rewards)
        out[f"{opponent} as {symbol}"] = (float((r > 0).mean()), float((r == 0).mean()), float((r < 0).mean()))
        env.close()
    return out


def selfplay(timesteps: int = 6_000, seed: int = 0, swap_every: int = 1_000, eval_games: int = 10,
             out: str | Path | None = None, progress: Any = None) -> SelfPlayResult:
    """Train by self-play; see the module docstring. ``progress(n)`` hears of every ``n`` steps."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.logger import Logger
    from stable_baselines3.common.vec_env import DummyVecEnv

    if not (isinstance(timesteps, int) and 1 <= timesteps <= 10_000_000):
        raise ValueError(f"timesteps={timesteps!r}; expected an integer 1..10,000,000")
    if not (isinstance(swap_every, int) and swap_every >= 1):
        raise ValueError(f"swap_every={swap_every!r}; expected an integer >= 1")
    torch.set_num_threads(1)
    holder: list[FrozenOpponent] = []

    def opponent(board: Any) -> int:  # the frozen self, once there is one
        return holder[0](board)

    vec = DummyVecEnv([lambda s=s: _env(s, opponent) for s in ("X", "O")])  # seeded by MaskablePPO(seed=...)
    from kinegym.agents.atomic_save import AtomicMaskablePPO

    model = AtomicMaskablePPO("MlpPolicy", vec, n_steps=128, batch_size=64, learning_rate=1e-3, ent_coef=0.01,
                        policy_kwargs={"net_arch": [64, 64]}, seed=seed, device="cpu", verbose=0)
    # a logger of no outputs: SB3's default one makes an empty SB3-<time> folder in the temporary folder per run
    model.set_logger(Logger(folder=None, output_formats=[]))
    holder.append(FrozenOpponent(model, seed))
    games = max(1, eval_games)
    before = {**score(model, "random", games, seed), **score(model, "thesis", games, seed)}

    class Swap(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % swap_every < vec.num_envs:
                holder[0].freeze(self.model)
            if callable(progress):
                progress(vec.num_envs)
            return True

    model.learn(total_timesteps=timesteps, callback=Swap())
    after = {**score(model, "random", games, seed + 1), **score(model, "thesis", games, seed + 1)}
    path = None
    if out is not None:
        path = Path(out) / "selfplay_model.zip"
        model.save(path)  # atomic: a temporary file renamed over the target
    vec.close()
    return SelfPlayResult(before, after, path)
