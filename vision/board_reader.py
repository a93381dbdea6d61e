"""Read a tic-tac-toe board from a camera image: find the grid, undo the perspective, and
call every cell empty, X or O with a confidence. OpenCV + numpy only.

Pipeline of :class:`BoardReader` (every frame from scratch: the paper may move):

1. **Ink map** (:func:`~kinegym.vision.ink.ink_map`). Luma darkness against the local
   background, ``1 - Y / background(Y)``, the background a morphological closing (removes
   strokes, keeps light gradients, shadows and glare): every pen colour is dark, a yellow
   highlighter nearly invisible, uneven light undone. A noisy photo is smoothed first.
2. **Grid.** Long straight segments (probabilistic Hough on the thresholded map) are
   merged into lines, split into the two families of the grid by direction (perspective
   lets each family fan out), and ordered across. The longest lines of each family are
   the field's; a family's outermost line is a *frame* line when the other family stops
   at it, an *interior* line when the other family runs on for about a cell (interior-only
   fields, full frames, frames with sides missing). The board size follows from the number
   of interior lines, or is given.
3. **Homography.** Every intersection of a column line with a row line is a point of the
   ideal grid; a least-squares homography maps grid coordinates (cells) to pixels (its
   reprojection error and the grid points found: the grid's confidence). A lattice whose
   cells grow more than 3 x across the field (a camera tilted 35 deg: 2.6 x) was
   extrapolated from wrong lines: the next lattice hypothesis is tried instead.
4. **Cells.** The ink map is warped onto a square grid of ``cell_px`` per cell, the grid
   lines are masked out, and each cell's ink is measured: its amount (against a threshold
   set from the grid lines' own contrast: faint ghosts of erased games fall below it), ink
   at the centre of the mark (an X crosses there, an O is hollow) and an enclosed hole. A
   logistic rule turns them into probabilities; a small trained convolutional network
   (:mod:`~kinegym.vision.cell_model`, shipped, run in numpy) reads the cell's window of ink
   and those features and gives the calibrated probabilities returned (``model=None``: the rule's).

**Hand-drawn grids.** A real person's '#' (wavy, converging lines, no frame, one line
stopping at a crossing, pale or coloured pen) is looked for as a hand-drawn '#'
(:mod:`~kinegym.vision.hand_grid`: strokes traced as curves, four chosen by how a tic-tac-toe
grid looks, found on a copy of the photo at one fixed scale whatever its size). Its traced
lines are erased from the ink, a cell of the photo's px is max-pooled onto the rectified cell
(a thin pen would alias into dots), the ink level is the photo's own (noise and strongest
strokes, not a fixed floor), and a mark whose centre lies up to 0.9 of a cell past the
crossings' lattice still belongs to its outer cell (real outer cells are larger than the
middle one).

**Choosing.** The straight field and the '#' at three ink thresholds are *hypotheses*
(:mod:`~kinegym.vision.grid_choice`), made in that order, each with its cells read; a
trained :class:`~kinegym.vision.grid_choice.GridArbiter` gives each the probability that it
reads the board right. The first that reaches its accept level is taken, else the most
probable made (on rendered and lab boards the straight field is taken at once). A lower accept
level (``BoardReader(accept=...)``) makes fewer hypotheses: faster, less often right. An unsure
reading of a field small in the photo is read again on a crop around it (:mod:`~kinegym.vision.zoom`).

Rows are returned top to bottom and columns left to right *as the image shows them*
(a board turned more than 45 degrees reads turned). :class:`ThresholdReader` keeps seed
003's rule as the baseline: the share of pixels darker than a grey level in fixed image
regions, which says "filled" or "empty" and cannot tell X from O.

No board in the image raises :class:`NoBoardError` (with the reason), never a guess.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

import cv2
import numpy as np

from .cell_model import CellEnsemble, CellModel, cell_inputs, load_cell_model
from .cells import _probabilities, _remove_grid_lines, board_features
from .counts import count_rule, most_probable_board
from .debug import debug_image
from .errors import NoBoardError, VisionError
from .grid_choice import HUE_KINDS, KINDS, PAGE_KINDS, SHIPPED_ARBITER, GridArbiter, Hypothesis
from .grid_lines import (
    _crossing,
    _crossings,
    _families,
    _Line,
    _median,
    _merge,
    _percentile,
    _refit,
    _segments,
    _union_length,
)
from .hash_cells import SearchCopy, line_contrast, read_hash
from .ink import NOISY_SIGMA, _apply, _as_rgb, denoised, ink_map, noise_sigma
from .reading import EMPTY, BoardReading, O, X
from .threshold_reader import ThresholdReader
from .zoom import second_look

__all__ = ["EMPTY", "X", "O", "BoardReading", "BoardReader", "ThresholdReader", "NoBoardError", "VisionError",
           "ink_map", "board_features", "debug_image"]


class BoardReader:
    """Finds the grid and reads every cell (see the module docstring).

    Args:
        size: 3 or 5 cells a side, or None to decide from the number of grid lines.
        cell_px: side of a rectified cell (px) for the cell features.
        max_side_px: larger images are shrunk to this longer side first (speed).
        grid_px: the grid is searched on a copy shrunk to about this longer side.
        model: the cell classifier - a :class:`CellModel` or :class:`CellEnsemble`, a model's path, a
            list of paths (their ensemble), ``"shipped"`` (the package's ensemble) or None (the hand rule).
        arbiter: what chooses among grid hypotheses - a :class:`GridArbiter`, the path of one,
            ``"shipped"`` or None for the first grid found.
        counts: the X and O counts a board may have (:data:`~kinegym.vision.counts.COUNT_RULES`):
            ``"alternate"`` (players take turns), ``"x-first"``, ``"o-first"`` or ``"any"`` (each
            cell's own most probable call); a reading that breaks the rule becomes the most
            probable board that keeps it (:func:`~kinegym.vision.counts.most_probable_board`).
        accept: the arbiter probability at which a hypothesis is taken without making the rest, in
            [0, 1]: lower reads faster and less often right (0: the first grid found; 1: every
            hypothesis made; bench/README.md "Speed against boards" measures the trade), None the
            arbiter's own level (``arbiter.accept``, chosen when it was trained).
        zoom: read an unsure reading of a field small in the photo again on a crop around it
            (:mod:`~kinegym.vision.zoom`; slower on such photos, more often right).
    """

    def __init__(self, size: int | None = None, cell_px: int = 40, max_side_px: int = 800,
                 grid_px: int = 400, model: CellModel | CellEnsemble | str | Sequence[str] | None = "shipped",
                 arbiter: GridArbiter | str | None = "shipped", counts: str = "alternate",
                 accept: float | None = None, zoom: bool = True) -> None:
        if size not in (None, 3, 5):
            raise VisionError(f"size={size!r}; expected 3, 5 or None (decide from the image)")
        if not 12 <= int(cell_px) <= 200:  # a grid line's band (a fifth of a cell) must fit in the margin
            raise VisionError(f"cell_px={cell_px!r}; expected 12..200 pixels per rectified cell")
        if min(int(max_side_px), int(grid_px)) < 64:
            raise VisionError(f"max_side_px={max_side_px!r}, grid_px={grid_px!r}; expected at least 64 pixels each")
        self.size, self.cell_px, self.max_side_px, self.grid_px = size, int(cell_px), int(max_side_px), int(grid_px)
        if model is not None and not isinstance(model, (CellModel, CellEnsemble)):
            if self.cell_px != 40:  # the shipped model was trained on 40 px cells
                raise VisionError(f"cell_px={cell_px!r} with a trained cell model; the model reads 40 px cells "
                                  "(pass model=None for the hand rule at other sizes)")
            model = load_cell_model(model)
        self.model = model
        if arbiter is not None and not isinstance(arbiter, GridArbiter):
            arbiter = GridArbiter.load(SHIPPED_ARBITER if arbiter == "shipped" else arbiter)
        self.arbiter = arbiter
        count_rule(counts)  # an unknown rule is named here
        self.counts = counts
        if accept is not None and not (isinstance(accept, (int, float)) and 0.0 <= accept <= 1.0):
            raise VisionError(f"accept={accept!r}; expected a probability in [0, 1] (0: the first grid found, "
                              "1: every hypothesis) or None (the arbiter's own level)")
        self.accept, self.zoom = (None if accept is None else float(accept)), bool(zoom)

    def read(self, image: object, trace: dict[str, object] | None = None) -> BoardReading:
        """Read one image (uint8 RGB or grey); raises :class:`NoBoardError` without a board.

        ``trace``, if given, is filled with the intermediate results (lines, lattice, ...), in the
        coordinates of the possibly shrunk working image (``trace["scale"]``), for :func:`debug_image`,
        ``trace["hypotheses"]``: each grid tried, (kind, probability), ``trace["kind"]``: the one read,
        ``trace["noise"]``: the photo's noise estimate (smoothed first above ``NOISY_SIGMA``), and
        ``trace["count_changed"]``: the (row, column) of cells the count rule called otherwise. With
        ``zoom``, an unsure reading of a small field is read again on a crop around it
        (:func:`~kinegym.vision.zoom.second_look`; ``trace["zoom"]``: the crop box)."""
        reading = self._read_once(rgb := _as_rgb(image), trace)  # (a grey photo turned to RGB once)
        return second_look(self._read_once, rgb, reading, self._accept(), trace) if self.zoom else reading

    def _accept(self) -> float:
        return self.accept if self.accept is not None else self.arbiter.accept if self.arbiter is not None else 0.0

    def _read_once(self, image: object, trace: dict[str, object] | None = None) -> BoardReading:
        """:meth:`read` without the second look."""
        made, reasons = [], []
        accept = self._accept()
        for hyp in self._hypotheses(image, reasons, trace):
            made.append(hyp)
            if hyp.p >= accept:  # (without an arbiter every p is 1: the first grid found)
                break
        if not made:
            if trace is not None:
                trace["hypotheses"] = []
            raise NoBoardError("; ".join(reasons))
        best = max(made, key=lambda h: h.p)
        cells = most_probable_board(best.probs, self.counts)
        conf = np.take_along_axis(best.probs, cells[..., None], axis=-1)[..., 0]
        if trace is not None:  # count_changed: the cells the count rule called otherwise than their own call
            trace.update(best.trace)
            trace["hypotheses"], trace["kind"] = [(h.kind, h.p) for h in made], best.kind
            trace["count_changed"] = [(int(r), int(c)) for r, c in np.argwhere(cells != best.probs.argmax(axis=-1))]
        scale, H, err = best.scale, best.H, best.err
        if scale < 1.0:  # the working copy's px to the photo's
            H, err = np.diag([1 / scale, 1 / scale, 1.0]) @ H, err / scale
        return BoardReading(cells.astype(np.int64), conf, best.probs, H, float(err), best.npts, best.frame, best.feats,
                            None if self.arbiter is None else float(best.p or 0.0))

    def hypotheses(self, image: object) -> list[Hypothesis]:
        """Every grid hypothesis of :data:`~kinegym.vision.grid_choice.KINDS` (then ``PAGE_KINDS``, ``HUE_KINDS``) that
        finds a grid (the same grid once), its cells read and its arbiter probability ``p`` (1.0 without an
        arbiter): what :meth:`read` chooses from, for training and inspecting the arbiter."""
        return list(self._hypotheses(image, []))

    def _hypotheses(self, image: object, reasons: list[str], info: dict[str, object] | None = None
                    ) -> Iterator[Hypothesis]:
        """The hypotheses, lazily, in :data:`KINDS`, ``PAGE_KINDS``, ``HUE_KINDS`` (on ruled paper) order; a kind that
        finds nothing adds its reason to ``reasons``, one that finds a grid already made is passed over; ``info`` gets
        ``"noise"``."""
        rgb = photo = _as_rgb(image)
        h0, w0 = rgb.shape[:2]
        scale = min(1.0, self.max_side_px / max(h0, w0))
        if scale < 1.0:
            rgb = cv2.resize(rgb, (int(round(w0 * scale)), int(round(h0 * scale))), interpolation=cv2.INTER_AREA)
        info = {} if info is None else info
        info["noise"] = noise = noise_sigma(rgb)
        if noise > NOISY_SIGMA:  # a noisy sensor: smoothed first (and the '#' sought on that)
            rgb, photo = denoised(rgb, noise), None
        h, w = rgb.shape[:2]
        diag = math.hypot(h, w)
        d = ink_map(rgb, stroke_px=max(6.0, diag / 100))
        made: list[Hypothesis] = []
        hashed: SearchCopy | None = None
        for kind in KINDS + PAGE_KINDS + HUE_KINDS:
            if kind in HUE_KINDS and (hashed is None or not hashed.ruled):  # no ruled paper seen
                continue
            sub: dict[str, object] = {}
            try:
                if kind == "straight":  # straight ruled lines (the lab's and the renderer's boards, frames)
                    hyp = self._straight(d, diag, sub)
                else:  # a hand-drawn '#': wavy, converging, unframed lines
                    hashed = hashed or SearchCopy.of(rgb, photo)
                    hyp = read_hash(self, rgb, d, sub, hashed, kind, made)
            except NoBoardError as exc:
                reasons.append(f"{'straight lines' if kind == 'straight' else kind}: {exc.reason}")
                continue
            if hyp is None:  # a grid already made: its cells were not read again
                continue
            hyp.kind, hyp.diag, hyp.trace, hyp.scale = kind, diag, sub, scale
            sub["scale"] = scale / float(sub.pop("_g", 1))  # type: ignore[arg-type]
            if "hash_to_px" in sub:  # the '#' was read: its px to the image's
                sub["hash_to_image"] = np.diag([1.0 / scale, 1.0 / scale, 1.0]) @ sub["hash_to_px"]
            hyp.p = 1.0 if self.arbiter is None else self.arbiter.weigh(hyp)
            made.append(hyp)
            yield hyp

    def _straight(self, d: np.ndarray, diag: float, trace: dict[str, object]) -> Hypothesis:
        """The straight ruled field: found on a copy of about ``grid_px`` (long lines need no
        more), the cells read at full resolution."""
        h, w = d.shape
        g = max(1, int(round(max(h, w) / self.grid_px)))
        dg = cv2.resize(d, (w // g, h // g), interpolation=cv2.INTER_AREA) if g > 1 else d
        trace["_g"] = g
        Hg, err, npts, frame, n = self._find_grid(dg, math.hypot(*dg.shape), trace)
        H = np.array([[g, 0, 0.5 * (g - 1)], [0, g, 0.5 * (g - 1)], [0, 0, 1.0]]) @ Hg
        line_ref, coverage = line_contrast(d, H, n)
        probs, feats, inputs = self._read_cells(d, H, n, line_ref)
        trace["cell_inputs"] = inputs
        return Hypothesis("straight", H, err * g, npts, frame, n, probs, feats, inputs, line_ref, coverage, 0.0, diag)

    # -- grid ------------------------------------------------------------------------
    def _find_grid(self, d: np.ndarray, diag: float, trace: dict[str, object] | None = None
                   ) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        """The field's homography (grid cells -> px), fit error, crossings used, frame sides
        and size. Ink is "dark" above a share of the image's darkest strokes; if no grid
        shows at that share, a lower one is tried (a light, thin field next to bold marks)."""
        trace = {} if trace is None else trace
        top = _percentile(d[::2, ::2].ravel(), 99.5)
        try:
            return self._find_grid_at(d, diag, max(0.18, 0.35 * top), trace)
        except NoBoardError as first:
            if 0.25 * top < 0.15:
                raise
            try:
                return self._find_grid_at(d, diag, 0.25 * top, trace)
            except NoBoardError:
                raise first from None

    def _find_grid_at(self, d: np.ndarray, diag: float, t0: float, trace: dict[str, object]
                      ) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        h, w = d.shape
        mask = (d > t0).astype(np.uint8)
        if cv2.countNonZero(mask) < 1e-4 * mask.size:
            raise NoBoardError("the image holds no ink")
        # straight segments on a shrunk copy (Hough costs grow with the ink pixels), then
        # each merged line refitted to the full-resolution ink around it
        f = max(1, int(round(max(h, w) / 400)))  # (1 when the caller already shrank it)
        small = cv2.resize(d, (w // f, h // f), interpolation=cv2.INTER_AREA) if f > 1 else d
        segs = _segments((small > 0.8 * t0).astype(np.uint8), 0.08 * diag / f) * f
        tol = 0.006 * diag + 2
        merged = _merge(segs, tol)
        shortest = 0.25 * max((ln.length for ln in merged), default=0.0)  # symbol strokes: not worth a refit
        refit = _refit([ln for ln in merged if ln.length >= shortest], d, t0, tol)
        lines = [ln for ln in refit if ln is not None]
        trace["lines"] = lines
        if len(lines) < 4:
            raise NoBoardError(f"{len(lines)} straight lines found; a grid needs at least 2 + 2")
        fa, fb = _families(lines)
        if len(fa) < 2 or len(fb) < 2:
            raise NoBoardError(f"lines in one direction only ({len(fa)} and {len(fb)}); a grid needs two")
        # columns: the family whose lines run closer to the image vertical
        if np.mean([abs(math.cos(ln.theta)) for ln in fa]) < np.mean([abs(math.cos(ln.theta)) for ln in fb]):
            fa, fb = fb, fa
        cols, rows = self._field_lines(fa, d, t0, tol), self._field_lines(fb, d, t0, tol)
        for _ in range(2):  # a field line crosses the other family's lines where both are drawn
            cols, rows = _crossing(cols, rows, 3 * tol), _crossing(rows, cols, 3 * tol)
        if len(cols) < 2 or len(rows) < 2:
            raise NoBoardError(f"{len(cols)} column and {len(rows)} row lines of field length; a grid needs 2 + 2")
        # columns left to right and rows top to bottom, as the image shows them
        if (cols[0].p0 + cols[0].p1)[0] > (cols[-1].p0 + cols[-1].p1)[0]:
            cols.reverse()
        if (rows[0].p0 + rows[0].p1)[1] > (rows[-1].p0 + rows[-1].p1)[1]:
            rows.reverse()
        trace["cols"], trace["rows"] = cols, rows
        near = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_RECT, (5, 5)))
        # the best lattice from the cells around the middle first; if no field follows from
        # it (a stray line took part), the next best lattices from every cell
        failure: NoBoardError | None = None
        tried = 0
        for Hl, nodes, err in self._lattices(cols, rows):
            try:
                return self._field(Hl, nodes, err, d, near, diag, trace)
            except NoBoardError as exc:
                failure = failure or exc
            tried += 1
            if tried >= 6:
                break
        raise failure or NoBoardError("the grid lines do not make a projective grid")

    def _field(self, Hl: np.ndarray, nodes: np.ndarray, err: float, d: np.ndarray, near: np.ndarray, diag: float,
               trace: dict[str, object]) -> tuple[np.ndarray, float, int, tuple[bool, bool, bool, bool], int]:
        """The field that a lattice implies: its extent, border and size (or NoBoardError)."""
        (i0, j0), (i1, j1) = nodes.min(axis=0), nodes.max(axis=0)
        # the outermost lattice lines must be drawn along their length: a line of symbol
        # strokes that happens to fall on the lattice is not (its ink covers little of it)
        i0, i1 = self._drawn_range(Hl, near, 0, i0, i1, j0, j1)
        j0, j1 = self._drawn_range(Hl, near, 1, j0, j1, i0, i1)
        nodes = nodes[(nodes[:, 0] >= i0) & (nodes[:, 0] <= i1) & (nodes[:, 1] >= j0) & (nodes[:, 1] <= j1)]
        trace["lattice"], trace["nodes"] = Hl, nodes
        # where is the border? the field's lines run one cell past its outermost interior
        # lines; a frame line is where the other lines stop
        ext = [self._extension(Hl, near, axis, at, out, lo, hi)
               for axis, at, out, lo, hi in ((0, i0, -1, j0, j1), (0, i1, 1, j0, j1), (1, j0, -1, i0, i1),
                                             (1, j1, 1, i0, i1))]
        trace["extension"] = ext
        steps, n = self._border_steps(ext, i1 - i0, j1 - j0)
        start_c, start_r = i0 - steps[0], j0 - steps[2]
        H = Hl @ np.array([[1.0, 0, start_c], [0, 1.0, start_r], [0, 0, 1.0]])
        src = nodes - [start_c, start_r]
        corners = _apply(H, np.array([[0, 0], [n, 0], [n, n], [0, n]], float))
        side = math.sqrt(max(cv2.contourArea(corners.astype(np.float32)), 0.0))
        if side < 0.1 * diag:
            raise NoBoardError("the grid found is too small to read")
        # a camera tilted up to ~35 deg scales the field's cells by at most ~2.5 from one
        # corner to another; a lattice that implies more was extrapolated from wrong lines
        cells = np.array([[c, r] for c in (0, n - 1) for r in (0, n - 1)], float)
        areas = [abs(cv2.contourArea(_apply(H, q + [[0, 0], [1, 0], [1, 1], [0, 1]]).astype(np.float32)))
                 for q in cells]
        if max(areas) > 3.0 * max(min(areas), 1e-9):
            raise NoBoardError(f"the lattice implies cells {max(areas) / max(min(areas), 1e-9):.1f} x larger "
                               "in one corner than in another; no camera tilts that much")
        _, coverage = line_contrast(d, H, n)
        if coverage < 0.6:
            raise NoBoardError(f"only {coverage:.0%} of the field's interior lines carry ink; not a grid")
        frame = (steps[0] == 0, steps[1] == 0, steps[2] == 0, steps[3] == 0)
        return H, err, len(src), frame, n

    def _field_lines(self, fam: list[_Line], d: np.ndarray, floor: float, tol: float) -> list[_Line]:
        """The field's lines of one family, ordered across.

        Pieces of one hand-drawn line (it bends, so its pieces fit slightly different lines)
        sit at nearly the same place across the family: they are joined and refitted; then
        lines with less than 45 % of the best line's ink are dropped (symbol strokes).
        """
        nrm = np.mean([ln.normal if ln.normal @ fam[0].normal >= 0 else -ln.normal for ln in fam], axis=0)
        nrm /= np.linalg.norm(nrm)
        mid = np.mean([0.5 * (ln.p0 + ln.p1) for ln in fam], axis=0)
        pos = []
        for ln in fam:
            den = float(ln.normal @ nrm)
            pos.append((ln.rho - float(ln.normal @ mid)) / den if abs(den) > 1e-6 else 0.0)
        order = np.argsort(pos)
        fam, pos = [fam[i] for i in order], [pos[i] for i in order]
        longest = max(ln.length for ln in fam)
        long_pos = [p for ln, p in zip(fam, pos) if ln.length >= 0.45 * longest]
        typical = _median(np.diff(long_pos)) if len(long_pos) > 1 else longest
        gaps = np.diff(long_pos)
        if len(gaps) > 1 and (gaps > 0.35 * typical).sum() >= 1:  # double detections shrink the median
            typical = _median(gaps[gaps > 0.35 * typical])
        groups: list[list[_Line]] = []
        last = -math.inf
        for ln, p in zip(fam, pos):
            if groups and p - last < 0.35 * typical:
                groups[-1].append(ln)
            else:
                groups.append([ln])
            last = p
        merged = []
        for g in groups:
            if len(g) == 1:
                merged.append(g[0])
                continue
            base = max(g, key=lambda ln: ln.length)
            iv = [tuple(sorted(((ln.p0 - base.p0) @ base.direction, (ln.p1 - base.p0) @ base.direction)))
                  for ln in g]
            cover = _union_length(iv)  # ink length: the union of the pieces' extents
            t0, t1 = min(a for a, _ in iv), max(b for _, b in iv)
            span = _Line(base.theta, base.rho, float(cover), base.p0 + t0 * base.direction,
                         base.p0 + t1 * base.direction)
            fit = _refit([span], d, floor, 2 * tol)[0]
            merged.append(_Line(fit.theta, fit.rho, float(cover), fit.p0, fit.p1) if fit else span)
        best = max(ln.length for ln in merged)
        return [ln for ln in merged if ln.length >= 0.45 * best]

    def _lattices(self, cols: list[_Line], rows: list[_Line]):  # type: ignore[no-untyped-def]
        """Lattices fitted to the line crossings, best first: ``(H, nodes, rms)``, H taking
        lattice coordinates (cells) to pixels, ``nodes`` the integer lattice points that
        crossings support and ``rms`` the crossings' distance from them (px).

        Every cell made by two neighbouring column lines and two neighbouring row lines is a
        hypothesis; it predicts the whole lattice, and scores by the crossings that fall on
        lattice points (within a fifth of a cell) less half the lattice points inside the
        supported range that no crossing supports - so a stray line between two real ones,
        which would halve the spacing, loses. The cells around the middle come first (stray
        lines sit at the ends); each hypothesis is refined on its inliers.
        """
        x, y, ok, _, _ = _crossings(cols, rows)
        cross = np.stack([x, y], -1)  # (cols, rows, 2)
        P = cross[ok]
        if len(P) < 4:
            raise NoBoardError("the grid lines do not intersect")
        unit = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
        mid_a = range(max(0, (len(cols) - 1) // 2 - 1), min(len(cols) - 1, (len(cols) - 1) // 2 + 2))
        mid_b = range(max(0, (len(rows) - 1) // 2 - 1), min(len(rows) - 1, (len(rows) - 1) // 2 + 2))
        middle = [(a, b) for a in mid_a for b in mid_b]
        rest = [(a, b) for a in range(len(cols) - 1) for b in range(len(rows) - 1) if (a, b) not in middle]
        seen: list[np.ndarray] = []
        for group in (middle, rest):
            H0s = []
            for a, b in group:
                corners = ((a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1))
                if not all(ok[c] for c in corners):
                    continue
                try:
                    H0 = cv2.getPerspectiveTransform(unit, np.array([cross[c] for c in corners], np.float32)
                                                     ).astype(np.float64)
                except cv2.error:
                    continue
                if abs(np.linalg.det(H0)) > 1e-12:
                    H0s.append(H0)
            if not H0s:
                continue
            scores = self._score_lattices(np.linalg.inv(np.array(H0s)), P)
            for k in np.argsort(-scores, kind="stable"):
                if not np.isfinite(scores[k]):
                    break
                fit = self._refine_lattice(H0s[k], P)
                if fit is None:
                    continue
                key = np.rint(_apply(fit[0], np.array([[0.0, 0.0], [1.0, 1.0]]))).ravel()
                if any(np.abs(key - prev).max() < 3 for prev in seen):  # the same lattice again
                    continue
                seen.append(key)
                yield fit

    @staticmethod
    def _refine_lattice(H: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
        """``H`` refitted to the crossings ``P``; None when under four lie on it or the fit is degenerate."""
        with np.errstate(divide="ignore", invalid="ignore"):
            for _ in range(2):  # refine on the inliers, re-assign
                L = _apply(np.linalg.inv(H), P)
                R = np.rint(L)
                inl = np.all(np.abs(L - R) < 0.2, axis=1)
                if inl.sum() < 4:
                    break
                Hn, _ = cv2.findHomography(R[inl], P[inl], 0)
                if Hn is None or not np.all(np.isfinite(Hn)):
                    break
                H = Hn
            L = _apply(np.linalg.inv(H), P)
            R = np.rint(L)
            inl = np.all(np.abs(L - R) < 0.2, axis=1)
            if inl.sum() < 4:
                return None
            res = _apply(H, R[inl]) - P[inl]
        err = float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))
        if not math.isfinite(err):  # points at infinity: no lattice (and no warning)
            return None
        nodes = np.array(sorted(set(map(tuple, R[inl].astype(np.int64).tolist()))), dtype=np.int64)
        return H, nodes, err

    @staticmethod
    def _score_lattices(Hinv: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Scores of lattice hypotheses ``Hinv`` ``(G, 3, 3)`` (px -> cells) against the line
        crossings ``P``: the distinct lattice points that crossings fall on (within 0.2 of a
        cell) less half the unsupported points of the box they span; -inf for a hypothesis
        with fewer than 4 such crossings, a box over 9 lattice lines, or points at infinity."""
        Lh = np.concatenate([P, np.ones((len(P), 1))], axis=1) @ Hinv.transpose(0, 2, 1)  # (G, N, 3)
        with np.errstate(divide="ignore", invalid="ignore"):
            L = Lh[..., :2] / Lh[..., 2:3]
        finite = np.isfinite(L).all(axis=(1, 2))
        L = np.where(finite[:, None, None], L, 0.0)
        R = np.rint(L)
        inl = np.all(np.abs(L - R) < 0.2, axis=2)
        big = np.iinfo(np.int64).max // 4
        ij = R.astype(np.int64)
        lo = np.where(inl[..., None], ij, big).min(axis=1)
        hi = np.where(inl[..., None], ij, -big).max(axis=1)
        ok = finite & (inl.sum(axis=1) >= 4)
        ok &= np.where(ok[:, None], hi - lo, 0).max(axis=1) <= 8
        rel = np.where(ok[:, None, None], ij - lo[:, None, :], 0)
        codes = np.sort(np.where(inl, rel[..., 0] * 16 + rel[..., 1], big), axis=1)
        distinct = ((codes[:, 1:] != codes[:, :-1]) & (codes[:, 1:] != big)).sum(axis=1) + (codes[:, 0] != big)
        box = np.where(ok[:, None], hi - lo + 1, 0).prod(axis=1)
        return np.where(ok, distinct - 0.5 * (box - distinct), -np.inf)

    def _border_steps(self, ext: list[float], span_c: int, span_r: int) -> tuple[list[int], int]:
        """Cells from the outermost lines to the border, per side (left, right, top, bottom),
        and the board size. Each side's run of the other lines past the outermost one says
        how many (0: a frame line; about 1: the last interior line); when a run sits between
        two counts, the count that makes a square board of an allowed size wins."""
        options = []
        for e in ext:
            near = {0} if e < 0.35 else {max(1, math.floor(e)), max(1, math.ceil(e))} if e >= 0.65 else {0, 1}
            options.append(sorted(near, key=lambda k: abs(k - e)))
        sizes = (self.size,) if self.size is not None else (3, 5)
        best: tuple[float, list[int], int] | None = None
        for a in options[0]:
            for b in options[1]:
                for c in options[2]:
                    for d in options[3]:
                        nc, nr = span_c + a + b, span_r + c + d
                        if nc != nr or nc not in sizes:
                            continue
                        cost = sum(abs(k - e) for k, e in zip((a, b, c, d), ext))
                        if best is None or cost < best[0]:
                            best = (cost, [a, b, c, d], nc)
        if best is None:
            guess = [o[0] for o in options]
            nc, nr = span_c + guess[0] + guess[1], span_r + guess[2] + guess[3]
            want = f"{self.size} x {self.size}" if self.size else "3 x 3 or 5 x 5"
            raise NoBoardError(f"a field of {nc} x {nr} cells found; expected {want}")
        return best[1], best[2]

    @staticmethod
    def _lattice_ink(H: np.ndarray, near: np.ndarray, axis: int, ks: np.ndarray, t: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Ink (``near``) at lattice points ``(ks, t)`` (axis 0: column lines ``u = ks``,
        ``v = t``; 1: row lines) and which of them lie in the image: two ``(len(ks), len(t))``
        bool arrays (no ink outside the image)."""
        h, w = near.shape
        u, v = np.broadcast_arrays(ks[:, None], t[None, :])
        pts = np.stack([u, v] if axis == 0 else [v, u], -1).reshape(-1, 2).astype(np.float64)
        px = np.rint(_apply(H, pts)).astype(np.intp)
        inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
        hit = np.zeros(len(px), bool)
        hit[inside] = near[px[inside, 1], px[inside, 0]] > 0
        return hit.reshape(u.shape), inside.reshape(u.shape)

    @classmethod
    def _drawn_range(cls, H: np.ndarray, near: np.ndarray, axis: int, lo: int, hi: int, a: int, b: int
                     ) -> tuple[int, int]:
        """Trim ``lo..hi`` (lattice lines along ``axis``; 0 = columns) to the outermost lines
        that carry ink along at least 60 % of their length between ``a`` and ``b``."""
        t = np.linspace(a, b, 12 * max(1, b - a) + 1)
        t = t[np.abs(t - np.rint(t)) > 0.15]  # away from the crossings, which any line has
        ks = np.arange(int(lo), int(hi) + 1)
        hit, inside = cls._lattice_ink(H, near, axis, ks, t)
        seen = inside.sum(axis=1)
        drawn = (seen > 0) & (hit.sum(axis=1) / np.maximum(seen, 1) >= 0.6)
        first = np.flatnonzero(drawn[:-1])  # the first drawn line, keeping at least one line
        lo_i = int(first[0]) if len(first) else len(ks) - 1
        last = np.flatnonzero(drawn[lo_i + 1:])
        hi_i = lo_i + 1 + int(last[-1]) if len(last) else lo_i
        return int(ks[lo_i]), int(ks[hi_i])

    @classmethod
    def _extension(cls, H: np.ndarray, near: np.ndarray, axis: int, at: int, outwards: int, lo: int, hi: int
                   ) -> float:
        """How far (in cells) the lattice lines that cross lattice line ``at`` run on past it
        as ink, going ``outwards`` (-1 or +1): the median over those lines (``lo..hi``) of
        the ink run from the crossing; two misses in a row end a run.

        ``axis`` 0: the column line ``u = at``, crossed by the rows; 1: the row line ``v = at``.
        """
        if hi < lo:
            return 0.0
        t = np.arange(0.1, 2.6, 0.1)
        # the crossing lines run along the other axis, at their own index k
        hit, _ = cls._lattice_ink(H, near, 1 - axis, np.arange(int(lo), int(hi) + 1), at + outwards * t)
        miss = ~hit[:, :-1] & ~hit[:, 1:]
        runs = np.where(miss.any(axis=1), t[miss.argmax(axis=1)] - 0.1, t[-1])
        return _median(runs)

    # -- cells -----------------------------------------------------------------------
    def _read_cells(self, d: np.ndarray, H: np.ndarray, n: int, line_ref: float, floor: float | None = None,
                    margin_cells: float = 0.5, outer: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell probabilities, features and the classifier's inputs (:func:`cell_inputs`).
        ``floor``: the image's own ink level (noise), which replaces the fixed floors for faint
        pens; ``margin_cells`` of the map around the field are rectified too (marks that cross
        the border stay whole), of which ``outer`` cells count for the outer cells."""
        s = self.cell_px
        o = int(round(margin_cells * s))
        # rectified px -> grid cells, with the margin
        M = H @ np.array([[1.0 / s, 0, -o / s], [0, 1.0 / s, -o / s], [0, 0, 1.0]])
        side = n * s + 2 * o
        rect = cv2.warpPerspective(d, M, (side, side), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                   borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        present, mark = (0.12, 0.1) if floor is None else (floor, floor)
        rect = _remove_grid_lines(rect, n, s, o, max(present, 0.4 * line_ref))
        feats = board_features(rect, n, s, o, max(mark, 0.25 * line_ref), 0.25 * line_ref, outer)
        rule = _probabilities(feats, line_ref)
        x = cell_inputs(rect, n, s, o, feats, rule, line_ref, outer)
        probs = rule if self.model is None else self.model.probs(x).reshape(n, n, 3)
        return probs, feats, x
