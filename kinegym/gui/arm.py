"""``kinegym gui arm``: seed 003's operational GUI - the writing arm drawing live.

Left, the board seen from above with the ink as the simulated arm lays it down (pymunk, the
servo loops of the arm YAML, stepped in slices between frames at ``time_scale`` x real time);
right, the controls and live plots refreshed at 10 Hz as the thesis's were:

* shape (X, O, sine, lines, field, erase; keys ``x o s l f e``), size (``-``/``=``, up to
  10 cm as the thesis's slider: the X and O are then drawn about the field's centre, not in
  a cell), the sine's peak-to-peak height (``,``/``.``), speed level (``[``/``]``, the
  arm's ``speed_levels``);
* trigger (``Space``: start drawing), stop (``Backspace``: the arm parks where it is);
* plots: desired vs real pen position per axis (x, y, z in cm) and per joint the commanded
  vs true angle, over the last 5 s. The thesis plotted motor current; the simulation models
  torque (N cm), which a DC servo's current follows (``I = tau / K_t``), so the status line
  shows the peak torque share instead.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kinegym.gui.widgets import Button, Choice, Event, Label, Panel, Slider, text

__all__ = ["ArmApp", "SHAPES"]

SHAPES = ("X", "O", "sine", "lines", "field", "erase")
_PANEL_W = 700
_PLOT_WINDOW_S = 5.0


def _free_x(centre: np.ndarray, size: float) -> list[Any]:
    from kinegym.envs.sim.strokes import Stroke

    h = 0.5 * size
    a = np.linspace(-h, h, max(20, int(size / 0.05)))
    return [Stroke(np.stack([centre[0] + a, centre[1] + a], 1), "pen", "X /"),
            Stroke(np.stack([centre[0] + a, centre[1] - a], 1), "pen", "X \\")]


def _free_o(centre: np.ndarray, size: float) -> list[Any]:
    from kinegym.envs.sim.strokes import Stroke

    r = 0.5 * size
    t = np.linspace(0.5 * math.pi, 0.5 * math.pi + math.radians(368), max(60, int(2 * math.pi * r / 0.05)))
    return [Stroke(np.stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)], 1), "pen", "O")]


class ArmApp:
    """The operational GUI's state, the simulated arm and the window (see the module docstring)."""

    def __init__(self, arm: str = "thesis_rrrr", time_scale: float = 1.0) -> None:
        from kinegym.envs.sim.arm import ArmSim

        if not (math.isfinite(time_scale) and 0.1 <= time_scale <= 20):
            raise ValueError(f"time_scale={time_scale!r}; expected 0.1..20 x real time")
        self.sim = ArmSim(arm)
        self.time_scale = time_scale
        self.board_scale = 16.0
        board = self.sim.render(scale=self.board_scale)
        self.size = (board.shape[1] + _PANEL_W, max(board.shape[0], 640))
        self.done = False
        self.run: Any = None
        self.status = "ready: choose a shape, press Space"
        self.sim_time = 0.0
        self._plots: np.ndarray | None = None
        self._plot_age = 1.0
        self.frames_while_drawing = 0
        x = board.shape[1] + 10
        self.panel = Panel()
        self.shape = self.panel.add(Choice((x, 8, 680, 44), "shape", options=SHAPES, keys=("x", "o", "s", "l", "f",
                                                                                          "e")))
        levels = self.sim.spec.speed_levels
        self.size_cm = self.panel.add(Slider((x, 58, 220, 40), "size", lo=1, hi=10, value=3, step=0.5, key="-",
                                             key_up="=", unit="cm"))
        self.height = self.panel.add(Slider((x + 230, 58, 220, 40), "sine height", lo=0.5, hi=6, value=4, step=0.5,
                                            key=",", key_up=".", unit="cm"))
        self.speed = self.panel.add(Slider((x + 460, 58, 220, 40), "speed level", lo=0, hi=len(levels) - 1, value=2,
                                           step=1, key="[", key_up="]"))
        self.start_btn = self.panel.add(Button((x, 104, 220, 30), "start", key="space", on_press=self.start))
        self.stop_btn = self.panel.add(Button((x + 230, 104, 220, 30), "stop", key="backspace", on_press=self.stop))
        self.info = self.panel.add(Label((x + 460, 100, 220, 40), "", size=0.38))

    # ------------------------------------------------------------------ control
    def strokes(self) -> list[Any]:
        from kinegym.envs.sim import strokes as S

        lay, shape, size = self.sim.layout, self.shape.value, self.size_cm.value
        centre = np.asarray(lay.field_centre, float)
        if shape == "X":
            return S.x_strokes(lay, lay.n // 2, lay.n // 2, size / lay.cell) if size <= lay.cell else \
                _free_x(centre, size)
        if shape == "O":
            return S.o_strokes(lay, lay.n // 2, lay.n // 2, 0.5 * size) if size < lay.cell else _free_o(centre, size)
        if shape == "sine":
            return [S.sine_stroke(centre, max(size, 2.0), self.height.value)]
        if shape == "lines":
            return S.parallel_lines(centre, size)
        if shape == "field":
            return S.field_strokes(lay.with_field(cell=size / lay.n) if size != lay.side else lay)
        return S.erase_strokes(lay, self.sim.spec)

    def start(self) -> None:
        """The trigger: plan the chosen shape at the chosen speed and start drawing it."""
        from kinegym.kinematics.errors import UnreachableError

        if self.run is not None and not self.run.done:
            self.status = "busy: the arm is drawing (Backspace stops it)"
            return
        speed = self.sim.spec.speed(int(self.speed.value))
        try:
            traj = self.sim.plan(self.strokes(), speed)
            self.run = self.sim.start(traj)
        except (UnreachableError, ValueError) as err:
            self.run, self.status = None, f"cannot draw that: {str(err)[:90]}"
            return
        self.status = f"drawing {self.shape.value} at {speed:g} cm/s ({traj.duration_s:.1f} s)"

    def stop(self) -> None:
        """Stop: the run ends where the arm is (what was drawn stays)."""
        if self.run is not None and not self.run.done:
            self.run.finish()
            self.status = f"stopped after {self.run.i * self.sim.dt:.1f} s"
            self.run = None

    @property
    def drawing(self) -> bool:
        return self.run is not None and not self.run.done

    # ------------------------------------------------------------------ loop
    def handle(self, ev: Event) -> None:
        if ev.kind == "quit" or (ev.kind == "key" and ev.key == "escape"):
            self.done = True
            return
        self.panel.handle(ev)

    def update(self, dt: float) -> None:
        self._plot_age += dt
        if not self.drawing:
            return
        self.frames_while_drawing += 1
        ticks = max(1, int(round(dt * self.time_scale / self.sim.dt)))
        self.sim_time += self.run.advance(ticks) * self.sim.dt
        self.run.show_ink()
        if self.run.done:
            rec = self.run.finish()
            err = rec.errors_mm()
            self.status = (f"done: {self.shape.value}, {rec.duration_s:.1f} s, drawing error rms "
                           f"{err.get('dynamic_xy_rms', float('nan')):.2f} mm, peak torque "
                           f"{100 * float(np.max(rec.peak_torque_ratio)):.0f} % of the limit")
            self._plot_age = 1.0

    def _plot(self) -> np.ndarray:
        from kinegym.envs.draw import live_chart

        if self.run is None or self.run.i < 2:
            return np.full((480, 690, 3), 255, np.uint8)
        rec = self.run.recording()
        n = len(rec)
        k0 = max(0, n - int(_PLOT_WINDOW_S / rec.dt))
        step = max(1, (n - k0) // 300)
        t = rec.t[k0::step]
        panels = []
        for ax, name in ((0, "x"), (1, "y"), (2, "z")):
            panels.append(live_chart({"desired": (t, rec.desired[k0::step, ax]), "real": (t, rec.tip[k0::step, ax])},
                                     f"pen {name}", "t (s)", "cm", size=(345, 160)))
        qs = {f"q{j + 1}": (t, np.degrees(rec.q_true[k0::step, j])) for j in range(4)}
        lag = float(np.degrees(np.abs(rec.q_ref[k0:] - rec.q_true[k0:]).max()))
        panels.append(live_chart(qs, f"joints, max lag {lag:.1f} deg", "t (s)", "deg", size=(345, 160)))
        grid = np.full((480, 690, 3), 255, np.uint8)
        for i, p in enumerate(panels):
            r, c = divmod(i, 2)
            grid[r * 160:(r + 1) * 160, c * 345:(c + 1) * 345] = p
        tq = rec.torque[k0:]
        share = float(np.max(np.abs(tq) / np.asarray(rec.arm.max_torque)[None, :])) if len(tq) else 0.0
        text(grid, f"peak torque {100 * share:.0f} % of the servo limit (current follows torque: I = tau / Kt)",
             (8, 470), 0.42)
        return grid

    def render(self) -> np.ndarray:
        img = np.full((self.size[1], self.size[0], 3), 250, np.uint8)
        board = self.sim.render(scale=self.board_scale, status=[self.status[:60]])
        img[: board.shape[0], : board.shape[1]] = board
        if self._plot_age >= 0.1 or self._plots is None:  # the thesis refreshed its plots at 10 Hz
            self._plots, self._plot_age = self._plot(), 0.0
        x0 = board.shape[1] + 5
        img[150:150 + 480, x0:x0 + 690] = self._plots
        self.info.lines = [f"sim {self.sim_time:.1f} s", f"x{self.time_scale:g} real time"]
        self.panel.draw(img)
        return img
