"""HoleClimb-v0: Gymnasium and SB3 conventions, determinism (also across processes), pickling
and subprocess vectorisation, masked PPO, a long random run, the planner on every wall."""

import hashlib
import pickle
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import kinegym  # noqa: F401  (registers the ids)
from kinegym.agents.gait_planner import PlannerAgent
from kinegym.envs.hole_climb import HoleClimbEnv

ENV_ID = "kinegym/HoleClimb-v0"


def rollout_digest(env: gym.Env, seed: int, steps: int) -> str:
    """Hash of every observation (and reward) of a rollout whose actions come from a
    generator seeded apart from the env - the same in every process."""
    rng = np.random.default_rng(12345)
    h = hashlib.sha256()
    obs, info = env.reset(seed=seed)
    h.update(obs.tobytes())
    for _ in range(steps):
        mask = info["action_mask"]
        a = int(rng.choice(np.flatnonzero(mask))) if mask.any() else 0
        obs, r, term, trunc, info = env.step(a)
        h.update(obs.tobytes())
        h.update(np.float64(r).tobytes())
        if term or trunc:
            obs, info = env.reset()
            h.update(obs.tobytes())
    return h.hexdigest()


def test_gymnasium_and_sb3_checkers_pass() -> None:
    """The checkers step actions sampled from the whole space, masks unseen: a masked one is an
    error by default, so they run with masked="fail" (a masked move is tried and fails)."""
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(ENV_ID, masked="fail")
    check_env(env.unwrapped)
    sb3_check_env(gym.make(ENV_ID, masked="fail"))
    full = gym.make("kinegym/HoleClimbMemoryHints-v0", wall_pool=4, masked="fail")  # what training uses
    check_env(full.unwrapped)
    sb3_check_env(gym.make("kinegym/HoleClimbMemoryHints-v0", wall_pool=4, masked="fail"))
    assert env.spec.max_episode_steps == 200
    assert env.unwrapped.metadata["render_fps"] > 0


def test_spaces_rewards_and_info() -> None:
    env = gym.make(ENV_ID)
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    mask = env.unwrapped.action_masks()
    assert mask.dtype == bool and mask.shape == (env.action_space.n,) and mask.any()
    assert np.array_equal(mask, info["action_mask"])
    a = int(np.flatnonzero(mask)[0])
    obs2, r, term, trunc, info = env.step(a)
    assert type(r) is float and env.observation_space.contains(obs2)
    assert info["outcome"] in ("ok", "unreachable", "torque_limit", "missed_hole", "grip_lost", "fell")
    assert obs2 is not obs and not np.shares_memory(obs2, obs)
    assert "is_success" in info and "estimated_pose" in info and "true_pose" in info
    # the estimate is the localiser's, not the truth, but close to it
    err = np.abs(info["estimated_pose"][:2] - info["true_pose"][:2]).max()
    assert 0 < err < 0.5


def test_same_seed_same_actions_same_observations() -> None:
    a = rollout_digest(gym.make(ENV_ID), 7, 150)
    b = rollout_digest(gym.make(ENV_ID), 7, 150)
    c = rollout_digest(gym.make(ENV_ID), 8, 150)
    assert a == b != c


@pytest.mark.parametrize("mode,steps", [("kinematic", 120), ("physics", 25)])
def test_observations_are_bit_identical_in_another_process(mode: str, steps: int) -> None:
    here = rollout_digest(gym.make(ENV_ID, mode=mode), 3, steps)
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, "tests")
        import gymnasium as gym
        import kinegym
        from test_hole_climb import rollout_digest
        print(rollout_digest(gym.make("kinegym/HoleClimb-v0", mode="{mode}"), 3, {steps}))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == here


def test_reset_without_seed_does_not_reseed() -> None:
    env = gym.make(ENV_ID)
    o1, _ = env.reset(seed=5)
    o2, _ = env.reset()
    o3, _ = env.reset(seed=5)
    assert np.array_equal(o1, o3) and not np.array_equal(o1, o2)


@pytest.mark.parametrize("mode", ["kinematic", "physics"])
def test_env_pickles_mid_episode_and_continues_identically(mode: str) -> None:
    env = gym.make(ENV_ID, mode=mode)
    obs, info = env.reset(seed=11)
    agent = PlannerAgent()
    for _ in range(3):
        obs, *_ = env.step(agent.act(env.unwrapped))
    twin = pickle.loads(pickle.dumps(env))
    for _ in range(2):
        a = agent.act(env.unwrapped)
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = twin.step(a)
        assert np.array_equal(o1, o2) and r1 == r2


def test_runs_under_subprocess_vec_env() -> None:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    # a fresh worker process has not imported kinegym: the "module:id" form imports it first
    vec = make_vec_env("kinegym:" + ENV_ID, n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
    try:
        vec.reset()
        for _ in range(10):
            masks = np.stack(vec.env_method("action_masks"))
            actions = np.array([int(np.flatnonzero(m)[0]) for m in masks])
            obs, rew, done, infos = vec.step(actions)
            assert obs.shape == (2, 68) and np.isfinite(obs).all()
    finally:
        vec.close()


def test_maskable_ppo_trains_a_few_hundred_steps() -> None:
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.logger import Logger

    env = gym.make(ENV_ID)
    model = MaskablePPO("MlpPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0, verbose=0, device="cpu")
    model.set_logger(Logger(folder=None, output_formats=[]))  # SB3's default leaves an empty folder in /tmp
    model.learn(total_timesteps=256)
    obs, _ = env.reset(seed=1)
    action, _ = model.predict(obs, action_masks=env.unwrapped.action_masks(), deterministic=True)
    assert env.unwrapped.action_masks()[int(action)]


def test_planner_climbs_every_wall_the_env_accepts() -> None:
    env = gym.make(ENV_ID)
    agent = PlannerAgent()
    for seed in range(8):
        obs, info = env.reset(seed=seed)
        done = False
        while not done:
            obs, r, term, trunc, info = env.step(agent.act(env.unwrapped))
            done = term or trunc
        assert info["is_success"] and info["moves"] == info["planner_moves"], seed


def test_fixed_walls_and_their_limits() -> None:
    env = gym.make(ENV_ID, wall="seed_4x4", robot="climber_long")
    obs, info = env.reset(seed=0)
    assert info["wall"] == "seed_4x4" and info["planner_moves"] > 0
    from kinegym.envs.errors import NoRouteError

    with pytest.raises(NoRouteError, match="climber_long"):
        gym.make(ENV_ID, wall="seed_4x4", robot="climber").reset(seed=0)
    with pytest.raises(ValueError, match="wall_kwargs"):
        HoleClimbEnv(wall_kwargs={"cols": 100_000})
    with pytest.raises(ValueError, match="wall_kwargs"):
        HoleClimbEnv(wall_kwargs={"missing": 0.99})
    with pytest.raises(ValueError, match="mode"):
        HoleClimbEnv(mode="dream")
    with pytest.raises(ValueError, match="wall_kwargs"):
        HoleClimbEnv(wall_kwargs={"colour": 3})


def test_rgb_array_render_needs_no_display() -> None:
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=2)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 5


@pytest.mark.slow
def test_100000_random_valid_actions_raise_nothing() -> None:
    """100,000 steps over a pool of 40 walls: the step, mask and localiser machinery (fresh walls
    every reset are exercised by the digests and the checkers; a pool keeps this test cheap)."""
    env = gym.make(ENV_ID, wall_pool=40)
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    for _ in range(100_000):
        mask = info["action_mask"]
        a = int(rng.choice(np.flatnonzero(mask))) if mask.any() else int(rng.integers(env.action_space.n))
        obs, r, term, trunc, info = env.step(a)
        assert np.isfinite(obs).all() and np.isfinite(r)
        if term or trunc:
            obs, info = env.reset()


def test_memory_features_count_believed_stances() -> None:
    plain = gym.make(ENV_ID)
    env = gym.make("kinegym/HoleClimbMemory-v0")
    u = env.unwrapped
    K = u.K
    assert plain.observation_space.shape == (68,) and env.observation_space.shape == (68 + 3 * K + 1,)
    m = 68
    for a in range(3 * K):  # a first move whose way back is offered
        obs, info = env.reset(seed=4)
        assert obs[m] == 0.25  # the start stance, seen once
        start = u.believed_stance
        if not info["action_mask"][a]:
            continue
        obs, r, term, trunc, info = env.step(a)
        arm = a // K
        back = u.action_for(arm, start[arm])
        if info["outcome"] == "ok" and back is not None and info["action_mask"][back]:
            break
    else:
        pytest.fail("no move with an offered way back on this wall")
    assert obs[m] == 0.25 and obs[m + 1 + back] == 0.25  # the new stance once; the way back leads to a seen one
    obs, r, term, trunc, info = env.step(back)
    assert info["outcome"] == "ok" and u.believed_stance == start and obs[m] == 0.5


def test_hint_features_bound_the_moves_left_and_flag_failed_moves() -> None:
    """hints: the map's lower bound on the moves left is admissible (the planner's shortest
    route is never shorter), each feasible move changes it by -1..1, and a move that failed
    from a stance is flagged there."""
    from kinegym.agents.gait_planner import GaitPlanner
    from kinegym.envs.climb_task import stance_hops

    env = gym.make("kinegym/HoleClimbMemoryHints-v0")
    u = env.unwrapped
    K = u.K
    assert env.observation_space.shape == (68 + 3 * K + 1 + 6 * K + 1,)
    m = 68 + 3 * K + 1
    for seed in range(4):
        obs, info = env.reset(seed=seed)
        now = stance_hops(u._hops, u.believed_stance)
        assert obs[m] == pytest.approx(min(now, 20) / 10)
        shortest = GaitPlanner(u.model, u.holes, weight=1.0, candidates=K).plan(u.believed_stance, u.goal)
        assert shortest.found and len(shortest.moves) >= now
        deltas = obs[m + 1: m + 1 + 3 * K] * 2
        feasible = info["action_mask"]
        assert feasible.any() and set(np.round(deltas[feasible]).tolist()) <= {-1.0, 0.0, 1.0}
        assert not obs[m + 1 + 3 * K:].any()  # nothing has failed yet
    # a masked (infeasible) move is an error; with masked="fail" it fails and is then flagged
    from kinegym.envs.errors import InvalidActionError

    obs, info = env.reset(seed=0)
    bad = next(a for a in range(3 * K) if not info["action_mask"][a] and u.candidates[a % K] >= 0)
    with pytest.raises(InvalidActionError, match="masked out"):
        env.step(bad)
    u.masked = "fail"
    obs, r, term, trunc, info = env.step(bad)
    assert info["outcome"] != "ok"
    assert obs[m + 1 + 3 * K + bad] == 1.0 and obs[m + 1 + 3 * K:].sum() == 1.0


def test_hint_features_equal_stance_hops_of_each_move() -> None:
    """The env finds each move's bound from the stance's hop counts with one arm's replaced
    (no call per move); along a random walk with failed moves it equals
    :func:`stance_hops` of the stance each move leads to, and the failed flags are this
    stance's failed moves."""
    from kinegym.envs.climb_task import stance_hops

    env = gym.make("kinegym/HoleClimbMemoryHints-v0", masked="fail")
    u = env.unwrapped
    K, m = u.K, 68 + 3 * u.K + 1
    rng = np.random.default_rng(3)
    obs, info = env.reset(seed=21)
    checked = failed = 0
    for _ in range(400):
        st, hops = u.believed_stance, u._hops
        now = stance_hops(hops, st)
        want = [min(now, 20) / 10] + [0.0] * (6 * K)
        for k, h in enumerate(u.candidates):
            for arm in range(3):
                if h >= 0:
                    nxt = st[:arm] + (h,) + st[arm + 1:]
                    want[1 + arm * K + k] = max(-2, min(2, stance_hops(hops, nxt) - now)) / 2
                    want[1 + 3 * K + arm * K + k] = float((st, arm, h) in u.failed_moves)
        assert obs[m:].tolist() == np.asarray(want, np.float32).tolist()
        checked += 1
        failed += int(obs[m + 1 + 3 * K:].sum())
        a = int(rng.integers(3 * K)) if rng.random() < 0.2 else int(rng.choice(np.flatnonzero(info["action_mask"])))
        obs, r, term, trunc, info = env.step(a)
        if term or trunc:
            obs, info = env.reset()
    assert checked == 400 and failed > 0


def test_wall_pool_reuses_fixed_tasks_and_stays_deterministic() -> None:
    env = gym.make(ENV_ID, wall_pool=3, wall_pool_seed=7)
    seen = set()
    for s in range(12):
        obs, info = env.reset(seed=s)
        seen.add((info["wall"], info["goal"], info["planner_moves"], env.unwrapped.holes.xy.tobytes()))
    assert len(seen) == 3  # three tasks, each made once and drawn again
    again = gym.make(ENV_ID, wall_pool=3, wall_pool_seed=7)
    assert rollout_digest(env, 5, 150) == rollout_digest(again, 5, 150)
    other = gym.make(ENV_ID, wall_pool=3, wall_pool_seed=8)
    assert rollout_digest(other, 5, 150) != rollout_digest(again, 5, 150)
    restored = pickle.loads(pickle.dumps(env))
    assert rollout_digest(restored, 5, 150) == rollout_digest(again, 5, 150)
    with pytest.raises(ValueError, match="wall_pool=-1"):
        HoleClimbEnv(wall_pool=-1)
    with pytest.raises(ValueError, match="needs wall='generated'"):
        HoleClimbEnv(wall="seed_4x4", wall_pool=4)


def test_observation_layout_is_the_documented_table() -> None:
    """The builder fills the parts the docstring's table names, at the sizes it states."""
    from kinegym.envs import hole_climb

    for memory, hints, total in ((False, False, 68), (True, False, 93), (True, True, 142)):
        lay = hole_climb.observation_layout(8, memory, hints)
        assert next(reversed(lay.values())).stop == total
        assert f"{total}" in hole_climb.__doc__
        env = HoleClimbEnv(memory=memory, hints=hints)
        assert env.observation_space.shape == (total,)
        for name in lay:
            assert f"`{name}`" in hole_climb.__doc__, name
        starts = [p.start for p in lay.values()]
        assert starts == sorted(starts) and starts[0] == 0
    obs, info = env.reset(seed=4)
    assert np.array_equal(obs[lay["action_mask"]], info["action_mask"].astype(np.float32))


def test_invalid_actions_and_steps_after_the_end_are_named_errors() -> None:
    from kinegym.envs.errors import InvalidActionError, ResetNeededError

    env = gym.make(ENV_ID)
    with pytest.raises(ResetNeededError):
        env.unwrapped.step(0)
    obs, info = env.reset(seed=1)
    n = env.action_space.n
    valid = [int(i) for i in np.flatnonzero(info["action_mask"])]
    for bad, needle in ((n, "out of range"), (-1, "out of range"), ("1", "type str"), (1.5, "type float"),
                        (None, "type NoneType"), (False, "type bool")):
        with pytest.raises(InvalidActionError, match=needle) as err:
            env.step(bad)
        assert err.value.valid == valid
    # an episode that ends refuses the next step until reset
    u = env.unwrapped
    done = False
    while not done:
        a = int(np.flatnonzero(u.action_masks())[0])
        obs, r, term, trunc, info = env.step(np.int64(a))
        done = term or trunc
    if term or info.get("stuck"):
        with pytest.raises(ResetNeededError):
            u.step(a)
    env.reset(seed=1)
    with pytest.raises(ValueError, match="masked="):
        gym.make(ENV_ID, masked="ignore")
