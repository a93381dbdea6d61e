"""TicTacToeDraw-v0: conventions, determinism across processes, pickling, vector envs, a full
game with the arm in physics, reading accuracy and the misread path."""

from __future__ import annotations

import hashlib
import pickle
import subprocess
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import kinegym  # noqa: F401

ENV_ID = "kinegym/TicTacToeDraw-v0"
FAST = {"draw_physics": False}


def play(env: gym.Env, seed: int, policy_seed: int = 0) -> tuple[list[Any], list[dict]]:
    """One game with random legal actions; returns the observations and infos."""
    rng = np.random.default_rng(policy_seed)
    obs, info = env.reset(seed=seed)
    obs_list, infos = [obs], [info]
    done = False
    while not done:
        a = int(rng.choice(np.flatnonzero(info["action_mask"])))
        obs, r, term, trunc, info = env.step(a)
        assert isinstance(r, float)
        obs_list.append(obs)
        infos.append(info)
        done = term or trunc
    return obs_list, infos


def digest(obs_list: list[Any]) -> str:
    h = hashlib.sha256()
    for o in obs_list:
        for part in (o.values() if isinstance(o, dict) else [o]):
            h.update(np.ascontiguousarray(part).tobytes())
    return h.hexdigest()


def test_gymnasium_and_sb3_checkers_pass() -> None:
    """The checkers step cells sampled from the whole board, masks unseen: an occupied one is an
    error by default, so they run with illegal="lose"."""
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    for env_id in (ENV_ID, "kinegym/TicTacToeDraw3x3BoardImage-v0"):
        env = gym.make(env_id, **FAST, illegal="lose")
        check_env(env.unwrapped)
        sb3_check_env(env.unwrapped)
        env.close()


def test_spaces_masks_and_info() -> None:
    env = gym.make("kinegym/TicTacToeDrawBoardImage-v0", **FAST)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    assert obs["board"].shape == (5, 5, 2) and obs["image"].shape == (96, 128, 3)
    assert env.action_space.n == 25
    assert np.array_equal(env.unwrapped.action_masks(), info["action_mask"])
    assert info["phase"] == "your move" and "the manipulator is drawing the playing field" in info["status"]
    obs, r, term, trunc, info = env.step(12)
    assert info["read_ok"] and info["read_board"] == info["true_board"]
    assert obs["board"][2, 2, 0] == 1 and obs["board"][..., 1].sum() == 1  # our X, their O
    assert not info["action_mask"][12]
    assert any("the manipulator is drawing X" in s for s in info["status"])


def test_illegal_and_bad_actions() -> None:
    from kinegym.envs.errors import InvalidActionError, ResetNeededError

    env = gym.make(ENV_ID, **FAST)
    with pytest.raises(ResetNeededError, match="reset"):
        env.unwrapped.step(0)
    env.reset(seed=2)
    obs, r, term, trunc, info = env.step(0)
    taken = int(np.flatnonzero(~info["action_mask"])[0])
    free = [int(i) for i in np.flatnonzero(info["action_mask"])]
    with pytest.raises(InvalidActionError, match="masked out") as err:
        env.step(taken)
    assert err.value.valid == free
    for bad, needle in ((25, "out of range"), (-1, "out of range"), ("3", "type str"), (2.0, "type float"),
                        (True, "type bool"), (np.array([1, 2]), "type ndarray")):
        with pytest.raises(InvalidActionError, match=needle):
            env.step(bad)
    obs, r, term, trunc, info = env.step(np.array(free[0]))  # SB3's 0-d array is an action
    # illegal="lose": an occupied cell loses instead (training without masks)
    env = gym.make(ENV_ID, **FAST, illegal="lose")
    env.reset(seed=2)
    obs, r, term, trunc, info = env.step(0)
    obs, r, term, trunc, info = env.step(taken)
    assert (r, term, trunc, info["illegal"]) == (-1.0, True, False, True)
    with pytest.raises(ResetNeededError, match="reset"):
        env.step(1)
    with pytest.raises(ValueError, match="opponent="):
        gym.make(ENV_ID, **FAST, opponent="grandmaster")
    with pytest.raises(ValueError, match="illegal="):
        gym.make(ENV_ID, **FAST, illegal="ignore")


def test_agent_as_o_sees_the_opponents_first_mark() -> None:
    env = gym.make(ENV_ID, **FAST, agent_symbol="O", opponent="strong")
    obs, info = env.reset(seed=3)
    assert obs[..., 1].sum() == 1 and obs[..., 0].sum() == 0
    assert info["opponent_move"] >= 0


def test_same_seed_same_game_bit_for_bit_across_processes() -> None:
    code = ("import gymnasium as gym, kinegym, numpy as np, sys; sys.path.insert(0, 'tests');"
            "from test_tictactoe_draw import play, digest;"
            "env = gym.make('kinegym/TicTacToeDrawBoardImage-v0', draw_physics=False, opponent='strong');"
            "print(digest(play(env, 11)[0]))")
    outs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
            for _ in range(2)]
    env = gym.make("kinegym/TicTacToeDrawBoardImage-v0", **FAST, opponent="strong")
    here = digest(play(env, 11)[0])
    assert outs[0] == outs[1] == here
    assert digest(play(env, 12)[0]) != here


def test_physics_game_is_deterministic_and_pickles_by_replay() -> None:
    env = gym.make("kinegym/TicTacToeDraw3x3-v0", erase=False).unwrapped
    obs, info = env.reset(seed=5)
    env.step(int(np.flatnonzero(info["action_mask"])[0]))
    clone = pickle.loads(pickle.dumps(env))
    a = int(np.flatnonzero(env.action_masks())[0])
    o1, r1, t1, tr1, i1 = env.step(a)
    o2, r2, t2, tr2, i2 = clone.step(a)
    assert np.array_equal(o1, o2) and (r1, t1, tr1) == (r2, t2, tr2)
    assert np.array_equal(env.sim.canvas.density, clone.sim.canvas.density)
    assert np.array_equal(env.sim.q_true(), clone.sim.q_true())


def test_full_physics_game_to_the_end_with_erase() -> None:
    env = gym.make("kinegym/TicTacToeDraw3x3-v0", opponent="strong")
    _, infos = play(env, 6)
    last = infos[-1]
    assert last["phase"] == "game over" and last["winner"] in ("X", "O", "draw")
    assert "the manipulator is erasing the board" in last["status"]
    assert env.unwrapped.sim.canvas.ink().max() < 0.05  # wiped clean
    assert last["arm_time_s"] > 30  # the field, every mark and the wipe were really drawn
    assert all(i["read_ok"] for i in infos)


def test_subproc_vec_env() -> None:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    venv = make_vec_env("kinegym:kinegym/TicTacToeDraw-v0", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv,
                        env_kwargs=FAST, vec_env_kwargs={"start_method": "forkserver"})
    try:
        obs = venv.reset()
        assert obs.shape == (2, 5, 5, 2)
        for _ in range(3):
            masks = np.stack(venv.env_method("action_masks"))
            acts = np.array([int(np.flatnonzero(m)[0]) if m.any() else 0 for m in masks])
            obs, rewards, dones, infos = venv.step(acts)
            assert rewards.dtype.kind == "f"
    finally:
        venv.close()


def test_read_board_matches_truth_in_99_percent_of_steps() -> None:
    env = gym.make(ENV_ID, **FAST, opponent="thesis", erase=False)
    steps = right = 0
    for seed in range(25):
        _, infos = play(env, 100 + seed, seed)
        for i in infos:
            steps += 1
            right += i["read_board"] == i["true_board"]
            # never silently wrong: a board that differs from the truth is flagged
            assert i["read_board"] == i["true_board"] or not i["read_ok"], i
    assert right / steps >= 0.99, f"{right}/{steps}"


class _FlakyReader:
    """Wraps the real reader; the first ``bad`` readings swap one empty cell to a wrong mark."""

    def __init__(self, reader: Any, bad: int) -> None:
        self.reader, self.bad, self.calls = reader, bad, 0

    def read(self, image: Any) -> Any:
        r = self.reader.read(image)
        self.calls += 1
        if self.calls <= self.bad:
            empty = np.argwhere(r.cells == 0)
            r.cells[tuple(empty[0])] = 1
        return r


class _UnsureReader(_FlakyReader):
    """Wraps the real reader; the first ``bad`` readings come with a grid confidence of 0.01."""

    def read(self, image: Any) -> Any:
        r = self.reader.read(image)
        self.calls += 1
        if self.calls <= self.bad:
            r.grid_confidence = 0.01
        return r


def test_a_reading_of_an_unsure_grid_is_photographed_again() -> None:
    env = gym.make(ENV_ID, **FAST).unwrapped
    env.reset(seed=9)
    env.reader = _UnsureReader(env.reader, bad=1)  # its cells are right: only the grid's confidence says no
    obs, r, term, trunc, info = env.step(12)
    assert info["read_ok"] and info["read_tries"] == 2 and env.reader.calls == 2
    assert sum("unsure reading" in s for s in info["status"]) == 1
    assert info["read_board"] == info["true_board"]


def test_misreads_are_retried_then_reported_never_invented() -> None:
    env = gym.make(ENV_ID, **FAST).unwrapped
    env.reset(seed=9)
    env.reader = _FlakyReader(env.reader, bad=2)  # two bad photos, then a good one
    obs, r, term, trunc, info = env.step(12)
    assert info["read_ok"] and info["read_tries"] == 3
    assert sum("inconsistent reading" in s for s in info["status"]) == 2
    assert info["read_board"] == info["true_board"]

    env.reader = _FlakyReader(env.reader.reader, bad=10**6)  # never consistent
    before = env.belief.copy()
    free = int(np.flatnonzero(info["action_mask"])[0])
    obs, r, term, trunc, info = env.step(free)
    assert not info["read_ok"] and info["read_tries"] == env.max_read_tries and info["read_error"]
    # the observation is the last accepted board plus the arm's own mark - not the misread
    expect = before.copy()
    expect.flat[free] = 1
    assert np.array_equal(env.belief, expect)
    assert obs[..., 1].sum() == before.ravel().tolist().count(2)  # the unseen O is not invented
    # once the reader recovers, the missed opponent mark is accepted with the next one
    env.reader = env.reader.reader
    nxt = next(int(c) for c in np.flatnonzero(env.action_masks()) if env.true_board.is_legal(int(c)))
    obs, r, term, trunc, info = env.step(nxt)
    assert info["read_ok"] and info["read_board"] == info["true_board"]


def test_rgb_render_is_headless() -> None:
    env = gym.make(ENV_ID, **FAST, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[1] > frame.shape[0] * 0.9


def test_kinegym_play_terminal_mode_with_scripted_stdin(monkeypatch: pytest.MonkeyPatch,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    import io
    import json

    from kinegym.cli import main

    # the person (X) types cells, one of them taken and one malformed; the solver (the arm) never loses
    script = "1,1\n1,1\nbad\n0,0\n2,2\n0,2\n2,0\n1,0\n0,1\n1,2\n2,1\n"
    monkeypatch.setattr("sys.stdin", io.StringIO(script))
    assert main(["play", "--board", "3", "--fast", "--json"]) == 0
    out = capsys.readouterr().out
    assert "no display found - playing in the terminal" in out
    assert "(1, 1) is taken" in out and "'bad' is not ROW,COL" in out
    assert "the manipulator is drawing O" in out and "reading the board" in out
    result = json.loads(out.strip().splitlines()[-1])
    assert result["winner"] in ("O", "draw")  # the person cannot beat the solver
    # the board shown at each of the person's turns includes the arm's latest mark
    lines = out.splitlines()
    boards = ["".join(lines[i + 1:i + 4]) for i, ln in enumerate(lines) if "the board, your move" in ln]
    assert len(boards) >= 3
    for i, b in enumerate(boards):
        assert (b.count("X"), b.count("O")) == (i, i), (i, b)

    monkeypatch.setattr("sys.stdin", io.StringIO("q\n"))
    assert main(["play", "--board", "3", "--fast"]) == 0
    assert "you left the game" in capsys.readouterr().out
