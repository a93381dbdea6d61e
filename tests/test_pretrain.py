"""The gait policy's warm start: the planner's climbs are recorded from the training env as it
is (observations, masks, rewards), and cloning them makes the policy choose the planner's moves."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from kinegym.agents import train as T
from kinegym.agents.pretrain import Demos, clone, planner_demos, policy_labels

KW = {"mode": "kinematic", "memory": True, "hints": True, "wall_pool": 6, "wall_pool_seed": 0}


@pytest.fixture(scope="module")
def demos() -> Demos:
    return planner_demos(T.make_env, KW, episodes=6, seed=5, gamma=0.98)


def test_the_planner_s_climbs_are_recorded_as_the_env_gives_them(demos: Demos) -> None:
    assert demos.episodes == 6 and demos.climbed == 6  # pool walls are accepted only with a route
    n = len(demos)
    assert n >= 6 * 3 and demos.obs.shape == (n, 142) and demos.masks.shape == (n, 24)
    assert demos.masks[np.arange(n), demos.actions].all()  # every recorded move was one the env offered
    # the observation's own mask part is the recorded mask (the rows line up with their moves)
    lay = T.make_env(**KW).unwrapped.layout
    assert np.array_equal(demos.obs[:, lay["action_mask"]] > 0.5, demos.masks)
    # discounted returns: each climb ends with the +10 of the goal, so the last move's return is its reward
    assert np.isfinite(demos.returns).all() and (demos.returns > 5.0).sum() >= 6
    with pytest.raises(ValueError, match="episodes=0"):
        planner_demos(T.make_env, KW, episodes=0, seed=0, gamma=0.98)


def test_cloning_makes_the_policy_choose_the_planner_s_moves(demos: Demos) -> None:
    from sb3_contrib import MaskablePPO

    model = MaskablePPO("MlpPolicy", T.make_env(**KW), seed=0, device="cpu", policy_kwargs={"net_arch": [64, 64]})
    before = clone(model.policy, demos, epochs=1, lr=1e-12)["agreement"]  # a step too small to change anything
    after = clone(model.policy, demos, epochs=60, batch_size=64, seed=0)
    assert after["agreement"] >= 0.9 > before + 0.2, (before, after)
    assert after["value_mse"] < 4.0  # the critic learnt the climbs' returns (they span about 0..12)
    with pytest.raises(ValueError, match="epochs=0"):
        clone(model.policy, demos, epochs=0)


def test_train_gait_with_a_warm_start_announces_and_records_it(tmp_path: Path) -> None:
    default = Path(T.__file__).parents[1] / "configs" / "train" / "hole_climb_maskable_ppo.yaml"
    base = yaml.safe_load(default.read_text())
    (section,) = base.values()
    section.update({"n_envs": 1, "n_timesteps": 128, "n_steps": 64, "batch_size": 64, "n_epochs": 1,
                    "eval_freq": 10**6, "eval_episodes": 1, "checkpoint_freq": 10**6,
                    "policy_kwargs": {"net_arch": [32, 32]}, "bc_episodes": 3, "bc_epochs": 2,
                    "dagger_rounds": 2, "dagger_episodes": 2, "dagger_epochs": 1,
                    "env_kwargs": {"mode": "kinematic", "wall_pool": 4}})
    cfg = tmp_path / "bc.yaml"
    cfg.write_text(yaml.safe_dump(base))
    done = subprocess.run([sys.executable, "-m", "kinegym", "train", "gait", "--config", str(cfg), "--seed", "1",
                           "--out", str(tmp_path / "runs")], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "warm start: the planner climbs 3 training tasks first" in done.stderr
    run = tmp_path / "runs" / "gait-seed1"
    got = yaml.safe_load((run / "pretrain.yaml").read_text())
    assert got["episodes"] == 3 and got["climbed"] == 3 and got["moves"] >= 9
    assert 0.0 <= got["agreement"] <= 1.0 and (run / "final_model.zip").is_file()
    assert (run / "warm_start_model.zip").is_file()  # the policy before PPO, to evaluate on its own
    assert f"warm start: 3 planner climbs, {got['moves']} moves cloned in" in done.stdout
    assert "then DAgger (2 x 2 climbs)" in done.stderr
    first, second = got["dagger"]
    assert second["rows"] - first["rows"] == second["states"] - second["no_route"] > 0  # each round adds its rows
    assert f"DAgger round 2: the policy climbed {second['climbed']} of its tasks" in done.stdout


def test_a_physics_run_is_warm_started_from_kinematic_climbs_of_its_own_pool(monkeypatch: pytest.MonkeyPatch,
                                                                           demos: Demos, tmp_path: Path) -> None:
    import kinegym.agents.pretrain as P

    seen: dict = {}

    def fake_demos(make, env_kwargs, episodes, seed, gamma, weight, workers):  # noqa: ANN001, ANN202
        seen.update(env_kwargs)
        weights.append(weight)
        shared.append(workers)
        return demos

    def fake_labels(make, env_kwargs, act, episodes, seed, weight, workers):  # noqa: ANN001, ANN202
        seen_labels.update(env_kwargs)
        weights.append(weight)
        shared.append(workers)
        picked = act(demos.obs[0], demos.masks[0])
        assert demos.masks[0][picked]  # the policy's move is one the env offered
        return Demos(demos.obs[:3], demos.actions[:3], demos.masks[:3], np.full(3, np.nan, np.float32), 1, 0), {
            "states": 3, "no_route": 0, "differed": 1, "climbed": 0}

    seen_labels: dict = {}
    weights: list[float] = []
    shared: list[int] = []
    monkeypatch.setattr(P, "planner_demos", fake_demos)
    monkeypatch.setattr(P, "policy_labels", fake_labels)
    from sb3_contrib import MaskablePPO

    cfg = T.load_train_config()
    cfg["env_kwargs"] = {**cfg["env_kwargs"], "mode": "physics"}
    model = MaskablePPO("MlpPolicy", T.make_env(**KW), seed=0, device="cpu", policy_kwargs={"net_arch": [16]})
    got = T._warm_start(model, cfg, seed=4, make=T.make_env, run=tmp_path)
    # the training envs' pool (and observation: memory and hints), climbed kinematically
    assert seen == {**cfg["env_kwargs"], "mode": "kinematic", "wall_pool": 2000, "wall_pool_seed": 4}
    assert got["moves"] == len(demos) and (tmp_path / "pretrain.yaml").is_file()
    assert seen_labels == seen  # DAgger's climbs too: the same pool, kinematic
    assert [r["rows"] for r in got["dagger"]] == [len(demos) + 3 * (r + 1) for r in range(cfg["dagger_rounds"])]
    # the config's teacher demonstrates and labels (the default: the planner near its shortest routes)
    assert weights == [cfg["teacher_weight"]] * (1 + cfg["dagger_rounds"]) and cfg["teacher_weight"] == 1.1
    # and two processes share every one of those runs (the config's: both cores)
    assert shared == [2] * (1 + cfg["dagger_rounds"]) and got["workers"] == 2


def test_a_teacher_nearer_the_shortest_routes_demonstrates_shorter_climbs() -> None:
    """The same twelve pool tasks climbed by the planner at A* weight 2 (its own default) and
    at 1.1: the second's climbs are shorter in all (weighted A* returns routes at most ``w``
    times the shortest), and its demonstrations are the moves it makes."""
    from kinegym.agents.gait_planner import PlannerAgent

    kw = {**KW, "wall_pool": 12, "wall_pool_seed": 3}
    far = planner_demos(T.make_env, kw, episodes=12, seed=5, gamma=0.98, weight=2.0)
    near = planner_demos(T.make_env, kw, episodes=12, seed=5, gamma=0.98, weight=1.1)
    assert far.climbed == near.climbed == 12 and len(near) < len(far)
    env = T.make_env(**kw)
    obs, _ = env.reset(seed=5)
    assert near.actions[0] == PlannerAgent(1.1).act(env.unwrapped, obs)


def test_dagger_labels_the_policy_s_own_states_with_the_planner_s_moves(demos: Demos) -> None:
    """A policy that always takes the first offered move wanders; every state it reaches is
    labelled with the move the planner would make from there, and the returns are left out."""
    from kinegym.agents.gait_planner import PlannerAgent

    first = lambda obs, mask: int(np.flatnonzero(mask)[0])  # noqa: E731
    got, stats = policy_labels(T.make_env, KW, first, episodes=2, seed=11, weight=1.1)
    n = len(got)
    assert n == stats["states"] - stats["no_route"] > 0 and np.isnan(got.returns).all()
    assert got.masks[np.arange(n), got.actions].all() and got.episodes == 2
    assert 0 < stats["differed"] <= n  # the first offered move is not always the planner's
    env = T.make_env(**KW)
    obs, _ = env.reset(seed=11)
    assert np.array_equal(got.obs[0], obs) and got.actions[0] == PlannerAgent(1.1).act(env.unwrapped, obs)
    with pytest.raises(ValueError, match="episodes=0"):
        policy_labels(T.make_env, KW, first, episodes=0, seed=0)


def test_cloning_rows_without_a_return_fits_the_critic_on_the_others(demos: Demos) -> None:
    from sb3_contrib import MaskablePPO

    unlabelled = Demos(demos.obs, demos.actions, demos.masks, np.full(len(demos), np.nan, np.float32), 1, 0)
    model = MaskablePPO("MlpPolicy", T.make_env(**KW), seed=0, device="cpu", policy_kwargs={"net_arch": [64, 64]})
    both = demos.joined(unlabelled)
    assert len(both) == 2 * len(demos) and both.episodes == demos.episodes + 1
    fit = clone(model.policy, both, epochs=60, batch_size=64, seed=0)
    assert np.isfinite(fit["value_mse"]) and fit["value_mse"] < 8.0  # half the rows' error, NaN rows left out
    assert fit["agreement"] >= 0.9


def test_climbs_shared_among_processes_are_one_process_s_runs_joined(demos: Demos) -> None:
    """Two processes share five climbs as runs of 3 and 2 (the second's first reset seeded
    ``seed + CHUNK_SEED``): the rows are those runs made in this process, in run order - for
    the planner's demonstrations and for a DAgger round of a policy pickled into the workers."""
    import pickle

    from sb3_contrib import MaskablePPO

    from kinegym.agents.pretrain import CHUNK_SEED, GreedyPolicy

    two = planner_demos(T.make_env, KW, episodes=5, seed=5, gamma=0.98, workers=2)
    one = planner_demos(T.make_env, KW, episodes=3, seed=5, gamma=0.98).joined(
        planner_demos(T.make_env, KW, episodes=2, seed=5 + CHUNK_SEED, gamma=0.98))
    assert (two.episodes, two.climbed) == (5, 5) and len(two) == len(one)
    for a, b in [(two.obs, one.obs), (two.actions, one.actions), (two.masks, one.masks), (two.returns, one.returns)]:
        assert np.array_equal(a, b)
    assert not np.array_equal(two.obs[: len(demos)], demos.obs[: len(two)])  # not one run of five from seed 5

    model = MaskablePPO("MlpPolicy", T.make_env(**KW), seed=3, device="cpu", policy_kwargs={"net_arch": [16]})
    clone(model.policy, demos, epochs=2, batch_size=32)
    act = GreedyPolicy(model.policy)
    copy = pickle.loads(pickle.dumps(act))  # as a worker gets it: rebuilt from class, parameters and weights
    assert copy.policy is not model.policy
    assert [copy(o, m) for o, m in zip(demos.obs, demos.masks)] == [act(o, m) for o, m in zip(demos.obs, demos.masks)]
    got, stats = policy_labels(T.make_env, KW, act, episodes=3, seed=11, weight=1.1, workers=2)
    a, sa = policy_labels(T.make_env, KW, act, episodes=2, seed=11, weight=1.1)
    b, sb = policy_labels(T.make_env, KW, act, episodes=1, seed=11 + CHUNK_SEED, weight=1.1)
    assert stats == {k: sa[k] + sb[k] for k in sa} and got.episodes == 3
    assert np.array_equal(got.obs, np.concatenate([a.obs, b.obs]))
    assert np.array_equal(got.actions, np.concatenate([a.actions, b.actions]))
    with pytest.raises(ValueError, match="workers=0"):
        planner_demos(T.make_env, KW, episodes=2, seed=0, gamma=0.98, workers=0)
