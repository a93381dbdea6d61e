"""Policies as agents for kinegym's environments: a trained masked policy behind the same
``act(env, obs)`` interface as the planner (:class:`kinegym.agents.gait_planner.PlannerAgent`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MaskedPolicyAgent"]


class MaskedPolicyAgent:
    """A saved sb3-contrib MaskablePPO model acting deterministically with the env's mask."""

    def __init__(self, path: str | Path, deterministic: bool = True) -> None:
        from sb3_contrib import MaskablePPO

        self.model = MaskablePPO.load(str(path), device="cpu")
        self.deterministic = deterministic

    def act(self, env: Any, obs: np.ndarray | None = None) -> int:
        if obs is None:
            raise ValueError("MaskedPolicyAgent.act needs the observation")
        action, _ = self.model.predict(obs, action_masks=env.action_masks(), deterministic=self.deterministic)
        return int(action)
