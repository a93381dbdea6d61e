"""The drawn game as a PettingZoo AEC env: PettingZoo's API and seed tests, masks in the
observations, determinism across processes, pickling, and the single-agent env as its wrapper."""

from __future__ import annotations

import hashlib
import pickle
import subprocess
import sys

import numpy as np
import pytest
from pettingzoo.test import api_test, seed_test

from kinegym.envs.errors import InvalidActionError, ResetNeededError
from kinegym.envs.tictactoe_aec import TicTacToeDrawAEC, env, raw_env

FAST = {"draw_physics": False, "erase": False}


def test_pettingzoo_api_test() -> None:
    api_test(env(**FAST), num_cycles=60)


def test_pettingzoo_seed_test() -> None:
    seed_test(lambda: env(**FAST), num_cycles=30)


def _play(aec: TicTacToeDrawAEC, seed: int, picks: int = 0) -> str:
    """Play a game choosing the ``picks``-th legal cell each turn; a digest of every observation,
    photo and the ink on the board."""
    aec.reset(seed=seed)
    h = hashlib.sha256()
    for _agent in aec.agent_iter():
        obs, reward, term, trunc, info = aec.last()
        h.update(obs["observation"].tobytes() + obs["action_mask"].tobytes() + str(reward).encode())
        h.update(aec.photo.tobytes() + aec.sim.canvas.density.tobytes())  # what the camera saw, the ink
        if term or trunc:
            aec.step(None)
            continue
        legal = np.flatnonzero(obs["action_mask"])
        aec.step(int(legal[picks % len(legal)]))
    return h.hexdigest()


def test_a_game_observes_the_board_as_read_with_masks() -> None:
    aec = raw_env(**FAST)
    with pytest.raises(ResetNeededError):
        aec.observe("arm")
    aec.reset(seed=4)
    assert aec.agent_selection == "arm"  # the arm holds X by default
    obs = aec.observe("arm")
    assert obs["action_mask"].sum() == 9 and aec.observe("person")["action_mask"].sum() == 0
    aec.step(4)
    assert aec.agent_selection == "person"
    seen = aec.observe("person")
    assert seen["observation"][1, 1, 1] == 1 and seen["observation"][..., 0].sum() == 0  # the arm's X, as the other
    assert seen["action_mask"][4] == 0 and aec.infos["person"]["read_ok"]
    with pytest.raises(InvalidActionError, match="masked out"):
        aec.step(4)
    final = {}
    while aec.agents:
        _, reward, term, trunc, info = aec.last()
        if term or trunc:
            final[aec.agent_selection] = (reward, info["winner"])
        aec.step(None if term or trunc else int(np.flatnonzero(aec.observe(aec.agent_selection)["action_mask"])[0]))
    rewards = sorted(r for r, _ in final.values())
    assert rewards == ([0.0, 0.0] if final["arm"][1] == "draw" else [-1.0, 1.0])


def test_illegal_lose_ends_the_game_for_the_mover() -> None:
    aec = raw_env(**FAST, illegal="lose")
    aec.reset(seed=1)
    aec.step(0)
    aec.step(0)  # the person plays the arm's cell
    assert aec.rewards == {"arm": 0.0, "person": -1.0} and all(aec.terminations.values())


def test_same_seed_same_game_across_processes_and_pickles() -> None:
    here = _play(raw_env(**FAST), 11, picks=2)
    assert here == _play(raw_env(**FAST), 11, picks=2) != _play(raw_env(**FAST), 12, picks=2)
    code = ("from tests.test_tictactoe_aec import _play, FAST; from kinegym.envs.tictactoe_aec import raw_env;"
            "print(_play(raw_env(**FAST), 11, picks=2))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.stdout.strip() == here, out.stderr[-2000:]
    aec = raw_env(**FAST)
    aec.reset(seed=5)
    aec.step(0)
    aec.observe("person")
    clone = pickle.loads(pickle.dumps(aec))
    assert np.array_equal(clone.sim.canvas.density, aec.sim.canvas.density)
    assert clone.agent_selection == aec.agent_selection and np.array_equal(clone.belief, aec.belief)


def test_the_single_agent_env_is_the_arms_side_of_the_aec() -> None:
    import gymnasium as gym

    single = gym.make("kinegym/TicTacToeDraw3x3-v0", **FAST, opponent="random").unwrapped
    obs, info = single.reset(seed=2)
    assert isinstance(single.aec, TicTacToeDrawAEC)
    assert np.array_equal(obs, single.aec.observe("arm")["observation"])
    obs, r, term, trunc, info = single.step(int(np.flatnonzero(info["action_mask"])[0]))
    assert info["true_board"].count("X") == 1 and info["true_board"].count("O") == 1
    assert np.array_equal(obs, single.aec.observe("arm")["observation"])


def test_selfplay_trains_against_its_frozen_self(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    import tempfile

    from kinegym.agents.selfplay import FrozenOpponent, selfplay

    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))  # SB3's own logger makes an empty SB3-<time> folder there
    res = selfplay(timesteps=256, swap_every=128, eval_games=1, out=tmp_path)
    assert not list(tmp.glob("SB3-*"))  # no empty logger folder left in the user's temporary folder
    assert res.model_path is not None and res.model_path.is_file()
    assert set(res.before) == set(res.after) == {"random as X", "random as O", "thesis as X", "thesis as O"}
    assert all(abs(sum(v) - 1.0) < 1e-9 for v in res.after.values())
    from sb3_contrib import MaskablePPO

    from kinegym.envs.game import Board

    opp = FrozenOpponent(MaskablePPO.load(res.model_path, device="cpu"))
    board = Board.parse("XO.|X..|O..")
    for _ in range(20):  # the frozen self only ever picks a free cell
        assert board.is_legal(opp(board))
