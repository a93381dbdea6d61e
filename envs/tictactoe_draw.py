"""TicTacToeDraw-v0: the writing arm of seed 003 plays tic-tac-toe on a real board - it draws
the field and its marks, a camera reads the board, an opponent draws by hand.

## Description

The agent is the arm's player. Each step it picks a cell; the arm draws its mark there
(in pymunk with ``draw_physics=True``, the default - :class:`kinegym.envs.sim.arm.ArmSim`; as ideal
strokes with ``draw_physics=False``, for speed). Then the opponent inside the env
(``opponent``: the strong player, the thesis player, random, or any callable
``Board -> cell``) draws its own mark by hand (:func:`kinegym.envs.sim.board.hand_x` /
:func:`~envs.sim.board.hand_o`: size, slant, wobble and placement vary), a camera
photographs the board (:class:`kinegym.envs.sim.camera.Camera`, preset ``camera``) and the board
reader (:class:`kinegym.vision.board_reader.BoardReader`) reads every cell as empty, X or O.

A reading is accepted only if it is **consistent** with the last accepted board: every
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

``gymnasium.make("kinegym/TicTacToeDraw-v0", board=5, k=None, agent_symbol="X",
opponent="thesis", draw_physics=True, draw_field=True, erase=True, obs_mode="board",
camera="default", max_read_tries=3, arm="thesis_rrrr", homing=False, render_mode=None)``.
The registered id gives the env the players of :mod:`kinegym.agents.minimax` (``"strong"`` is
:class:`~agents.minimax.StrongPlayer` with its budget counted in search nodes, so seeded
games replay bit for bit).

Determinism: everything random (opponent, hand-drawn marks, camera) draws from
``self.np_random``; the same seed and the same actions give the same observations, bit for
bit. Pickling replays the episode from its seed (pymunk states do not copy exactly).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from kinegym.envs.errors import ResetNeededError, check_action
from kinegym.envs.game import EMPTY, Board, Game, O, X

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
        if illegal not in ("raise", "lose"):
            raise ValueError(f"illegal={illegal!r}; expected 'raise' (an occupied cell is an error) or 'lose'")
        self.illegal = illegal
        self._kwargs = dict(board=board, k=k, agent_symbol=agent_symbol, opponent=opponent, opponents=opponents,
                            illegal=illegal, draw_physics=draw_physics, draw_field=draw_field, erase=erase,
                            obs_mode=obs_mode, camera=camera, max_read_tries=max_read_tries,
                            image_obs_size=image_obs_size, arm=arm, homing=homing, render_mode=render_mode)
        if board not in (3, 5):
            raise ValueError(f"board={board!r}; expected 3 or 5 (cells a side)")
        k = (3 if board == 3 else 4) if k is None else int(k)
        if not 2 <= k <= board:
            raise ValueError(f"k={k!r}; expected 2..{board} in a row")
        if agent_symbol not in _SYM:
            raise ValueError(f"agent_symbol={agent_symbol!r}; expected 'X' (moves first) or 'O'")
        if obs_mode not in ("board", "image", "both"):
            raise ValueError(f"obs_mode={obs_mode!r}; expected 'board', 'image' or 'both'")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r}; expected one of {self.metadata['render_modes']} or None")
        if not (isinstance(max_read_tries, int) and max_read_tries >= 1):
            raise ValueError(f"max_read_tries={max_read_tries!r}; expected an integer >= 1")
        self._opponents: dict[str, OpponentFactory] = {"random": random_opponent, **(opponents or {})}
        if isinstance(opponent, str) and opponent not in self._opponents:
            raise ValueError(f"opponent={opponent!r}; expected a callable Board -> cell or one of "
                             f"{sorted(self._opponents)} (gymnasium.make('kinegym/TicTacToeDraw-v0') brings "
                             "'strong' and 'thesis')")
        self.n, self.k = board, k
        self.game = Game(board, board, k)
        self.agent = _SYM[agent_symbol]
        self.opp = O if self.agent == X else X
        self.opponent_spec = opponent
        self.draw_physics, self.draw_field, self.erase = bool(draw_physics), bool(draw_field), bool(erase)
        self.obs_mode, self.camera_preset = obs_mode, camera
        self.max_read_tries = max_read_tries
        self.image_obs_size = (int(image_obs_size[0]), int(image_obs_size[1]))
        self.render_mode = render_mode
        self.action_space = spaces.Discrete(board * board)
        board_space = spaces.Box(0, 1, (board, board, 2), np.int8)
        w, h = self.image_obs_size
        image_space = spaces.Box(0, 255, (h, w, 3), np.uint8)
        self.observation_space = {"board": board_space, "image": image_space,
                                  "both": spaces.Dict({"board": board_space, "image": image_space})}[obs_mode]
        from kinegym.envs.sim.arm import ArmSim  # pymunk: only once an env is made
        from kinegym.vision.board_reader import BoardReader

        self.sim = ArmSim(arm, homing=False)
        self.homing = bool(homing)
        self.layout = self.sim.layout if board == self.sim.layout.n else self.sim.layout.with_field(n=board)
        self.reader = BoardReader(size=board)
        self._history: list[tuple[str, Any]] = []
        self._window: Any = None
        self.true_board: Board = self.game.empty()
        self.belief = np.zeros((board, board), np.int64)
        self._photo: np.ndarray | None = None
        self._status: list[str] = []
        self._last_read: dict[str, Any] = {}
        self._done = True
        #: called with a rendered frame every ``frame_every_s`` of simulated drawing (GIFs)
        self.on_frame: Callable[[np.ndarray], None] | None = None
        self.frame_every_s = 1.0

    # ------------------------------------------------------------------ drawing
    def _arm_draw(self, strokes: list[Any]) -> None:
        if not strokes:
            return
        if self.draw_physics:
            hook = self.on_frame
            self.sim.draw(strokes, on_frame=(lambda _s: hook(self._frame())) if hook else None,
                          frame_every_s=self.frame_every_s)
            return
        sp = self.sim.cfg["sponge"]
        for st in strokes:
            if st.tool == "sponge":
                self.sim.canvas.erase(st.points, sp["width_cm"], sp["efficiency"])
            else:
                self.sim.canvas.stroke(st.points, self.sim.pen)
            if self.on_frame is not None:  # ideal strokes: a frame per stroke
                self.on_frame(self._frame())

    def _arm_mark(self, cell: int) -> None:
        from kinegym.envs.sim import strokes as S

        r, c = divmod(cell, self.n)
        st = S.x_strokes(self.layout, r, c) if self.agent == X else S.o_strokes(self.layout, r, c)
        self._status.append(f"the manipulator is drawing {_NAME[self.agent]} in cell ({r}, {c})")
        self._arm_draw(st)

    def _hand_mark(self, cell: int) -> None:
        from kinegym.envs.sim.board import PENS
        from kinegym.envs.sim.scenes import draw_mark

        r, c = divmod(cell, self.n)
        centre = self.layout.cell_centre(r, c)
        draw_mark(self.sim.canvas, self.opp, centre, 0.6 * self.layout.cell, PENS["black"], self.np_random)
        self._status.append(f"the opponent drew {_NAME[self.opp]} in cell ({r}, {c})")

    # ------------------------------------------------------------------ reading
    def _consistent(self, cells: np.ndarray, arm_cells: list[int], opp_new: int) -> str | None:
        """None if ``cells`` is what the last accepted board plus the known changes allow,
        else what is wrong."""
        prev = self.belief.ravel()
        now = cells.ravel()
        changed = np.flatnonzero(prev != now)
        bad_old = [int(i) for i in changed if prev[i] != EMPTY]
        if bad_old:
            i = bad_old[0]
            return f"cell {divmod(i, self.n)} was {_NAME[int(prev[i])]} and now reads {_NAME[int(now[i])]}"
        for i in arm_cells:
            if now[i] != self.agent:
                return f"the arm's {_NAME[self.agent]} in cell {divmod(i, self.n)} reads {_NAME[int(now[i])]}"
        new = [int(i) for i in changed if i not in arm_cells]
        wrong = [i for i in new if now[i] != self.opp]
        if wrong:
            return (f"new {_NAME[int(now[wrong[0]])]} in cell {divmod(wrong[0], self.n)}, "
                    f"expected only {_NAME[self.opp]}")
        if len(new) != opp_new:
            return f"{len(new)} new {_NAME[self.opp]} marks seen, expected {opp_new}"
        return None

    def _read(self, arm_cells: list[int], opp_new: int) -> None:
        """Photograph and read until consistent (or out of tries); updates the belief."""
        from kinegym.envs.sim.camera import Camera
        from kinegym.vision.errors import VisionError

        self._status.append("reading the board")
        aim = self.layout.field_centre
        err: str | None = "no photo"
        tries, conf = 0, 0.0
        cells = None
        for _ in range(self.max_read_tries):
            tries += 1
            cam = Camera(self.camera_preset, seed=self.np_random)
            photo = cam.photograph(self.sim.canvas, aim)
            self._photo = photo.image
            try:
                reading = self.reader.read(photo.image)
            except VisionError as exc:
                err = f"no board found ({exc})"
                continue
            err = self._consistent(reading.cells, arm_cells, opp_new)
            if err is None:
                cells, conf = reading.cells.astype(np.int64), float(reading.confidence.min())
                break
            self._status.append(f"inconsistent reading ({err}): photographing again")
        if cells is not None:
            self.belief = cells
            self._pending_arm, self._pending_opp = [], 0
        else:  # keep what is known for sure: the last accepted board and the arm's own marks
            self._pending_arm, self._pending_opp = list(arm_cells), opp_new
            for i in arm_cells:
                self.belief.flat[i] = self.agent
            self._status.append(f"could not read the board consistently in {tries} tries: {err}")
        self._last_read = {"read_ok": cells is not None, "read_error": None if cells is not None else err,
                           "read_tries": tries, "read_confidence": conf}

    # ------------------------------------------------------------------ observation
    def action_masks(self) -> np.ndarray:
        """Cells free on the board as read (all False once the game is over). Through
        ``gymnasium.make``'s wrappers: ``env.get_wrapper_attr("action_masks")()``. Before the
        first ``reset()``: :class:`~kinegym.envs.errors.ResetNeededError`."""
        if not self._history:
            raise ResetNeededError("action_masks() before reset(): there is no board yet; call reset() first")
        if self._done:
            return np.zeros(self.n * self.n, bool)
        return self.belief.ravel() == EMPTY

    def _obs(self) -> Any:
        b = np.zeros((self.n, self.n, 2), np.int8)
        b[..., 0] = self.belief == self.agent
        b[..., 1] = self.belief == self.opp
        if self.obs_mode == "board":
            return b
        import cv2

        img = np.zeros((self.image_obs_size[1], self.image_obs_size[0], 3), np.uint8)
        if self._photo is not None:
            img = cv2.resize(self._photo, self.image_obs_size, interpolation=cv2.INTER_AREA)
        return img if self.obs_mode == "image" else {"board": b, "image": img}

    def _info(self, **extra: Any) -> dict[str, Any]:
        w = self.true_board.winner
        winner = None if not self.true_board.is_over else ("draw" if w == EMPTY else _NAME[w])
        return {"phase": "game over" if self._done else "your move", "status": list(self._status),
                "true_board": str(self.true_board), "read_board": "|".join(
                    "".join(_NAME[int(v)] for v in row) for row in self.belief),
                **self._last_read, "winner": winner, "action_mask": self.action_masks(),
                "is_success": winner == _NAME[self.agent], "arm_time_s": self.sim.time_s, **extra}

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        if seed is not None or not self._history:
            self._history = [("reset", self.np_random_seed)]
        else:
            self._history.append(("reset", None))
        from kinegym.envs.sim.board import BoardCanvas

        w, h = self.sim.layout.canvas_size
        self.sim.canvas = BoardCanvas(w, h, self.sim.canvas.px_per_cm)
        self.sim.reset(seed=int(self.np_random.integers(2**31)), homing=self.homing)
        self.sim.time_s = 0.0
        spec = self.opponent_spec
        self._opponent = spec if callable(spec) else self._opponents[spec](int(self.np_random.integers(2**31)))
        self.true_board = self.game.empty()
        self.belief = np.zeros((self.n, self.n), np.int64)
        self._pending_arm, self._pending_opp = [], 0
        self._status, self._done = [], False
        if self.draw_field:
            from kinegym.envs.sim import strokes as S

            self._status.append("the manipulator is drawing the playing field")
            self._arm_draw(S.field_strokes(self.layout))
        opp_new = 0
        if self.opp == X:
            self._status.append("waiting for the opponent")
            cell = self._opponent_move()
            opp_new = 1
        else:
            cell = -1
        self._read([], opp_new)
        return self._obs(), self._info(opponent_move=cell, illegal=False)

    def _opponent_move(self) -> int:
        cell = int(self._opponent(self.true_board))
        if not self.true_board.is_legal(cell):
            raise RuntimeError(f"the opponent chose cell {cell}, illegal on {self.true_board}")
        self.true_board = self.true_board.play(cell)
        if getattr(self._opponent, "draws_itself", False):  # a person at the board: the ink is theirs
            self._status.append(f"the opponent drew {_NAME[self.opp]} in cell {divmod(cell, self.n)}")
        else:
            self._hand_mark(cell)
        return cell

    def _finish(self) -> None:
        self._done = True
        w = self.true_board.winner
        self._status.append("game over: " + ("draw" if w == EMPTY else f"{_NAME[w]} wins"))
        if self.erase:
            from kinegym.envs.sim import strokes as S

            self._status.append("the manipulator is erasing the board")
            self._arm_draw(S.erase_strokes(self.layout, self.sim.spec))

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        if self._done:
            raise ResetNeededError("step() without a live game: call reset() first (the game ended or never began)")
        a = check_action(action, self.n * self.n, self.action_masks() if self.illegal == "raise" else None)
        self._history.append(("step", a))
        self._status = []
        if self.belief.flat[a] != EMPTY:
            self._done = True
            self._status.append(f"cell {divmod(a, self.n)} is occupied: an illegal move loses")
            return self._obs(), -1.0, True, False, self._info(opponent_move=-1, illegal=True)
        if not self.true_board.is_legal(a):  # free as read, taken in truth: a misread got through
            self._done = True
            self._last_read = {**self._last_read, "read_error": f"cell {divmod(a, self.n)} is occupied on the "
                               "real board though the last accepted reading showed it free"}
            return self._obs(), 0.0, False, True, self._info(opponent_move=-1, illegal=False)
        self.true_board = self.true_board.play(a)
        self._arm_mark(a)
        arm_cells = [*self._pending_arm, a]
        opp_new, cell = self._pending_opp, -1
        if not self.true_board.is_over:
            self._status.append("waiting for the opponent")
            cell = self._opponent_move()
            opp_new += 1
        self._read(arm_cells, opp_new)
        reward = 0.0
        if self.true_board.is_over:
            w = self.true_board.winner
            reward = 1.0 if w == self.agent else (-1.0 if w == self.opp else 0.0)
            self._finish()
        return self._obs(), reward, self._done, False, self._info(opponent_move=cell, illegal=False)

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
        import cv2

        arm = self.sim.render(scale=20.0, status=self._status[-2:])
        h = arm.shape[0]
        pw = 260
        panel = np.empty((h, pw, 3), np.uint8)
        panel[...] = (245, 245, 240)
        cv2.putText(panel, "board as read", (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (20, 20, 20), 1, cv2.LINE_AA)
        cs = min(40, (pw - 20) // self.n)
        x0, y0 = 10, 35
        for r in range(self.n):
            for c in range(self.n):
                p0 = (x0 + c * cs, y0 + r * cs)
                cv2.rectangle(panel, p0, (p0[0] + cs, p0[1] + cs), (150, 150, 150), 1)
                v = int(self.belief[r, c])
                if v != EMPTY:
                    col = (25, 60, 175) if v == self.agent else (30, 30, 30)
                    cv2.putText(panel, _NAME[v], (p0[0] + cs // 4, p0[1] + 3 * cs // 4), cv2.FONT_HERSHEY_SIMPLEX,
                                cs / 35, col, 2, cv2.LINE_AA)
        y = y0 + self.n * cs + 20
        ok = self._last_read.get("read_ok")
        cv2.putText(panel, f"read ok: {ok}  tries: {self._last_read.get('read_tries', 0)}", (10, y),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.45, (20, 20, 20), 1, cv2.LINE_AA)
        if self._photo is not None:
            th = int(round(self._photo.shape[0] * (pw - 20) / self._photo.shape[1]))
            thumb = cv2.resize(self._photo, (pw - 20, th), interpolation=cv2.INTER_AREA)
            y1 = min(h - th - 5, y + 15)
            if y1 > y:
                panel[y1:y1 + th, 10:10 + pw - 20] = thumb
                cv2.putText(panel, "camera", (10, y1 - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (60, 60, 60), 1,
                            cv2.LINE_AA)
        return np.hstack([arm, panel])

    def close(self) -> None:
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
