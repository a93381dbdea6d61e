"""``kinegym gui climber``: seed 000's inverse program and its localisation, as one live window.

Left, the wall (a built-in wall or any wall YAML) with the robot drawn at the wanted centre;
right, the controls and the seed's numbers. As in the seed: choose the three holes (click a
hole: it goes to the selected arm, then the next arm is selected; ``1``/``2``/``3`` select an
arm, ``e`` loads the seed's example holes ``(20, 0), (0, 20), (0, 0)`` and centre), then
click or drag where the centre should be (``c`` switches to centre mode, ``h`` back to holes).
Shown live: the six joint angles, the centre angles ``theta12``, ``theta23``, ``theta31``
(hole 1 - centre - hole 2, ...), ``xR``, ``yR`` (the centre), and what the localiser makes of
those six angles on this wall (the holes it finds, or how many triples fit). ``[``/``]`` turn
the body, ``b`` flips the elbows, ``Esc`` quits.
"""

from __future__ import annotations

import math

import numpy as np

from kinegym.gui.widgets import Button, Choice, Event, Label, Panel, Slider

__all__ = ["ClimberApp", "SEED_HOLES", "SEED_CENTRE"]

#: Seed 000's inverse-program example: holes of arms 1, 2, 3 and the clicked centre (cm).
SEED_HOLES = np.array([[20.0, 0.0], [0.0, 20.0], [0.0, 0.0]])
SEED_CENTRE = np.array([6.6289, 7.7378])
_MAP_W, _PANEL_W, _H = 640, 330, 600


def centre_angles(holes: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Seed 000's ``theta12, theta23, theta31``: the angles at the centre between the holes of
    arms 1-2, 2-3 and 3-1 (rad, 0..pi)."""
    v = holes - centre
    out = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, b = v[i], v[j]
        out.append(math.atan2(abs(a[0] * b[1] - a[1] * b[0]), float(a @ b)))
    return np.array(out)


class ClimberApp:
    """The inverse program's state and window (see the module docstring)."""

    def __init__(self, wall: str = "seed_4x4", robot: str = "climber") -> None:
        from kinegym.envs.draw import fit_canvas
        from kinegym.kinematics.climber import ClimberGeometry
        from kinegym.kinematics.holes import HoleMap
        from kinegym.kinematics.localization import Localizer

        self.wall = HoleMap.from_config(wall)
        self.geom = ClimberGeometry.from_config(robot)
        self.localizer = Localizer(self.wall, self.geom)
        pts = np.vstack([self.wall.xy, SEED_HOLES])
        span = float(np.ptp(pts, axis=0).max()) + 30.0
        self.canvas = fit_canvas(pts, margin=15.0, scale=min(_MAP_W, _H) / span)
        from kinegym.envs.draw import draw_wall

        draw_wall(self.canvas, self.wall, labels=len(self.wall) <= 400)  # drawn once: the background
        self.canvas.background = self.canvas.image.copy()
        self.size = (min(self.canvas.width, _MAP_W) + _PANEL_W, max(_H, self.canvas.height))
        self.done = False
        self.holes = SEED_HOLES.copy()
        self.centre = SEED_CENTRE.copy()
        self.heading = 0.0
        self.branch = 1
        self.arm = 0
        self.q: np.ndarray | None = None
        self.error = ""
        self.fix_text: list[str] = []
        self._dragging = False
        x = self.size[0] - _PANEL_W + 10
        self.panel = Panel()
        self.mode = self.panel.add(Choice((x, 10, 310, 44), "click sets", options=("holes", "centre"),
                                          keys=("h", "c"), index=1))
        self.arm_choice = self.panel.add(Choice((x, 60, 310, 44), "hole for arm", options=("1", "2", "3"),
                                                keys=("1", "2", "3"), on_change=lambda s: self._select(int(s) - 1)))
        self.panel.add(Slider((x, 110, 310, 40), "heading", lo=-180, hi=180, value=0, step=5, key="[", key_up="]",
                              unit="deg", on_change=self._set_heading))
        self.panel.add(Button((x, 156, 150, 28), "elbows", key="b", on_press=self._flip))
        self.panel.add(Button((x + 160, 156, 150, 28), "seed example", key="e", on_press=self.load_example))
        self.readout = self.panel.add(Label((x, 196, 310, 390), "inverse program"))
        self.solve()

    # ------------------------------------------------------------------ state
    def _select(self, arm: int) -> None:
        self.arm = arm

    def _set_heading(self, deg: float) -> None:
        self.heading = math.radians(deg)
        self.solve()

    def _flip(self) -> None:
        self.branch = -self.branch
        self.solve()

    def load_example(self) -> None:
        self.holes, self.centre, self.heading = SEED_HOLES.copy(), SEED_CENTRE.copy(), 0.0
        self.solve()

    def set_hole(self, arm: int, xy: np.ndarray) -> None:
        self.holes[arm] = xy
        self.arm_choice.select((arm + 1) % 3)
        self.solve()

    def set_centre(self, xy: np.ndarray) -> None:
        self.centre = np.asarray(xy, float)
        self.solve()

    def solve(self) -> None:
        """The six angles for the current holes and centre, and the localiser's answer."""
        from kinegym.kinematics.climber import inverse_program
        from kinegym.kinematics.errors import UnreachableError
        from kinegym.kinematics.pose_fit import AmbiguousFixError, NoFixError

        try:
            self.q = inverse_program(self.holes, self.centre, self.heading, self.geom, branch=self.branch)
            self.error = ""
        except UnreachableError as err:
            self.q, self.error = None, str(err)
        self.fix_text = []
        if self.q is None:
            return
        try:
            fix = self.localizer.localize(self.q)
            self.fix_text = [f"localiser: holes {fix.ids}", f"  centre ({fix.centre[0]:.2f}, {fix.centre[1]:.2f}) cm"]
        except AmbiguousFixError as err:
            best = err.candidates[0]
            self.fix_text = [f"localiser: {err.count} triples fit;", f"  likeliest {best.ids} p={best.likelihood:.2f}"]
        except NoFixError:
            self.fix_text = ["localiser: no hole triple of this", "  wall fits these angles"]

    # ------------------------------------------------------------------ events
    def _world(self, pos: tuple[int, int]) -> np.ndarray:
        c = self.canvas
        return np.array([c.x0 + pos[0] / c.scale, c._y1 - pos[1] / c.scale])

    def handle(self, ev: Event) -> None:
        if ev.kind == "quit" or (ev.kind == "key" and ev.key == "escape"):
            self.done = True
            return
        if self.panel.handle(ev):
            return
        on_map = ev.pos[0] < self.size[0] - _PANEL_W
        if ev.kind == "down" and on_map:
            p = self._world(ev.pos)
            if self.mode.value == "holes":
                d = np.hypot(*(self.wall.xy - p).T)
                k = int(np.argmin(d))
                if d[k] <= 0.45 * self.wall.spacing:
                    self.set_hole(self.arm, self.wall.xy[k].copy())
            else:
                self._dragging = True
                self.set_centre(p)
        elif ev.kind == "move" and self._dragging and ev.buttons and on_map:
            self.set_centre(self._world(ev.pos))
        elif ev.kind == "up":
            self._dragging = False

    def update(self, dt: float) -> None:
        pass

    # ------------------------------------------------------------------ drawing
    def render(self) -> np.ndarray:
        from kinegym.envs.draw import ARM_COLOURS, draw_climber

        c = self.canvas
        c.clear()
        for i, h in enumerate(self.holes):
            c.line(self.centre, h, (170, 170, 170), 0.15)
            c.circle(h, 1.5, ARM_COLOURS[i], fill=False, width=0.4)
        if self.q is not None:
            draw_climber(c, [*self.centre, self.heading], self.q, self.geom)
        else:
            c.circle(self.centre, 2.2, (200, 40, 40))
        c.caption([f"click sets: {self.mode.value}" + (f" (arm {self.arm + 1})" if self.mode.value == "holes" else "")])
        img = np.full((self.size[1], self.size[0], 3), 250, np.uint8)
        mw = min(c.width, _MAP_W)
        img[: min(c.height, self.size[1]), :mw] = c.image[: self.size[1], :mw]
        lines = [f"xR = {self.centre[0]:.4f} cm", f"yR = {self.centre[1]:.4f} cm",
                 f"heading = {math.degrees(self.heading):g} deg", ""]
        lines += [f"p{i + 1} = ({h[0]:.2f}, {h[1]:.2f})" for i, h in enumerate(self.holes)]
        if self.q is not None:
            qd = np.degrees(self.q)
            lines += [""] + [f"angulo{i + 1} = {qd[i, 0]:9.4f} {qd[i, 1]:9.4f}" for i in range(3)]
            th = np.degrees(centre_angles(self.holes, self.centre))
            lines += [f"theta12 = {th[0]:.2f}  theta23 = {th[1]:.2f}", f"theta31 = {th[2]:.2f} deg"]
            lines += [""] + self.fix_text
        else:
            words = self.error.split()
            lines += ["", "unreachable:"] + [" ".join(words[i:i + 6]) for i in range(0, min(len(words), 30), 6)]
        self.readout.lines = lines
        self.panel.draw(img)
        return img

