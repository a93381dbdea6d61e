"""Held-out conditions laid over the 15 real photos of ``tests/data/real``: how phone photos the
reader has never seen differ from them (noise, keystone, blur, JPEG, shadows, light, a dark table,
a pen, a highlighter, a red light, a binding, a cut-off top, a second board, turns), and the
issue's four kinds of held-out photo as groups of those (graph paper in black marker cut off at
the top; a whiteboard in green marker with a reflection, turned; graph paper in a pale ballpoint
with ghost marks, lines gone over twice, a binding, perspective; white paper under a hand's
shadow, a red light, a highlighter, a second board). ``bench_vision.py`` reads each row
(:func:`photo_conditions`); the tests take single conditions from here too.

Every transform is ``f(img, i)`` or has the photo's index ``i`` as its seed: the same photo gets the
same condition in every run.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from kinegym.vision.board_reader import BoardReader

Condition = tuple[str, Callable[[np.ndarray, int], np.ndarray], Callable[[str], list[str]]]


def turned_whole(img: np.ndarray, deg: float) -> np.ndarray:
    """Photo ``img`` turned ``deg`` about its centre on a canvas grown so that no corner of it is lost
    (edges replicated): a held-out condition of :func:`photo_conditions`, and a real test's."""
    h, w = img.shape[:2]
    M = cv2.getRotationMatrix2D((w / 2, h / 2), deg, 1.0)
    c, s = abs(M[0, 0]), abs(M[0, 1])
    nw, nh = int(h * s + w * c), int(h * c + w * s)
    M[0, 2] += nw / 2 - w / 2
    M[1, 2] += nh / 2 - h / 2
    return cv2.warpAffine(img, M, (nw, nh), borderMode=cv2.BORDER_REPLICATE)


def on_a_dark_table(img: np.ndarray, grow: float, seed: int) -> np.ndarray:
    """Photo ``img`` lying on a dark grey table (40 grey levels) with a phone's sensor noise (3 grey
    levels), the frame ``grow`` times as large, the photo's edge blended over 8 px: a held-out
    condition of :func:`photo_conditions`, and a real test's."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    H, W = int(h * grow), int(w * grow)
    table = np.clip(np.float32(40.0) + rng.normal(0.0, 3.0, (H, W, 3)), 0, 255).astype(np.float32)
    y, x = int(rng.uniform(0.05, grow - 1.05) * h), int(rng.uniform(0.05, grow - 1.05) * w)
    page = np.zeros((H, W), np.float32)
    page[y:y + h, x:x + w] = 1.0
    page = cv2.GaussianBlur(page, (0, 0), 8.0)[..., None]
    photo = table.copy()
    photo[y:y + h, x:x + w] = img
    return (table * (1.0 - page) + photo * page).astype(np.uint8)


def under_a_hand_s_shadow(img: np.ndarray, light: float, seed: int) -> np.ndarray:
    """Photo ``img`` with a hand's soft-edged shadow rising from the bottom edge, ``light`` of the
    light left in it: a held-out condition of :func:`photo_conditions`, and a real test's."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    m = np.ones((h, w), np.float32)
    cv2.ellipse(m, (int(rng.uniform(0.2, 0.8) * w), int(1.05 * h)), (int(0.25 * w), int(0.45 * h)),
                float(rng.uniform(-30, 30)), 0, 360, light, -1)
    return np.clip(img * cv2.GaussianBlur(m, (0, 0), 6.0)[..., None], 0, 255).astype(np.uint8)


def washed_out(img: np.ndarray, contrast: float) -> np.ndarray:
    """Photo ``img`` at ``contrast`` of its contrast against white (a faint pen, or the light washing
    the photo out): a held-out condition of :func:`photo_conditions`, and real tests'."""
    return np.clip(255 - (255 - img.astype(np.float64)) * contrast, 0, 255).astype(np.uint8)


def with_a_pen_beside(img: np.ndarray, seed: int) -> np.ndarray:
    """Photo ``img`` with a dark pen lying on the page beside the board: a bar along the top or the
    bottom edge, 45 % of the photo's width long and a 45th of it thick (2.5-5 times the '#''s
    strokes in the real photos), slightly tilted: a held-out condition of :func:`photo_conditions`,
    and a real test's."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    out = img.copy()
    y, x = int(rng.choice([0.06, 0.94]) * h), int(rng.uniform(0.05, 0.4) * w)
    cv2.line(out, (x, y), (x + int(0.45 * w), y + int(rng.uniform(-0.04, 0.04) * h)), (20, 20, 30), max(6, w // 45))
    return out


def highlighted(img: np.ndarray, seed: int) -> np.ndarray:
    """Photo ``img`` with a green highlighter scribbled across the board: a zigzag a 22nd of the
    width thick, multiplied over the photo as a highlighter's dye is: a held-out condition of
    :func:`photo_conditions`."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    x0 = rng.uniform(0.1, 0.3) * w
    pts = [(int(x0 + k * 0.12 * w), int(((0.3 if k % 2 else 0.7) + rng.uniform(-0.1, 0.1)) * h)) for k in range(6)]
    m = np.zeros((h, w), np.uint8)
    cv2.polylines(m, [np.array(pts, np.int32)], False, 255, max(8, w // 22))
    dye = cv2.GaussianBlur(m, (0, 0), 1.5)[..., None].astype(np.float64) / 255
    return np.clip(img * (1 - dye * (1 - np.array([190, 255, 90]) / 255)), 0, 255).astype(np.uint8)


def red_light_spot(img: np.ndarray, seed: int, strength: float = 0.6, radius: float = 0.15) -> np.ndarray:
    """Photo ``img`` with a red light's glare on the board: the photo blended towards red
    (255, 70, 60) by ``strength`` at the spot's centre, falling off as a Gaussian ``radius`` of the
    width wide, the centre within the middle third of the photo - the lines there keep 40 % of
    their contrast: a held-out condition of :func:`photo_conditions`."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    cx, cy = rng.uniform(0.35, 0.65) * w, rng.uniform(0.35, 0.65) * h
    yy, xx = np.mgrid[0:h, 0:w]
    g = strength * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * (radius * w) ** 2))[..., None]
    return np.clip(img * (1 - g) + g * np.array([255.0, 70.0, 60.0]), 0, 255).astype(np.uint8)


def with_a_spiral_binding(img: np.ndarray, seed: int) -> np.ndarray:
    """Photo ``img`` as a notebook's page with its spiral binding along the left (even ``seed``) or
    right side, 6 % of the width in: dark wire loops every 3 % of the height, each with its punched
    hole beside it, and the cover beyond the page darker: a held-out condition of
    :func:`photo_conditions`."""
    h, w = img.shape[:2]
    out = img.copy()
    left = seed % 2 == 0
    x = int(0.06 * w) if left else int(0.94 * w)
    cover = np.s_[:, :x - int(0.02 * w)] if left else np.s_[:, x + int(0.02 * w):]
    out[cover] = (out[cover] * 0.45).astype(np.uint8)
    r, step = max(3, int(0.012 * w)), max(6, int(0.03 * h))
    hole = x + (int(2.5 * r) if left else -int(2.5 * r))
    for y in range(step // 2, h, step):
        cv2.ellipse(out, (x, y), (int(2.2 * r), r), 0, 0, 360, (35, 35, 40), max(2, w // 250), cv2.LINE_AA)
        cv2.circle(out, (hole, y), max(2, r // 2), (40, 40, 45), -1, cv2.LINE_AA)
    return out


def cut_off_at_top(img: np.ndarray, cells: float = 0.75) -> np.ndarray:
    """Photo ``img`` cut off ``cells`` of a cell above the '#''s top row line, where the column lines
    still run on: the field as read on the photo as taken (each of the 15 read right there, as
    ``tests/test_vision_real.py`` asserts): a held-out condition of :func:`photo_conditions`."""
    H = BoardReader(size=3).read(img).homography
    top = [H @ [u, 1.0 - cells, 1.0] for u in (0.0, 1.5, 3.0)]
    return np.ascontiguousarray(img[max(0, int(min(p[1] / p[2] for p in top))):])


def beside_a_second_board(img: np.ndarray) -> np.ndarray:
    """Photo ``img`` with a second, smaller board half in view beside it: the canvas grown by half its
    width, where the photo mirrored at 0.7 of its size shows its left half (the board's other
    side): a held-out condition of :func:`photo_conditions`."""
    h, w = img.shape[:2]
    other = cv2.resize(np.ascontiguousarray(img[:, ::-1]), (int(0.7 * w), int(0.7 * h)), interpolation=cv2.INTER_AREA)
    out = np.empty((h, w + w // 2, 3), np.uint8)
    out[:] = np.median(img.reshape(-1, 3), axis=0).astype(np.uint8)
    out[:, :w] = img
    y = (h - other.shape[0]) // 2
    out[y:y + other.shape[0], w:] = other[:, :w // 2]
    return out


def keystone(img: np.ndarray, top: bool, share: float = 0.1) -> np.ndarray:
    """Photo ``img`` as a camera tilted towards its top (``top``) or its left side takes it: that side
    ``2 * share`` shorter, the corners filled with the photo's border colour."""
    h, w = img.shape[:2]
    src = np.float32([[0, 0], [w, 0], [w, h], [0, h]])
    dst = src + (np.float32([[share * w, 0], [-share * w, 0], [0, 0], [0, 0]]) if top
                 else np.float32([[0, share * h], [0, 0], [0, 0], [0, -share * h]]))
    table = np.median(np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]]), axis=0)
    return cv2.warpPerspective(img, cv2.getPerspectiveTransform(src, dst), (w, h),
                               borderMode=cv2.BORDER_CONSTANT, borderValue=tuple(float(v) for v in table))


def _ink_and_page(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The photo's ink (0..1, its darkest 0.5 % at 1) and the page without it (RGB float32): the
    page's light from a closing and a wide median of the grey photo."""
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    page = cv2.dilate(grey, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (15, 15)))
    page = cv2.medianBlur(page, min(255, max(31, (img.shape[1] // 12) | 1))).astype(np.float32)
    ink = np.clip(1.0 - grey.astype(np.float32) / np.maximum(page, 1.0), 0.0, 1.0)
    ink = np.clip(ink / max(float(np.percentile(ink, 99.5)), 1e-3), 0.0, 1.0)
    bare = np.clip(img / np.maximum(1.0 - ink, 0.05)[..., None], 0.0, page[..., None] * 1.05)
    return ink, bare.astype(np.float32)


def in_another_pen(img: np.ndarray, rgb: tuple[int, int, int]) -> np.ndarray:
    """Photo ``img`` redrawn in a pen of colour ``rgb`` (the darkest strokes full, paler ones as pale
    as they were): a green or black marker, a blue ballpoint."""
    ink, bare = _ink_and_page(img)
    out = bare * (1.0 - ink[..., None] * (1.0 - np.array(rgb, np.float32) / 255))
    return np.clip(out, 0, 255).astype(np.uint8)


def on_graph_paper(img: np.ndarray, seed: int, pitch: float = 0.025, strength: float = 0.3,
                   rgb: tuple[int, int, int] = (120, 170, 220)) -> np.ndarray:
    """Photo ``img`` on graph paper: rules of colour ``rgb`` every ``pitch`` of the width (a 5 mm
    square on an A4 page filling the frame), 1.6 px wide, multiplied over the photo at ``strength``,
    square to the frame (the drawn '#' is not: the 15 boards are turned a little)."""
    h, w = img.shape[:2]
    p = pitch * w
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    ox, oy = np.random.default_rng(seed).uniform(0, p, 2)
    on = (np.abs((xx - ox) % p - p / 2) > p / 2 - 0.8) | (np.abs((yy - oy) % p - p / 2) > p / 2 - 0.8)
    dye = on[..., None] * strength * (1.0 - np.array(rgb, np.float32) / 255)
    return np.clip(img * (1.0 - dye), 0, 255).astype(np.uint8)


def with_a_reflection(img: np.ndarray, seed: int, strength: float = 0.65) -> np.ndarray:
    """Photo ``img`` with a ceiling light's reflection on the whiteboard: a long soft streak (8 % of
    the width across, 70 % of the height long, up to 35 deg from upright) where the photo is blended
    towards white by up to ``strength`` - the lines in its middle keep a third of their contrast."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    a = rng.uniform(-0.6, 0.6)
    cx, cy = rng.uniform(0.3, 0.7) * w, rng.uniform(0.3, 0.7) * h
    across = (xx - cx) * np.cos(a) + (yy - cy) * np.sin(a)
    along = (yy - cy) * np.cos(a) - (xx - cx) * np.sin(a)
    g = strength * np.exp(-across ** 2 / (2 * (0.04 * w) ** 2) - along ** 2 / (2 * (0.35 * h) ** 2))
    return np.clip(img * (1.0 - g[..., None]) + 255.0 * g[..., None], 0, 255).astype(np.uint8)


def gone_over_twice(img: np.ndarray, seed: int) -> np.ndarray:
    """Photo ``img`` with every stroke drawn a second time beside itself, a 150th of the width off in
    a direction of the seed's: double-stroked lines (and marks)."""
    h, w = img.shape[:2]
    a = np.random.default_rng(seed).uniform(0, 2 * np.pi)
    px = max(2.0, w / 150)
    M = np.float32([[1, 0, px * np.cos(a)], [0, 1, px * np.sin(a)]])
    return np.minimum(img, cv2.warpAffine(img, M, (w, h), borderMode=cv2.BORDER_REPLICATE))


def with_ghost_marks(img: np.ndarray, seed: int, strength: float = 0.1) -> np.ndarray:
    """Photo ``img`` with the faint ghosts of an erased game: its own ink, blurred, at ``strength`` of
    its darkest strokes' darkness, shifted a tenth to a fifth of the frame (marks and lines where none
    are drawn now)."""
    h, w = img.shape[:2]
    rng = np.random.default_rng(seed)
    ink, _ = _ink_and_page(img)
    dx, dy = int(rng.uniform(0.1, 0.2) * w) * int(rng.choice([-1, 1])), int(rng.uniform(0.1, 0.2) * h)
    ghost = cv2.GaussianBlur(np.roll(ink, (dy, dx), axis=(0, 1)), (0, 0), 1.0) * strength
    return np.clip(img * (1.0 - ghost[..., None]), 0, 255).astype(np.uint8)


def photo_conditions() -> list[Condition]:
    """How held-out phone photos differ from the 15 real ones, as transforms of photo ``i``:
    ``(label, transform(img, i), readings(board))``; ``readings``: the board texts that count as
    right for the labelled ``board`` - itself; its columns reversed when mirrored; any quarter
    turn when turned so far that a photo's own turn may pass 45 deg, where the reader reads the
    board turned by a quarter (its documented order)."""
    def size(side: int) -> Callable[[np.ndarray, int], np.ndarray]:
        return lambda img, i: cv2.resize(img, (side, side * 3 // 4), interpolation=cv2.INTER_CUBIC)

    def noise(level: float) -> Callable[[np.ndarray, int], np.ndarray]:  # a phone's sensor in dim light
        return lambda img, i: np.clip(img + np.random.default_rng(100 + i).normal(0.0, level, img.shape), 0,
                                      255).astype(np.uint8)

    def lit(img: np.ndarray, shade: np.ndarray) -> np.ndarray:
        return np.clip(img * shade[..., None], 0, 255).astype(np.uint8)

    def shadow(img: np.ndarray) -> np.ndarray:  # a hard-edged shadow over the lower part, at 55 %
        h, w = img.shape[:2]
        m = np.ones((h, w), np.float32)
        cv2.fillPoly(m, [np.array([[0, int(0.3 * h)], [w, int(0.55 * h)], [w, h], [0, h]], np.int32)], 0.55)
        return lit(img, cv2.GaussianBlur(m, (0, 0), 3))

    def turned(img: np.ndarray, deg: float) -> np.ndarray:
        h, w = img.shape[:2]
        return cv2.warpAffine(img, cv2.getRotationMatrix2D((w / 2, h / 2), deg, 1.0), (w, h),
                              borderMode=cv2.BORDER_REPLICATE)

    def jpeg(img: np.ndarray, quality: int) -> np.ndarray:
        buf = cv2.imencode(".jpg", img[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])[1]
        return np.ascontiguousarray(cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1])

    return [("as taken, 577 x 433", lambda img, i: img, as_labelled),
            ("enlarged to 960 x 720", size(960), as_labelled),
            ("enlarged to 4000 x 3000", size(4000), as_labelled),
            *((f"as taken, white noise of {v} grey levels added", noise(v), as_labelled) for v in (5, 8, 12)),
            ("keystone, top 20 % narrower", lambda img, i: keystone(img, True), as_labelled),
            ("keystone, left side 20 % shorter", lambda img, i: keystone(img, False), as_labelled),
            ("blurred, Gaussian 3 px at 960 x 720", lambda img, i: cv2.GaussianBlur(size(960)(img, i), (0, 0), 3.0),
             as_labelled),
            ("JPEG quality 25", lambda img, i: jpeg(img, 25), as_labelled),
            ("a hard shadow across", lambda img, i: shadow(img), as_labelled),
            ("a hand's shadow leaving 25 % of the light", lambda img, i: under_a_hand_s_shadow(img, 0.25, i),
             as_labelled),
            ("on a dark noisy table, the frame 1.3 x as large", lambda img, i: on_a_dark_table(img, 1.3, i),
             as_labelled),
            ("a dark pen lying beside the board", lambda img, i: with_a_pen_beside(img, i), as_labelled),
            ("a faint pen: washed out to 35 % of the contrast", lambda img, i: washed_out(img, 0.35), as_labelled),
            ("a green highlighter scribbled across", lambda img, i: highlighted(img, i), as_labelled),
            ("a red light's glare on the board", lambda img, i: red_light_spot(img, i), as_labelled),
            ("a notebook's spiral binding along a side", lambda img, i: with_a_spiral_binding(img, i), as_labelled),
            ("cut off 0.75 cell above the top row line", lambda img, i: cut_off_at_top(img), as_labelled),
            ("a second board half in view beside it", lambda img, i: beside_a_second_board(img), as_labelled),
            ("light falling off to 45 % across", lambda img, i: lit(img, np.tile(np.linspace(
                1.0, 0.45, img.shape[1], dtype=np.float32), (img.shape[0], 1))), as_labelled),
            ("turned 10 deg", lambda img, i: turned(img, 10.0), as_labelled),
            *((f"turned {v:+d} deg, the canvas grown (read turned counts)", lambda img, i, v=v: turned_whole(img, v),
               quarter_turns) for v in (15, -15, 30)),
            ("grey, no colour", lambda img, i: cv2.cvtColor(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY), cv2.COLOR_GRAY2RGB),
             as_labelled),
            ("mirrored", lambda img, i: np.ascontiguousarray(img[:, ::-1]), mirrored),
            ("shrunk to 400 x 300", lambda img, i: cv2.resize(img, (400, 300), interpolation=cv2.INTER_AREA),
             as_labelled),
            ("in a green marker", lambda img, i: in_another_pen(img, GREEN), as_labelled),
            ("on graph paper, blue rules every 2.5 % of the width", on_graph_paper, as_labelled),
            ("a whiteboard's reflection across", with_a_reflection, as_labelled),
            ("every stroke gone over twice", gone_over_twice, as_labelled),
            ("ghosts of an erased game", with_ghost_marks, as_labelled),
            *HELD_OUT_GROUPS]


def as_labelled(board: str) -> list[str]:
    return [board]


def mirrored(board: str) -> list[str]:
    return ["|".join(row[::-1] for row in board.split("|"))]


def quarter_turns(board: str) -> list[str]:
    """A board's text (``"X..|.O.|..."``) and its three quarter turns."""
    g = np.array([list(row) for row in board.split("|")])
    return ["|".join("".join(row) for row in np.rot90(g, k)) for k in range(4)]


#: pens the 15 photos are redrawn in (RGB of a full stroke)
GREEN, BLACK, BALLPOINT = (40, 160, 60), (25, 25, 35), (40, 60, 160)

#: The issue's four kinds of held-out photo, each as the 15 photos under several conditions at once.
HELD_OUT_GROUPS: list[Condition] = [
    ("group: graph paper, black marker, cut off at the top",
     lambda img, i: on_graph_paper(in_another_pen(cut_off_at_top(img), BLACK), i), as_labelled),
    ("group: whiteboard, green marker, a reflection, turned 30 deg",
     lambda img, i: turned_whole(with_a_reflection(in_another_pen(img, GREEN), i, 0.5), 30), quarter_turns),
    ("group: graph paper, a pale blue ballpoint, keystone",
     lambda img, i: keystone(on_graph_paper(washed_out(in_another_pen(img, BALLPOINT), 0.6), i), True), as_labelled),
    ("group: graph paper, blue ballpoint, ghost marks",
     lambda img, i: on_graph_paper(with_ghost_marks(in_another_pen(img, BALLPOINT), i), i), as_labelled),
    ("group: graph paper, lines gone over twice, a spiral binding",
     lambda img, i: with_a_spiral_binding(on_graph_paper(gone_over_twice(img, i), i), i), as_labelled),
    ("group: white paper, a hand's shadow, a red light, a highlighter",
     lambda img, i: highlighted(red_light_spot(under_a_hand_s_shadow(img, 0.4, i), i), i), as_labelled),
    ("group: a second board beside it, a hand's shadow",
     lambda img, i: beside_a_second_board(under_a_hand_s_shadow(img, 0.4, i)), as_labelled)]
