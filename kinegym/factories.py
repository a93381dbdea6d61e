"""Environment factories behind the ids :mod:`kinegym` registers.

``envs`` may not import ``agents`` (dependencies point one way: kinegym -> agents -> envs),
yet HoleClimb-v0 checks every wall it makes for a route with the gait planner. The front
door joins them: ``gymnasium.make("kinegym/HoleClimb-v0")`` calls :func:`hole_climb`, which
hands the environment :func:`kinegym.agents.gait_planner.find_route`. Likewise TicTacToeDraw-v0
gets its ``"strong"`` and ``"thesis"`` opponents from :mod:`kinegym.agents.minimax` here.

Each registered id has its own factory, which fixes the keyword arguments that decide the id's
spaces (:mod:`kinegym.envs.variants`): ``gymnasium.make("kinegym/HoleClimb-v0", memory=True)``
is a :class:`~kinegym.envs.variants.SpaceKwargError` naming ``kinegym/HoleClimbMemory-v0``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from kinegym.envs.variants import check_space_kwargs

__all__ = ["hole_climb", "hole_climb_memory", "hole_climb_memory_hints", "tictactoe_draw", "strong_opponent",
           "thesis_opponent", "FACTORY_NAMES"]


def _hole_climb(env_id: str, kwargs: dict[str, Any]) -> Any:
    from kinegym.agents.gait_planner import find_route
    from kinegym.envs.hole_climb import HoleClimbEnv

    kwargs = check_space_kwargs(env_id, kwargs)
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


#: the players ``gymnasium.make`` gives TicTacToeDraw by name (besides the env's own "random")
OPPONENTS = {"strong": strong_opponent, "thesis": thesis_opponent}


def _tictactoe(env_id: str, kwargs: dict[str, Any]) -> Any:
    from kinegym.envs.tictactoe_draw import TicTacToeDrawEnv

    kwargs = check_space_kwargs(env_id, kwargs)
    kwargs.setdefault("opponents", OPPONENTS)
    return TicTacToeDrawEnv(**kwargs)


def _factory(env_id: str, build: Callable[[str, dict[str, Any]], Any]) -> Callable[..., Any]:
    def make(**kwargs: Any) -> Any:
        return build(env_id, kwargs)

    make.__doc__ = f"The env behind ``gymnasium.make({env_id!r})``, its space-deciding keyword arguments fixed."
    return make


hole_climb = _factory("kinegym/HoleClimb-v0", _hole_climb)
hole_climb_memory = _factory("kinegym/HoleClimbMemory-v0", _hole_climb)
hole_climb_memory_hints = _factory("kinegym/HoleClimbMemoryHints-v0", _hole_climb)
tictactoe_draw = _factory("kinegym/TicTacToeDraw-v0", _tictactoe)
tictactoe_draw_3x3 = _factory("kinegym/TicTacToeDraw3x3-v0", _tictactoe)
tictactoe_draw_image = _factory("kinegym/TicTacToeDrawImage-v0", _tictactoe)
tictactoe_draw_3x3_image = _factory("kinegym/TicTacToeDraw3x3Image-v0", _tictactoe)
tictactoe_draw_board_image = _factory("kinegym/TicTacToeDrawBoardImage-v0", _tictactoe)
tictactoe_draw_3x3_board_image = _factory("kinegym/TicTacToeDraw3x3BoardImage-v0", _tictactoe)

#: registered id -> the name of its factory in this module (what kinegym registers)
FACTORY_NAMES = {
    "kinegym/HoleClimb-v0": "hole_climb",
    "kinegym/HoleClimbMemory-v0": "hole_climb_memory",
    "kinegym/HoleClimbMemoryHints-v0": "hole_climb_memory_hints",
    "kinegym/TicTacToeDraw-v0": "tictactoe_draw",
    "kinegym/TicTacToeDraw3x3-v0": "tictactoe_draw_3x3",
    "kinegym/TicTacToeDrawImage-v0": "tictactoe_draw_image",
    "kinegym/TicTacToeDraw3x3Image-v0": "tictactoe_draw_3x3_image",
    "kinegym/TicTacToeDrawBoardImage-v0": "tictactoe_draw_board_image",
    "kinegym/TicTacToeDraw3x3BoardImage-v0": "tictactoe_draw_3x3_board_image",
}
