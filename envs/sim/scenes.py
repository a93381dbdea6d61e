"""Random photographed boards with their truth, for the reader's tests and benchmark.

:func:`random_scene` draws a legal game position on a :class:`BoardCanvas` and
photographs it. Difficulty ``"default"`` is the lab set-up (arm-drawn field, black pen,
camera on a stand); ``"hard"`` is what people do with phones: hand-drawn fields, any pen
colour for either symbol, thin and thick pens, paper, whiteboards and graph paper,
printed boards with some of the outer frame missing, highlighter scribbles, faint ghosts
of an erased earlier game, and the ``"hard"`` camera (tilt up to 35 deg, board turned up
to 30 deg, shadows, glare, blur, noise, JPEG). Seeded: the same seed gives the same scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinegym.envs.game import EMPTY, Board, Game, X

from .board import (
    PAPERS,
    PENS,
    BoardCanvas,
    Pen,
    cell_centre,
    draw_graph_paper,
    field_segments,
    hand_line,
    hand_o,
    hand_x,
    scribble,
)
from .camera import Camera, Photo

__all__ = ["Scene", "random_position", "draw_field", "draw_mark", "random_scene"]


@dataclass
class Scene:
    """A drawn board and its photo: ``cells`` (n x n of 0 empty, 1 X, 2 O, row 0 on top),
    the field's ``origin_cm`` (lower-left corner) and ``cell_cm``, the canvas and the photo."""

    cells: np.ndarray
    n: int
    cell_cm: float
    origin_cm: np.ndarray
    canvas: BoardCanvas
    photo: Photo
    notes: dict[str, object]

    def corners_px(self) -> np.ndarray:
        """The field's four corners in the photo (px): top-left, top-right, bottom-right, bottom-left."""
        x0, y0 = self.origin_cm
        s = self.n * self.cell_cm
        return self.photo.project(np.array([[x0, y0 + s], [x0 + s, y0 + s], [x0 + s, y0], [x0, y0]]))


def random_position(game: Game, rng: np.random.Generator, stones: int | None = None) -> Board:
    """A legal, unfinished position reached by random play (``stones`` moves, default random)."""
    for _ in range(100):
        target = int(rng.integers(0, game.n_cells)) if stones is None else stones
        b = game.empty()
        for _ in range(target):
            moves = b.legal_moves()
            if not moves:
                break
            b = b.play(int(rng.choice(moves)))
            if b.is_over:
                break
        if not b.is_over or stones is None:
            return b
    return b


def draw_field(canvas: BoardCanvas, n: int, cell_cm: float, origin_cm: object, pen: Pen,
               rng: np.random.Generator | None = None, frame: bool = False, missing_sides: int = 0,
               wobble_cm: float = 0.0) -> None:
    """The field's lines; ``rng`` + ``wobble_cm`` make them hand-drawn, ``frame`` adds a
    border of which ``missing_sides`` (0..3) are left out."""
    segs = field_segments(n, cell_cm, origin_cm, frame=frame)
    if frame and missing_sides:
        border = [0, n, n + 1, 2 * n + 1]  # left, right, bottom, top in field_segments' order
        drop = set((rng or np.random.default_rng(0)).choice(border, missing_sides, replace=False).tolist())
        segs = [s for i, s in enumerate(segs) if i not in drop]
    for a, b in segs:
        if rng is not None and wobble_cm > 0:
            over = rng.normal(0, 0.08 * cell_cm, 2)  # people overshoot and stop short
            d = (b - a) / np.linalg.norm(b - a)
            canvas.stroke(hand_line(a - over[0] * d, b + over[1] * d, rng, wobble_cm), pen)
        else:
            canvas.stroke(np.stack([a, b]), pen)


def draw_mark(canvas: BoardCanvas, symbol: int, centre: object, size_cm: float, pen: Pen,
              rng: np.random.Generator, jitter: float = 1.0) -> None:
    """A hand-drawn X or O about ``size_cm`` across, centred near ``centre`` (cm)."""
    strokes = hand_x(centre, size_cm, rng, jitter) if symbol == X else hand_o(centre, size_cm, rng, jitter)
    for s in strokes:
        canvas.stroke(s, pen)


def _random_pen(rng: np.random.Generator, width: tuple[float, float]) -> Pen:
    name = str(rng.choice(["black", "black", "blue", "blue", "green", "red", "purple"]))
    return PENS[name].with_(width_cm=float(rng.uniform(*width)))


def random_scene(seed: int | np.random.Generator | None = None, n: int = 5, cell_cm: float | None = None,
                 difficulty: str = "hard", board: Board | None = None, camera: Camera | None = None,
                 distractors: bool | None = None) -> Scene:
    """A random board, drawn and photographed, with its truth (see the module docstring).

    ``distractors`` (default: on for ``"hard"``) adds graph paper, ghosts of an erased game
    and highlighter scribbles to a hard scene.
    """
    if difficulty not in ("ideal", "default", "hard"):
        raise ValueError(f"difficulty {difficulty!r}; expected ideal, default or hard")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    game = Game(n, n, 3 if n == 3 else 4)
    board = board if board is not None else random_position(game, rng)
    cells = np.array(board.cells(), dtype=np.int64)
    cell = float(cell_cm if cell_cm is not None else (3.0 if n == 5 else 5.0))
    side = n * cell
    margin = 4.0
    hard = difficulty == "hard"
    distract = hard if distractors is None else bool(distractors)
    paper = PAPERS[str(rng.choice(list(PAPERS)))] if hard else PAPERS["whiteboard"]
    canvas = BoardCanvas(side + 2 * margin, side + 2 * margin, 16.0, paper)
    origin = np.array([margin, margin])
    notes: dict[str, object] = {}
    if distract and rng.random() < 0.2:
        draw_graph_paper(canvas, float(rng.choice([0.5, 1.0])))
        notes["graph_paper"] = True
    if distract and rng.random() < 0.3:  # ghosts of an earlier game, wiped off imperfectly
        ghost = random_position(game, rng)
        for r, c in zip(*np.nonzero(np.array(ghost.cells()))):
            centre = cell_centre(int(r), int(c), n, cell, origin) + rng.normal(0, 0.3 * cell, 2)
            draw_mark(canvas, int(ghost.cells()[r][c]), centre, 0.6 * cell, PENS["black"], rng)
        for y in np.arange(0.0, canvas.height_cm + 1, 2.0):
            canvas.erase(np.array([[0.0, y], [canvas.width_cm, y]]), 2.6, float(rng.uniform(0.88, 0.96)))
        notes["ghosts"] = True
    if hard:
        field_pen = _random_pen(rng, (0.1, 0.3))
        frame = bool(rng.random() < 0.3)
        missing = int(rng.integers(0, 3)) if frame else 0
        wobble = float(rng.uniform(0.02, 0.12)) if rng.random() < 0.7 else 0.0
        draw_field(canvas, n, cell, origin, field_pen, rng, frame=frame, missing_sides=missing, wobble_cm=wobble)
        notes.update(frame=frame, missing_sides=missing, field_pen=field_pen)
        x_pen = _random_pen(rng, (0.1, 0.3))
        o_pen = x_pen if rng.random() < 0.5 else _random_pen(rng, (0.1, 0.3))
        jitter = float(rng.uniform(0.5, 1.5))
    else:
        field_pen = PENS["black"]
        draw_field(canvas, n, cell, origin, field_pen)
        x_pen = o_pen = PENS["black"]
        jitter = 0.7
    for r in range(n):
        for c in range(n):
            if cells[r, c] == EMPTY:
                continue
            size = cell * float(rng.uniform(0.45, 0.7))
            draw_mark(canvas, int(cells[r, c]), cell_centre(r, c, n, cell, origin), size,
                      x_pen if cells[r, c] == X else o_pen, rng, jitter)
    if distract and rng.random() < 0.3:
        for _ in range(int(rng.integers(1, 3))):
            scribble(canvas, origin + rng.uniform(0, side, 2), float(rng.uniform(0.5, 1.5) * cell), rng)
        notes["highlighter"] = True
    cam = camera or Camera(difficulty, rng)
    corners = np.array([[0, 0], [side, 0], [side, side], [0, side]]) + origin
    w, h = cam.spec.image_size
    for _ in range(20):  # a photographer keeps the whole field in the picture
        photo = cam.photograph(canvas, origin + side / 2)
        px = photo.project(corners)
        if np.all((px > [0.03 * w, 0.03 * h]) & (px < [0.97 * w, 0.97 * h])):
            break
    return Scene(cells, n, cell, origin, canvas, photo, notes)

