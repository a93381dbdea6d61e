"""Choosing the board's grid among hypotheses: which of the lines found is the drawn '#'.

A real photo can show more than one grid-like structure: the drawn '#' and graph paper's
rules, page edges, a second partial grid, a '#' whose pale lines only show at a low ink
threshold beside black marks. The :class:`~kinegym.vision.board_reader.BoardReader` therefore
makes several *hypotheses* (:data:`KINDS`: the straight ruled field, and the hand-drawn '#'
found in ink masks at three thresholds), reads the cells of each, and a :class:`GridArbiter`
(a logistic model over what the reading looks like, :data:`FEATURES`) gives each the
probability that it is the board read right. Hypotheses are made in order, cheapest first;
the first whose probability reaches the arbiter's ``accept`` level is taken, else the most
probable of all. A wrong grid reads as uncertain cells, no ink along its lines, a large
reprojection error or a field that fills the whole photo; the arbiter learnt from rendered
real-like photos (:mod:`kinegym.agents.train_grid_arbiter`) how much each of those counts.

The arbiter is a small JSON file shipped with the package (:data:`SHIPPED_ARBITER`), loaded
through the bounded reader and checked against :data:`FEATURES`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from kinegym.configs.io import read_bytes

from .errors import VisionError
from .ink import _apply

__all__ = ["KINDS", "PAGE_KINDS", "HUE_KINDS", "BASE_FEATURES", "FEATURES", "SHIPPED_ARBITER", "Hypothesis",
           "GridArbiter", "ONE_SIDE_FRAMED_P", "features", "with_kinds", "base_kind", "area_ratio", "wiggle",
           "same_grid", "same_lattice"]

#: The hypotheses, in the order they are made: the straight ruled field, then the '#' in ink
#: masks at 22 %, 45 % and 0 % (all ink above the noise) of the strongest ink.
KINDS: tuple[str, ...] = ("straight", "hash 22%", "hash 45%", "hash 0%")
#: The '#' sought once more at each share in the ink on the page alone (:mod:`~kinegym.vision.page`),
#: made after :data:`KINDS` when none was sure and the page lies amid something else; the arbiter
#: weighs each as the kind of its share (stop 58: +11 -4 boards, refusals 6 -> 1, on 1,000 real-like photos).
PAGE_KINDS: tuple[str, ...] = tuple(f"{k} page" for k in KINDS if k != "straight")
#: On ruled or graph paper whose rules have a colour of their own, the '#' sought last at 22 % and
#: 0 % in the ink not of the rules' colour, however pale (a teal '#' on blue rules, no darker
#: than they are; :func:`~kinegym.vision.hand_grid.find_hash_grid`'s ``other_colour``), when
#: none was sure and a '#' found before lay on ruled paper; the arbiter weighs each as the kind of
#: its share (stop 62: +2 -1 boards on 1,000 real-like photos, the real photos' readings as they were).
HUE_KINDS: tuple[str, ...] = ("hash 22% hue", "hash 0% hue")
_HASH_SHARES = {"hash 22%": 0.22, "hash 45%": 0.45, "hash 0%": 0.0}
#: Hash kinds' ink shares (see :func:`~kinegym.vision.hand_grid.find_hash_grid`); a page or hue kind's is its share's.
SHARES = {**_HASH_SHARES, **{f"{k} page": v for k, v in _HASH_SHARES.items()},
          **{k: _HASH_SHARES[k.removesuffix(" hue")] for k in HUE_KINDS}}
#: What a hypothesis's reading looks like (:func:`features`, before the kind's own copies).
BASE_FEATURES: tuple[str, ...] = (
    *(f"kind={k}" for k in KINDS),
    "5x5",               # the grid found is 5 x 5
    "conf_mean",         # mean of the cells' top probability
    "conf_min",          # the least sure cell
    "log_conf_mean",     # mean log top probability (one very unsure cell weighs)
    "marked_share",      # share of cells called X or O
    "err_cells",         # reprojection error of the lattice, in cells
    "log_field_share",   # log of the field's side over the image's diagonal (at most 2)
    "line_contrast",     # darkness along the grid lines (0..1)
    "line_coverage",     # share of the interior lines' length that carries ink
    "hash_score",        # the '#' search's own score per crossing (0 for the straight field; -1..2)
    "log_area_ratio",    # log of the largest cell's area over the smallest's, in the photo
    "wiggle",            # the '#' lines' farthest point off a smooth curve, in cells (0 for the straight field)
)
_PER_KIND = BASE_FEATURES[len(KINDS):]
#: What the arbiter sees: :data:`BASE_FEATURES`, then each non-kind feature again for each kind
#: (zero for the other kinds): a straight field's confidences mean something else than a '#''s.
FEATURES: tuple[str, ...] = (*BASE_FEATURES, *(f"{f}|{k}" for k in KINDS for f in _PER_KIND))
#: The most a straight field framed on one side only is given (:meth:`GridArbiter.weigh`). No board is
#: framed on one side (the renderer's printed boards lose at most two of four); on a hand-drawn '#'
#: such a field is a row or column line taken for a border - the lines crossing it stop there, or a
#: line gone over twice looks so - and the field is shifted by a cell. The arbiter, whose features
#: do not show the frame, gave those 0.91-0.95 (real-like seeds 20,000-20,999: 20 such readings, 7
#: shifted; in 4 of the 7 a '#' reading of the same photo was right, at p 0.86-0.95).
ONE_SIDE_FRAMED_P = 0.5
SHIPPED_ARBITER = Path(__file__).resolve().parent / "data" / "grid_arbiter.json"
_MAX_BYTES = 1 << 20


@dataclass
class Hypothesis:
    """One grid found and its cells read: ``kind`` (:data:`KINDS`), ``H`` cells to working px,
    ``err`` reprojection error (working px), ``npts`` lattice points, ``frame`` which sides are
    framed, ``n`` cells a side, ``probs`` ``(n, n, 3)``, ``feats`` and ``inputs`` (the cell
    classifier's), ``line_ref`` / ``coverage`` the grid lines' darkness and inked share,
    ``score`` the '#' search's score per crossing (0 for the straight field), ``diag`` the
    working image's diagonal (px), ``trace`` what the search recorded, ``p`` the arbiter's
    probability (None before it was asked), ``scale`` working px per photo px (``H`` in the
    photo's px is ``diag(1 / scale, 1 / scale, 1) @ H``)."""

    kind: str
    H: np.ndarray
    err: float
    npts: int
    frame: tuple[bool, bool, bool, bool]
    n: int
    probs: np.ndarray
    feats: np.ndarray
    inputs: np.ndarray
    line_ref: float
    coverage: float
    score: float
    diag: float
    trace: dict[str, object] = field(default_factory=dict)
    p: float | None = None
    scale: float = 1.0
    lattice: np.ndarray | None = None  # the crossings' own lattice, where the cells were read with another ``H``

    @property
    def found(self) -> np.ndarray:
        """The grid's lattice as found (cells to working px): ``H``, or the crossings' own
        projective lattice where the cells were read with its affine fit (a hand's converging
        lines, :func:`~kinegym.vision.hash_cells.read_hash`). The arbiter's features describe it."""
        return self.H if self.lattice is None else self.lattice


def cell_side_px(H: np.ndarray, n: int) -> float:
    """The side of the middle cell (px) under ``H`` (cells to px)."""
    c = n / 2.0
    p = _apply(H, np.array([[c, c], [c + 1, c], [c, c + 1]]))
    return float(0.5 * (np.hypot(*(p[1] - p[0])) + np.hypot(*(p[2] - p[0]))))


def features(h: Hypothesis) -> np.ndarray:
    """The hypothesis as the arbiter sees it, in the order of :data:`FEATURES`."""
    conf = h.probs.reshape(-1, 3).max(axis=1)
    side = max(cell_side_px(h.found, h.n), 1e-6)
    kind = [float(base_kind(h.kind) == k) for k in KINDS]  # a page or hue kind as its share's
    base = np.array([*kind, float(h.n == 5), conf.mean(), conf.min(), np.log(np.clip(conf, 1e-4, 1.0)).mean(),
                     float((h.probs.reshape(-1, 3).argmax(axis=1) > 0).mean()), h.err / side,
                     min(math.log(max(h.n * side / max(h.diag, 1.0), 1e-3)), 2.0), h.line_ref, h.coverage,
                     min(max(h.score, -1.0), 2.0),  # a '#' the search scored -inf still reads
                     min(area_ratio(h.found, h.n), 10.0), min(wiggle(h), 2.0)])
    return with_kinds(base)


def base_kind(kind: str) -> str:
    """The kind of :data:`KINDS` a hypothesis kind is weighed as: a page or hue kind as its share's."""
    return kind.removesuffix(" page").removesuffix(" hue")


def area_ratio(H: np.ndarray, n: int) -> float:
    """log(largest / smallest) area of the ``n`` x ``n`` cells under ``H`` (cells to px): a
    lattice bent by a wrong line makes cells of very different sizes."""
    g = _apply(H, np.stack(np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="ij"), -1).reshape(-1, 2))
    g = g.reshape(n + 1, n + 1, 2)
    a, b, c, d = g[:-1, :-1], g[1:, :-1], g[1:, 1:], g[:-1, 1:]
    u, v = c - a, d - b  # the diagonals: a quadrilateral's area is half their cross product
    area = 0.5 * np.abs(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])
    return float(math.log(max(area.max(), 1e-9) / max(area.min(), 1e-9)))


def wiggle(h: Hypothesis) -> float:
    """The '#' lines' largest distance from a quadratic through them, in cells: a hand-drawn
    line waves gently, a track that jumps onto a mark's stroke zigzags (0 for straight fields)."""
    grid = h.trace.get("hash")
    if grid is None:
        return 0.0
    side = max(cell_side_px(grid.H, grid.n), 1e-6)  # type: ignore[attr-defined]
    worst = 0.0
    for tr in grid.cols + grid.rows:  # type: ignore[attr-defined]
        p = np.asarray(tr.dense, np.float64)
        chord = p[-1] - p[0]
        length = float(np.hypot(*chord))
        if len(p) < 5 or length < 1e-6:
            continue
        u = chord / length
        t, off = (p - p[0]) @ u, (p - p[0]) @ np.array([-u[1], u[0]])
        res = off - np.polyval(np.polyfit(t, off, 2), t)
        worst = max(worst, float(np.abs(res).max()) / side)
    return worst


def with_kinds(base: np.ndarray) -> np.ndarray:
    """Rows of :data:`BASE_FEATURES` (``(..., B)``) with each kind's copies appended (:data:`FEATURES`)."""
    k = len(KINDS)
    rest = base[..., k:]
    return np.concatenate([base, *(rest * base[..., j:j + 1] for j in range(k))], axis=-1)


def same_grid(a: Hypothesis, b: Hypothesis) -> bool:
    """Whether two hypotheses found the same grid (:func:`same_lattice`)."""
    return a.n == b.n and same_lattice(a.found, b.found, a.n)


def same_lattice(Ha: np.ndarray, Hb: np.ndarray, n: int) -> bool:
    """Whether two ``n`` x ``n`` grids (cells to px) put every lattice point within a tenth of a cell."""
    g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1)), -1).reshape(-1, 2).astype(np.float64)
    dist = np.hypot(*(_apply(Ha, g) - _apply(Hb, g)).T)
    return bool(dist.max() < 0.1 * cell_side_px(Ha, n))


@dataclass
class GridArbiter:
    """A logistic model over :data:`FEATURES`: ``mean`` / ``scale`` standardise, ``weights`` and
    ``bias`` weigh; ``accept`` is the probability at which a hypothesis is taken without making
    the rest; ``info`` the training record."""

    mean: np.ndarray
    scale: np.ndarray
    weights: np.ndarray
    bias: float
    accept: float
    info: dict[str, object] = field(default_factory=dict)

    def weigh(self, h: Hypothesis) -> float:
        """The probability that ``h`` reads the board right: :meth:`prob` of its :func:`features`, at
        most :data:`ONE_SIDE_FRAMED_P` for a straight field framed on one side only, which its
        features do not show."""
        p = float(self.prob(features(h)[None])[0])
        return min(p, ONE_SIDE_FRAMED_P) if base_kind(h.kind) == "straight" and sum(h.frame) == 1 else p

    def prob(self, x: np.ndarray) -> np.ndarray:
        """The probability that each row of ``x`` (:func:`features`) is the board read right."""
        z = ((np.asarray(x, np.float64) - self.mean) / self.scale) @ self.weights + self.bias
        return 1.0 / (1.0 + np.exp(-np.clip(z, -50.0, 50.0)))

    def to_json(self) -> str:
        return json.dumps({"features": list(FEATURES), "mean": self.mean.tolist(), "scale": self.scale.tolist(),
                           "weights": self.weights.tolist(), "bias": self.bias, "accept": self.accept,
                           "info": self.info}, indent=1)

    @classmethod
    def load(cls, path: str | Path = SHIPPED_ARBITER) -> GridArbiter:
        """An arbiter saved by :meth:`to_json`; :class:`VisionError` names the file and what is wrong."""
        raw = read_bytes(path, _MAX_BYTES, "grid arbiter (.json)")
        try:
            obj = json.loads(raw)
        except (ValueError, UnicodeDecodeError) as err:
            raise VisionError(f"{path}: not a grid arbiter ({err}); expected JSON saved by GridArbiter") from None
        if not isinstance(obj, dict) or obj.get("features") != list(FEATURES):
            got = obj.get("features") if isinstance(obj, dict) else type(obj).__name__
            raise VisionError(f"{path}: grid arbiter over features {got!r}; expected {list(FEATURES)} (an arbiter "
                              "of another reader? retrain it with python -m kinegym.agents.train_grid_arbiter)")
        try:
            arrays = [np.asarray(obj[key], np.float64) for key in ("mean", "scale", "weights")]
            bias, accept = float(obj["bias"]), float(obj["accept"])
        except (KeyError, TypeError, ValueError) as err:
            raise VisionError(f"{path}: grid arbiter lacks or mistypes {err}; expected mean, scale, weights "
                              "(one number per feature), bias and accept") from None
        k = len(FEATURES)
        if any(a.shape != (k,) or not np.isfinite(a).all() for a in arrays) or not (arrays[1] > 0).all() \
                or not math.isfinite(bias) or not 0.0 < accept <= 1.0:
            raise VisionError(f"{path}: grid arbiter with shapes {[a.shape for a in arrays]}, bias {bias}, accept "
                              f"{accept}; expected {k} finite numbers each (positive scales), a finite bias and "
                              "accept in (0, 1]")
        info = obj.get("info", {})
        return cls(*arrays, bias, accept, info if isinstance(info, dict) else {})
