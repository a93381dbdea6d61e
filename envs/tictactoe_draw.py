"""TicTacToeDraw-v0: the writing arm of seed 003 plays tic-tac-toe on a real board - it draws
the field and its marks, a camera reads the board, an opponent draws by hand.

## Description

This is the two-player game of :mod:`kinegym.envs.tictactoe_aec` (a PettingZoo AEC env, agents
``"arm"`` and ``"person"``) seen from the arm's side, with a policy playing the person: a thin
wrapper that steps the arm's move, then the opponent's, and returns the arm's observation.

The agent is the arm's player. Each step it picks a cell; the arm draws its mark there
(in pymunk with ``draw_physics=True``, the default - :class:`kinegym.envs.sim.arm.ArmSim`; as ideal
strokes with ``draw_physics=False``, for speed). Then the opponent inside the env
(``opponent``: the strong player, the thesis player, random, or any callable
``Board -> cell``) draws its own mark by hand (:func:`kinegym.envs.sim.board.hand_x` /
:func:`~envs.sim.board.hand_o`: size, slant, wobble and placement vary), a camera
photographs the board (:class:`kinegym.envs.sim.camera.Camera`, preset ``camera``) and the board
reader (:class:`kinegym.vision.board_reader.BoardReader`) reads every cell as empty, X or O.

A reading is accepted only if the reader is sure of its grid (its arbiter gave it at least
``kinegym.vision.reading.UNSURE_GRID``) and it is **consistent** with the last accepted board: every
mark seen before is still there, the arm's new mark is where it drew it, and exactly as
many new marks of the opponent's symbol as it made - nothing else changed. Otherwise the
board is photographed again (a new camera sample), up to ``max_read_tries`` times; then
the step reports ``info["read_ok"] = False`` and ``info["read_error"]`` and the observation
keeps the last accepted board plus the arm's own marks - the env never invents a board.
At reset the arm draws the field (``draw_field``); when the game ends it wipes the board
with the sponge (``erase``). Both 5 x 5 (four in a row, the thesis's game) and 3 x 3 via
``board`` and ``k``.

## Action Space

``Discrete(n * n)``: the cell ``row * n + col`` (row 0 at the top) to draw in. Cells the
board *as read* shows occupied are masked: ``action_masks()`` and ``info["action_mask"]``.

## Observation Space

``obs_mode="board"`` (default): ``Box(0, 1, (n, n, 2), int8)``, PettingZoo's tic-tac-toe
layout - plane 0 the agent's marks, plane 1 the opponent's, from the board as read:

| index | observation |
|---|---|
| ``[r, c, 0]`` | 1 if the reader sees the agent's symbol in cell (r, c) |
| ``[r, c, 1]`` | 1 if the reader sees the opponent's symbol in cell (r, c) |

``obs_mode="image"``: the camera's last photo, ``Box(0, 255, (H, W, 3), uint8)``, resized to
``image_obs_size`` (default 128 x 96). ``obs_mode="both"``: ``Dict(board=..., image=...)``.

## Rewards

``+1`` for a win, ``-1`` for a loss, ``0`` for a draw and for every other step (plain floats).
A masked cell (occupied on the board the agent was shown), a cell out of range or an action
of the wrong type raises :class:`~kinegym.envs.errors.InvalidActionError` naming the free
cells; with ``illegal="lose"`` a masked cell instead loses the game: ``-1``, ``terminated``,
``info["illegal"] = True`` (for training without masks). ``step()`` before ``reset()`` or
after the game ended raises :class:`~kinegym.envs.errors.ResetNeededError`. A cell free on
the shown board but occupied on the real one (possible only after an unresolved misread) ends the episode *truncated*,
reward ``0``, with ``info["read_error"]``.

## Starting State

A clean board; the arm draws the field; the camera reads the empty board. If the agent
plays ``O`` (``agent_symbol``), the opponent (``X``) has made its first mark.

## Episode End

Terminated when the game is won, lost or drawn (then erased) or on an illegal move;
truncated only as above. ``info["is_success"]`` is True for a win.

## Info

``phase`` (``"your move"`` / ``"game over"``), ``status`` (the thesis GUI's messages for this
step, e.g. ``"the manipulator is drawing"``, ``"... is erasing"``), ``true_board`` and
``read_board`` (text form ``"X..|.O.|..."``), ``read_confidence`` (least cell confidence of
the accepted reading), ``read_tries``, ``read_ok``, ``read_error``, ``opponent_move``,
``winner`` (``"X"``, ``"O"``, ``"draw"`` or None), ``action_mask``, ``is_success``,
``arm_time_s`` (simulated drawing time so far).

An opponent callable with ``draws_itself = True`` (a person at the board, ``kinegym play``)
puts its own ink on ``env.sim.canvas`` before returning its cell; the env then draws no
synthetic hand mark for it.

## Arguments

``gymnasium.make("kinegym/TicTacToeDraw-v0", k=None, agent_symbol="X", opponent="thesis",
draw_physics=True, draw_field=True, erase=True, camera="default", max_read_tries=3,
arm="thesis_rrrr", homing=False, illegal="raise", render_mode=None)``. ``board`` (5 or 3) and
``obs_mode`` change the spaces, so each pair is its own id (:mod:`kinegym.envs.variants`):
``kinegym/TicTacToeDraw3x3-v0``, ``...Image-v0``, ``...BoardImage-v0`` (``obs_mode="both"``).
The registered id gives the env the players of :mod:`kinegym.agents.minimax` (``"strong"`` is
:class:`~agents.minimax.StrongPlayer` with its budget counted in search nodes, so seeded
games replay bit for bit).

Determinism: everything random (opponent, hand-drawn marks, camera) draws from
``self.np_random``; the same seed and the same actions give the same observations, bit for
bit. Pickling replays the episode from its seed (pymunk states do not copy exactly).

## Version History

* v0 (kinegym 0.1): the first release. Within v0, before 1.0: ``board`` and ``obs_mode``
  variants became their own ids (``kinegym/TicTacToeDraw3x3-v0``, ``...Image-v0``,
  ``...BoardImage-v0``), the env became the arm's side of the AEC env
  (:mod:`kinegym.envs.tictactoe_aec`), and ``action_masks()`` before ``reset()`` raises
  ``ResetNeededError``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from kinegym.envs.errors import ResetNeededError, check_action
from kinegym.envs.game import EMPTY, Board, O, X

__all__ = ["TicTacToeDrawEnv", "random_opponent", "OpponentFactory"]

#: Builds an opponent for one episode from a seed: ``factory(seed) -> (Board -> cell)``.
OpponentFactory = Callable[[int], Callable[[Board], int]]
_SYM = {"X": X, "O": O}
_NAME = {X: "X", O: "O", EMPTY: "."}


def random_opponent(seed: int) -> Callable[[Board], int]:
    """An opponent that plays a uniformly random legal cell."""
    rng = np.random.default_rng(seed)
    return lambda board: int(rng.choice(board.legal_moves()))


class TicTacToeDrawEnv(gym.Env):
    """See the module docstring for spaces, rewards and arguments."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __init__(self, board: int = 5, k: int | None = None, agent_symbol: str = "X",
                 opponent: str | Callable[[Board], int] = "thesis",
                 opponents: Mapping[str, OpponentFactory] | None = None, draw_physics: bool = True,
                 draw_field: bool = True, erase: bool = True, obs_mode: str = "board", camera: str = "default",
                 max_read_tries: int = 3, image_obs_size: tuple[int, int] = (128, 96), arm: str = "thesis_rrrr",
                 homing: bool = False, render_mode: str | None = None, illegal: str = "raise") -> None:
        from kinegym.envs.tictactoe_aec import TicTacToeDrawAEC

        self._kwargs = dict(board=board, k=k, agent_symbol=agent_symbol, opponent=opponent, opponents=opponents,
                            illegal=illegal, draw_physics=draw_physics, draw_field=draw_field, erase=erase,
                            obs_mode=obs_mode, camera=camera, max_read_tries=max_read_tries,
                            image_obs_size=image_obs_size, arm=arm, homing=homing, render_mode=render_mode)
        if agent_symbol not in _SYM:
            raise ValueError(f"agent_symbol={agent_symbol!r}; expected 'X' (moves first) or 'O'")
        if obs_mode not in ("board", "image", "both"):
            raise ValueError(f"obs_mode={obs_mode!r}; expected 'board', 'image' or 'both'")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r}; expected one of {self.metadata['render_modes']} or None")
        self._opponents: dict[str, OpponentFactory] = {"random": random_opponent, **(opponents or {})}
        if isinstance(opponent, str) and opponent not in self._opponents:
            raise ValueError(f"opponent={opponent!r}; expected a callable Board -> cell or one of "
                             f"{sorted(self._opponents)} (gymnasium.make('kinegym/TicTacToeDraw-v0') brings "
                             "'strong' and 'thesis')")
        #: the two-player game this env plays the arm's side of
        self.aec = TicTacToeDrawAEC(board=board, k=k, arm_symbol=agent_symbol, draw_physics=draw_physics,
                                    draw_field=draw_field, erase=erase, camera=camera,
                                    max_read_tries=max_read_tries, arm=arm, homing=homing, illegal=illegal)
        self.illegal, self.n, self.k, self.game = illegal, board, self.aec.k, self.aec.game
        self.agent, self.opp = self.aec.symbol["arm"], self.aec.symbol["person"]
        self.opponent_spec = opponent
        self.obs_mode, self.max_read_tries = obs_mode, max_read_tries
        self.image_obs_size = (int(image_obs_size[0]), int(image_obs_size[1]))
        self.render_mode = render_mode
        self.action_space = spaces.Discrete(board * board)
        board_space = spaces.Box(0, 1, (board, board, 2), np.int8)
        w, h = self.image_obs_size
        image_space = spaces.Box(0, 255, (h, w, 3), np.uint8)
        self.observation_space = {"board": board_space, "image": image_space,
                                  "both": spaces.Dict({"board": board_space, "image": image_space})}[obs_mode]
        self._history: list[tuple[str, Any]] = []
        self._window: Any = None
        self._step_mark = 0
        self._done = True

    # ------------------------------------------------------------------ the game's parts, by their old names
    sim = property(lambda self: self.aec.sim, doc="the arm's simulation and its board canvas")
    layout = property(lambda self: self.aec.layout, doc="where the field and its cells lie on the board")
    true_board = property(lambda self: self.aec.true_board, doc="the board as it really is")
    belief = property(lambda self: self.aec.belief, doc="the board as last accepted from the camera")
    photo = property(lambda self: self.aec.photo, doc="the camera's last photo (RGB)")
    _status = property(lambda self: self.aec.log[self._step_mark:], doc="this step's messages so far")
    reader = property(lambda self: self.aec.reader, lambda self, r: setattr(self.aec, "reader", r),
                      doc="the board reader")
    on_frame = property(lambda self: self.aec.on_frame, lambda self, f: setattr(self.aec, "on_frame", f),
                        doc="called with a rendered frame every ``frame_every_s`` of simulated drawing (GIFs)")
    frame_every_s = property(lambda self: self.aec.frame_every_s,
                             lambda self, v: setattr(self.aec, "frame_every_s", v))

    def action_masks(self) -> np.ndarray:
        """Cells free on the board as read (all False once the game is over). Through
        ``gymnasium.make``'s wrappers: ``env.get_wrapper_attr("action_masks")()``. Before the
        first ``reset()``: :class:`~kinegym.envs.errors.ResetNeededError`."""
        if not self._history:
            raise ResetNeededError("action_masks() before reset(): there is no board yet; call reset() first")
        if self._done:
            return np.zeros(self.n * self.n, bool)
        return self.aec.legal_cells()

    def _obs(self) -> Any:
        b = self.aec.observe("arm")["observation"]
        if self.obs_mode == "board":
            return b
        import cv2

        img = np.zeros((self.image_obs_size[1], self.image_obs_size[0], 3), np.uint8)
        if self.aec.photo is not None:
            img = cv2.resize(self.aec.photo, self.image_obs_size, interpolation=cv2.INTER_AREA)
        return img if self.obs_mode == "image" else {"board": b, "image": img}

    def _info(self, **extra: Any) -> dict[str, Any]:
        info = self.aec._info()
        return {"phase": "game over" if self._done else "your move", **info, "status": self._status,
                "action_mask": self.action_masks(), "is_success": info["winner"] == _NAME[self.agent], **extra}

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        if seed is not None or not self._history:
            self._history = [("reset", self.np_random_seed)]
        else:
            self._history.append(("reset", None))
        self.aec.new_game(self.np_random)
        self._step_mark = 0
        spec = self.opponent_spec
        self._opponent = spec if callable(spec) else self._opponents[spec](int(self.np_random.integers(2**31)))
        self._done = False
        cell = -1
        if self.opp == X:
            self.aec.log.append("waiting for the opponent")
            cell = self._opponent_move()
        obs = self._obs()  # the camera reads the board
        return obs, self._info(opponent_move=cell, illegal=False)

    def _opponent_move(self) -> int:
        """The opponent looks at the real board (a person at the board, not the camera) and draws."""
        cell = int(self._opponent(self.true_board))
        if not self.true_board.is_legal(cell):
            raise RuntimeError(f"the opponent chose cell {cell}, illegal on {self.true_board}")
        self.aec.person_inks = not getattr(self._opponent, "draws_itself", False)  # a person at the board inks
        self.aec.play_unobserved(cell)
        return cell

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        if self._done:
            raise ResetNeededError("step() without a live game: call reset() first (the game ended or never began)")
        a = check_action(action, self.n * self.n, self.action_masks() if self.illegal == "raise" else None)
        self._history.append(("step", a))
        self._step_mark = len(self.aec.log)
        aec = self.aec
        aec.step(a)
        reward, cell = float(aec.rewards["arm"]), -1
        illegal = bool(aec.terminations["arm"] and aec.rewards["arm"] < 0 and not aec.true_board.is_over)
        if aec.live:
            cell = self._opponent_move()
            reward += float(aec.rewards["arm"])
        self._done = not aec.live
        obs = self._obs()
        return obs, reward, bool(aec.terminations["arm"]), bool(aec.truncations["arm"]), self._info(
            opponent_move=cell, illegal=illegal)

    # ------------------------------------------------------------------ pictures
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; make the env with render_mode='rgb_array'")
            return None
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from kinegym.envs.viewer import Window

            self._window = Window("kinegym TicTacToeDraw-v0", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def _frame(self) -> np.ndarray:
        return self.aec.frame()

    def close(self) -> None:
        self.aec.close()
        if self._window is not None:
            self._window.close()
            self._window = None

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        # pymunk states do not copy bit-identically: replay the episode from its seed instead
        return {"kwargs": self._kwargs, "history": list(self._history)}  # on_frame hooks are not kept

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state["kwargs"])  # type: ignore[misc]
        for kind, arg in state["history"]:
            if kind == "reset":
                self.reset(seed=arg)
            elif not self._done:
                self.step(arg)
