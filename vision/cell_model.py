"""The learned cell classifier: a small convolutional network, run in numpy, shipped in the
package (``vision/data/cell_model.npz``), that turns what the reader sees of one cell into
calibrated empty / X / O probabilities.

What it sees of a cell (:func:`cell_inputs`, one row per cell):

* the window: the cell and a quarter cell around it (an outer cell of a hand-drawn grid: as
  far out as its mark may lie), from the rectified ink map with the grid lines removed,
  resized to ``WIN`` x ``WIN`` (area means), its darkness over the grid lines' own darkness,
  clipped to 0..2 - so a faint pen on a faint grid looks like a dark pen on a dark grid;
* the seven hand features of :func:`~kinegym.vision.cells.board_features` (peak over the
  lines' darkness, ink, hollow, hole, extent, elongation, spread);
* the hand rule's three probabilities (:func:`~kinegym.vision.cells._probabilities`);
* the lines' darkness itself.

The network (:meth:`CellModel.logits`): three views of the window (:func:`channels`) - the
darkness as it is, its square root (a pale pen's strokes stand out of the paper's noise) and
over the window's own darkest ink (the mark's shape whatever its darkness: a pale X beside
black lines is still an X) - go through three stages of a 3 x 3 convolution, ReLU and 2 x 2
max-pooling; what comes out, with the standardised hand features, goes through one hidden
ReLU layer to three logits. Those are divided by a temperature fitted on held-out photos (a
confidence of 0.9 is right about nine times in ten), a small weight times the hand rule's
log-probabilities is added - a prior that keeps the rule's say where the network, which has
seen rendered photos only, is unsure - and a softmax gives the probabilities.
:mod:`kinegym.agents.train_cells` trains it (in torch) on the rendered real-like and hard sets;
reading needs numpy only. The file records how it was trained (``info``).

The reader's default is a :class:`CellEnsemble` of two such networks (:data:`SHIPPED_MODELS`):
one trained on the cells of the first grid found, one on the cells of every grid hypothesis
whose grid is right (``train_cells --all-grids``); their probabilities are averaged. The second
reads more rendered real-like boards, the first is surer of the real photos' looped marks
(``bench/README.md``); together they keep the real photos and gain on the rendered ones.
"""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from kinegym.configs.io import read_bytes

from .errors import VisionError

__all__ = ["WIN", "N_CHANNELS", "N_SCALARS", "N_INPUTS", "CellModel", "CellEnsemble", "cell_inputs", "channels",
           "rule_probs", "load_cell_model", "SHIPPED_MODEL", "SHIPPED_MODELS"]

#: side of a cell's window (px) as the network sees it
WIN = 32
#: inputs per cell besides the window: 7 hand features, 3 rule probabilities, the line darkness
N_SCALARS = 7 + 3 + 1
#: inputs per cell: the window, then the scalars
N_INPUTS = WIN * WIN + N_SCALARS
_RULE = WIN * WIN + 7  # where the rule's probabilities start
#: views of the window the network sees (:func:`channels`)
N_CHANNELS = 3
#: the model the reader uses by default
SHIPPED_MODEL = Path(__file__).with_name("data") / "cell_model.npz"
#: the ensemble the reader uses by default: the first-grid model and the every-right-grid one
SHIPPED_MODELS = (SHIPPED_MODEL, SHIPPED_MODEL.with_name("cell_model_all_grids.npz"))
_MAX_BYTES = 8 << 20
_ARRAYS = ("cmean", "cscale", "smean", "sscale", "k1", "b1", "k2", "b2", "k3", "b3", "w4", "b4", "w5", "b5")


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
    lo = [ext if i == 0 else m for i in range(n)]
    hi = [ext if i == n - 1 else m for i in range(n)]
    wins = np.empty((n * n, WIN, WIN), np.float32)
    for r in range(n):
        for c in range(n):
            y0, x0 = ext + o + r * s - lo[r], ext + o + c * s - lo[c]  # in ``padded``
            win = padded[y0:y0 + s + lo[r] + hi[r], x0:x0 + s + lo[c] + hi[c]]
            wins[r * n + c] = cv2.resize(win, (WIN, WIN), interpolation=cv2.INTER_AREA)
    f = feats.reshape(n * n, 7)
    hand = np.stack([f[:, 0] / ref, f[:, 1], f[:, 2], f[:, 3], f[:, 4], np.minimum(f[:, 5], 10.0) / 10.0,
                     f[:, 6]], axis=1)
    return np.concatenate([np.clip(wins / ref, 0.0, 2.0).reshape(n * n, -1), np.minimum(hand, 4.0),
                           rule.reshape(n * n, 3), np.full((n * n, 1), ref)], axis=1).astype(np.float32)


def channels(x: np.ndarray) -> np.ndarray:
    """``(N, N_CHANNELS, WIN, WIN)`` float32: the three views of each row's window (module
    docstring) - darkness over the lines', its square root, and over the window's darkest."""
    w = np.asarray(x, np.float32)[:, :WIN * WIN].reshape(-1, WIN, WIN)
    own = w / np.maximum(w.max(axis=(1, 2), keepdims=True), 0.05)
    return np.stack([w, np.sqrt(w), own], axis=1)


def rule_probs(x: np.ndarray) -> np.ndarray:
    """``(N, 3)`` the hand rule's probabilities of empty / X / O, as they lie in the inputs ``x``."""
    return np.asarray(x, np.float64)[:, _RULE:_RULE + 3]


def _conv_relu_pool(a: np.ndarray, k: np.ndarray, b: np.ndarray) -> np.ndarray:
    """One stage on channels-first-then-cells ``a`` ``(C, N, H, W)``: a 3 x 3 convolution padded
    by 1 with kernels ``k`` ``(O, C, 3, 3)`` (torch's layout), ReLU, 2 x 2 max-pooling:
    ``(O, N, H / 2, W / 2)``.

    The convolution is one matrix product over the unfolded windows, whose columns are laid
    out by pooling phase, so the pooling is a maximum of four contiguous blocks; the bias and
    ReLU come after it (both rise monotonically, so they commute with the maximum exactly)."""
    c, nb, h, w = a.shape
    p = np.pad(a, ((0, 0), (0, 0), (1, 1), (1, 1)))
    win = sliding_window_view(p, (3, 3), axis=(2, 3)).reshape(c, nb, h // 2, 2, w // 2, 2, 3, 3)
    cols = win.transpose(0, 6, 7, 3, 5, 1, 2, 4).reshape(c * 9, 4 * nb * (h // 2) * (w // 2))
    out = (k.reshape(len(k), c * 9) @ cols).reshape(len(k), 4, -1)
    pooled = np.maximum(np.maximum(out[:, 0], out[:, 1]), np.maximum(out[:, 2], out[:, 3]))
    pooled += b[:, None]
    np.maximum(pooled, 0.0, out=pooled)
    return pooled.reshape(len(k), nb, h // 2, w // 2)


@dataclass
class CellModel:
    """Weights of the classifier (see the module docstring); torch's layouts.

    Attributes:
        cmean, cscale: ``(N_CHANNELS,)`` standardisation of the window's views.
        smean, sscale: ``(N_SCALARS,)`` standardisation of the scalar inputs.
        k1, b1, k2, b2, k3, b3: the three convolutions ``(O, C, 3, 3)``, ``(O,)``.
        w4, b4: ``(k3 channels * (WIN / 8) ** 2 + N_SCALARS, H)``, ``(H,)`` the hidden layer.
        w5, b5: ``(H, 3)``, ``(3,)`` the logits (empty, X, O).
        temperature: the logits are divided by it before the softmax (calibration).
        rule_weight: how much the hand rule's own log-probabilities add to the logits (a weak
            prior: the rule was set on real photos, the network learnt on rendered ones).
        info: how the model was trained (a JSON object).
    """

    cmean: np.ndarray
    cscale: np.ndarray
    smean: np.ndarray
    sscale: np.ndarray
    k1: np.ndarray
    b1: np.ndarray
    k2: np.ndarray
    b2: np.ndarray
    k3: np.ndarray
    b3: np.ndarray
    w4: np.ndarray
    b4: np.ndarray
    w5: np.ndarray
    b5: np.ndarray
    temperature: float = 1.0
    rule_weight: float = 0.0
    info: str = "{}"

    def logits(self, x: np.ndarray) -> np.ndarray:
        """``(N, 3)`` logits before the temperature."""
        x = np.asarray(x, np.float32)
        a = ((channels(x) - self.cmean[:, None, None]) / self.cscale[:, None, None]).transpose(1, 0, 2, 3)
        for k, b in ((self.k1, self.b1), (self.k2, self.b2), (self.k3, self.b3)):
            a = _conv_relu_pool(a, k, b)
        flat = a.transpose(1, 0, 2, 3).reshape(len(x), -1)  # each cell's (C, H, W), as torch flattens
        scalars = (x[:, WIN * WIN:] - self.smean) / self.sscale
        h = np.maximum(np.concatenate([flat, scalars], axis=1) @ self.w4 + self.b4, 0.0)
        return h @ self.w5 + self.b5

    def probs(self, x: np.ndarray) -> np.ndarray:
        """``(N, 3)`` calibrated probabilities of empty / X / O."""
        return self.calibrated(self.logits(x), rule_probs(x))

    def calibrated(self, logits: np.ndarray, rule: np.ndarray) -> np.ndarray:
        """:meth:`probs` from the network's ``logits`` and the hand rule's probabilities
        ``rule`` (both ``(N, 3)``), at this model's temperature and rule weight: lets a caller
        that tries many temperatures run the network once."""
        z = logits / self.temperature + self.rule_weight * np.log(np.clip(rule, 1e-4, 1.0))
        z = np.exp(z - z.max(axis=1, keepdims=True))
        return (z / z.sum(axis=1, keepdims=True)).astype(np.float64)

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        np.savez(buf, **{key: getattr(self, key) for key in _ARRAYS}, temperature=np.float64(self.temperature),
                 rule_weight=np.float64(self.rule_weight), info=np.array(self.info))
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
        need = (*_ARRAYS, "temperature", "rule_weight", "info")
        missing = [key for key in need if key not in arrays]
        if missing:
            raise VisionError(f"{path}: cell model lacks {', '.join(missing)}; expected the arrays {', '.join(need)} "
                              "(a model of an older reader? retrain it with python -m kinegym.agents.train_cells)")
        f32 = {key: np.asarray(arrays[key], np.float32) for key in _ARRAYS}
        temperature, rule_weight = float(arrays["temperature"]), float(arrays["rule_weight"])
        problem = _shape_problem(f32)
        if problem or not 0 < temperature < np.inf or not 0 <= rule_weight <= 10:
            raise VisionError(f"{path}: cell model with {problem or 'consistent shapes'}, temperature {temperature}, "
                              f"rule weight {rule_weight}; expected three 3 x 3 convolutions from {N_CHANNELS} "
                              f"channels, a hidden layer over their {WIN // 8} x {WIN // 8} output and "
                              f"{N_SCALARS} scalars, 3 logits, a positive temperature and a rule weight in 0..10")
        return cls(**f32, temperature=temperature, rule_weight=rule_weight, info=str(arrays["info"]))

    def describe(self) -> dict[str, object]:
        """The training record stored with the model."""
        return dict(json.loads(self.info))


@dataclass
class CellEnsemble:
    """Several :class:`CellModel` read alike: :meth:`probs` is the mean of theirs (each calibrated
    on its own, so the mean is a mixture of calibrated forecasts)."""

    members: tuple[CellModel, ...]

    def __post_init__(self) -> None:
        if not self.members:
            raise VisionError("a cell ensemble of no models; expected at least one CellModel")

    def probs(self, x: np.ndarray) -> np.ndarray:
        """``(N, 3)`` the members' probabilities of empty / X / O, averaged."""
        return sum(m.probs(x) for m in self.members) / len(self.members)  # type: ignore[return-value]

    @classmethod
    def load(cls, paths: tuple[str | Path, ...] | list[str | Path] = SHIPPED_MODELS) -> CellEnsemble:
        """The models saved at ``paths`` (:meth:`CellModel.load` each; its errors name the file)."""
        return cls(tuple(CellModel.load(p) for p in paths))

    def describe(self) -> list[dict[str, object]]:
        """Each member's training record."""
        return [m.describe() for m in self.members]


def load_cell_model(spec: str | Path | Sequence[str | Path]) -> CellModel | CellEnsemble:
    """``"shipped"``: the package's ensemble (:data:`SHIPPED_MODELS`); a list or tuple of paths:
    their ensemble; a path: that model."""
    if isinstance(spec, str) and spec == "shipped":
        return CellEnsemble.load(SHIPPED_MODELS)
    if isinstance(spec, (list, tuple)):
        return CellEnsemble.load(list(spec))
    return CellModel.load(spec)  # type: ignore[arg-type]


def _shape_problem(a: dict[str, np.ndarray]) -> str:
    """What is inconsistent in a model's arrays (``""`` when nothing)."""
    c_in = N_CHANNELS
    for i in (1, 2, 3):
        k, b = a[f"k{i}"], a[f"b{i}"]
        if k.ndim != 4 or k.shape[1:] != (c_in, 3, 3) or b.shape != (k.shape[0],):
            return f"k{i} {k.shape} and b{i} {b.shape} after {c_in} channels"
        c_in = k.shape[0]
    w4, b4, w5, b5 = a["w4"], a["b4"], a["w5"], a["b5"]
    flat = c_in * (WIN // 8) ** 2 + N_SCALARS
    if w4.ndim != 2 or w4.shape[0] != flat or b4.shape != (w4.shape[1],) or w5.shape != (w4.shape[1], 3) \
            or b5.shape != (3,):
        return f"w4 {w4.shape}, b4 {b4.shape}, w5 {w5.shape}, b5 {b5.shape} after {flat} inputs"
    if any(a[key].shape != (N_CHANNELS,) for key in ("cmean", "cscale")) \
            or any(a[key].shape != (N_SCALARS,) for key in ("smean", "sscale")):
        return f"standardisation of shapes {a['cmean'].shape}, {a['smean'].shape}"
    return ""
