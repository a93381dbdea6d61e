"""Registered ids: each space is its own id, space-changing kwargs are named errors, and
action masks are reachable through gymnasium's wrappers and SB3's vector envs."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import kinegym
from kinegym.envs.errors import ResetNeededError
from kinegym.envs.variants import HOLE_CLIMB, TICTACTOE, SpaceKwargError, split_space_kwargs


def test_every_variant_is_registered_with_its_own_fixed_space() -> None:
    assert set(kinegym.ALL_ENV_IDS) == set(HOLE_CLIMB) | set(TICTACTOE)
    shapes = {i: gym.make(i).observation_space.shape for i in HOLE_CLIMB}
    assert shapes == {"kinegym/HoleClimb-v0": (68,), "kinegym/HoleClimbMemory-v0": (93,),
                      "kinegym/HoleClimbMemoryHints-v0": (142,)}
    env = gym.make("kinegym/TicTacToeDraw3x3Image-v0", draw_physics=False)
    assert env.observation_space.shape == (96, 128, 3) and env.action_space.n == 9


@pytest.mark.parametrize(("env_id", "kwargs", "use"), [
    ("kinegym/HoleClimb-v0", {"memory": True}, "kinegym/HoleClimbMemory-v0"),
    ("kinegym/HoleClimbMemory-v0", {"hints": True}, "kinegym/HoleClimbMemoryHints-v0"),
    ("kinegym/HoleClimb-v0", {"candidates": 6}, None),
    ("kinegym/TicTacToeDraw-v0", {"board": 3}, "kinegym/TicTacToeDraw3x3-v0"),
    ("kinegym/TicTacToeDraw3x3-v0", {"obs_mode": "image"}, "kinegym/TicTacToeDraw3x3Image-v0"),
    ("kinegym/TicTacToeDrawImage-v0", {"image_obs_size": (64, 48)}, None),
])
def test_a_kwarg_that_changes_a_space_names_the_id_to_use(env_id: str, kwargs: dict, use: str | None) -> None:
    with pytest.raises(SpaceKwargError) as err:
        gym.make(env_id, **kwargs)
    assert err.value.use == use and env_id in str(err.value) and (use is None or use in str(err.value))
    gym.make(env_id, **{k: v for k, v in (HOLE_CLIMB | TICTACTOE)[env_id].items() if k in kwargs})  # same value: fine


def test_kinegym_and_zoo_spellings_meet() -> None:
    assert split_space_kwargs("kinegym/HoleClimb-v0", {"memory": True, "hints": True, "mode": "physics"}) == (
        "kinegym/HoleClimbMemoryHints-v0", {"mode": "physics"})
    assert split_space_kwargs("kinegym/HoleClimbMemoryHints-v0", {"wall_pool": 3}) == (
        "kinegym/HoleClimbMemoryHints-v0", {"wall_pool": 3})


@pytest.mark.parametrize("env_id", ["kinegym/HoleClimb-v0", "kinegym/TicTacToeDraw3x3-v0"])
def test_masks_through_wrappers_and_before_reset(env_id: str) -> None:
    env = gym.make(env_id, **({"draw_physics": False} if "TicTac" in env_id else {}))
    with pytest.raises(AttributeError):  # gymnasium 1.x wrappers forward no attributes: documented
        env.action_masks()
    with pytest.raises(ResetNeededError, match="before reset"):
        env.get_wrapper_attr("action_masks")()
    _, info = env.reset(seed=3)
    mask = env.get_wrapper_attr("action_masks")()
    assert mask.dtype == bool and np.array_equal(mask, info["action_mask"]) and mask.any()


def test_sb3_get_action_masks_on_vector_envs() -> None:
    from sb3_contrib.common.maskable.utils import get_action_masks, is_masking_supported
    from stable_baselines3.common.env_util import make_vec_env

    vec = make_vec_env("kinegym/HoleClimb-v0", n_envs=2, seed=5)
    assert is_masking_supported(vec)
    vec.reset()
    masks = get_action_masks(vec)
    assert masks.shape == (2, 24) and masks.dtype == bool and masks.any(axis=1).all()
    vec.close()
    gvec = gym.make_vec("kinegym/HoleClimb-v0", num_envs=2, vectorization_mode="sync")
    gvec.reset(seed=5)
    assert np.array(gvec.call("action_masks")).shape == (2, 24)
    gvec.close()
