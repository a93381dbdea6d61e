"""Evaluating a trained gait policy: the policy and the planner, deterministically and masked,
on the same held-out (or validation) walls, in either mode; one row per agent and mode
(``kinegym evaluate gait``).

The planner runs at its own A* weight 2 unless asked otherwise (``planner_weight``; 1.1 comes
within about 1 % of the shortest routes at about three times the cost): "moves vs planner" is
the mean over the walls both climbed of the policy's moves over the planner's. The policy acts
with its loop guard unless ``loop_guard=False``
(:class:`~kinegym.agents.policies.MaskedPolicyAgent`); its row counts the decisions the guard
changed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.agents.policies import policy_env_kwargs
from kinegym.agents.train import HELD_OUT_SEED, VALIDATION_SEED, EnvFactory, make_env

__all__ = ["EvalRow", "evaluate", "check_planner_weight", "PLANNER_WEIGHTS"]

#: the planner's A* weights ``evaluate`` takes (1 = shortest routes, 2 = the planner's own)
PLANNER_WEIGHTS = (1.0, 10.0)


def check_planner_weight(weight: float, name: str = "planner_weight=") -> None:
    """ValueError naming ``name`` and ``weight`` unless it lies in :data:`PLANNER_WEIGHTS`."""
    lo, hi = PLANNER_WEIGHTS
    if not lo <= weight <= hi:
        raise ValueError(f"{name}{weight!r}; expected {lo:g}..{hi:g} (1 = shortest routes, 2 = the planner's own)")


@dataclass
class EvalRow:
    """One agent on the held-out walls in one mode."""

    agent: str
    mode: str
    episodes: int
    success: float
    falls: int
    mean_moves: float
    moves_vs_planner: float
    decision_ms: float
    #: the policy's decisions its loop guard changed (its own choice was a move back into a visited stance)
    guarded: int = 0

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def evaluate(policy: str | Path, episodes: int = 50, modes: Sequence[str] = ("kinematic",), walls: str = "held-out",
             progress: Callable[[], None] | None = None, make_env: EnvFactory = make_env,
             planner_weight: float = 2.0, loop_guard: bool = True) -> list[EvalRow]:
    """The policy and the planner, deterministically, on the same walls: ``held-out`` (wall
    ``i`` = ``reset(seed=HELD_OUT_SEED + i)``) or ``validation``. ``planner_weight``: the
    planner's A* weight; its row is named ``planner`` at 2, else ``planner (weight W)``.
    ``loop_guard``: the policy agent's (:class:`~kinegym.agents.policies.MaskedPolicyAgent`)."""
    from kinegym.agents.gait_planner import PlannerAgent
    from kinegym.agents.policies import MaskedPolicyAgent
    from kinegym.agents.rollout import run_episode

    if walls not in ("held-out", "validation"):
        raise ValueError(f"walls={walls!r}; expected 'held-out' or 'validation'")
    check_planner_weight(planner_weight)
    planner = "planner" if planner_weight == 2.0 else f"planner (weight {planner_weight:g})"
    base = HELD_OUT_SEED if walls == "held-out" else VALIDATION_SEED
    pol = MaskedPolicyAgent(policy, loop_guard=loop_guard)
    rows = []
    env_kwargs = policy_env_kwargs(policy)
    for mode in modes:
        env = make_env(**{**env_kwargs, "mode": mode})
        if env.observation_space.shape != pol.model.observation_space.shape:
            raise ValueError(f"{policy}: the model sees observations of shape {pol.model.observation_space.shape}, "
                             f"the env {env.observation_space.shape} with env_kwargs {env_kwargs} (no run config.yaml "
                             "beside the model?)")
        results: dict[str, list[dict[str, Any]]] = {"policy": [], "planner": []}
        guarded_before = pol.guarded
        for i in range(episodes):
            for name in ("planner", "policy"):
                ep = run_episode(env, PlannerAgent(planner_weight) if name == "planner" else pol, seed=base + i)
                results[name].append({"success": ep.success, "falls": ep.falls, "moves": ep.moves,
                                      "think": float(np.median(ep.think_s)) if ep.think_s else 0.0})
            if progress:
                progress()
        env.close()
        for name in ("policy", "planner"):
            res = results[name]
            ok = [r for r in res if r["success"]]
            both = [(p["moves"], q["moves"]) for p, q in zip(results["policy"], results["planner"])
                    if p["success"] and q["success"]]
            if not both:
                ratio = math.nan
            else:
                ratio = float(np.mean([a / b for a, b in both])) if name == "policy" else 1.0
            rows.append(EvalRow(planner if name == "planner" else str(policy), mode, len(res),
                                len(ok) / len(res), sum(r["falls"] for r in res),
                                float(np.mean([r["moves"] for r in ok])) if ok else math.nan, ratio,
                                1000 * float(np.median([r["think"] for r in res])),
                                pol.guarded - guarded_before if name == "policy" else 0))
    return rows
