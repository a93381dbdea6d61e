"""Pen paths for the writing arm: the playing field, X, O, sponge passes, test shapes, and
their timing at a speed limit.

Everything here is geometry on the board, with no physics: strokes are polylines in
*canvas* cm (the :class:`kinegym.envs.sim.board.BoardCanvas` frame: x right, y up, origin at the
canvas's lower-left corner), and :func:`plan` turns a list of strokes into a
:class:`Trajectory` of pen poses ``(x, y, z, phi)`` in the *arm* frame, sampled at the servo
rate, with the pen lifted between strokes (seed 003, section 3.6.1):

* field - ``n - 1`` lines each way (the thesis's 4 + 4 lines of 15 cm, 3 cm apart), drawn
  boustrophedon so that the pen-up moves are short;
* X - the two diagonals of the cell, inset by ``x_margin_ratio`` of a cell at each corner
  (the thesis starts at ``L/5`` from the corner, eq. 3.37-3.44);
* O - a circle of ``o_radius_ratio`` of a cell (the thesis: ``R = L/4``, eq. 3.47) drawn as
  one closed polyline that runs 8 degrees past its start, so it always closes - the reason
  the thesis drew it in four overlapping parts;
* erase - the pen turned to ``phi = 90 deg`` so the sponge on its side faces the board,
  passes back and forth along y, ``pass_step_cm`` apart (thesis: 3 cm);
* a sine wave and two parallel lines (the thesis's precision drawings, section 3.5.3).

Timing: every move follows a trapezoidal speed profile (``accel_cm_s2`` ramps, drawing or
travel speed cap) along its arc length; a change of pen pitch counts as 5 cm of arc per
radian so tilting to the sponge takes time too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .board import cell_centre, field_segments

__all__ = [
    "Stroke",
    "BoardLayout",
    "DrawingSpec",
    "Trajectory",
    "field_strokes",
    "x_strokes",
    "o_strokes",
    "erase_strokes",
    "sine_stroke",
    "parallel_lines",
    "plan",
    "hold_points",
    "TOOL_NONE",
    "TOOL_PEN",
    "TOOL_SPONGE",
]

TOOL_NONE, TOOL_PEN, TOOL_SPONGE = 0, 1, 2
_PHI_ARC_CM = 5.0  # a pen-pitch change of 1 rad is timed like 5 cm of travel


@dataclass(frozen=True)
class Stroke:
    """A polyline ``(N, 2)`` in canvas cm drawn with the pen or wiped with the sponge."""

    points: np.ndarray
    tool: str = "pen"
    label: str = ""

    def __post_init__(self) -> None:
        p = np.asarray(self.points, dtype=np.float64).reshape(-1, 2)
        if len(p) < 2 or not np.all(np.isfinite(p)):
            raise ValueError(f"stroke {self.label!r}: need >= 2 finite points, got {p.tolist()[:3]}")
        if self.tool not in ("pen", "sponge"):
            raise ValueError(f"stroke tool {self.tool!r}; expected 'pen' or 'sponge'")
        object.__setattr__(self, "points", p)

    @property
    def length_cm(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=1)))


@dataclass(frozen=True)
class BoardLayout:
    """Where the canvas and the field lie (the arm YAML's ``sim.board`` section).

    ``canvas_origin``: arm-frame position of the canvas's lower-left corner (cm);
    ``field_origin``: the field's lower-left corner on the canvas (cm).
    """

    canvas_origin: tuple[float, float] = (-10.0, 3.0)
    canvas_size: tuple[float, float] = (20.0, 20.0)
    field_origin: tuple[float, float] = (2.5, 2.0)
    n: int = 5
    cell: float = 3.0
    o_radius_ratio: float = 0.25
    x_margin_ratio: float = 0.2

    @classmethod
    def from_section(cls, board: dict) -> BoardLayout:
        return cls(tuple(board["canvas_origin_cm"]), tuple(board["canvas_size_cm"]),  # type: ignore[arg-type]
                   tuple(board["field_origin_cm"]), int(board["n"]), float(board["cell_cm"]),  # type: ignore[arg-type]
                   float(board["o_radius_ratio"]), float(board["x_margin_ratio"]))

    def with_field(self, n: int | None = None, cell: float | None = None) -> BoardLayout:
        """The same board with another field size, kept centred where the field was."""
        n = self.n if n is None else int(n)
        cell = self.cell if cell is None else float(cell)
        cx = self.field_origin[0] + 0.5 * self.n * self.cell
        cy = self.field_origin[1] + 0.5 * self.n * self.cell
        return BoardLayout(self.canvas_origin, self.canvas_size, (cx - 0.5 * n * cell, cy - 0.5 * n * cell), n,
                           cell, self.o_radius_ratio, self.x_margin_ratio)

    @property
    def side(self) -> float:
        return self.n * self.cell

    @property
    def field_centre(self) -> np.ndarray:
        return np.asarray(self.field_origin) + 0.5 * self.side

    def cell_centre(self, row: int, col: int) -> np.ndarray:
        """Canvas cm of cell ``(row, col)``'s centre; row 0 is the top row."""
        if not (0 <= row < self.n and 0 <= col < self.n):
            raise ValueError(f"cell ({row}, {col}) is off the {self.n} x {self.n} field; "
                             f"rows and cols are 0..{self.n - 1}")
        return cell_centre(row, col, self.n, self.cell, self.field_origin)

    def to_arm(self, pts: object) -> np.ndarray:
        return np.asarray(pts, dtype=np.float64) + np.asarray(self.canvas_origin)

    def to_canvas(self, pts: object) -> np.ndarray:
        return np.asarray(pts, dtype=np.float64) - np.asarray(self.canvas_origin)


@dataclass(frozen=True)
class DrawingSpec:
    """Pen, sponge and speed settings (the arm YAML's ``sim.pen``, ``sim.sponge``, ``sim.drawing``).

    Lengths cm, speeds cm/s, angles rad."""

    press_cm: float = 0.15
    lift_cm: float = 1.0
    sponge_offset_cm: float = 1.5
    sponge_press_cm: float = 0.2
    sponge_width_cm: float = 3.6
    pass_step_cm: float = 3.0
    speed_levels: tuple[float, ...] = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0)
    default_level: int = 2
    travel_speed: float = 8.0
    accel: float = 30.0
    settle_s: float = 0.15
    pen_phi: float = 0.0
    sponge_phi: float = 0.5 * math.pi
    turn_height_cm: float = 6.0

    @classmethod
    def from_sim(cls, sim: dict, pen_phi: float = 0.0, sponge_phi: float = 0.5 * math.pi) -> DrawingSpec:
        """From an arm YAML's ``sim`` section; ``pen_phi`` / ``sponge_phi``: the pen pitch
        (rad, the arm's own convention) that holds the pen vertical / the sponge down."""
        pen, sp, dr = sim["pen"], sim["sponge"], sim["drawing"]
        return cls(pen["press_cm"], pen["lift_cm"], sp["offset_cm"], sp["press_cm"], sp["width_cm"],
                   sp["pass_step_cm"], tuple(dr["speed_levels_cm_s"]), int(dr["default_level"]),
                   dr["travel_speed_cm_s"], dr["accel_cm_s2"], dr["settle_s"], pen_phi, sponge_phi,
                   dr["turn_height_cm"])

    def speed(self, level: float | None = None) -> float:
        """Pen speed (cm/s) of GUI level 0..5 (fractional levels interpolate)."""
        lv = self.default_level if level is None else level
        top = len(self.speed_levels) - 1
        if not (isinstance(lv, (int, float)) and 0 <= lv <= top):
            raise ValueError(f"speed level {level!r}; expected 0..{top}")
        return float(np.interp(lv, np.arange(top + 1), self.speed_levels))


# ------------------------------------------------------------------ strokes
def field_strokes(layout: BoardLayout) -> list[Stroke]:
    """The field's ``n - 1`` vertical and ``n - 1`` horizontal lines, alternating direction."""
    out = []
    for i, (a, b) in enumerate(field_segments(layout.n, layout.cell, layout.field_origin)):
        if i % 2:
            a, b = b, a
        out.append(Stroke(np.stack([a, b]), "pen", f"field line {i + 1}"))
    return out


def x_strokes(layout: BoardLayout, row: int, col: int, size_ratio: float | None = None) -> list[Stroke]:
    """An X in cell ``(row, col)``: top-left to bottom-right, then top-right to bottom-left."""
    c = layout.cell_centre(row, col)
    m = layout.x_margin_ratio if size_ratio is None else 0.5 * (1.0 - size_ratio)
    h = layout.cell * (0.5 - m)
    return [Stroke(np.array([c + (-h, h), c + (h, -h)]), "pen", f"X ({row},{col}) 1"),
            Stroke(np.array([c + (h, h), c + (-h, -h)]), "pen", f"X ({row},{col}) 2")]


def _circle(centre: np.ndarray, radius: float, overrun_deg: float = 8.0, step_cm: float = 0.05) -> np.ndarray:
    sweep = 2 * math.pi + math.radians(overrun_deg)
    k = max(24, int(math.ceil(sweep * radius / step_cm)))
    a = math.pi / 2 + np.linspace(0.0, sweep, k + 1)  # from the top, counter-clockwise
    return centre + radius * np.stack([np.cos(a), np.sin(a)], axis=1)


def o_strokes(layout: BoardLayout, row: int, col: int, radius_cm: float | None = None) -> list[Stroke]:
    """An O in cell ``(row, col)``: one circle from its top, running 8 deg past the start."""
    r = layout.o_radius_ratio * layout.cell if radius_cm is None else float(radius_cm)
    if not 0 < r < 0.5 * layout.cell:
        raise ValueError(f"O radius {r} cm; expected 0 < r < half a cell ({0.5 * layout.cell} cm)")
    return [Stroke(_circle(layout.cell_centre(row, col), r), "pen", f"O ({row},{col})")]


def erase_strokes(layout: BoardLayout, spec: DrawingSpec, margin_cm: float = 0.6,
                  region: tuple[float, float, float, float] | None = None) -> list[Stroke]:
    """Sponge passes along y over ``region = (x0, y0, x1, y1)`` canvas cm (default: the field
    plus ``margin_cm``), ``pass_step_cm`` apart, back and forth in one continuous wipe."""
    if region is None:
        x0, y0 = np.asarray(layout.field_origin) - margin_cm
        x1, y1 = np.asarray(layout.field_origin) + layout.side + margin_cm
    else:
        x0, y0, x1, y1 = map(float, region)
    half = 0.5 * spec.sponge_width_cm
    if spec.pass_step_cm > spec.sponge_width_cm:
        raise ValueError(f"sponge passes {spec.pass_step_cm} cm apart leave gaps with a "
                         f"{spec.sponge_width_cm} cm sponge; expected pass_step_cm <= width_cm")
    # passes from the left edge + half a sponge to the right edge - half, evenly spread
    span = max(0.0, (x1 - x0) - 2 * half)
    k = int(math.ceil(span / spec.pass_step_cm - 1e-9)) + 1
    xs = np.linspace(x0 + half, x1 - half, k) if k > 1 else np.array([0.5 * (x0 + x1)])
    ya, yb = y0 + 0.3 * half, y1 - 0.3 * half  # the sponge's round footprint reaches the ends
    pts = []
    for i, x in enumerate(xs):
        pts += [(x, ya), (x, yb)] if i % 2 == 0 else [(x, yb), (x, ya)]
    return [Stroke(np.array(pts), "sponge", "erase")]


def sine_stroke(centre: Sequence[float], length_cm: float = 10.0, peak_to_peak_cm: float = 4.0,
                periods: float = 2.0, step_cm: float = 0.05) -> Stroke:
    """A sine wave along x about ``centre`` (canvas cm); the thesis's amplitude is peak to
    peak (its GUI's "magnitude"), 4 cm in its drawing (2 cm amplitude)."""
    if length_cm <= 0 or periods <= 0:
        raise ValueError(f"sine of length {length_cm} cm and {periods} periods; expected both > 0")
    k = max(50, int(math.ceil(length_cm * (1 + peak_to_peak_cm) / step_cm)))
    x = np.linspace(-0.5 * length_cm, 0.5 * length_cm, k + 1)
    y = 0.5 * peak_to_peak_cm * np.sin(2 * math.pi * periods * (x / length_cm + 0.5))
    return Stroke(np.stack([x + centre[0], y + centre[1]], 1), "pen", "sine")


def parallel_lines(centre: Sequence[float], length_cm: float = 10.0, spacing_cm: float = 5.0) -> list[Stroke]:
    """Two lines parallel to x, ``spacing_cm`` apart about ``centre`` (thesis fig. 3.19: 5 cm)."""
    c = np.asarray(centre, float)
    h = 0.5 * length_cm
    return [Stroke(np.array([c + (-h, 0.5 * spacing_cm), c + (h, 0.5 * spacing_cm)]), "pen", "line 1"),
            Stroke(np.array([c + (h, -0.5 * spacing_cm), c + (-h, -0.5 * spacing_cm)]), "pen", "line 2")]


# ------------------------------------------------------------------ timing
@dataclass
class Trajectory:
    """Pen poses sampled every ``dt`` s: ``pose (T, 4)`` arm-frame ``(x, y, z, phi)`` (cm, rad),
    ``tool (T,)`` which tool is meant to touch (0 none, 1 pen, 2 sponge), ``stroke (T,)`` the
    index of the stroke being drawn (-1 while travelling), ``hold (T,)`` True where the pose
    is held still (a dwell: where static errors are measured)."""

    dt: float
    pose: np.ndarray
    tool: np.ndarray
    stroke: np.ndarray
    hold: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    def __post_init__(self) -> None:
        if len(self.hold) != len(self.pose):
            self.hold = np.zeros(len(self.pose), bool)

    def __len__(self) -> int:
        return len(self.pose)

    @property
    def duration_s(self) -> float:
        return len(self.pose) * self.dt

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.pose)) * self.dt

    @staticmethod
    def concat(parts: Sequence[Trajectory]) -> Trajectory:
        parts = [p for p in parts if len(p)]
        if not parts:
            raise ValueError("no trajectory parts to join")
        return Trajectory(parts[0].dt, np.concatenate([p.pose for p in parts]),
                          np.concatenate([p.tool for p in parts]), np.concatenate([p.stroke for p in parts]),
                          np.concatenate([p.hold for p in parts]))


def _profile(length: float, vmax: float, accel: float, dt: float) -> np.ndarray:
    """Arc-length samples ``s(t)`` (excluding 0, ending exactly at ``length``) of a
    trapezoidal speed profile."""
    if length <= 1e-12:
        return np.zeros(0)
    t_acc = vmax / accel
    if accel * t_acc * t_acc >= length:  # triangle: never reaches vmax
        t_acc = math.sqrt(length / accel)
        vmax = accel * t_acc
        t_flat = 0.0
    else:
        t_flat = (length - accel * t_acc * t_acc) / vmax
    total = 2 * t_acc + t_flat
    n = max(1, int(math.ceil(total / dt)))
    t = np.arange(1, n + 1) * (total / n)
    s = np.where(
        t < t_acc, 0.5 * accel * t * t,
        np.where(t < t_acc + t_flat, 0.5 * accel * t_acc * t_acc + vmax * (t - t_acc),
                 length - 0.5 * accel * np.square(np.maximum(total - t, 0.0))))
    s[-1] = length
    return s


def _move(path: np.ndarray, vmax: float, accel: float, dt: float) -> np.ndarray:
    """Samples ``(M, 4)`` along a polyline of poses at a trapezoidal speed."""
    d = np.diff(path, axis=0)
    seg = np.sqrt(np.sum(d[:, :3] ** 2, axis=1) + (_PHI_ARC_CM * d[:, 3]) ** 2)
    s_knots = np.concatenate([[0.0], np.cumsum(seg)])
    s = _profile(float(s_knots[-1]), vmax, accel, dt)
    if not len(s):
        return np.zeros((0, 4))
    return np.stack([np.interp(s, s_knots, path[:, i]) for i in range(4)], axis=1)


def hold_points(points: Sequence[Sequence[float]], hold_s: float, dt: float, speed: float, accel: float,
                start: Sequence[float]) -> Trajectory:
    """Move from pose ``start`` through each pose of ``points`` (arm frame ``(x, y, z, phi)``),
    holding each for ``hold_s`` (the precision stairs)."""
    cur = np.asarray(start, float)
    parts = []
    n_hold = max(1, int(round(hold_s / dt)))
    for p in points:
        p = np.asarray(p, float)
        m = _move(np.stack([cur, p]), speed, accel, dt)
        parts.append(Trajectory(dt, m, np.zeros(len(m), np.int8), np.full(len(m), -1, np.int16)))
        parts.append(Trajectory(dt, np.repeat(p[None], n_hold, 0), np.zeros(n_hold, np.int8),
                                np.full(n_hold, -1, np.int16), np.ones(n_hold, bool)))
        cur = p
    return Trajectory.concat(parts)


def plan(strokes: Sequence[Stroke], layout: BoardLayout, spec: DrawingSpec, dt: float,
         start: Sequence[float], speed_cm_s: float | None = None, end: Sequence[float] | None = None
         ) -> Trajectory:
    """Time a list of strokes into a :class:`Trajectory` (arm frame).

    From pose ``start`` (arm ``(x, y, z, phi)``): for each stroke, travel with the tool lifted
    to above its first point, lower it to ``press_cm`` below the board (the pen holder's
    spring takes the rest), dwell ``settle_s``, draw at ``speed_cm_s`` (default: the
    configured default level), dwell, lift. A sponge stroke first turns the pen to
    ``phi = 90 deg`` (the sponge's face is ``sponge_offset_cm`` below the tool axis); tools
    turn ``turn_height_cm`` above the end pose (the park, well inside the workspace), where
    the turn needs no change of IK branch.
    Ends at ``end`` (default: back at ``start``).
    """
    v = spec.speed() if speed_cm_s is None else float(speed_cm_s)
    if not v > 0:
        raise ValueError(f"drawing speed {speed_cm_s!r} cm/s; expected > 0")
    cur = np.asarray(start, dtype=np.float64).copy()
    parts: list[Trajectory] = []
    n_settle = int(round(spec.settle_s / dt))

    fin = np.asarray(start if end is None else end, dtype=np.float64)

    def add(path: np.ndarray, speed: float, tool: int, idx: int) -> None:
        nonlocal cur
        m = _move(np.vstack([cur[None], path]), speed, spec.accel, dt)
        if len(m):
            parts.append(Trajectory(dt, m, np.full(len(m), tool, np.int8), np.full(len(m), idx, np.int16)))
            cur = m[-1].copy()

    def turn(phi: float) -> None:  # lift, go over the end pose (the park), turn the tool there
        z_safe = max(cur[2], spec.turn_height_cm)
        add(np.array([[cur[0], cur[1], z_safe, cur[3]], [fin[0], fin[1], z_safe, cur[3]]]), spec.travel_speed,
            TOOL_NONE, -1)
        add(np.array([[fin[0], fin[1], z_safe, phi]]), spec.travel_speed, TOOL_NONE, -1)

    def dwell(tool: int, idx: int) -> None:
        if n_settle:
            parts.append(Trajectory(dt, np.repeat(cur[None], n_settle, 0), np.full(n_settle, tool, np.int8),
                                    np.full(n_settle, idx, np.int16), np.ones(n_settle, bool)))

    for i, st in enumerate(strokes):
        sponge = st.tool == "sponge"
        phi = spec.sponge_phi if sponge else spec.pen_phi
        z_touch = (spec.sponge_offset_cm - spec.sponge_press_cm) if sponge else -spec.press_cm
        z_up = (spec.sponge_offset_cm if sponge else 0.0) + spec.lift_cm
        pts = layout.to_arm(st.points)
        tool = TOOL_SPONGE if sponge else TOOL_PEN
        if cur[2] < z_up - 1e-9:  # lift first
            add(np.array([[cur[0], cur[1], z_up, cur[3]]]), spec.travel_speed, TOOL_NONE, -1)
        if abs(cur[3] - phi) > 1e-9:
            turn(phi)
        add(np.array([[pts[0, 0], pts[0, 1], z_up, phi]]), spec.travel_speed, TOOL_NONE, -1)  # lifted, straight
        add(np.array([[pts[0, 0], pts[0, 1], z_touch, phi]]), min(v, spec.travel_speed), tool, i)
        dwell(tool, i)
        add(np.column_stack([pts, np.full(len(pts), z_touch), np.full(len(pts), phi)]), v, tool, i)
        dwell(tool, i)
        add(np.array([[cur[0], cur[1], z_up, phi]]), spec.travel_speed, TOOL_NONE, -1)
    if abs(cur[3] - fin[3]) > 1e-9:
        turn(fin[3])
    add(np.array([[fin[0], fin[1], max(cur[2], fin[2]), fin[3]], fin]), spec.travel_speed, TOOL_NONE, -1)
    return Trajectory.concat(parts) if parts else Trajectory(dt, cur[None].copy(), np.zeros(1, np.int8),
                                                            np.full(1, -1, np.int16))
