"""Headless drawing of walls, climbers and arms with OpenCV: pictures in cm, PNG files out.

One small :class:`Canvas` maps world coordinates (cm, y up) to pixels and draws
anti-aliased shapes and labels into an RGB ``uint8`` array. The CLI uses it for its
PNGs and the environments for ``render_mode="rgb_array"``; no display is ever needed.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from kinegym.configs.io import FileError, write_atomic
from kinegym.kinematics.climber import ClimberGeometry, body_to_wall, elbow_positions, hand_positions
from kinegym.kinematics.holes import HoleMap
from kinegym.vision.image_io import write_image

__all__ = ["Canvas", "draw_wall", "draw_climber", "fit_canvas", "live_chart", "nice_ticks", "save_rgb",
    "save_gif", "ARM_COLOURS"]

Colour = tuple[int, int, int]
#: One colour per climber arm (RGB), in label order.
ARM_COLOURS: tuple[Colour, ...] = ((214, 39, 40), (44, 160, 44), (31, 119, 180))
_BG: Colour = (250, 248, 242)
_INK: Colour = (40, 40, 40)


class Canvas:
    """An RGB image showing the world box ``[x0, x1] x [y0, y1]`` cm at ``scale`` px/cm."""

    def __init__(self, x0: float, y0: float, x1: float, y1: float, scale: float = 8.0,
                 background: Colour = _BG) -> None:
        if not (x1 > x0 and y1 > y0 and scale > 0):
            raise ValueError(f"empty canvas box ({x0}, {y0})-({x1}, {y1}) at scale {scale}")
        self.x0, self.y0, self.scale = x0, y0, scale
        self.width = int(np.ceil((x1 - x0) * scale))
        self.height = int(np.ceil((y1 - y0) * scale))
        self._y1 = y1
        self.background = np.empty((self.height, self.width, 3), np.uint8)
        self.background[...] = background
        self.image = self.background.copy()

    def clear(self) -> None:
        """Reset to the background (a copy, no per-pixel Python work)."""
        np.copyto(self.image, self.background)

    def px(self, pts: object) -> np.ndarray:
        """World points ``(..., 2)`` cm -> integer pixel coordinates ``(..., 2)``."""
        p = np.asarray(pts, dtype=np.float64)
        u = (p[..., 0] - self.x0) * self.scale
        v = (self._y1 - p[..., 1]) * self.scale
        return np.rint(np.stack([u, v], axis=-1)).astype(np.int32)

    def line(self, a: object, b: object, colour: Colour = _INK, width: float = 0.3) -> None:
        """Segment from ``a`` to ``b`` (cm), ``width`` in cm."""
        pa, pb = self.px(a), self.px(b)
        cv2.line(self.image, tuple(map(int, pa)), tuple(map(int, pb)), colour,
                 max(1, round(width * self.scale)), cv2.LINE_AA)

    def polyline(self, pts: object, colour: Colour = _INK, width: float = 0.3,
                 closed: bool = False) -> None:
        p = self.px(pts).reshape(-1, 1, 2)
        cv2.polylines(self.image, [p], closed, colour, max(1, round(width * self.scale)),
                      cv2.LINE_AA)

    def circle(self, c: object, radius: float, colour: Colour = _INK, fill: bool = True,
               width: float = 0.2) -> None:
        """Circle of ``radius`` cm; filled or outlined."""
        pc = self.px(c)
        thick = -1 if fill else max(1, round(width * self.scale))
        cv2.circle(self.image, tuple(map(int, pc)), max(1, round(radius * self.scale)), colour,
                   thick, cv2.LINE_AA)

    def text(self, at: object, label: str, colour: Colour = _INK, size: float = 0.45,
             offset_px: tuple[int, int] = (4, -4)) -> None:
        p = self.px(at)
        cv2.putText(self.image, label, (int(p[0]) + offset_px[0], int(p[1]) + offset_px[1]),
                    cv2.FONT_HERSHEY_SIMPLEX, size, colour, 1, cv2.LINE_AA)

    def caption(self, lines: Sequence[str], colour: Colour = _INK) -> None:
        """Text lines in the top-left corner (pixel placement)."""
        for i, s in enumerate(lines):
            cv2.putText(self.image, s, (8, 18 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1,
                        cv2.LINE_AA)

    def save(self, path: str | Path) -> Path:
        """Write a PNG (creating folders); returns the path."""
        return write_image(self.image, path)


def fit_canvas(points: object, margin: float = 12.0, scale: float = 8.0) -> Canvas:
    """A canvas that shows every point ``(N, 2)`` with ``margin`` cm around."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    lo, hi = p.min(0) - margin, p.max(0) + margin
    return Canvas(lo[0], lo[1], hi[0], hi[1], scale)


def draw_wall(canvas: Canvas, holes: HoleMap, labels: bool = True) -> None:
    """Holes as rings with their ``(col, row)`` ids (seed 000's part 4.1 chart)."""
    for hid, xy in zip(holes.ids, holes.xy):
        canvas.circle(xy, 1.0, (120, 120, 120), fill=False, width=0.25)
        if labels:
            canvas.text(xy, f"{hid[0]},{hid[1]}", (130, 130, 130), size=0.35, offset_px=(6, 14))


def draw_climber(canvas: Canvas, pose: object, q: object, geom: ClimberGeometry,
                 alpha: float = 1.0, label: bool = True) -> None:
    """The robot at ``pose = (x, y, heading)``: body, links, elbows, hands (seed's part 4.2).

    ``alpha`` < 1 draws a faded ghost (e.g. an estimated pose beside the true one).
    """
    pose = np.asarray(pose, dtype=np.float64)
    shoulders = body_to_wall(geom.shoulders, pose)
    elbows = body_to_wall(elbow_positions(q, geom), pose)
    hands = body_to_wall(hand_positions(q, geom), pose)

    def tone(c: Colour) -> Colour:
        return tuple(int(round(alpha * v + (1 - alpha) * b)) for v, b in zip(c, _BG))  # type: ignore[return-value]

    canvas.polyline(hands, tone((150, 150, 150)), 0.15, closed=True)
    for i in range(3):
        col = tone(ARM_COLOURS[i])
        canvas.line(shoulders[i], elbows[i], col, 0.6)
        canvas.line(elbows[i], hands[i], col, 0.45)
        canvas.circle(elbows[i], 0.7, col)
        canvas.circle(hands[i], 1.1, col, fill=False, width=0.35)
        if label:
            canvas.text(hands[i], f"arm {i + 1}", col, size=0.45, offset_px=(8, -8))
    canvas.circle(pose[:2], 2.2, tone((60, 60, 60)))
    head = pose[:2] + 3.5 * np.array([np.cos(pose[2]), np.sin(pose[2])])
    canvas.line(pose[:2], head, tone((250, 250, 250)), 0.35)


_SERIES: tuple[Colour, ...] = ((31, 119, 180), (214, 39, 40), (44, 160, 44), (255, 127, 14), (148, 103, 189),
                               (140, 86, 75))


def nice_ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About ``n`` round tick values (steps of 1, 2 or 5 times a power of ten) within [lo, hi]."""
    span = hi - lo
    if not (np.isfinite(span) and span > 0):
        return [lo]
    raw = span / max(1, n)
    mag = 10.0 ** np.floor(np.log10(raw))
    step = min((m * mag for m in (1, 2, 5, 10)), key=lambda st: abs(span / st - n))
    first = np.ceil(lo / step - 1e-9) * step
    return [float(round(v, 12)) + 0.0 for v in np.arange(first, hi + step * 1e-9, step)]


def live_chart(series: dict[str, tuple[Sequence[float], Sequence[float]]], title: str, xlabel: str,
               ylabel: str, size: tuple[int, int] = (345, 160), ylim: tuple[float, float] | None = None,
               markers: bool = False) -> np.ndarray:
    """A small line chart (RGB array) drawn with OpenCV in about a millisecond, for panels that
    refresh every frame (the arm's window); round ticks (:func:`nice_ticks`), the legend in a
    row above the plot, the y unit in the title line. Charts written to files use
    :func:`kinegym.envs.charts.line_chart` (matplotlib)."""
    w, h = size
    img = np.empty((h, w, 3), np.uint8)
    img[...] = (255, 255, 255)
    left, right, top, bottom = 44, 8, 34, 30
    xs = np.concatenate([np.asarray(s[0], float) for s in series.values()])
    ys = np.concatenate([np.asarray(s[1], float) for s in series.values()])
    ys = ys[np.isfinite(ys)]
    x0, x1 = (float(xs.min()), float(xs.max())) if len(xs) else (0.0, 1.0)
    if x1 <= x0:
        x0, x1 = x0 - 1, x1 + 1
    y0, y1 = ylim if ylim else ((float(ys.min()), float(ys.max())) if len(ys) else (0.0, 1.0))
    if y1 <= y0:
        y0, y1 = y0 - 1, y1 + 1
    pad = 0.06 * (y1 - y0)
    y0, y1 = (y0, y1) if ylim else (y0 - pad, y1 + pad)

    def to_px(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        u = left + (np.asarray(x, float) - x0) / (x1 - x0) * (w - left - right)
        v = h - bottom - (np.asarray(y, float) - y0) / (y1 - y0) * (h - top - bottom)
        return np.stack([u, v], -1).round().astype(np.int32)

    font, grey = cv2.FONT_HERSHEY_SIMPLEX, (60, 60, 60)
    cv2.rectangle(img, (left, top), (w - right, h - bottom), grey, 1)
    for yv in nice_ticks(y0, y1, 4):
        v = int(to_px(np.array([x0]), np.array([yv]))[0, 1])
        cv2.line(img, (left, v), (w - right, v), (228, 228, 228), 1)
        cv2.putText(img, f"{yv:g}", (3, v + 4), font, 0.33, grey, 1, cv2.LINE_AA)
    for xv in nice_ticks(x0, x1, 5):
        u = int(to_px(np.array([xv]), np.array([y0]))[0, 0])
        cv2.line(img, (u, h - bottom), (u, h - bottom + 4), grey, 1)
        cv2.putText(img, f"{xv:g}", (u - 8, h - bottom + 14), font, 0.33, grey, 1, cv2.LINE_AA)
    lx = left
    for i, (name, (x, y)) in enumerate(series.items()):
        col = _SERIES[i % len(_SERIES)]
        y_arr = np.asarray(y, float)
        ok = np.isfinite(y_arr)
        pts = to_px(np.asarray(x, float)[ok], y_arr[ok])
        if len(pts) > 1:
            cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, col, 1, cv2.LINE_AA)
        for p in pts if markers else ():
            cv2.circle(img, (int(p[0]), int(p[1])), 3, col, -1, cv2.LINE_AA)
        if len(series) > 1:  # the legend: a row above the plot, never over the data
            cv2.line(img, (lx, top - 8), (lx + 12, top - 8), col, 2, cv2.LINE_AA)
            cv2.putText(img, name, (lx + 15, top - 4), font, 0.33, (40, 40, 40), 1, cv2.LINE_AA)
            lx += 22 + 6 * len(name)
    cv2.putText(img, f"{title}  [{ylabel}]" if ylabel else title, (4, 13), font, 0.4, (20, 20, 20), 1, cv2.LINE_AA)
    cv2.putText(img, xlabel, (w // 2 - 20, h - 4), font, 0.35, (40, 40, 40), 1, cv2.LINE_AA)
    return img


def save_rgb(img: np.ndarray, path: str | Path) -> Path:
    """Write an RGB array as PNG or JPEG (by the extension) through the one atomic writer
    (:func:`kinegym.vision.image_io.write_image`; a bad path is a named ``FileError``)."""
    return write_image(img, path)


def _same_size(frames: list[np.ndarray], even: bool = False) -> list[np.ndarray]:
    h = max(f.shape[0] for f in frames)
    w = max(f.shape[1] for f in frames)
    if even:  # H.264 wants even sides
        h, w = h + h % 2, w + w % 2
    out = []
    for f in frames:
        canvas = np.full((h, w, 3), 255, np.uint8)
        canvas[: f.shape[0], : f.shape[1]] = f
        out.append(canvas)
    return out


def save_gif(frames: list[np.ndarray], path: str | Path, fps: float) -> Path:
    """Write RGB frames as an animation: ``.gif`` (Pillow) or ``.mp4`` (H.264 through
    imageio-ffmpeg, the ``video`` extra: ``pip install "kinegym[video]"``); frames of
    different sizes are padded to the largest."""
    import io

    out = Path(path)
    ext = out.suffix.lower()
    if ext not in (".gif", ".mp4"):
        raise FileError(out, f"extension {out.suffix or '(none)'!r}", "an animation path ending in .gif or .mp4")
    if not frames:
        raise ValueError("save_gif needs at least one frame")
    if ext == ".mp4":
        return _save_mp4(_same_size(frames, even=True), out, fps)
    from PIL import Image

    imgs = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=128) for f in _same_size(frames)]
    buf = io.BytesIO()
    imgs[0].save(buf, format="GIF", save_all=True, append_images=imgs[1:], duration=int(1000 / fps), loop=0,
                 optimize=False)
    return write_atomic(out, buf.getvalue(), (".gif",), "GIF")


def _save_mp4(frames: list[np.ndarray], out: Path, fps: float) -> Path:
    import os
    import tempfile

    try:
        import imageio_ffmpeg
    except ImportError:
        raise FileError(out, "an .mp4 needs imageio-ffmpeg, which is not installed",
                        'pip install "kinegym[video]", or a .gif path') from None
    h, w = frames[0].shape[:2]
    fd, tmp = tempfile.mkstemp(suffix=".mp4")  # encoded aside, then written atomically where asked
    os.close(fd)
    try:
        writer = imageio_ffmpeg.write_frames(tmp, (w, h), fps=float(fps), codec="libx264", pix_fmt_out="yuv420p",
                                             macro_block_size=1, ffmpeg_log_level="error")
        writer.send(None)
        for f in frames:
            writer.send(np.ascontiguousarray(f))
        writer.close()
        data = Path(tmp).read_bytes()
    finally:
        Path(tmp).unlink(missing_ok=True)
    return write_atomic(out, data, (".mp4",), "MP4 video")


def draw_climb(holes: HoleMap, goal: int, pose: object, q: object, geom: ClimberGeometry, estimate: object,
               candidates: Sequence[int], mask: np.ndarray, k: int, caption: Sequence[str] = (),
               height_px: int = 560) -> np.ndarray:
    """One frame of a climb (RGB array): the wall's holes, the goal hole (gold ring), the
    candidate holes numbered (green where some arm may go, grey where none may), the robot
    at its true pose and a ghost at the pose the localiser estimates, and a caption."""
    xy = holes.xy
    lo, hi = xy.min(axis=0) - 12.0, xy.max(axis=0) + 12.0
    scale = max(1.5, min(10.0, height_px / float(hi[1] - lo[1])))
    canvas = Canvas(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]), scale)
    canvas.image = np.ascontiguousarray(canvas.image)
    for p in xy:
        canvas.circle(p, 0.8, (150, 150, 150), fill=False, width=0.2)
    canvas.circle(xy[goal], 2.2, (230, 170, 20), fill=False, width=0.6)
    for i, h in enumerate(candidates):
        ok = bool(mask[[arm * k + i for arm in range(3)]].any())
        col = (40, 160, 60) if ok else (170, 170, 170)
        canvas.circle(xy[h], 1.3, col, fill=False, width=0.35)
        canvas.text(xy[h], str(i), col, size=0.35, offset_px=(5, -5))
    est = np.asarray(estimate, dtype=np.float64)
    draw_climber(canvas, est, q, geom, alpha=0.3, label=False)
    draw_climber(canvas, pose, q, geom, alpha=1.0, label=False)
    canvas.circle(est[:2], 0.6, (220, 60, 60), fill=True)
    canvas.caption(list(caption))
    return canvas.image


def board_panel(belief: np.ndarray, own: int, last_read: dict, photo: np.ndarray | None, height: int,
                width: int = 260) -> np.ndarray:
    """The TicTacToeDraw side panel: the board as read (the arm's marks in blue), whether the
    last reading was accepted, and a thumbnail of the camera's photo."""
    n = belief.shape[0]
    panel = np.empty((height, width, 3), np.uint8)
    panel[...] = (245, 245, 240)
    text = dict(fontFace=cv2.FONT_HERSHEY_SIMPLEX, lineType=cv2.LINE_AA)
    cv2.putText(panel, "board as read", (10, 22), fontScale=0.55, color=(20, 20, 20), thickness=1, **text)
    cs = min(40, (width - 20) // n)
    x0, y0 = 10, 35
    for r in range(n):
        for c in range(n):
            p0 = (x0 + c * cs, y0 + r * cs)
            cv2.rectangle(panel, p0, (p0[0] + cs, p0[1] + cs), (150, 150, 150), 1)
            v = int(belief[r, c])
            if v:
                col = (25, 60, 175) if v == own else (30, 30, 30)
                cv2.putText(panel, "XO"[v - 1], (p0[0] + cs // 4, p0[1] + 3 * cs // 4), fontScale=cs / 35, color=col,
                            thickness=2, **text)
    y = y0 + n * cs + 20
    cv2.putText(panel, f"read ok: {last_read.get('read_ok')}  tries: {last_read.get('read_tries', 0)}", (10, y),
                fontScale=0.45, color=(20, 20, 20), thickness=1, **text)
    if photo is not None:
        th = int(round(photo.shape[0] * (width - 20) / photo.shape[1]))
        thumb = cv2.resize(photo, (width - 20, th), interpolation=cv2.INTER_AREA)
        y1 = min(height - th - 5, y + 15)
        if y1 > y:
            panel[y1:y1 + th, 10:10 + width - 20] = thumb
            cv2.putText(panel, "camera", (10, y1 - 4), fontScale=0.4, color=(60, 60, 60), thickness=1, **text)
    return panel
