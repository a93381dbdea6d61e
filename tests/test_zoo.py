"""RL Baselines3 Zoo through ``python -m kinegym.zoo``: MaskablePPO as ``ppo_mask``, masks in
Zoo's evaluation and in ``enjoy``; kinegym's trainer reads the shipped Zoo file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

pytest.importorskip("rl_zoo3")

from kinegym.envs.errors import InvalidActionError  # noqa: E402
from kinegym.zoo import ZOO_CONFIG, zoo_argv, zoo_scope  # noqa: E402

ENV = "kinegym/HoleClimbMemoryHints-v0"


def _zoo(tmp: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "CUDA_VISIBLE_DEVICES": ""}
    return subprocess.run([sys.executable, "-m", "kinegym.zoo", *args], cwd=tmp, capture_output=True, text=True,
                          timeout=600, env=env)


def test_defaults_are_added_only_when_absent() -> None:
    argv = zoo_argv("train", ["--algo", "ppo_mask", "--env", ENV])
    assert argv[-6:] == ["--gym-packages", "kinegym", "--conf-file", str(ZOO_CONFIG), "--eval-env-kwargs",
                         "wall_pool:0"]
    mine = zoo_argv("train", ["--env", ENV, "--conf-file", "x.yml", "--eval-env-kwargs", "mode:'physics'"])
    assert mine.count("--conf-file") == 1 and mine.count("--eval-env-kwargs") == 1
    assert "--gym-packages" not in zoo_argv("record_video", ["--env", ENV])
    assert zoo_argv("enjoy", ["--env", "kinegym/TicTacToeDraw3x3-v0"]) == ["--env", "kinegym/TicTacToeDraw3x3-v0",
                                                                           "--gym-packages", "kinegym"]


def test_scope_registers_ppo_mask_and_restores_zoo() -> None:
    import rl_zoo3.exp_manager
    from rl_zoo3.utils import ALGOS

    before = rl_zoo3.exp_manager.EvalCallback
    with zoo_scope():
        assert "ppo_mask" in ALGOS and rl_zoo3.exp_manager.EvalCallback.__name__ == "MaskableEvalCallback"
    assert "ppo_mask" not in ALGOS and rl_zoo3.exp_manager.EvalCallback is before


def test_train_and_enjoy_through_zoo_with_masks(tmp_path: Path) -> None:
    """Zoo trains a few thousand steps and evaluates during training, then ``enjoy`` plays the
    model. The env raises on a masked action (``masked="raise"``, its default), so both only
    pass if masks reach ``predict``; the same model played without masks does hit one."""
    run = _zoo(tmp_path, "train", "--algo", "ppo_mask", "--env", ENV, "-n", "2048", "--eval-freq", "1024",
               "--eval-episodes", "2", "--seed", "3", "-params", "n_steps:256", "n_envs:2",
               "env_kwargs:dict(wall_pool=8)")
    assert run.returncode == 0, run.stderr[-3000:]
    folder = tmp_path / "logs" / "ppo_mask" / "kinegym-HoleClimbMemoryHints-v0_1"
    assert (folder / "evaluations.npz").is_file() and (folder / "kinegym-HoleClimbMemoryHints-v0.zip").is_file()
    play = _zoo(tmp_path, "enjoy", "--algo", "ppo_mask", "--env", ENV, "-f", "logs", "--exp-id", "1",
                "--no-render", "-n", "400")
    assert play.returncode == 0 and "Episode Reward" in play.stdout, play.stderr[-3000:]

    from sb3_contrib import MaskablePPO

    model = MaskablePPO.load(folder / "kinegym-HoleClimbMemoryHints-v0.zip", device="cpu")
    env = gym.make(ENV)
    with pytest.raises(InvalidActionError, match="masked out"):
        for seed in range(20):
            obs, _ = env.reset(seed=seed)
            for _ in range(200):
                action, _ = model.predict(obs, deterministic=False)  # no masks
                obs, _, term, trunc, _ = env.step(action)
                if term or trunc:
                    break


def test_kinegym_trainer_reads_the_zoo_file() -> None:
    from kinegym.agents.train import load_train_config

    cfg = load_train_config(ZOO_CONFIG, ENV)
    assert cfg["env_kwargs"] == {"mode": "kinematic", "wall_pool": 2000, "memory": True, "hints": True}
    assert cfg["policy_kwargs"] == {"net_arch": [128, 128]} and cfg["n_timesteps"] == 1_000_000
