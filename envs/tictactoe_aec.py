"""The drawn tic-tac-toe game as a two-player PettingZoo AEC env: the writing arm of seed 003
against a person, on a real board that a camera reads.

## Description

Two agents take turns: ``"arm"`` draws its mark with the writing arm (in pymunk with
``draw_physics=True``, the default; as ideal strokes with ``draw_physics=False``) and
``"person"`` draws by hand (:func:`kinegym.envs.sim.scenes.draw_mark`: size, slant, wobble and
placement vary). ``arm_symbol`` says which of them is X (X moves first). At reset the arm
draws the field; when the game ends the arm wipes the board (``erase``).

Neither agent sees the true board: each sees the board **as read** - a camera photographs it
(:class:`kinegym.envs.sim.camera.Camera`) and the board reader reads every cell
(:class:`kinegym.vision.board_reader.BoardReader`). A photo is taken when an agent first
observes a changed board. A reading is accepted only if the reader is sure of its grid
(:attr:`~kinegym.vision.reading.BoardReading.unsure` false) and it is consistent with the last
accepted board (every mark seen before still there, the arm's marks where it drew them,
exactly as many new person marks as were made); otherwise the board is photographed again,
up to ``max_read_tries`` times, and then the belief keeps the last accepted board plus the
arm's own marks (``infos[agent]["read_ok"] = False``). The env never invents a board.

Like PettingZoo's ``tictactoe_v3`` (same observation layout), the game is not parallelisable.
:class:`kinegym.envs.tictactoe_draw.TicTacToeDrawEnv` (``gymnasium.make("kinegym/TicTacToeDraw-v0")``)
is this env seen from the arm's side, with a policy playing the person.

## Agents

``possible_agents = ["arm", "person"]``; the agent holding X acts first.

## Action Space

``Discrete(n * n)`` for each agent: the cell ``row * n + col`` (row 0 at the top). A cell
occupied on the board as read, out of range or of the wrong type raises
:class:`~kinegym.envs.errors.InvalidActionError` (``illegal="raise"``, default); with
``illegal="lose"`` an occupied cell loses the game for the mover (reward -1, the other 0,
both terminated; PettingZoo's ``TerminateIllegalWrapper`` convention). A terminated agent
steps with ``None``.

## Observation Space

``Dict(observation=Box(0, 1, (n, n, 2), int8), action_mask=Box(0, 1, (n*n,), int8))`` per agent:

| key | index | observation |
|---|---|---|
| ``observation`` | ``[r, c, 0]`` | 1 if the reader sees this agent's symbol in cell (r, c) |
| ``observation`` | ``[r, c, 1]`` | 1 if the reader sees the other agent's symbol in cell (r, c) |
| ``action_mask`` | ``[i]`` | 1 if cell ``i`` is free on the board as read and it is this agent's turn |

## Rewards

``+1`` to the winner and ``-1`` to the loser when the game ends, ``0`` otherwise and for a
draw (plain floats).

## Episode End

All agents terminate when the game is won, lost or drawn (then the board is erased), or on
an illegal move with ``illegal="lose"``. All are truncated if an agent picks a cell free on the
board as read but taken on the real one (only after an unresolved misread;
``infos[agent]["read_error"]`` says so).

## Info

Per agent: ``status`` (the thesis GUI's messages since the last move), ``true_board`` and
``read_board`` (text ``"X..|.O.|..."``), ``read_ok``, ``read_error``, ``read_tries``,
``read_confidence``, ``winner`` (``"X"``, ``"O"``, ``"draw"`` or None), ``arm_time_s``.

## Arguments

``env(board=3, k=None, arm_symbol="X", draw_physics=True, draw_field=True, erase=True,
camera="default", max_read_tries=3, arm="thesis_rrrr", homing=False, illegal="raise",
render_mode=None)``; ``board`` is 3 or 5 (``k`` in a row: 3 on 3 x 3, 4 on 5 x 5).

Determinism: hand marks and camera samples draw from the env's generator, seeded by
``reset(seed=...)``; the same seed and actions give the same observations, bit for bit.

## Version History

* v0 (kinegym 0.1): the first release (``metadata["name"] = "kinegym_tictactoe_draw_v0"``).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv

from kinegym.envs.errors import ResetNeededError, check_action
from kinegym.envs.game import EMPTY, Board, Game, O, X

__all__ = ["TicTacToeDrawAEC", "env", "raw_env", "AGENTS"]

AGENTS = ("arm", "person")
_SYM = {"X": X, "O": O}
_NAME = {X: "X", O: "O", EMPTY: "."}


class TicTacToeDrawAEC(AECEnv):
    """See the module docstring for agents, spaces, rewards and arguments."""

    metadata = {"render_modes": ["human", "rgb_array"], "name": "kinegym_tictactoe_draw_v0",
                "is_parallelizable": False, "render_fps": 4}

    def __init__(self, board: int = 3, k: int | None = None, arm_symbol: str = "X", draw_physics: bool = True,
                 draw_field: bool = True, erase: bool = True, camera: str = "default", max_read_tries: int = 3,
                 arm: str = "thesis_rrrr", homing: bool = False, illegal: str = "raise",
                 render_mode: str | None = None) -> None:
        super().__init__()
        if board not in (3, 5):
            raise ValueError(f"board={board!r}; expected 3 or 5 (cells a side)")
        k = (3 if board == 3 else 4) if k is None else k
        if not (isinstance(k, int) and 2 <= k <= board):
            raise ValueError(f"k={k!r}; expected an integer 2..{board} in a row")
        if arm_symbol not in _SYM:
            raise ValueError(f"arm_symbol={arm_symbol!r}; expected 'X' (moves first) or 'O'")
        if illegal not in ("raise", "lose"):
            raise ValueError(f"illegal={illegal!r}; expected 'raise' (an occupied cell is an error) or 'lose'")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r}; expected one of {self.metadata['render_modes']} or None")
        if not (isinstance(max_read_tries, int) and max_read_tries >= 1):
            raise ValueError(f"max_read_tries={max_read_tries!r}; expected an integer >= 1")
        self._kwargs = dict(board=board, k=k, arm_symbol=arm_symbol, draw_physics=draw_physics,
                            draw_field=draw_field, erase=erase, camera=camera, max_read_tries=max_read_tries,
                            arm=arm, homing=homing, illegal=illegal, render_mode=render_mode)
        self.n, self.k, self.illegal, self.render_mode = board, k, illegal, render_mode
        self.game = Game(board, board, k)
        self.symbol = {"arm": _SYM[arm_symbol], "person": O if arm_symbol == "X" else X}
        self.draw_physics, self.draw_field, self.erase = bool(draw_physics), bool(draw_field), bool(erase)
        self.camera_preset, self.max_read_tries, self.homing = camera, max_read_tries, bool(homing)
        self.possible_agents = list(AGENTS)
        self.action_spaces = {a: spaces.Discrete(board * board) for a in AGENTS}
        self.observation_spaces = {a: spaces.Dict({"observation": spaces.Box(0, 1, (board, board, 2), np.int8),
                                                   "action_mask": spaces.Box(0, 1, (board * board,), np.int8)})
                                   for a in AGENTS}
        from kinegym.envs.sim.arm import ArmSim  # pymunk: only once an env is made
        from kinegym.vision.board_reader import BoardReader

        self.sim = ArmSim(arm, homing=False)
        self.layout = self.sim.layout if board == self.sim.layout.n else self.sim.layout.with_field(n=board)
        self.reader = BoardReader(size=board)
        self.np_random: np.random.Generator | None = None
        self.true_board: Board = self.game.empty()
        self.belief = np.zeros((board, board), np.int64)
        #: the camera's last photo (RGB), None before the first reading
        self.photo: np.ndarray | None = None
        #: this game's messages (the thesis GUI's status lines), oldest first
        self.log: list[str] = []
        self._mark = 0  # where the current move's messages begin in the log
        self._last_read: dict[str, Any] = {}
        self._history: list[tuple[str, Any]] = []
        self._window: Any = None
        self._live = False
        #: False while a person draws their own ink (``kinegym play``): the env then draws no hand mark
        self.person_inks = True
        #: called with a rendered frame every ``frame_every_s`` of simulated drawing (GIFs)
        self.on_frame: Any = None
        self.frame_every_s = 1.0

    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self.action_spaces[agent]

    # ------------------------------------------------------------------ drawing
    def _arm_draw(self, strokes: list[Any]) -> None:
        if not strokes:
            return
        if self.draw_physics:
            hook = self.on_frame
            self.sim.draw(strokes, on_frame=(lambda _s: hook(self.frame())) if hook else None,
                          frame_every_s=self.frame_every_s)
            return
        sp = self.sim.cfg["sponge"]
        for st in strokes:
            if st.tool == "sponge":
                self.sim.canvas.erase(st.points, sp["width_cm"], sp["efficiency"])
            else:
                self.sim.canvas.stroke(st.points, self.sim.pen)
            if self.on_frame is not None:  # ideal strokes: a frame per stroke
                self.on_frame(self.frame())

    def _draw_move(self, agent: str, cell: int) -> None:
        from kinegym.envs.sim import strokes as S

        sym, (r, c) = self.symbol[agent], divmod(cell, self.n)
        if agent == "arm":
            st = S.x_strokes(self.layout, r, c) if sym == X else S.o_strokes(self.layout, r, c)
            self.log.append(f"the manipulator is drawing {_NAME[sym]} in cell ({r}, {c})")
            self._arm_draw(st)
            self._pending_arm.append(cell)
            return
        if self.person_inks:
            from kinegym.envs.sim.board import PENS
            from kinegym.envs.sim.scenes import draw_mark

            draw_mark(self.sim.canvas, sym, self.layout.cell_centre(r, c), 0.6 * self.layout.cell, PENS["black"],
                      self.np_random)
        self.log.append(f"the opponent drew {_NAME[sym]} in cell ({r}, {c})")
        self._pending_person += 1

    # ------------------------------------------------------------------ reading
    def _consistent(self, cells: np.ndarray) -> str | None:
        """None if ``cells`` is what the last accepted board plus the known changes allow, else what is wrong."""
        arm, person = self.symbol["arm"], self.symbol["person"]
        prev, now = self.belief.ravel(), cells.ravel()
        changed = np.flatnonzero(prev != now)
        bad_old = [int(i) for i in changed if prev[i] != EMPTY]
        if bad_old:
            i = bad_old[0]
            return f"cell {divmod(i, self.n)} was {_NAME[int(prev[i])]} and now reads {_NAME[int(now[i])]}"
        for i in self._pending_arm:
            if now[i] != arm:
                return f"the arm's {_NAME[arm]} in cell {divmod(i, self.n)} reads {_NAME[int(now[i])]}"
        new = [int(i) for i in changed if i not in self._pending_arm]
        wrong = [i for i in new if now[i] != person]
        if wrong:
            return f"new {_NAME[int(now[wrong[0]])]} in cell {divmod(wrong[0], self.n)}, expected only {_NAME[person]}"
        if len(new) != self._pending_person:
            return f"{len(new)} new {_NAME[person]} marks seen, expected {self._pending_person}"
        return None

    def read_board(self) -> None:
        """Photograph and read the board if it changed since the last reading (until a reading
        is consistent, or out of tries); updates the belief every agent observes."""
        if not self._stale:
            return
        from kinegym.envs.sim.camera import Camera
        from kinegym.vision.errors import VisionError
        from kinegym.vision.reading import UNSURE_GRID

        self._stale = False
        self._history.append(("read", None))  # photos draw from the generator: a replay takes them too
        self.log.append("reading the board")
        err: str | None = "no photo"
        tries, conf, cells = 0, 0.0, None
        for _ in range(self.max_read_tries):
            tries += 1
            photo = Camera(self.camera_preset, seed=self.np_random).photograph(self.sim.canvas,
                                                                                self.layout.field_centre)
            self.photo = photo.image
            try:
                reading = self.reader.read(photo.image)
            except VisionError as exc:
                err = f"no board found ({exc})"
                continue
            err = (f"grid confidence {reading.grid_confidence:.3f}, under {UNSURE_GRID}" if reading.unsure
                   else self._consistent(reading.cells))
            if err is None:
                cells, conf = reading.cells.astype(np.int64), float(reading.confidence.min())
                break
            self.log.append(f"{'unsure' if reading.unsure else 'inconsistent'} reading ({err}): photographing again")
        if cells is not None:
            self.belief = cells
            self._pending_arm, self._pending_person = [], 0
        else:  # keep what is known for sure: the last accepted board and the arm's own marks
            for i in self._pending_arm:
                self.belief.flat[i] = self.symbol["arm"]
            self.log.append(f"could not read the board consistently in {tries} tries: {err}")
        self._last_read = {"read_ok": cells is not None, "read_error": None if cells is not None else err,
                           "read_tries": tries, "read_confidence": conf}

    # ------------------------------------------------------------------ observation
    def legal_cells(self) -> np.ndarray:
        """Cells free on the board as read (the photo is taken first if the board changed)."""
        self.read_board()
        return self.belief.ravel() == EMPTY

    def observe(self, agent: str) -> dict[str, np.ndarray]:
        if self.np_random is None:
            raise ResetNeededError("observe() before reset(): there is no board yet; call reset() first")
        self.read_board()
        me, other = self.symbol[agent], self.symbol["person" if agent == "arm" else "arm"]
        obs = np.zeros((self.n, self.n, 2), np.int8)
        obs[..., 0] = self.belief == me
        obs[..., 1] = self.belief == other
        mask = np.zeros(self.n * self.n, np.int8)
        if self._live and agent == self.agent_selection:
            mask[self.belief.ravel() == EMPTY] = 1
        return {"observation": obs, "action_mask": mask}

    def _info(self) -> dict[str, Any]:
        w = self.true_board.winner
        winner = None if not self.true_board.is_over else ("draw" if w == EMPTY else _NAME[w])
        return {"status": self.log[self._mark:], "true_board": str(self.true_board),
                "read_board": "|".join("".join(_NAME[int(v)] for v in row) for row in self.belief),
                **self._last_read, "winner": winner, "arm_time_s": self.sim.time_s}

    # ------------------------------------------------------------------ AEC API
    def new_game(self, rng: np.random.Generator) -> None:
        """Start a game drawing from ``rng`` (the single-agent env passes its own generator)."""
        from kinegym.envs.sim.board import BoardCanvas

        self.np_random = rng
        w, h = self.sim.layout.canvas_size
        self.sim.canvas = BoardCanvas(w, h, self.sim.canvas.px_per_cm)
        self.sim.reset(seed=int(rng.integers(2**31)), homing=self.homing)
        self.sim.time_s = 0.0
        self.true_board = self.game.empty()
        self.belief = np.zeros((self.n, self.n), np.int64)
        self._pending_arm: list[int] = []
        self._pending_person = 0
        self.log, self._mark, self._last_read, self.photo = [], 0, {}, None
        self.agents = list(AGENTS)
        first = "arm" if self.symbol["arm"] == X else "person"
        self.agent_selection = first
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self._live, self._stale = True, True
        if self.draw_field:
            from kinegym.envs.sim import strokes as S

            self.log.append("the manipulator is drawing the playing field")
            self._arm_draw(S.field_strokes(self.layout))
        self.infos = {a: self._info() for a in self.agents}

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        if seed is not None or self.np_random is None:
            self.np_random, _ = seeding.np_random(seed)
            self._history = [("reset", seed)]
        else:
            self._history.append(("reset", None))
        self.new_game(self.np_random)

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if self.np_random is None:
            raise ResetNeededError("step() before reset(): call reset() first")
        if self.terminations.get(agent) or self.truncations.get(agent):
            self._history.append(("step", None))
            self._was_dead_step(action)
            return
        legal = self.legal_cells()
        a = check_action(action, self.n * self.n, legal if self.illegal == "raise" else None)
        self._history.append(("step", a))
        self._play(agent, a, bool(legal[a]))

    def play_unobserved(self, cell: int) -> None:
        """The current agent's move made without looking through the camera: a person at the
        board sees the real board (the single-agent env's opponent). The cell must be free on
        the real board; no photo is taken before it."""
        if not self._live:
            raise ResetNeededError("play_unobserved() without a live game: call reset() first")
        free = np.zeros(self.n * self.n, bool)
        free[self.true_board.legal_moves()] = True
        a = check_action(cell, self.n * self.n, free)
        self._history.append(("unobserved", a))
        self._play(self.agent_selection, a, True)

    def _play(self, agent: str, a: int, free_as_read: bool) -> None:
        self._cumulative_rewards[agent] = 0.0
        self._clear_rewards()
        self._mark = len(self.log)
        other = "person" if agent == "arm" else "arm"
        if not free_as_read:  # illegal="lose"
            self.log.append(f"cell {divmod(a, self.n)} is occupied: an illegal move loses")
            self.rewards[agent] = -1.0
            self._end(terminated=True)
        elif not self.true_board.is_legal(a):  # free as read, taken in truth: a misread got through
            self._last_read = {**self._last_read, "read_error": f"cell {divmod(a, self.n)} is occupied on the "
                               "real board though the last accepted reading showed it free"}
            self._end(terminated=False)
        else:
            self.true_board = self.true_board.play(a)
            self._draw_move(agent, a)
            self._stale = True
            if self.true_board.is_over:
                self.read_board()  # the last look at the board, before the sponge
                w = self.true_board.winner
                if w != EMPTY:
                    winner = agent if self.symbol[agent] == w else other
                    self.rewards[winner] = 1.0
                    self.rewards["person" if winner == "arm" else "arm"] = -1.0
                self.log.append("game over: " + ("draw" if w == EMPTY else f"{_NAME[w]} wins"))
                self._end(terminated=True)
                if self.erase:
                    from kinegym.envs.sim import strokes as S

                    self.log.append("the manipulator is erasing the board")
                    self._arm_draw(S.erase_strokes(self.layout, self.sim.spec))
            else:
                self.log.append("waiting for the opponent" if other == "person" else "waiting for the arm")
        self.agent_selection = other
        self._accumulate_rewards()
        self.infos = {ag: self._info() for ag in self.agents}
        if self.render_mode == "human":
            self.render()

    def _end(self, terminated: bool) -> None:
        self._live = False
        for ag in self.agents:
            (self.terminations if terminated else self.truncations)[ag] = True

    @property
    def live(self) -> bool:
        """A game is on (reset, not yet ended)."""
        return self._live

    # ------------------------------------------------------------------ pictures
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; make the env with render_mode='rgb_array'")
            return None
        frame = self.frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from kinegym.envs.viewer import Window

            self._window = Window("kinegym TicTacToeDraw", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def frame(self) -> np.ndarray:
        """The arm and its board beside the board as read and the camera's last photo."""
        from kinegym.envs.draw import board_panel

        arm = self.sim.render(scale=20.0, status=self.log[-2:])
        return np.hstack([arm, board_panel(self.belief, self.symbol["arm"], self._last_read, self.photo,
                                           arm.shape[0])])

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        # pymunk states do not copy bit-identically: replay the episode from its seed instead
        return {"kwargs": self._kwargs, "history": list(self._history)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state["kwargs"])  # type: ignore[misc]
        for kind, arg in state["history"]:
            if kind == "reset":
                self.reset(seed=arg)
            elif kind == "unobserved":
                self.play_unobserved(arg)
            elif kind == "read":
                self._stale = True
                self.read_board()
            else:
                self.step(arg)


def raw_env(**kwargs: Any) -> TicTacToeDrawAEC:
    """The AEC env without PettingZoo's wrappers (see the module docstring for the arguments)."""
    return TicTacToeDrawAEC(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The AEC env behind PettingZoo's ``OrderEnforcingWrapper`` (PettingZoo's convention)."""
    from pettingzoo.utils import wrappers

    return wrappers.OrderEnforcingWrapper(TicTacToeDrawAEC(**kwargs))
