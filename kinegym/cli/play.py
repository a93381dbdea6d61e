"""``kinegym play``: a person plays tic-tac-toe against the writing arm.

The game runs in :class:`kinegym.envs.tictactoe_draw.TicTacToeDrawEnv` with the person as the
opponent: the arm draws the field, the person makes a mark, the camera photographs the
board and the reader reads it like any other mark, the arm's player answers and the arm
draws it; at the end the arm wipes the board. A status line shows the thesis GUI's
messages.

* With a display: a pygame window; draw your mark with the mouse (hold the left button),
  ``Backspace`` takes your last stroke back, ``Enter`` says you are done; ``Esc`` quits.
  Your cell is the one under the middle of your strokes.
* Without a display (or ``--terminal``): type your cell as ``ROW,COL`` (0-based, row 0 at
  the top); the program draws a hand-made mark there for you. It says that it fell back.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from typing import Any, TextIO

import numpy as np

from kinegym.cli.common import EXIT_OK, UsageError, add_json, emit

__all__ = ["add_parsers", "cmd_play", "TerminalPerson", "display_available"]

_FRAME_SCALE = 20.0  # TicTacToeDrawEnv._frame draws the arm view at 20 px/cm


class Quit(Exception):
    """The person left the game."""


def display_available() -> bool:
    """True when a pygame window can be shown (a display, not SDL's dummy driver)."""
    if os.environ.get("SDL_VIDEODRIVER", "") in ("dummy", "offscreen"):
        return False
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    try:
        import pygame  # noqa: F401
    except ImportError:
        return False
    return True


class TerminalPerson:
    """The person as the env's opponent, typing cells (``draws_itself`` False: the env draws
    a hand-made mark in the typed cell)."""

    draws_itself = False

    def __init__(self, stdin: TextIO, stdout: TextIO, n: int, show: Callable[..., None]) -> None:
        self.stdin, self.stdout, self.n, self.show = stdin, stdout, n, show

    def __call__(self, board: Any) -> int:
        self.show(board=board)  # the board as it stands, the arm's latest mark included
        while True:
            self.stdout.write(f"your move: ROW,COL (0..{self.n - 1}, row 0 at the top), or q to quit: ")
            self.stdout.flush()
            line = self.stdin.readline()
            if not line or line.strip().lower() in ("q", "quit", "exit"):
                raise Quit()
            try:
                r, c = (int(v) for v in line.replace(" ", "").split(","))
            except ValueError:
                self.stdout.write(f"  {line.strip()!r} is not ROW,COL\n")
                continue
            if not (0 <= r < self.n and 0 <= c < self.n):
                self.stdout.write(f"  ({r}, {c}) is off the board\n")
                continue
            cell = r * self.n + c
            if not board.is_legal(cell):
                self.stdout.write(f"  ({r}, {c}) is taken\n")
                continue
            return cell


class StopGame(Exception):
    """The person pressed Stop: this game ends, the window stays."""


_PANEL = 250


class WindowPerson:
    """The person drawing with the mouse in a pygame window (``draws_itself``: the strokes
    are inked on the board as drawn), with the thesis game GUI's controls on the right:
    your symbol (``x``/``o``), Play (``p``), Stop (``s``), the board as the camera read it,
    and the status messages. The arm's moves are shown as it draws them."""

    draws_itself = True

    def __init__(self, env: Any, symbol: str = "X") -> None:
        from kinegym.gui.widgets import Button, Choice, Label, Panel
        from kinegym.gui.window import pygame_or_hint

        pygame = pygame_or_hint()
        self.pg, self.env = pygame, env
        pygame.display.init()
        frame = env._frame()
        self.fw, self.fh = frame.shape[1], frame.shape[0]
        self.screen = pygame.display.set_mode((self.fw + _PANEL, max(self.fh, 420)))
        pygame.display.set_caption("kinegym play - draw your mark, Enter when done")
        from kinegym.envs.sim.arm import view_box

        self.box = view_box(env.sim)
        x = self.fw + 10
        self.panel = Panel()
        self.symbol = self.panel.add(Choice((x, 8, 230, 44), "your symbol", options=("X", "O"), keys=("x", "o"),
                                            index=0 if symbol == "X" else 1))
        self.play_btn = self.panel.add(Button((x, 60, 110, 30), "play", key="p", on_press=self._press_play))
        self.stop_btn = self.panel.add(Button((x + 120, 60, 110, 30), "stop", key="s", on_press=self._press_stop))
        self.board_label = self.panel.add(Label((x, 100, 230, 150), "board as read", size=0.5))
        self.status_label = self.panel.add(Label((x, 250, 230, 170), "status", size=0.36))
        self.play_pressed = self.stop_pressed = False
        env.on_frame, env.frame_every_s = self._arm_frame, 0.1  # the arm's moves, shown as it draws

    def _press_play(self) -> None:
        self.play_pressed = True

    def _press_stop(self) -> None:
        self.stop_pressed = True

    def _events(self, block: bool) -> list[Any]:
        """Pygame events turned into widget events; the panel takes its own, the rest return."""
        from kinegym.gui.window import _to_event

        pg = self.pg
        raw = [pg.event.wait()] if block else []
        raw += pg.event.get()
        out = []
        for r in raw:
            ev = _to_event(pg, r)
            if ev is None:
                continue
            if ev.kind == "quit" or (ev.kind == "key" and ev.key == "escape"):
                raise Quit()
            if not self.panel.handle(ev):
                out.append((ev, r))
        return out

    def _arm_frame(self, frame: np.ndarray) -> None:
        self.show(frame)
        self._events(block=False)
        if self.stop_pressed:
            raise StopGame()

    def show(self, frame: np.ndarray | None = None, hint: str = "") -> None:
        import cv2

        env = self.env
        frame = env._frame() if frame is None else frame
        if hint:
            frame = frame.copy()
            cv2.putText(frame, hint, (8, frame.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (180, 20, 20), 1,
                        cv2.LINE_AA)
        img = np.full((self.screen.get_height(), self.screen.get_width(), 3), 250, np.uint8)
        img[: frame.shape[0], : frame.shape[1]] = frame
        self.board_label.lines = ["  ".join("." if v == 0 else "XO"[int(v) - 1] for v in row) for row in env.belief]
        self.status_label.lines = [m[:34] for m in env._status[-8:]]
        self.panel.draw(img)
        self.last = img
        self.pg.display.get_surface().blit(self.pg.image.frombuffer(img.tobytes(), img.shape[1::-1], "RGB"), (0, 0))
        self.pg.display.flip()

    def wait_for_play(self) -> str:
        """The lobby: until Play is pressed (returns the chosen symbol); Esc quits."""
        self.play_pressed = self.stop_pressed = False
        while not self.play_pressed:
            self.show(hint="choose your symbol, then Play [p]")
            self._events(block=True)
        self.play_pressed = self.stop_pressed = False
        return self.symbol.value

    def to_canvas(self, u: float, v: float) -> np.ndarray:
        x0, _, _, y1 = self.box
        p = np.array([x0 + u / _FRAME_SCALE, y1 - v / _FRAME_SCALE])
        return p - np.asarray(self.env.sim.layout.canvas_origin)

    def __call__(self, board: Any) -> int:
        from kinegym.envs.sim.board import PENS

        env = self.env
        lay, n = env.layout, env.n
        strokes: list[list[np.ndarray]] = []
        base = env.sim.canvas.copy()
        hint = "draw your mark (mouse), Backspace: undo, Enter: done"
        while True:
            self.show(hint=hint)
            for ev, _ in self._events(block=True):
                if self.stop_pressed:
                    raise StopGame()
                on_board = ev.pos[0] < self.fw
                if ev.kind == "down" and on_board:
                    strokes.append([self.to_canvas(*ev.pos)])
                elif ev.kind == "move" and ev.buttons and strokes and on_board:
                    strokes[-1].append(self.to_canvas(*ev.pos))
                    env.sim.canvas.stroke(np.array(strokes[-1][-2:]), PENS["black"])
                elif ev.kind == "key" and ev.key == "backspace" and strokes:
                    strokes.pop()
                    env.sim.canvas = base.copy()
                    for st in strokes:
                        env.sim.canvas.stroke(np.array(st), PENS["black"])
                elif ev.kind == "key" and ev.key in ("return", "enter") and strokes:
                    pts = np.concatenate([np.array(st) for st in strokes])
                    c = (pts.min(0) + pts.max(0)) / 2 - np.asarray(lay.field_origin)
                    col, row = int(c[0] // lay.cell), int(n - 1 - c[1] // lay.cell)
                    if not (0 <= row < n and 0 <= col < n):
                        hint = "that is off the field - Backspace and draw inside a cell"
                    elif not board.is_legal(row * n + col):
                        hint = f"cell ({row}, {col}) is taken - Backspace and draw in a free cell"
                    else:
                        return row * n + col
            if self.stop_pressed:
                raise StopGame()

    def close(self) -> None:
        self.pg.display.quit()


def cmd_play(args: argparse.Namespace) -> int:
    from kinegym.agents.minimax import make_player
    from kinegym.envs.game import Board
    from kinegym.envs.tictactoe_draw import TicTacToeDrawEnv
    from kinegym.factories import strong_opponent, thesis_opponent

    if args.board not in (3, 5):
        raise UsageError(f"--board {args.board}; expected 3 or 5")
    k = args.k if args.k is not None else (3 if args.board == 3 else 4)
    if not 2 <= k <= args.board:
        raise UsageError(f"--k {k}; expected 2..{args.board}")
    person_sym = args.symbol.upper()
    if person_sym not in ("X", "O"):
        raise UsageError(f"--symbol {args.symbol!r}; expected X or O")
    out = sys.stdout
    gui = not args.terminal and display_available()
    if not gui and not args.terminal:
        out.write("kinegym play: no display found - playing in the terminal (type your cells)\n")
    player = make_player(args.opponent, seed=args.seed)

    def new_env(person_symbol: str) -> Any:
        return TicTacToeDrawEnv(board=args.board, k=k, agent_symbol="O" if person_symbol == "X" else "X",
                                opponent=lambda b: 0, opponents={"strong": strong_opponent, "thesis": thesis_opponent},
                                draw_physics=not args.fast, erase=not args.no_erase)

    def play_one(env: Any, person: Any, person_sym: str) -> dict[str, Any]:
        """One game; the person is the env's opponent. Returns the result."""
        arm_sym = "O" if person_sym == "X" else "X"
        shown = [0]

        def show_status(info: dict[str, Any] | None = None, board: Any = None) -> None:
            """The env's new status messages, then the board: as it stands when it is the person's
            turn (``board``, the arm's latest mark included), else as the camera last read it."""
            msgs = env._status[shown[0]:]
            for m in msgs:
                out.write(f"  [{m}]\n")
            shown[0] = len(env._status)
            if board is not None:
                cells, title = np.asarray(board.cells()), "the board, your move"
            else:
                cells, title = env.belief, "board as read"
            if info is not None or msgs or board is not None:
                rows = ["|".join(" " + ("." if v == 0 else "XO"[int(v) - 1]) + " " for v in row) for row in cells]
                out.write(f"  {title}:\n" + "\n".join("    " + r for r in rows) + "\n")
            out.flush()

        if isinstance(person, TerminalPerson):
            person.show = show_status
        env.opponent_spec = person
        result: dict[str, Any] = {"symbol": person_sym, "winner": None, "moves": 0}
        env.reset(seed=args.seed)
        show_status()
        done, info = False, {}
        while not done:
            shown[0] = 0
            a = player.choose(Board.from_cells(env.game, env.belief))
            obs, r, term, trunc, info = env.step(a)
            result["moves"] += 1
            show_status(info)
            if gui:
                person.show()
            done = term or trunc
        result["winner"] = info.get("winner")
        who = {arm_sym: "the arm", person_sym: "you"}.get(str(info.get("winner")), "nobody (a draw)")
        out.write(f"game over: {info.get('winner')} - {who} won\n" if info.get("winner") != "draw"
                  else "game over: a draw\n")
        return result

    results: list[dict[str, Any]] = []
    if not gui:
        env = new_env(person_sym)
        try:
            results.append(play_one(env, TerminalPerson(sys.stdin, out, args.board, lambda **_: None), person_sym))
        except Quit:
            out.write("you left the game\n")
            results.append({"symbol": person_sym, "winner": "quit", "moves": 0})
    else:
        env = new_env(person_sym)
        person = WindowPerson(env, person_sym)
        try:
            while True:  # the lobby: choose a symbol, Play; Stop ends a game, Esc the program
                sym = person.wait_for_play()
                env = new_env(sym)
                person.env, env.on_frame, env.frame_every_s = env, person._arm_frame, 0.1
                try:
                    results.append(play_one(env, person, sym))
                except StopGame:
                    out.write("game stopped\n")
                    results.append({"symbol": sym, "winner": "stopped", "moves": 0})
        except Quit:
            out.write("you left the game\n")
        finally:
            person.close()
    if args.json:
        last = results[-1] if results else {"winner": "quit", "moves": 0}
        emit(args, {**last, "games": results}, "")
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    pl = sub.add_parser("play", help="play tic-tac-toe against the writing arm (window, or terminal without one)")
    pl.add_argument("--board", type=int, default=5, help="3 or 5 cells a side (default 5, the thesis's game)")
    pl.add_argument("--k", type=int, default=None, help="in a row to win (default 4 on 5 x 5, 3 on 3 x 3)")
    pl.add_argument("--symbol", default="X", help="your symbol: X (you start) or O")
    pl.add_argument("--opponent", default="solver", choices=("solver", "thesis", "random"),
                    help="the arm's player (default: the solver, which never loses)")
    pl.add_argument("--seed", type=int, default=0)
    pl.add_argument("--terminal", action="store_true", help="type cells in the terminal even with a display")
    pl.add_argument("--fast", action="store_true", help="ideal strokes instead of the arm in pymunk")
    pl.add_argument("--no-erase", action="store_true", help="leave the board as it is at the end")
    add_json(pl)
    pl.set_defaults(func=cmd_play)
