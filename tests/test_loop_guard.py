"""The gait policy's loop guard (:func:`kinegym.agents.policies.loop_guard_mask`,
``MaskedPolicyAgent(loop_guard=True)``): moves into stances the observation counts as visited
this episode are left out while a move to a fresh stance is offered, and every other decision
is the policy's own."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kinegym.agents.policies import MaskedPolicyAgent, loop_guard_mask
from kinegym.envs.hole_climb import VISITS_SEEN, HoleClimbEnv, observation_layout


def test_the_guard_drops_only_moves_into_stances_already_visited() -> None:
    lay = observation_layout(8, memory=True)
    obs = np.zeros(lay["visits_next"].stop, dtype=np.float32)
    obs[lay["visits_next"].start + 3] = 1.0  # visited VISITS_SEEN times or more
    obs[lay["visits_next"].start + 5] = 1 / VISITS_SEEN  # visited once
    obs[lay["visits_next"].start + 9] = 1.0  # visited, but not offered
    mask = np.zeros(24, dtype=bool)
    mask[[3, 5, 7]] = True
    assert np.flatnonzero(loop_guard_mask(obs, mask, lay)).tolist() == [7]
    only_seen = mask.copy()
    only_seen[7] = False  # every offered move leads to a visited stance: the mask stands
    assert np.array_equal(loop_guard_mask(obs, only_seen, lay), only_seen)
    plain = observation_layout(8)  # no visit counts in the observation: nothing to guard by
    assert np.array_equal(loop_guard_mask(obs[:plain["last_outcome"].stop], mask, plain), mask)


def test_an_untrained_policy_that_cycles_is_kept_out_of_its_cycle(tmp_path: Path) -> None:
    """A freshly initialised deterministic policy cycles between stances; with the guard it
    never re-enters a visited stance while a move to a fresh one is offered, and wherever its
    own choice is not such a move the guard leaves that choice alone."""
    from sb3_contrib import MaskablePPO

    kw = {"memory": True}
    env = HoleClimbEnv(**kw)
    MaskablePPO("MlpPolicy", env, seed=3, device="cpu").save(tmp_path / "fresh.zip")
    free = MaskedPolicyAgent(tmp_path / "fresh.zip", env_kwargs=kw, loop_guard=False)
    guard = MaskedPolicyAgent(tmp_path / "fresh.zip", env_kwargs=kw)
    nxt = env.layout["visits_next"]

    def visits(agent: MaskedPolicyAgent) -> tuple[dict[tuple[int, int, int], int], int]:
        obs, _ = env.reset(seed=11)
        done, steps = False, 0
        while not done and steps < 200:  # the registered id's time limit
            mask = env.action_masks()
            own = free.act(env, obs)
            a = agent.act(env, obs)
            seen = obs[nxt] > 0.0
            if agent is guard:
                if seen[a]:
                    assert seen[mask].all(), "a seen stance re-entered while a fresh one was offered"
                if not seen[own]:
                    assert a == own, "the guard changed a choice that was not a loop"
            obs, _, term, trunc, _ = env.step(a)
            done, steps = term or trunc, steps + 1
        return dict(env._visits), steps

    unguarded, _ = visits(free)
    assert max(unguarded.values()) > VISITS_SEEN  # this policy does cycle on this wall
    guarded, _ = visits(guard)
    assert guard.guarded > 0 and max(guarded.values()) < max(unguarded.values())


def test_evaluate_reports_what_the_guard_changed_and_can_leave_it_off(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``kinegym evaluate gait`` acts with the guard unless ``--no-loop-guard``, and its policy row
    counts the decisions the guard changed; the planner's row never has any."""
    import yaml
    from sb3_contrib import MaskablePPO

    from kinegym.agents.policies import GAIT_ENV_ID
    from kinegym.cli import main

    MaskablePPO("MlpPolicy", HoleClimbEnv(memory=True), seed=3, device="cpu").save(tmp_path / "fresh.zip")
    (tmp_path / "config.yaml").write_text(yaml.safe_dump({GAIT_ENV_ID: {"env_kwargs": {"memory": True}}}))
    rows = {}
    for flags in ((), ("--no-loop-guard",)):
        argv = ["evaluate", "gait", "--policy", str(tmp_path / "fresh.zip"), "--episodes", "2", "--mode", "kinematic",
                "--json", *flags]
        assert main(argv) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["loop_guard"] is not bool(flags)
        for r in out["rows"]:
            rows[(r["agent"] == "planner", not flags)] = r
    assert rows[(False, True)]["guarded"] > 0 and rows[(False, False)]["guarded"] == 0
    assert rows[(True, True)]["guarded"] == rows[(True, False)]["guarded"] == 0
    assert rows[(True, True)]["mean_moves"] == rows[(True, False)]["mean_moves"]  # the planner is not guarded
