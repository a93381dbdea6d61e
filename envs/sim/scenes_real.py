"""Real-like photos of hand-drawn 3 x 3 boards: the conditions real phone pictures show.

The ``"hard"`` scenes of :mod:`~kinegym.envs.sim.scenes` draw a field of equal cells with
straight (if wobbly) lines on a clean page. Real photos of a person's board break more
than that (issue 18 lists what a held-out set of real photos holds), so
:func:`real_like_scene` draws, each with its own probability:

* **Surfaces**: white paper, a whiteboard, **graph paper** whose rules can be as dark as
  the pen (with darker major rules), ruled notebook paper with a margin line.
* **Pens**: thick black marker, **thin pale ballpoint**, light whiteboard markers (green,
  teal, red, blue), a very faint pen; the marks in the same pen or another one.
* **The '#'**: four hand-drawn lines, **wavy** and **converging** (each turned a few
  degrees), some **double-stroked**, overshooting their crossings by a random amount, so
  the inner cells are **unequal** and the **outer cells larger** than the inner ones.
* **Marks** that touch the lines or spill over them, **lopsided X** whose strokes cross
  off-centre, **X gone over** two to four times, some passes in loops (a real whiteboard X
  drawn so), ovals that do not close.
* **Ghosts**: an erased earlier '#' and erased marks still faintly there.
* **Clutter**: the **page edge** and the table, a **spiral binding**, a **pen** lying on the
  page, a **second partial grid** beside the board, highlighter scribbles.
* **Light**: a gradient, a **hard-edged shadow** (a hand or a phone), a **coloured light
  spot**, **structured reflections** on whiteboards (a window's bright panes).
* **Camera**: tilt up to 35 deg, the board turned up to 38 deg either way, **portrait or
  landscape** frames **from 520 to 4,000 px** wide, the grid sometimes **cut off** by the
  frame edge (every cell still in view), blur, noise and JPEG scaled to the resolution.

Truth is the cells as drawn (row 0 at the top of the board as it lies after undoing its
turn, which stays under 45 deg). Seeded: the same seed gives the same photo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from kinegym.envs.game import EMPTY, Game, X

from .board import PAPERS, BoardCanvas, Pen, draw_graph_paper, hand_line, hand_o, scribble
from .camera import Camera, CameraSpec, Photo
from .scenes import random_position

__all__ = ["RealLikeScene", "real_like_scene", "WIDTHS"]

#: Photo widths (px) a real-like scene is taken at, and how often (phones, webcams, scans).
WIDTHS = ((520, 0.12), (640, 0.2), (800, 0.16), (960, 0.16), (1280, 0.12), (1600, 0.08), (2048, 0.06),
          (3000, 0.05), (4000, 0.05))

_INKS = {  # RGB of a full stroke, width range cm, opacity range
    "marker": ((25, 25, 35), (0.18, 0.35), (0.9, 1.0)),
    "ballpoint": ((40, 60, 160), (0.04, 0.08), (0.35, 0.75)),
    "green": ((40, 150, 80), (0.15, 0.3), (0.4, 0.8)),
    "teal": ((30, 140, 150), (0.15, 0.3), (0.4, 0.8)),
    "red": ((200, 45, 50), (0.15, 0.3), (0.5, 0.9)),
    "blue": ((30, 70, 180), (0.12, 0.3), (0.5, 0.95)),
    "pencil": ((90, 90, 95), (0.05, 0.1), (0.3, 0.6)),
    "faint": ((110, 140, 200), (0.06, 0.15), (0.25, 0.4)),
}
_INK_P = {"marker": 0.24, "ballpoint": 0.2, "green": 0.1, "teal": 0.1, "red": 0.08, "blue": 0.14,
          "pencil": 0.06, "faint": 0.08}


@dataclass
class RealLikeScene:
    """A real-like photo and its truth: ``cells`` (3 x 3 of 0 empty, 1 X, 2 O, row 0 on
    top), ``centres_px`` (3 x 3 x 2, each cell's centre in the photo), the ``photo`` and
    ``notes`` (which conditions were drawn)."""

    cells: np.ndarray
    centres_px: np.ndarray
    photo: Photo
    notes: dict[str, object]

    @property
    def image(self) -> np.ndarray:
        return self.photo.image

    def text(self) -> str:
        """The truth in the game's text form, e.g. ``"X..|.O.|..."``."""
        return "|".join("".join(".XO"[int(v)] for v in row) for row in self.cells)


def _pen(rng: np.random.Generator, kind: str | None = None) -> tuple[str, Pen]:
    kind = kind or str(rng.choice(list(_INK_P), p=list(_INK_P.values())))
    colour, width, opacity = _INKS[kind]
    jitter = rng.integers(-15, 16, 3)
    rgb = tuple(int(np.clip(c + j, 0, 255)) for c, j in zip(colour, jitter))
    return kind, Pen(rgb, float(rng.uniform(*width)), float(rng.uniform(*opacity)))


def _turned(a: np.ndarray, b: np.ndarray, deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The segment a-b turned ``deg`` about its midpoint."""
    m, t = (a + b) / 2, math.radians(deg)
    R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    return m + (a - m) @ R.T, m + (b - m) @ R.T


def _hash(canvas: BoardCanvas, origin: np.ndarray, inner: np.ndarray, outer: np.ndarray, pen: Pen,
          rng: np.random.Generator, converge_deg: float, wobble: float, double: float) -> None:
    """Four hand-drawn lines: the inner cells ``inner`` (widths of the middle column and
    row), the outer bands ``outer`` (left, right, bottom, top: how far the lines run past
    the crossings), ``origin`` the lower-left crossing."""
    x1, y1 = origin
    x2, y2 = x1 + inner[0], y1 + inner[1]
    left, right, bottom, top = outer
    segs = [(np.array([x, y1 - bottom]), np.array([x, y2 + top])) for x in (x1, x2)]
    segs += [(np.array([x1 - left, y]), np.array([x2 + right, y])) for y in (y1, y2)]
    for a, b in segs:
        a, b = _turned(a, b, float(rng.normal(0, converge_deg)))
        strokes = [hand_line(a, b, rng, wobble, 32)]
        if rng.random() < double:  # gone over again, a little apart
            off = rng.normal(0, 0.06, 2)
            strokes.append(hand_line(a + off + rng.normal(0, 0.2, 2), b + off + rng.normal(0, 0.2, 2), rng, wobble, 32))
        for s in strokes:
            canvas.stroke(s, pen)


def _lopsided_x(centre: np.ndarray, size: float, rng: np.random.Generator, wobble: float) -> list[np.ndarray]:
    """Two strokes of an X crossing anywhere between a quarter and three quarters along each."""
    out = []
    tilt = rng.normal(0, math.radians(10))
    for base in (math.pi / 4, 3 * math.pi / 4):
        ang = base + tilt + rng.normal(0, math.radians(8))
        u = np.array([math.cos(ang), math.sin(ang)])
        length = size * rng.uniform(0.8, 1.25)
        f = rng.uniform(0.25, 0.75) if rng.random() < 0.5 else rng.uniform(0.42, 0.58)
        out.append(hand_line(centre - f * length * u, centre + (1 - f) * length * u, rng, wobble * size))
    return out


def _gone_over(strokes: list[np.ndarray], size: float, rng: np.random.Generator) -> list[np.ndarray]:
    """The strokes of a mark and 1-3 more passes over each, as a person goes over an X again:
    each pass from near the stroke's ends, some in loops (a scribble along the stroke)."""
    out = list(strokes)
    for s in strokes:
        a, b = s[0], s[-1]
        for _ in range(int(rng.integers(1, 4))):
            pa, pb = a + rng.normal(0, 0.05 * size, 2), b + rng.normal(0, 0.05 * size, 2)
            if rng.random() < 0.5:
                out.append(hand_line(pa, pb, rng, 0.05 * size))
            else:  # loops: a circle of the pen's sweep carried along the stroke
                t = np.linspace(0.0, 1.0, 60)[:, None]
                turns, radius = float(rng.uniform(3.0, 6.0)), float(rng.uniform(0.03, 0.07)) * size
                phase = 2 * math.pi * turns * t
                out.append(pa + t * (pb - pa) + radius * np.hstack([np.cos(phase), np.sin(phase)]))
    return out


def _clutter(canvas: BoardCanvas, rng: np.random.Generator, box: tuple[float, float, float, float],
             grid_pen: Pen, notes: dict[str, object]) -> None:
    """Things people leave in view: a pen on the page, highlighter, a second partial grid,
    a spiral binding."""
    x0, y0, x1, y1 = box
    W, Hh = canvas.width_cm, canvas.height_cm
    if rng.random() < 0.2:  # a pen lying on the page, clear of the board
        side = rng.integers(4)
        y = rng.uniform(0.5, max(0.6, y0 - 1.0)) if side == 0 else rng.uniform(min(y1 + 1.0, Hh - 0.6), Hh - 0.5)
        ang = rng.normal(0, 0.15)
        a = np.array([rng.uniform(0, W / 3), y])
        b = a + rng.uniform(10, 14) * np.array([math.cos(ang), math.sin(ang)])
        body = Pen(tuple(int(v) for v in rng.integers(10, 200, 3)), float(rng.uniform(0.8, 1.2)), 1.0)
        canvas.stroke(np.stack([a, b]), body)
        notes["pen_in_view"] = True
    if rng.random() < 0.25:
        for _ in range(int(rng.integers(1, 3))):
            hl = Pen(((250, 240, 70), (120, 235, 90), (250, 140, 200))[int(rng.integers(3))], 0.6, 0.55)
            at = np.array([rng.uniform(0, W), rng.uniform(0, Hh)])
            scribble(canvas, at, float(rng.uniform(3, 8)), rng, hl)
        notes["highlighter"] = True
    if rng.random() < 0.2:  # a second grid beside the board, partly in view
        w = x1 - x0
        dx = (w + rng.uniform(1.5, 4.0)) * (1 if rng.random() < 0.5 else -1)
        origin = np.array([x0 + dx + w / 3, y0 + (y1 - y0) / 3]) + rng.normal(0, 1.0, 2)
        _hash(canvas, origin, np.full(2, w / 3), np.full(4, w / 3), grid_pen, rng, 2.0, 0.05, 0.0)
        notes["second_grid"] = True
    if rng.random() < 0.15:  # a spiral binding along the left or right page edge
        x = 0.8 if rng.random() < 0.5 else W - 0.8
        ring = Pen((70, 70, 80), 0.12, 1.0)
        for y in np.arange(0.6, Hh, 0.85):
            canvas.stroke(np.array([[x - 0.7, y], [x + 0.3, y + 0.15]]), ring)
            canvas.stroke(np.array([[x, y]]), Pen((30, 30, 30), 0.35, 1.0))
        notes["binding"] = True


def _surface(canvas: BoardCanvas, kind: str, rng: np.random.Generator, notes: dict[str, object]) -> None:
    if kind == "graph":
        spacing = float(rng.choice([0.5, 0.5, 1.0]))
        rule = Pen(tuple(int(v) for v in rng.integers([60, 110, 130], [150, 190, 220])),
                   float(rng.uniform(0.02, 0.05)), float(rng.uniform(0.4, 1.0)))
        draw_graph_paper(canvas, spacing, rule)
        if rng.random() < 0.6:  # darker major rules every 5
            draw_graph_paper(canvas, 5 * spacing, rule.with_(width_cm=rule.width_cm * 1.8))
        notes["rules"] = rule
    elif kind == "notebook":
        rule = Pen((120, 160, 210), float(rng.uniform(0.02, 0.04)), float(rng.uniform(0.5, 0.9)))
        lines = [np.array([[0.0, y], [canvas.width_cm, y]]) for y in np.arange(1.0, canvas.height_cm, 0.8)]
        canvas.strokes(lines, rule)
        x = rng.uniform(1.5, 3.0)
        canvas.stroke(np.array([[x, 0.0], [x, canvas.height_cm]]), Pen((210, 80, 90), 0.03, 0.8))


def _light(img: np.ndarray, rng: np.random.Generator, whiteboard: bool, notes: dict[str, object]) -> np.ndarray:
    """Hard shadows, coloured light spots and window reflections on a float RGB image."""
    h, w = img.shape[:2]
    if rng.random() < 0.3:  # a hard-edged shadow: a hand, a phone, an arm across a corner
        mask = np.zeros((h, w), np.float32)
        c = np.array([rng.uniform(-0.2, 1.2) * w, rng.uniform(-0.2, 1.2) * h])
        ang = rng.uniform(0, math.pi)
        u, v = np.array([math.cos(ang), math.sin(ang)]), np.array([-math.sin(ang), math.cos(ang)])
        a, b = rng.uniform(0.3, 0.8) * w, rng.uniform(0.08, 0.3) * w
        quad = np.array([c - a * u - b * v, c + a * u - b * v, c + a * u + b * v, c - a * u + b * v])
        cv2.fillPoly(mask, [np.rint(quad).astype(np.int32)], 1.0, cv2.LINE_AA)
        mask = cv2.GaussianBlur(mask, (0, 0), max(0.5, rng.uniform(0.002, 0.012) * w))
        notes["hard_shadow"] = strength = float(rng.uniform(0.25, 0.6))
        img = img * (1.0 - strength * mask)[..., None]
    yy, xx = np.ogrid[0:h, 0:w]
    yy, xx = yy.astype(np.float32), xx.astype(np.float32)
    if rng.random() < 0.2:  # a coloured light spot (a red LED, a warm lamp)
        gx, gy, gs = rng.uniform(0.1, 0.9) * w, rng.uniform(0.1, 0.9) * h, rng.uniform(0.04, 0.15) * w
        colour = np.array(((90, -10, -20), (70, 40, -30), (-20, 20, 80))[int(rng.integers(3))], np.float32)
        spot = np.exp(-((xx - gx) ** 2 + (yy - gy) ** 2) / (2 * gs * gs))
        img = img + spot[..., None] * colour * float(rng.uniform(0.6, 1.2))
        notes["light_spot"] = True
    if whiteboard and rng.random() < 0.5:  # a window's reflection: bright panes with bars between
        ang = rng.uniform(0, math.pi)
        along = (xx - rng.uniform(0, w)) * math.cos(ang) + (yy - rng.uniform(0, h)) * math.sin(ang)
        across = -(xx - rng.uniform(0, w)) * math.sin(ang) + (yy - rng.uniform(0, h)) * math.cos(ang)
        width, length = rng.uniform(0.06, 0.2) * w, rng.uniform(0.3, 0.8) * w
        band = np.exp(-(across / width) ** 4) * np.exp(-(along / length) ** 2)
        panes = 0.75 + 0.25 * np.sign(np.sin(along * (2 * math.pi / rng.uniform(0.08, 0.2) / w)))
        img = img + (float(rng.uniform(40, 110)) * band * panes)[..., None]
        notes["reflection"] = True
    return img


def real_like_scene(seed: int | np.random.Generator | None = None, width: int | None = None) -> RealLikeScene:
    """A random real-like photo of a hand-drawn 3 x 3 board (see the module docstring).

    ``width`` fixes the photo's width (px); by default it is drawn from :data:`WIDTHS`.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    # marks gone over draw from their own stream (spawning draws nothing from ``rng``): every
    # other draw of a seed is what it was before they were added
    over = rng.spawn(1)[0]
    game = Game(3, 3, 3)
    cells = np.array(random_position(game, rng).cells(), dtype=np.int64)
    notes: dict[str, object] = {}
    c = float(rng.uniform(3.0, 7.0))  # the inner cell, cm
    inner = c * rng.uniform(0.8, 1.2, 2)
    outer = c * rng.uniform(0.55, 1.6, 4)  # left, right, bottom, top: the lines' overshoot
    margin = rng.uniform(1.0, 10.0, 4)  # the page beyond the grid: its edges may be in view
    surface = str(rng.choice(["paper", "whiteboard", "graph", "notebook"], p=[0.3, 0.3, 0.25, 0.15]))
    notes["surface"] = surface
    W = outer[0] + inner[0] + outer[1] + margin[0] + margin[1]
    Hh = outer[2] + inner[1] + outer[3] + margin[2] + margin[3]
    if width is None:
        width = int(rng.choice([v for v, _ in WIDTHS], p=[p for _, p in WIDTHS]))
    span = float(max(inner[0] + outer[:2].sum(), inner[1] + outer[2:].sum()))
    fill = float(rng.uniform(0.35, 0.85))  # of the frame's shorter side the grid covers
    portrait = bool(rng.random() < 0.3)
    frame = (int(width), int(round(width * 4 / 3))) if portrait else (int(width), int(round(width * 3 / 4)))
    ppc = float(np.clip(fill * min(frame) / span * 1.3, 12.0, 40.0))
    paper = PAPERS["whiteboard" if surface == "whiteboard" else str(rng.choice(["paper", "paper", "recycled"]))]
    canvas = BoardCanvas(W, Hh, ppc, paper)
    origin = np.array([margin[0] + outer[0], margin[2] + outer[2]])  # lower-left crossing
    _surface(canvas, surface, rng, notes)
    grid_kind, grid_pen = _pen(rng)
    while surface == "graph" and grid_kind in ("faint", "pencil"):  # a faint pen is lost among the rules
        grid_kind, grid_pen = _pen(rng)
    notes["grid_pen"] = grid_kind
    converge, wobble = float(rng.uniform(0.0, 4.0)), float(rng.uniform(0.02, 0.18))
    if rng.random() < 0.3 and surface in ("whiteboard", "paper"):  # an erased earlier game
        ghost = origin + rng.normal(0, 0.6 * c, 2)
        _hash(canvas, ghost, inner * rng.uniform(0.8, 1.2), outer, grid_pen.with_(opacity=1.0), rng, 3, 0.1, 0)
        for y in np.arange(0.0, Hh + 1, 2.0):
            canvas.erase(np.array([[0.0, y], [W, y]]), 2.6, float(rng.uniform(0.8, 0.95)))
        notes["ghosts"] = True
    _hash(canvas, origin, inner, outer, grid_pen, rng, converge, wobble, 0.3)
    # cell centres and sizes: inner cells between the lines, outer ones in the overshoot
    xs = [origin[0] - 0.5 * min(outer[0], 1.2 * c), origin[0] + inner[0] / 2,
          origin[0] + inner[0] + 0.5 * min(outer[1], 1.2 * c)]
    ys = [origin[1] + inner[1] + 0.5 * min(outer[3], 1.2 * c), origin[1] + inner[1] / 2,
          origin[1] - 0.5 * min(outer[2], 1.2 * c)]
    wx = [min(outer[0], 1.2 * c), inner[0], min(outer[1], 1.2 * c)]
    wy = [min(outer[3], 1.2 * c), inner[1], min(outer[2], 1.2 * c)]
    pick = rng.random()  # the marks in the grid's pen, in one other pen, or X and O in two
    mark_pens = (grid_pen,) * 2 if pick < 0.3 else (_pen(rng)[1],) * 2 if pick < 0.65 else (_pen(rng)[1], _pen(rng)[1])
    spill = float(rng.uniform(0.0, 0.2))
    centres_cm = np.zeros((3, 3, 2))
    for r in range(3):
        for k in range(3):
            cell = min(wx[k], wy[r])
            centre = np.array([xs[k], ys[r]]) + rng.normal(0, spill * cell, 2)
            centres_cm[r, k] = xs[k], ys[r]
            if cells[r, k] == EMPTY:
                continue
            size = cell * float(rng.uniform(0.45, 0.9))
            pen = mark_pens[0] if cells[r, k] == X else mark_pens[1]
            strokes = (_lopsided_x(centre, size, rng, 0.04) if cells[r, k] == X
                       else hand_o(centre, size, rng, float(rng.uniform(0.6, 1.5))))
            if cells[r, k] == X and over.random() < 0.25:
                strokes = _gone_over(strokes, size, over)
                notes["gone_over"] = True
            for s in strokes:
                canvas.stroke(s, pen)
    box = (origin[0] - outer[0], origin[1] - outer[2], origin[0] + inner[0] + outer[1], origin[1] + inner[1] + outer[3])
    _clutter(canvas, rng, box, grid_pen, notes)
    spec = CameraSpec(image_size=frame, fov_deg=60.0, distance_cm=(1.0, 1.0), tilt_deg=(0.0, 35.0),
                      roll_deg=(-38.0, 38.0), aim_jitter_cm=0.0, gradient=(0.0, 0.5), vignette=(0.0, 0.3),
                      exposure=(0.75, 1.1), white_balance=0.08, blur_px=(0.0, 0.0), noise=(0.0, 0.0),
                      jpeg_quality=(100.0, 100.0))
    view = 2 * math.tan(math.radians(30)) * min(frame) / frame[0]  # cm of the shorter side per cm away
    cam = Camera(replace(spec, distance_cm=(span / (fill * view),) * 2), rng)
    centre = np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])
    corners = np.array([[box[0], box[1]], [box[2], box[1]], [box[2], box[3]], [box[0], box[3]]])
    w, h = frame
    cut = rng.random() < 0.2
    fallback, whole = None, False
    for _ in range(60):  # every cell in view; with ``cut`` the lines run out of the frame
        pose = cam.pose(centre + (rng.normal(0, 0.6 * c, 2) if cut else 0.0))
        project = Photo(np.zeros((1, 1, 3), np.uint8), pose[0]).project
        cpx = project(centres_cm)
        reach = np.linalg.norm(project(centres_cm + np.array([0.3 * c, 0.0])) - cpx, axis=-1)[..., None]
        if not np.all((cpx - reach > 0) & (cpx + reach < [w, h])):
            continue
        gpx = project(corners)
        whole = bool(np.all((gpx > 0) & (gpx < [w, h])))
        fallback = fallback or (pose, cpx, whole)
        if whole != cut:
            break
    else:
        pose, cpx, whole = fallback if fallback is not None else (pose, cpx, whole)
    photo = cam.photograph(canvas, pose=pose)
    notes["cut_off"] = not whole
    img = _light(photo.image.astype(np.float32), rng, surface == "whiteboard", notes)
    scale = w / 640.0
    img = cv2.GaussianBlur(img, (0, 0), float(rng.uniform(0.4, 1.4)) * max(1.0, 0.7 * scale))
    noise = float(rng.uniform(1.0, 6.0))
    img += noise * rng.standard_normal(img.shape, dtype=np.float32)
    out = np.clip(img + 0.5, 0, 255).astype(np.uint8)
    q = int(rng.integers(50, 96))
    ok, buf = cv2.imencode(".jpg", out[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, q])
    if ok:
        out = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].copy()
    notes.update(width=w, height=h, jpeg_quality=q,
                 mark_pens="grid" if pick < 0.3 else "one" if pick < 0.65 else "two")
    return RealLikeScene(cells, cpx, Photo(out, photo.homography, {**photo.settings, **notes}), notes)
