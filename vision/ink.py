"""The ink map: how dark each pixel is against its local background (uneven light, shadows and
glare removed), and small image helpers every reader shares.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .errors import VisionError

__all__ = ["DIM_BACKGROUND", "FAINT_TOP", "INK_FLOOR", "ink_floor", "ink_map", "ink_colour", "ink_threshold",
           "noise_floor_and_top", "local_ink_threshold", "ink_mask", "median_at", "colour_at", "angle_deg", "unit",
           "noise_sigma", "denoised", "NOISY_SIGMA"]


def _apply(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = np.concatenate([pts, np.ones((len(pts), 1))], axis=1) @ H.T
    return p[:, :2] / p[:, 2:3]


def _as_rgb(image: object) -> np.ndarray:
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (3, 4)):
        raise VisionError(f"image of dtype {img.dtype} and shape {img.shape}; expected uint8 (H, W) or (H, W, 3)")
    if min(img.shape[:2]) < 32:
        raise VisionError(f"image of shape {img.shape} is too small; expected at least 32 x 32 pixels")
    if img.ndim == 2:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    return img[..., :3]


def ink_map(image: object, stroke_px: float = 12.0) -> np.ndarray:
    """Ink darkness ``(H, W)`` float32 in 0..1: luma darkness against the local background.

    The background is a grey closing (max then min filter) over a square a little wider
    than ``stroke_px``, the widest stroke expected: it removes thin dark strokes and keeps
    anything wide - light gradients, shadows, glare, and the table around the paper, whose
    edge therefore does not turn into a line of ink. Where that background is darker than
    :data:`DIM_BACKGROUND` of the page's white (a dark table, a deep shadow), the sensor's noise,
    divided by so little light, looks like ink: there only what stands above the dim parts' own
    noise is ink (a pen under a hand's shadow is; a dark table's grain is not).
    """
    return _darkness(cv2.cvtColor(_as_rgb(image), cv2.COLOR_RGB2GRAY), stroke_px)


def ink_colour(image: object, stroke_px: float = 12.0) -> np.ndarray:
    """Per-channel ink darkness ``(H, W, 3)`` float32 in 0..1 (R, G, B), each channel against
    its own local background as :func:`ink_map` does for luma. Its direction is the pen's
    colour whatever the stroke's coverage: a thin or pale stroke scales all three alike (black
    ink darkens them equally, blue ink mostly red and green, a green marker red and blue)."""
    return _darkness(np.ascontiguousarray(_as_rgb(image)), stroke_px)  # the three channels in one pass


#: A background darker than this share of the page's white (the 95th percentile of the map's
#: background) is dim: there ink must stand above the dim parts' own noise (their median darkness + 6
#: robust sigmas), else its darkness is 0 (stop 68: the 15 real photos on a dark, noisy table read 42 ->
#: 54 of 60 in four such scenes, and under a hand's shadow at 25 % all 15 as before).
DIM_BACKGROUND = 0.3


def _darkness(y8: np.ndarray, stroke_px: float) -> np.ndarray:
    k = 2 * int(math.ceil(stroke_px)) + 1
    # replicate the border first: a sliver of dark table along the image edge would
    # otherwise look like a stroke (8-bit morphology: several times faster than float)
    padded = cv2.copyMakeBorder(y8, k, k, k, k, cv2.BORDER_REPLICATE)
    bg = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))[k:-k, k:-k]
    # a closing never darkens, so 0 <= y8 <= bg and the darkness lies in 0..1 as it is
    d = y8.astype(np.float32)
    # (cv2.max: numpy's is 6x slower on uint8; on one channel, where a scalar means every value)
    floor = cv2.max(bg.reshape(bg.shape[0], -1), 8).reshape(bg.shape)
    np.divide(d, floor.astype(np.float32), out=d)
    np.subtract(1.0, d, out=d)
    # where the background is dim (a dark table, the room behind, a hand's deep shadow) the sensor's noise,
    # divided by so little light, looks like ink: there ink must stand above the dim parts' own noise
    level = DIM_BACKGROUND * float(np.percentile(bg[::4, ::4], 95))
    sample = d[::4, ::4][bg[::4, ::4] < level]  # (the full-size mask only where there are dim parts)
    if sample.size >= 50:
        med = float(np.median(sample))
        d[(bg < level) & (d < med + 6.0 * 1.4826 * float(np.median(np.abs(sample - med))))] = 0.0
    return d


#: The noise (:func:`noise_sigma`, grey levels) above which the reader smooths a photo first.
#: Clean photos and prints estimate 0-1.5; a sensor's noise of 3 grey levels estimates about 2.
NOISY_SIGMA = 2.0
_LAPLACE = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)  # Immerkaer's: flat on lines and ramps


def noise_sigma(image: object) -> float:
    """The photo's pixel noise, grey levels (1 sigma), from every other pixel each way:
    Immerkaer's difference-of-Laplacians operator (blind to flat areas, ramps and straight
    lines) over the grey image, its median absolute response over its spread for white noise
    (``0.6745 * 6``). Strokes and edges cover a minority of pixels and move the median little.
    (JPEG and 8-bit rounding hide some noise: white noise of 4 / 8 / 12 levels estimates about
    2.7 / 5.4 / 8.)"""
    rgb = _as_rgb(image)
    h, w = rgb.shape[:2]
    g = cv2.cvtColor(cv2.resize(rgb, (max(3, w // 2), max(3, h // 2)), interpolation=cv2.INTER_NEAREST),
                     cv2.COLOR_RGB2GRAY)
    r = cv2.convertScaleAbs(cv2.filter2D(g, cv2.CV_16S, _LAPLACE)[1:-1, 1:-1])  # |response|, 255 at most
    # the median from the histogram (np.median sorts: several times slower here)
    hist = cv2.calcHist([r], [0], None, [256], [0, 256]).ravel()
    med = int(np.searchsorted(np.cumsum(hist), 0.5 * r.size))
    return med / (0.6745 * 6.0)


def denoised(image: object, sigma: float) -> np.ndarray:
    """``image`` (uint8 RGB) with noise of ``sigma`` (:func:`noise_sigma`) smoothed: a Gaussian
    of ``0.15 sigma`` px, then a 3 x 3 median (which takes the speckle the blur leaves and keeps
    a stroke's edges). On the 15 real photos with white noise added (seeds 100 on), reads right
    of 15 at noise 5 / 8 / 12 / 16 levels: 15 / 15 / 13 / 8, against 14 / 10 / 8 / 5 unsmoothed
    (stop 50, with the noise floor capped; 12 / 6 / 4 / 0 unsmoothed before the cap)."""
    rgb = _as_rgb(image)
    return cv2.medianBlur(cv2.GaussianBlur(rgb, (0, 0), 0.15 * float(sigma)), 3)


#: the noise floor of :func:`ink_threshold` never rises above this share of the strongest ink
NOISE_FLOOR_CAP = 0.5


def ink_threshold(d: np.ndarray, share: float = 0.22, levels: tuple[float, float] | None = None) -> float:
    """The level above which a darkness map's pixel is ink: the larger of its noise (median +
    6 robust sigmas, but at most :data:`NOISE_FLOOR_CAP` of the strong ink), ``share`` of its
    strong ink (99.7th percentile) and :data:`INK_FLOOR` (at ``share`` 0 scaled down where even the
    strong ink is faint, :func:`ink_floor`). The cap: dense graph rules in a small photo, or
    heavy sensor noise, spread the map's middle so far that six robust sigmas rose above the
    drawn lines themselves (real-like photo 20,109: floor 0.56, its '#' about 0.45, its darkest
    strokes 0.64); ink half as dark as the darkest strokes is ink, whatever lies around it.
    ``levels``: the map's :func:`noise_floor_and_top`, where already measured."""
    return _level(*(levels or noise_floor_and_top(d)), share)


def noise_floor_and_top(d: np.ndarray) -> tuple[float, float]:
    """A darkness map's noise floor (median + 6 robust sigmas) and strong ink (99.7th percentile),
    from every other pixel each way (three selections: measure once per map, pass as ``levels``)."""
    sample = d[::2, ::2].ravel()
    med = float(np.median(sample))
    mad = float(np.median(np.abs(sample - med))) * 1.4826
    return med + 6.0 * mad, float(np.percentile(sample, 99.7))


#: The least darkness that is ink, whatever the map's noise (paper grain, JPEG's blocks).
INK_FLOOR = 0.035

#: Strong ink (the map's 99.7th percentile) under this is a faint pen's - a ballpoint, a dry marker, a
#: photo washed out by the light: there all ink above the noise (``share`` 0) is taken down to
#: :data:`INK_FLOOR` times ``top / FAINT_TOP`` (:func:`ink_floor`). The 15 real photos washed to 45 / 35 /
#: 25 % of their contrast read 14 / 11 / 6 of 15 with the plain floor, 15 / 14 / 14 so (stop 69;
#: the floor 0.02 everywhere read 14 at 35 % but lost 3 of the 255 real condition readings).
FAINT_TOP = 0.25


def ink_floor(top: float, share: float) -> float:
    """The least darkness that is ink in a map whose strong ink is ``top``, at ink ``share``:
    :data:`INK_FLOOR`, scaled by ``top / FAINT_TOP`` where that is under 1 and ``share`` is 0 (all
    ink above the noise: a faint pen's lines; at a share of the strong ink the floor stays)."""
    return INK_FLOOR * min(1.0, top / FAINT_TOP) if share == 0.0 else INK_FLOOR


def _level(floor: float, top: float, share: float) -> float:
    """:func:`ink_threshold` from a map's noise ``floor`` and strong ink ``top``."""
    return max(min(floor, NOISE_FLOOR_CAP * top), share * top, ink_floor(top, share))


#: side of the blocks (px) whose own noise :func:`local_ink_threshold` measures
NOISE_BLOCK_PX = 32


def local_ink_threshold(d: np.ndarray, share: float = 0.22, levels: tuple[float, float] | None = None
                        ) -> np.ndarray:
    """:func:`ink_threshold` per pixel ``(H, W)`` float32, with the noise floor measured locally
    where that is lower: each :data:`NOISE_BLOCK_PX` block's own median + 6 robust sigmas,
    interpolated between block centres. A textured table, a cloth or a wood grain around the
    page spreads the whole map's darkness and raised the one floor above pencil and faint-pen
    lines on the plain page (real-like photos 30,011, 30,077, 30,085 and 30,097 were refused so,
    their '#' plain to see); the page's own floor lets them in, and the floor is never raised
    above the whole map's (so no ink it kept is lost). ``levels`` as for :func:`ink_threshold`."""
    floor, top = levels or noise_floor_and_top(d)
    t = _level(floor, top, share)
    sample = d[::2, ::2]
    h, w = sample.shape
    b = NOISE_BLOCK_PX // 2  # the block in the half-resolution sample
    by, bx = max(1, h // b), max(1, w // b)
    if by * bx < 4:  # too small to tell regions apart
        return np.full(d.shape, t, np.float32)
    blocks = sample[:by * b, :bx * b].reshape(by, b, bx, b).transpose(0, 2, 1, 3).reshape(by, bx, b * b)
    med = np.median(blocks, axis=2)
    mad = np.median(np.abs(blocks - med[..., None]), axis=2) * 1.4826
    local = cv2.resize((med + 6.0 * mad).astype(np.float32), (d.shape[1], d.shape[0]), interpolation=cv2.INTER_LINEAR)
    return np.maximum(np.minimum(local, np.float32(t)), np.float32(max(share * top, ink_floor(top, share))))


def median_at(m: float | np.ndarray, pts: np.ndarray) -> float:
    """The median of the map ``m`` at points ``pts`` ``(N, 2)`` (x, y; rounded, clipped to the map);
    a number ``m`` is a map of that value everywhere."""
    if np.ndim(m) == 0:
        return float(m)  # type: ignore[arg-type]
    px = np.rint(pts).astype(np.intp)
    return float(np.median(m[np.clip(px[:, 1], 0, m.shape[0] - 1), np.clip(px[:, 0], 0, m.shape[1] - 1)]))


def colour_at(d: np.ndarray, colour: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The unit ink colour along points ``pts`` ``(N, 2)`` (x, y) of a stroke: the RGB darkness
    ``colour`` (:func:`ink_colour`) at the darkest pixel of ``d`` within 2 px of each point,
    weighted by that darkness."""
    h, w = d.shape
    dy, dx = (v.ravel() for v in np.mgrid[-2:3, -2:3])
    px = np.rint(pts).astype(np.intp)
    ys, xs = np.clip(px[:, 1, None] + dy, 0, h - 1), np.clip(px[:, 0, None] + dx, 0, w - 1)
    at = (np.arange(len(px)), d[ys, xs].argmax(axis=1))
    y, x = ys[at], xs[at]
    return unit((colour[y, x] * d[y, x, None]).sum(axis=0))


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` scaled to length 1 (a zero vector stays zero)."""
    return v / max(float(np.linalg.norm(v)), 1e-9)


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (deg) between two unit vectors."""
    return math.degrees(math.acos(float(np.clip(np.dot(a, b), -1.0, 1.0))))


def ink_mask(d: np.ndarray, share: float = 0.22, above: float = 0.0, local: bool = False,
             levels: tuple[float, float] | None = None) -> tuple[np.ndarray, float | np.ndarray, float]:
    """The ink mask of a darkness map (uint8 0/1), its threshold and the stroke width (px).

    The threshold is the larger of the map's noise level (median + 6 robust sigmas; with ``local``
    each region's own where that is lower, :func:`local_ink_threshold`, and the threshold is a map),
    ``share`` of its strong ink (the 99.7th percentile) and ``above``; a pixel joins the mask also
    at 60 % of that level when it touches a pixel above it (hysteresis: a faint stretch of a line
    stays connected). ``levels``: the map's :func:`noise_floor_and_top`, where already measured."""
    t = (np.maximum(local_ink_threshold(d, share, levels), np.float32(above)) if local
         else max(ink_threshold(d, share, levels), above))
    hi = (d > t).astype(np.uint8)
    lo = (d > 0.6 * t).astype(np.uint8)
    # hysteresis: low pixels within a pixel of high ones
    mask = cv2.bitwise_and(lo, cv2.dilate(hi, np.ones((3, 3), np.uint8)))
    return mask, t, _stroke_width(mask)


def _stroke_width(mask: np.ndarray) -> float:
    """Median length of the mask's runs along rows and columns, the shorter of the two
    medians (a run across a stroke is its width; one along it is long)."""
    widths = []
    for m in (mask, mask.T):
        # each row with a 0 after it, the rows end to end: a run starts or ends where the
        # value changes (one flat pass, not two 2-D nonzero calls)
        h, w = m.shape
        pad = np.zeros((h, w + 1), np.uint8)
        pad[:, :w] = m
        flat = pad.ravel()
        edges = np.flatnonzero(flat[1:] != flat[:-1]) + 1
        if flat[0]:
            edges = np.concatenate([[0], edges])
        runs = edges[1::2] - edges[0::2]
        if len(runs):
            widths.append(float(np.median(runs)))
    return max(1.0, min(widths)) if widths else 2.0
