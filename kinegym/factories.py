"""Environment factories behind the ids :mod:`kinegym` registers.

``envs`` may not import ``agents`` (dependencies point one way: kinegym -> agents -> envs),
yet HoleClimb-v0 checks every wall it makes for a route with the gait planner. The front
door joins them: ``gymnasium.make("kinegym/HoleClimb-v0")`` calls :func:`hole_climb`, which
hands the environment :func:`kinegym.agents.gait_planner.find_route`. Likewise TicTacToeDraw-v0
gets its ``"strong"`` and ``"thesis"`` opponents from :mod:`kinegym.agents.minimax` here.
"""

from __future__ import annotations

from typing import Any

__all__ = ["hole_climb", "tictactoe_draw", "strong_opponent", "thesis_opponent"]


def hole_climb(**kwargs: Any) -> Any:
    """:class:`kinegym.envs.hole_climb.HoleClimbEnv` with the gait planner as its route finder."""
    from kinegym.agents.gait_planner import find_route
    from kinegym.envs.hole_climb import HoleClimbEnv

    kwargs.setdefault("route_finder", find_route)
    return HoleClimbEnv(**kwargs)


def strong_opponent(seed: int) -> Any:
    """The strong player (never loses), its budget counted in nodes: seeded games replay exactly."""
    from kinegym.agents.minimax import StrongPlayer

    return StrongPlayer(seed=seed, deterministic=True).choose


def thesis_opponent(seed: int) -> Any:
    """Seed 003's 3-ply minimax player."""
    from kinegym.agents.minimax import ThesisPlayer

    return ThesisPlayer(seed=seed).choose


def tictactoe_draw(**kwargs: Any) -> Any:
    """:class:`kinegym.envs.tictactoe_draw.TicTacToeDrawEnv` with the players of :mod:`kinegym.agents.minimax`."""
    from kinegym.envs.tictactoe_draw import TicTacToeDrawEnv

    kwargs.setdefault("opponents", {"strong": strong_opponent, "thesis": thesis_opponent})
    return TicTacToeDrawEnv(**kwargs)
