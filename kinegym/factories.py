"""Environment factories behind the ids :mod:`kinegym` registers.

``envs`` may not import ``agents`` (dependencies point one way: kinegym -> agents -> envs),
yet HoleClimb-v0 checks every wall it makes for a route with the gait planner. The front
door joins them: ``gymnasium.make("kinegym/HoleClimb-v0")`` calls :func:`hole_climb`, which
hands the environment :func:`agents.gait_planner.find_route`.
"""

from __future__ import annotations

from typing import Any

__all__ = ["hole_climb"]


def hole_climb(**kwargs: Any) -> Any:
    """:class:`envs.hole_climb.HoleClimbEnv` with the gait planner as its route finder."""
    from agents.gait_planner import find_route
    from envs.hole_climb import HoleClimbEnv

    kwargs.setdefault("route_finder", find_route)
    return HoleClimbEnv(**kwargs)
