"""The registered environment ids, and the keyword arguments each id fixes.

Gymnasium's rule: an id's spaces never change. So every keyword argument that changes an
observation or action space is fixed by the id, and a variant with another space is its own
id (as Gymnasium registers ``FrozenLake-v1`` and ``FrozenLake8x8-v1``):

| id | fixed keyword arguments | observation | action |
|---|---|---|---|
| ``kinegym/HoleClimb-v0`` | ``candidates=8, memory=False, hints=False`` | ``Box(68,)`` | ``Discrete(24)`` |
| ``kinegym/HoleClimbMemory-v0`` | ``candidates=8, memory=True, hints=False`` | ``Box(93,)`` | ``Discrete(24)`` |
| ``kinegym/HoleClimbMemoryHints-v0`` | ``candidates=8, memory=True, hints=True`` | ``Box(142,)`` | ``Discrete(24)`` |
| ``kinegym/TicTacToeDraw-v0`` | ``board=5, obs_mode="board"`` | ``Box(5, 5, 2)`` | ``Discrete(25)`` |
| ``kinegym/TicTacToeDraw3x3-v0`` | ``board=3, obs_mode="board"`` | ``Box(3, 3, 2)`` | ``Discrete(9)`` |
| ``kinegym/TicTacToeDrawImage-v0`` | ``board=5, obs_mode="image"`` | ``Box(96, 128, 3)`` | ``Discrete(25)`` |
| ``kinegym/TicTacToeDraw3x3Image-v0`` | ``board=3, obs_mode="image"`` | ``Box(96, 128, 3)`` | ``Discrete(9)`` |
| ``kinegym/TicTacToeDrawBoardImage-v0`` | ``board=5, obs_mode="both"`` | ``Dict`` | ``Discrete(25)`` |
| ``kinegym/TicTacToeDraw3x3BoardImage-v0`` | ``board=3, obs_mode="both"`` | ``Dict`` | ``Discrete(9)`` |

The TicTacToeDraw ids also fix ``image_obs_size=(128, 96)``. Passing a fixed keyword with
another value to ``gymnasium.make`` raises :class:`SpaceKwargError` naming the id to use; the
classes themselves (``HoleClimbEnv``, ``TicTacToeDrawEnv``) still take every value.
This module is plain data: :mod:`kinegym` registers from it without importing an env.
"""

from __future__ import annotations

from typing import Any

__all__ = ["HOLE_CLIMB", "TICTACTOE", "VARIANTS", "SpaceKwargError", "check_space_kwargs", "hole_climb_id",
           "tictactoe_id", "split_space_kwargs"]

#: HoleClimb ids -> the keyword arguments each fixes
HOLE_CLIMB: dict[str, dict[str, Any]] = {
    "kinegym/HoleClimb-v0": {"candidates": 8, "memory": False, "hints": False},
    "kinegym/HoleClimbMemory-v0": {"candidates": 8, "memory": True, "hints": False},
    "kinegym/HoleClimbMemoryHints-v0": {"candidates": 8, "memory": True, "hints": True},
}
_OBS_NAME = {"board": "", "image": "Image", "both": "BoardImage"}
#: TicTacToeDraw ids -> the keyword arguments each fixes
TICTACTOE: dict[str, dict[str, Any]] = {
    f"kinegym/TicTacToeDraw{'' if n == 5 else '3x3'}{_OBS_NAME[mode]}-v0":
        {"board": n, "obs_mode": mode, "image_obs_size": (128, 96)}
    for mode in ("board", "image", "both") for n in (5, 3)
}
#: every registered id -> its fixed keyword arguments
VARIANTS: dict[str, dict[str, Any]] = {**HOLE_CLIMB, **TICTACTOE}


class SpaceKwargError(ValueError):
    """A keyword argument that would change the spaces of a registered id."""

    def __init__(self, env_id: str, key: str, value: Any, use: str | None) -> None:
        fixed = VARIANTS[env_id][key]
        hint = f"make {use!r} instead" if use else f"no registered id has {key}={value!r}; make the class directly"
        super().__init__(f"{key}={value!r} would change the spaces of {env_id!r} (which fixes {key}={fixed!r}): "
                         f"{hint}. Ids: {', '.join(HOLE_CLIMB if env_id in HOLE_CLIMB else TICTACTOE)}")
        self.env_id, self.key, self.value, self.use = env_id, key, value, use


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return tuple(a) == tuple(b)
    return type(a) is type(b) and a == b if isinstance(a, bool) or isinstance(b, bool) else a == b


def hole_climb_id(memory: bool = False, hints: bool = False) -> str | None:
    """The HoleClimb id with these observation parts (None if none is registered)."""
    return next((i for i, kw in HOLE_CLIMB.items() if kw["memory"] == bool(memory) and kw["hints"] == bool(hints)),
                None)


def tictactoe_id(board: int = 5, obs_mode: str = "board") -> str | None:
    """The TicTacToeDraw id with this board size and observation (None if none is registered)."""
    return next((i for i, kw in TICTACTOE.items() if kw["board"] == board and kw["obs_mode"] == obs_mode), None)


def check_space_kwargs(env_id: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with ``env_id``'s fixed keyword arguments added; :class:`SpaceKwargError` if
    one of them is given with another value."""
    fixed = VARIANTS[env_id]
    for key, value in kwargs.items():
        if key in fixed and not _same(value, fixed[key]):
            want = {**fixed, key: value}
            use = None
            if env_id in HOLE_CLIMB and key != "candidates":
                use = hole_climb_id(want["memory"], want["hints"])
            elif env_id in TICTACTOE and key != "image_obs_size":
                use = tictactoe_id(want["board"], want["obs_mode"])
            raise SpaceKwargError(env_id, key, value, use)
    return {**kwargs, **fixed}


def split_space_kwargs(env_id: str, kwargs: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The id a HoleClimb ``env_id`` plus ``memory``/``hints`` keyword arguments name, and the
    other keyword arguments: how configs written as ``{HoleClimb-v0: {env_kwargs: {memory:
    true}}}`` (kinegym's older spelling) and as ``{HoleClimbMemory-v0: ...}`` (RL Zoo's) meet."""
    if env_id not in HOLE_CLIMB:
        return env_id, dict(kwargs)
    rest = dict(kwargs)
    base = HOLE_CLIMB[env_id]
    memory, hints = bool(rest.pop("memory", base["memory"])), bool(rest.pop("hints", base["hints"]))
    new = hole_climb_id(memory, hints)
    if new is None:
        raise SpaceKwargError(env_id, "hints", hints, None)
    return new, rest
