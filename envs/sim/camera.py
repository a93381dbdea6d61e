"""A camera that photographs the drawing board: pose and perspective, light, blur, noise, JPEG.

A :class:`Camera` holds the *ranges* of everything that varies from one photo to the next
(:class:`CameraSpec`; presets ``"ideal"``, ``"default"``, ``"hard"``) and a seeded
generator; :meth:`Camera.photograph` draws one sample and returns a :class:`Photo` with
the image and the truth (the homography from board cm to image pixels and the sampled
settings), so tests can check a reader against where the board really was.

The model, in the order light takes:

1. **Pose** - a pinhole camera (square pixels, ``fov_deg`` across the image width) aimed
   at a point near the field's centre from ``distance_cm``, tilted ``tilt_deg`` away from
   the board normal towards a random azimuth, rolled ``roll_deg`` about its axis. The
   board plane maps to the image by ``H = K [r1 r2 t]``.
2. **Scene** - the canvas warped by ``H`` over a table top (a flat colour with mottling).
3. **Light** - a linear gradient across the image, a vignette, optionally a soft hand
   shadow and a specular glare spot (whiteboards), and a per-channel white balance.
4. **Optics and sensor** - Gaussian defocus blur, additive and shot noise, 8-bit clipping,
   JPEG compression at a random quality.

Everything is numpy/OpenCV; a 640 x 480 photo takes a few milliseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np

from .board import BoardCanvas

__all__ = ["CameraSpec", "Camera", "Photo", "PRESETS", "look_at_homography"]

Range = tuple[float, float]


@dataclass(frozen=True)
class CameraSpec:
    """Ranges (uniform ``(lo, hi)``) of what varies per photo; lengths cm, angles degrees.

    Attributes:
        image_size: ``(width, height)`` in pixels.
        fov_deg: horizontal field of view.
        distance_cm: camera to aim point.
        tilt_deg: angle between the optical axis and the board normal (0 = straight down).
        roll_deg: rotation of the image about the optical axis (the board turns in the image).
        aim_jitter_cm: the aim point wanders this far from the given centre.
        gradient: brightness change across the image, as a fraction (0.3 = +-15 %).
        vignette: darkening at the image corners (fraction).
        exposure: overall brightness factor.
        white_balance: per-channel gain spread (0.05 = +-5 %).
        shadow_p, shadow_strength: probability and depth of a soft hand shadow.
        glare_p, glare_strength: probability and brightness of a specular spot.
        blur_px: Gaussian blur sigma (px).
        noise: additive noise sigma (0..255 levels).
        jpeg_quality: JPEG quality (100 = no artefacts worth the name).
    """

    image_size: tuple[int, int] = (640, 480)
    fov_deg: float = 55.0
    distance_cm: Range = (32.0, 40.0)
    tilt_deg: Range = (0.0, 10.0)
    roll_deg: Range = (-8.0, 8.0)
    aim_jitter_cm: float = 0.8
    gradient: Range = (0.0, 0.15)
    vignette: Range = (0.0, 0.1)
    exposure: Range = (0.9, 1.05)
    white_balance: float = 0.03
    shadow_p: float = 0.0
    shadow_strength: Range = (0.2, 0.4)
    glare_p: float = 0.0
    glare_strength: Range = (0.2, 0.5)
    blur_px: Range = (0.3, 0.8)
    noise: Range = (1.0, 3.0)
    jpeg_quality: Range = (85.0, 95.0)

    def __post_init__(self) -> None:
        w, h = self.image_size
        if not (isinstance(w, int) and isinstance(h, int) and 32 <= w <= 8192 and 32 <= h <= 8192):
            raise ValueError(f"image_size={self.image_size!r}; expected (width, height) integers 32..8192")
        if not 5 < self.fov_deg < 170:
            raise ValueError(f"fov_deg={self.fov_deg!r}; expected 5 < fov_deg < 170")
        for name, lo_ok, hi_ok in (("distance_cm", 1.0, 1e4), ("tilt_deg", 0.0, 75.0), ("roll_deg", -180.0, 180.0),
                                   ("gradient", 0.0, 2.0), ("vignette", 0.0, 1.0), ("exposure", 0.05, 3.0),
                                   ("shadow_strength", 0.0, 1.0), ("glare_strength", 0.0, 3.0),
                                   ("blur_px", 0.0, 20.0), ("noise", 0.0, 100.0), ("jpeg_quality", 5.0, 100.0)):
            lo, hi = getattr(self, name)
            if not (lo_ok <= lo <= hi <= hi_ok):
                raise ValueError(f"{name}={(lo, hi)!r}; expected {lo_ok:g} <= lo <= hi <= {hi_ok:g}")
        for name in ("shadow_p", "glare_p"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name}={getattr(self, name)!r}; expected a probability 0..1")


#: ``ideal``: straight down, even light, no noise. ``default``: a camera on a stand as in
#: the thesis (small tilt and roll, mild light). ``hard``: a hand-held phone - tilt up to
#: 35 deg, board turned up to 30 deg, strong light gradient, shadows, glare, blur, noise.
PRESETS: dict[str, CameraSpec] = {
    "ideal": CameraSpec(distance_cm=(36.0, 36.0), tilt_deg=(0.0, 0.0), roll_deg=(0.0, 0.0), aim_jitter_cm=0.0,
                        gradient=(0.0, 0.0), vignette=(0.0, 0.0), exposure=(1.0, 1.0), white_balance=0.0,
                        blur_px=(0.0, 0.0), noise=(0.0, 0.0), jpeg_quality=(100.0, 100.0)),
    "default": CameraSpec(),
    "hard": CameraSpec(distance_cm=(28.0, 46.0), tilt_deg=(0.0, 35.0), roll_deg=(-30.0, 30.0), aim_jitter_cm=2.0,
                       gradient=(0.1, 0.6), vignette=(0.0, 0.3), exposure=(0.7, 1.15), white_balance=0.08,
                       shadow_p=0.4, shadow_strength=(0.25, 0.55), glare_p=0.3, glare_strength=(0.2, 0.6),
                       blur_px=(0.4, 1.6), noise=(2.0, 7.0), jpeg_quality=(45.0, 90.0)),
}


@dataclass
class Photo:
    """One photograph: ``image`` (H, W, 3) uint8 RGB, ``homography`` taking board cm
    (x, y, 1) to image pixels, and ``settings`` (the sampled values, for the record)."""

    image: np.ndarray
    homography: np.ndarray
    settings: dict[str, Any] = field(default_factory=dict)

    def project(self, pts_cm: object) -> np.ndarray:
        """Board points ``(..., 2)`` cm -> image pixels ``(..., 2)``."""
        p = np.asarray(pts_cm, dtype=np.float64)
        h = np.concatenate([p, np.ones((*p.shape[:-1], 1))], axis=-1) @ self.homography.T
        return h[..., :2] / h[..., 2:3]


def look_at_homography(aim_cm: object, distance_cm: float, tilt_deg: float, azimuth_deg: float, roll_deg: float,
                       image_size: tuple[int, int], fov_deg: float) -> np.ndarray:
    """Homography board cm -> image px of a pinhole camera looking at ``aim_cm`` on the board.

    The camera sits ``distance_cm`` from the aim point, its axis tilted ``tilt_deg`` from the
    board normal towards ``azimuth_deg``; ``roll_deg`` turns the image about the axis. With
    no tilt and no roll, image x runs along board x and image y along board -y.
    """
    w, h = image_size
    f = 0.5 * w / math.tan(math.radians(fov_deg) / 2)
    K = np.array([[f, 0, 0.5 * w - 0.5], [0, f, 0.5 * h - 0.5], [0, 0, 1.0]])
    tilt, az, roll = math.radians(tilt_deg), math.radians(azimuth_deg), math.radians(roll_deg)
    aim = np.array([float(aim_cm[0]), float(aim_cm[1]), 0.0])  # type: ignore[index]
    centre = aim + distance_cm * np.array([math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az),
                                           math.cos(tilt)])
    z = (aim - centre) / np.linalg.norm(aim - centre)
    ref = np.array([math.cos(roll), math.sin(roll), 0.0])  # board direction that should read as image x
    x = ref - ref.dot(z) * z
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    t = -R @ centre
    return K @ np.column_stack([R[:, 0], R[:, 1], t])


class Camera:
    """Photographs a :class:`BoardCanvas`; ``spec`` is a :class:`CameraSpec` or a preset name."""

    def __init__(self, spec: CameraSpec | str = "default", seed: int | np.random.Generator | None = None) -> None:
        if isinstance(spec, str):
            try:
                spec = PRESETS[spec]
            except KeyError:
                raise ValueError(f"camera preset {spec!r}; expected one of: {', '.join(PRESETS)}") from None
        self.spec = spec
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)

    def with_spec(self, **changes: Any) -> Camera:
        """The same generator with some ranges changed."""
        cam = Camera(replace(self.spec, **changes))
        cam.rng = self.rng
        return cam

    def _u(self, r: Range) -> float:
        lo, hi = r
        return float(lo if lo == hi else self.rng.uniform(lo, hi))

    def pose(self, aim_cm: object) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a camera pose aimed near ``aim_cm``: the homography board cm -> image px and
        the sampled values. Cheap: a caller can search poses before rendering one."""
        s, rng = self.spec, self.rng
        aim = np.asarray(aim_cm, float) + (rng.normal(0, s.aim_jitter_cm / 2, 2) if s.aim_jitter_cm else 0.0)
        st = {
            "distance_cm": self._u(s.distance_cm), "tilt_deg": self._u(s.tilt_deg),
            "azimuth_deg": float(rng.uniform(0, 360)), "roll_deg": self._u(s.roll_deg),
        }
        H = look_at_homography(aim, st["distance_cm"], st["tilt_deg"], st["azimuth_deg"], st["roll_deg"],
                               s.image_size, s.fov_deg)
        return H, st

    def photograph(self, canvas: BoardCanvas, aim_cm: object | None = None,
                   pose: tuple[np.ndarray, dict[str, Any]] | None = None) -> Photo:
        """One photo of ``canvas`` aimed near ``aim_cm`` (default: the canvas centre), or
        taken from ``pose`` (a :meth:`pose` drawn before)."""
        s, rng = self.spec, self.rng
        w, h = s.image_size
        aim = aim_cm if aim_cm is not None else (canvas.width_cm / 2, canvas.height_cm / 2)
        H, st = pose if pose is not None else self.pose(aim)
        st = dict(st)
        M = H @ canvas.px_to_cm()
        board = cv2.warpPerspective(canvas.image(), M, (w, h), flags=cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0)).astype(np.float32)
        cover = cv2.warpPerspective(np.ones(canvas.shape, np.float32), M, (w, h), flags=cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        # table top: a flat colour with low-frequency mottling
        table = np.asarray(rng.uniform([60, 45, 30], [170, 150, 130]), np.float32)
        mott = cv2.resize(rng.normal(1.0, 0.06, (6, 8)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        img = board + (1.0 - cover)[..., None] * (table * mott[..., None])

        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        xn, yn = (xx - w / 2) / w, (yy - h / 2) / w
        g_dir = rng.uniform(0, 2 * np.pi)
        st["gradient"] = self._u(s.gradient)
        light = 1.0 + st["gradient"] * (xn * math.cos(g_dir) + yn * math.sin(g_dir))
        st["vignette"] = self._u(s.vignette)
        light *= 1.0 - st["vignette"] * np.clip((xn ** 2 + yn ** 2) / 0.4, 0, 1)
        if rng.random() < s.shadow_p:  # a soft elliptical shadow, as of a hand or an arm
            st["shadow"] = self._u(s.shadow_strength)
            mask = np.zeros((h, w), np.float32)
            c = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
            axes = (int(rng.uniform(0.15, 0.4) * w), int(rng.uniform(0.08, 0.2) * w))
            cv2.ellipse(mask, c, axes, float(rng.uniform(0, 180)), 0, 360, 1.0, -1, cv2.LINE_AA)
            mask = cv2.GaussianBlur(mask, (0, 0), rng.uniform(0.01, 0.05) * w)
            light *= 1.0 - st["shadow"] * mask
        st["exposure"] = self._u(s.exposure)
        wb = 1.0 + rng.uniform(-s.white_balance, s.white_balance, 3) if s.white_balance else np.ones(3)
        img = img * (light * st["exposure"])[..., None] * wb.astype(np.float32)
        if rng.random() < s.glare_p:  # a specular spot: additive, saturating
            st["glare"] = self._u(s.glare_strength)
            gx, gy, gs = rng.uniform(0.1, 0.9) * w, rng.uniform(0.1, 0.9) * h, rng.uniform(0.05, 0.18) * w
            img += (255.0 * st["glare"]) * np.exp(-((xx - gx) ** 2 + (yy - gy) ** 2) / (2 * gs * gs))[..., None]
        st["blur_px"] = self._u(s.blur_px)
        if st["blur_px"] > 0.05:
            img = cv2.GaussianBlur(img, (0, 0), st["blur_px"])
        st["noise"] = self._u(s.noise)
        if st["noise"] > 0:
            shot = np.sqrt(np.clip(img, 0, None) / 255.0)
            img = img + rng.normal(0, st["noise"], img.shape).astype(np.float32) * (0.5 + shot)
        out = np.clip(img + 0.5, 0, 255).astype(np.uint8)
        st["jpeg_quality"] = int(round(self._u(s.jpeg_quality)))
        if st["jpeg_quality"] < 100:
            ok, buf = cv2.imencode(".jpg", out[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, st["jpeg_quality"]])
            if ok:
                out = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].copy()
        return Photo(out, H, st)
