"""The learned cell classifier: a small two-layer perceptron, numpy only, shipped in the package
(``vision/data/cell_model.npz``), that turns what the reader sees of one cell into calibrated
empty / X / O probabilities.

What it sees of a cell (:func:`cell_inputs`, one row per cell):

* the cell and a quarter cell around it (an outer cell of a hand-drawn grid: as far out as
  its mark may lie), from the rectified ink map with the grid lines removed, pooled to
  10 x 10 three times: the mean (how much ink) and the max (where a thin pen runs) over the
  grid lines' own darkness, clipped to 0..2, so a faint pen on a faint grid looks like a dark
  pen on a dark grid; and the max over the window's own darkest ink - the mark's shape
  whatever its darkness (a pale X beside black lines is still an X);
* the seven hand features of :func:`~kinegym.vision.cells.board_features` (peak over the
  lines' darkness, ink, hollow, hole, extent, elongation, spread);
* the hand rule's three probabilities (:func:`~kinegym.vision.cells._probabilities`), which
  the network corrects rather than replaces;
* the lines' darkness itself.

The network: standardised inputs, one hidden layer of ReLU units, three logits over a
temperature fitted on held-out scenes (so a confidence of 0.9 is right about nine times in
ten), plus a small weight times the hand rule's log-probabilities - a prior that keeps the
rule's say where the network, which has seen rendered photos only, is unsure (on the real dev
photos that prior turns 133/135 cells right into 135/135), then a softmax.
:mod:`kinegym.agents.train_cells` trains it on the rendered real-like and hard sets; the file
records how (``info``).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from kinegym.configs.io import read_bytes

from .errors import VisionError

__all__ = ["POOL", "CROPS", "N_INPUTS", "CellModel", "cell_inputs", "rule_probs", "dihedral", "SHIPPED_MODEL"]

#: side of the pooled crop
POOL = 10
#: pooled crops per cell: mean and max of the ink over the lines' darkness, max over the cell's own darkest
CROPS = 3
#: inputs per cell: the pooled crops, 7 features, 3 rule probabilities, the line darkness
N_INPUTS = CROPS * POOL * POOL + 7 + 3 + 1
_RULE = CROPS * POOL * POOL + 7  # where the rule's probabilities start
#: the model the reader uses by default
SHIPPED_MODEL = Path(__file__).with_name("data") / "cell_model.npz"
_MAX_BYTES = 8 << 20


def cell_inputs(rect: np.ndarray, n: int, s: int, o: int, feats: np.ndarray, rule: np.ndarray,
                line_ref: float, outer: float = 0.0) -> np.ndarray:
    """``(n * n, N_INPUTS)`` float32: what the classifier sees of each cell (module docstring).

    ``rect``: the rectified ink map, grid lines removed, cells ``s`` px with the field ``o`` px
    in from its edge; ``feats`` ``(n, n, 7)`` and ``rule`` ``(n, n, 3)``: the hand features
    and the hand rule's probabilities; ``line_ref``: the grid lines' darkness. ``outer``: how
    far (cells) an outer cell reaches past the field (a hand-drawn grid's outer cells are
    larger): its window reaches that far out, at least a quarter cell, on its outer sides."""
    ref = max(float(line_ref), 1e-3)
    m = s // 4
    ext = max(m, int(round(outer * s)))
    padded = np.pad(rect, ext)
    side = POOL * (-(-(s + 2 * m) // POOL))  # every window is resized to this, then pooled
    k = side // POOL
    lo = [ext if i == 0 else m for i in range(n)]
    hi = [ext if i == n - 1 else m for i in range(n)]
    wins = np.empty((n * n, side, side), np.float32)
    for r in range(n):
        for c in range(n):
            y0, x0 = ext + o + r * s - lo[r], ext + o + c * s - lo[c]  # in ``padded``
            win = padded[y0:y0 + s + lo[r] + hi[r], x0:x0 + s + lo[c] + hi[c]]
            wins[r * n + c] = win if win.shape == (side, side) else cv2.resize(win, (side, side),
                                                                               interpolation=cv2.INTER_AREA)
    wins = np.minimum(wins / ref, 2.0)
    own = wins / np.maximum(wins.max(axis=(1, 2), keepdims=True), 0.05)  # the shape, whatever the darkness
    wins, own = wins.reshape(n * n, POOL, k, POOL, k), own.reshape(n * n, POOL, k, POOL, k)
    f = feats.reshape(n * n, 7)
    hand = np.stack([f[:, 0] / ref, f[:, 1], f[:, 2], f[:, 3], f[:, 4], np.minimum(f[:, 5], 10.0) / 10.0,
                     f[:, 6]], axis=1)
    return np.concatenate([wins.mean(axis=(2, 4)).reshape(n * n, -1), wins.max(axis=(2, 4)).reshape(n * n, -1),
                           own.max(axis=(2, 4)).reshape(n * n, -1), np.minimum(hand, 4.0), rule.reshape(n * n, 3),
                           np.full((n * n, 1), ref)], axis=1).astype(np.float32)


def rule_probs(x: np.ndarray) -> np.ndarray:
    """``(N, 3)`` the hand rule's probabilities of empty / X / O, as they lie in the inputs ``x``."""
    return np.asarray(x, np.float64)[:, _RULE:_RULE + 3]


def dihedral(x: np.ndarray) -> np.ndarray:
    """The 8 rotations and mirror images of each row's crops (the other inputs unchanged):
    ``(8 * N, N_INPUTS)``. An X turned or mirrored is still an X; so is an O."""
    crops = x[:, :CROPS * POOL * POOL].reshape(-1, CROPS, POOL, POOL)
    rest = x[:, CROPS * POOL * POOL:]
    out = []
    for flip in (False, True):
        c = crops[..., ::-1] if flip else crops
        for turn in range(4):
            out.append(np.concatenate([np.rot90(c, turn, axes=(2, 3)).reshape(len(x), -1), rest], axis=1))
    return np.concatenate(out, axis=0)


@dataclass
class CellModel:
    """Weights of the classifier (see the module docstring).

    Attributes:
        mean, scale: ``(N_INPUTS,)`` input standardisation.
        w1, b1: ``(N_INPUTS, H)``, ``(H,)`` hidden layer (ReLU).
        w2, b2: ``(H, 3)``, ``(3,)`` output logits (empty, X, O).
        temperature: the logits are divided by it before the softmax (calibration).
        rule_weight: how much the hand rule's own log-probabilities add to the logits (a weak
            prior: the rule was set on real photos, the network learnt on rendered ones).
        info: how the model was trained (a JSON object).
    """

    mean: np.ndarray
    scale: np.ndarray
    w1: np.ndarray
    b1: np.ndarray
    w2: np.ndarray
    b2: np.ndarray
    temperature: float = 1.0
    rule_weight: float = 0.0
    info: str = "{}"

    def logits(self, x: np.ndarray) -> np.ndarray:
        """``(N, 3)`` logits before the temperature."""
        h = np.maximum(((np.asarray(x, np.float32) - self.mean) / self.scale) @ self.w1 + self.b1, 0.0)
        return h @ self.w2 + self.b2

    def probs(self, x: np.ndarray) -> np.ndarray:
        """``(N, 3)`` calibrated probabilities of empty / X / O."""
        rule = rule_probs(x)
        z = self.logits(x) / self.temperature + self.rule_weight * np.log(np.clip(rule, 1e-4, 1.0))
        z = np.exp(z - z.max(axis=1, keepdims=True))
        return (z / z.sum(axis=1, keepdims=True)).astype(np.float64)

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        np.savez(buf, mean=self.mean, scale=self.scale, w1=self.w1, b1=self.b1, w2=self.w2, b2=self.b2,
                 temperature=np.float64(self.temperature), rule_weight=np.float64(self.rule_weight),
                 info=np.array(self.info))
        return buf.getvalue()

    @classmethod
    def load(cls, path: str | Path = SHIPPED_MODEL) -> CellModel:
        """A model saved by :meth:`to_bytes`; :class:`VisionError` names the file and what is wrong."""
        raw = read_bytes(path, _MAX_BYTES, "cell model (.npz)")
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                arrays = {key: z[key] for key in z.files}
        except (ValueError, OSError, EOFError) as err:
            raise VisionError(f"{path}: not a cell model ({err}); expected an .npz saved by CellModel") from None
        need = ("mean", "scale", "w1", "b1", "w2", "b2", "temperature", "rule_weight", "info")
        missing = [key for key in need if key not in arrays]
        if missing:
            raise VisionError(f"{path}: cell model lacks {', '.join(missing)}; expected the arrays {', '.join(need)}")
        w1, w2 = arrays["w1"], arrays["w2"]
        hidden = w1.shape[1] if w1.ndim == 2 else -1
        shapes_ok = (w1.shape == (N_INPUTS, hidden) and arrays["b1"].shape == (hidden,) and w2.shape == (hidden, 3)
                     and arrays["b2"].shape == (3,) and arrays["mean"].shape == arrays["scale"].shape == (N_INPUTS,))
        temperature, rule_weight = float(arrays["temperature"]), float(arrays["rule_weight"])
        if not shapes_ok or not 0 < temperature < np.inf or not 0 <= rule_weight <= 10:
            raise VisionError(f"{path}: cell model of shapes w1 {w1.shape}, w2 {w2.shape}, temperature {temperature}, "
                              f"rule weight {rule_weight}; expected w1 ({N_INPUTS}, H), w2 (H, 3), a positive "
                              "temperature and a rule weight in 0..10")
        f32 = {key: np.asarray(arrays[key], np.float32) for key in need[:6]}
        return cls(**f32, temperature=temperature, rule_weight=rule_weight, info=str(arrays["info"]))

    def describe(self) -> dict[str, object]:
        """The training record stored with the model."""
        return dict(json.loads(self.info))
