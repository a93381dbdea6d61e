"""Reading and writing images through kinegym's one input and one output boundary.

:func:`read_image` reads a photo through :func:`kinegym.configs.io.read_bytes` (a bounded,
regular file) and decodes it in memory, refusing what is not an image or is too large to be
a camera frame; :func:`encode_image` / :func:`write_image` write PNG or JPEG through
:func:`kinegym.configs.io.write_atomic` (never half a file). Errors are
:class:`~kinegym.configs.io.FileError` naming the path, what was wrong and what would be valid.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from kinegym.configs.io import FileError, read_bytes, write_atomic

__all__ = ["read_image", "write_image", "encode_image", "MAX_IMAGE_BYTES", "MAX_IMAGE_PIXELS", "IMAGE_SUFFIXES"]

MAX_IMAGE_BYTES = 64 << 20
#: 100 megapixels: beyond any phone's photo, below a decompression bomb.
MAX_IMAGE_PIXELS = 100_000_000
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


def read_image(path: str | Path, max_bytes: int = MAX_IMAGE_BYTES, max_pixels: int = MAX_IMAGE_PIXELS) -> np.ndarray:
    """An RGB ``uint8`` array ``(H, W, 3)`` of the image at ``path`` (PNG, JPEG, BMP, ...)."""
    data = read_bytes(path, max_bytes, "image file")
    buf = np.frombuffer(data, np.uint8)
    # the header's size first, so a tiny file claiming gigapixels is refused before decoding
    import io
    import warnings

    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)) as im:
                w, h = im.size
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise FileError(path, "an image whose header claims more pixels than a camera has",
                        f"an image of at most {max_pixels:,} pixels") from None
    except Exception:  # noqa: BLE001 - Pillow does not know every format OpenCV reads; decode decides
        w = h = 0
    if w * h > max_pixels:
        raise FileError(path, f"a {w} x {h} image", f"an image of at most {max_pixels:,} pixels")
    try:
        bgr = cv2.imdecode(buf, cv2.IMREAD_COLOR) if len(buf) else None
    except cv2.error:
        bgr = None
    if bgr is None or bgr.size == 0:
        raise FileError(path, "not an image OpenCV can decode", "a PNG, JPEG, BMP or TIFF image")
    return np.ascontiguousarray(bgr[..., ::-1])


def encode_image(rgb: np.ndarray, suffix: str = ".png") -> bytes:
    """PNG or JPEG bytes of an RGB ``uint8`` array."""
    ok, enc = cv2.imencode(suffix.lower(), cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2BGR))
    if not ok:
        raise ValueError(f"cannot encode a {rgb.shape} image as {suffix}")
    return enc.tobytes()


def write_image(rgb: np.ndarray, path: str | Path) -> Path:
    """Write an RGB array as PNG or JPEG (by the extension), atomically; folders are made."""
    out = Path(path)
    if out.suffix.lower() not in IMAGE_SUFFIXES:
        raise FileError(out, f"extension {out.suffix or '(none)'!r}", "an image path ending in .png, .jpg or .jpeg")
    return write_atomic(out, encode_image(rgb, out.suffix), IMAGE_SUFFIXES, "image")
