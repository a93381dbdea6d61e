"""Train the board reader's cell classifier (:mod:`kinegym.vision.cell_model`) on rendered photos.

``python -m kinegym.agents.train_cells --out vision/data/cell_model.npz`` renders photos, reads
each with the hand rule (and the first grid found: the grid arbiter is trained on this model's
calls, not before it), and keeps the cells of every board whose grid was found right (each true
cell centre falls in its own cell; the classifier cannot mend a wrong grid). With
``--all-grids`` it makes every grid hypothesis the reader makes instead and keeps the cells of
each whose grid is right (the arbiter may choose any of them, so the classifier learns each
one's view of the cells): the shipped ensemble's second model. It then:

1. splits the photos (never the cells of one photo) into training and held-out parts;
2. fits the network in torch (one thread) by AdamW on the training cells, each batch's windows
   turned and mirrored at random (an X turned is still an X), weight decay against
   over-fitting, and hands the weights to the numpy :class:`~kinegym.vision.cell_model.CellModel`;
3. fits the softmax temperature on the held-out cells (least negative log-likelihood), so the
   confidences are calibrated, and reports accuracy and expected calibration error (ECE)
   before and after.

Photos: real-like 3 x 3 boards (:func:`~kinegym.envs.sim.scenes_real.real_like_scene`, seeds
from 1,000,000) and hard rendered 3 x 3 and 5 x 5 boards
(:func:`~kinegym.envs.sim.scenes.random_scene`, seeds from 2,000,000); the benchmark's seeds
(below 500,000) are never trained on. The same arguments give the same model, bit for bit.
``--cells FILE`` keeps the collected cells (the slow part: rendering and reading the photos)
and reuses them when the same photos are asked for again, so that fitting can be varied in
seconds.

``--recalibrate MODEL --rule-weight W`` keeps a trained model's network and sets how much the hand
rule's prior weighs: the network is fit without the prior (step 2), so only the temperature is
fitted anew (step 3), on the cells of photos no model or arbiter was trained on (real-like seeds
from 5,000,000, hard from 6,000,000). The cells are collected the same way (``--all-grids`` for the
every-right-grid model).
"""

from __future__ import annotations

import argparse
import io
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinegym.vision.board_reader import BoardReader, NoBoardError
from kinegym.vision.cell_model import (
    N_CHANNELS,
    N_INPUTS,
    N_SCALARS,
    SHIPPED_MODEL,
    WIN,
    CellModel,
    channels,
    rule_probs,
)
from kinegym.vision.ink import _apply

from .parallel import in_order

__all__ = ["CellData", "grid_is_right", "collect", "load_or_collect", "fit", "expected_calibration_error",
           "recalibrate", "main"]

REAL_LIKE_SEED, HARD_SEED = 1_000_000, 2_000_000
#: the photos the shipped networks were trained on (stop 65; 3,000 + 600 before): the defaults
REAL_LIKE_PHOTOS, HARD_PHOTOS = 6000, 1000
#: the weight of the hand rule's log-probabilities at reading, a prior (stop 61: at 0.15, recalibrated and the
#: arbiter retrained, 28 more of 1,000 real-like boards than at 0.3; at 0.1 as it was, 27 more but 3 of the real
#: photos' condition readings fewer; bench/README.md, "The rule's weight halved")
RULE_WEIGHT = 0.15
#: the first seeds of the photos a trained model is recalibrated on (:func:`recalibrate`)
RECAL_REAL_LIKE_SEED, RECAL_HARD_SEED = 5_000_000, 6_000_000
#: channels of the network's three convolutions
CONVS = (16, 32, 64)
_MAX_CACHE_BYTES = 2 << 30  # 100,000 photos' cells, compressed, stay well under this


class _Ticker:
    """A line on stderr at every tenth of ``total`` (agents may not import kinegym's progress bar)."""

    def __init__(self, total: int, what: str, enabled: bool) -> None:
        self.total, self.what, self.enabled, self.done, self.t0 = max(total, 1), what, enabled, 0, time.perf_counter()

    def update(self) -> None:
        self.done += 1
        if self.enabled and (self.done * 10 // self.total > (self.done - 1) * 10 // self.total):
            print(f"  {self.what}: {self.done}/{self.total}, {time.perf_counter() - self.t0:.0f} s", file=sys.stderr,
                  flush=True)


@dataclass
class CellData:
    """Cells with their truth: inputs ``x`` ``(N, N_INPUTS)``, labels ``y`` (0 empty, 1 X, 2 O)
    and ``photo`` (which photo each came from); ``kept`` / ``photos``: photos whose grid was right."""

    x: np.ndarray
    y: np.ndarray
    photo: np.ndarray
    kept: int
    photos: int


def _scene_cells(job: tuple[str, int, bool]) -> tuple[np.ndarray, np.ndarray] | None:
    """Render one photo, read it with the hand rule; the inputs and truth of the cells of the
    first grid found, or with ``all_grids`` (the job's third item) of every grid hypothesis whose
    grid is right (each a view of the cells the reader may be asked to call, as the arbiter may
    choose any of them); None when no grid is right."""
    kind, seed, all_grids = job
    if kind == "real-like":
        from kinegym.envs.sim.scenes_real import real_like_scene

        sc = real_like_scene(seed)
        n, truth, centres, image = 3, sc.cells, sc.centres_px.reshape(-1, 2), sc.image
    else:
        from kinegym.envs.sim.scenes import random_scene

        rng = np.random.default_rng(seed)
        n = int(rng.choice([3, 5]))
        hs = random_scene(rng, n=n, difficulty="hard", distractors=bool(rng.random() < 0.5))
        rc = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)
        # the canvas's y runs up the page: row 0, on top, is the highest
        centres = hs.photo.project(hs.origin_cm + np.stack([rc[:, 1] + 0.5, n - rc[:, 0] - 0.5], 1) * hs.cell_cm)
        truth, image = hs.cells, hs.photo.image
    reader = BoardReader(size=n, model=None, arbiter=None)
    if all_grids:
        xs = [h.inputs for h in reader.hypotheses(image)
              if h.n == n and grid_is_right(np.diag([1.0 / h.scale, 1.0 / h.scale, 1.0]) @ h.H, centres, n)]
    else:
        trace: dict[str, object] = {}
        try:
            reading = reader.read(image, trace)
        except NoBoardError:
            return None
        xs = [np.asarray(trace["cell_inputs"])] if grid_is_right(reading.homography, centres, n) else []
    if not xs:
        return None
    return np.concatenate(xs).astype(np.float32), np.tile(truth.reshape(-1).astype(np.int64), len(xs))


def grid_is_right(homography: np.ndarray, centres: np.ndarray, n: int) -> bool:
    """Whether a reading's grid (``homography``: cells to px) puts every true cell centre
    (``centres`` ``(n * n, 2)`` px, row by row) in its own cell, outer cells reaching up to 0.9
    of a cell past the field."""
    with np.errstate(divide="ignore", invalid="ignore"):  # a degenerate grid puts centres at infinity: not right
        g = _apply(np.linalg.inv(homography), centres)
    rc = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)
    inside = bool((g > -0.9).all() and (g < n + 0.9).all())
    return inside and bool((np.clip(np.floor(g[:, ::-1]), 0, n - 1) == rc).all())


def collect(real_like: int, hard: int, workers: int = 2, progress: bool = True, all_grids: bool = False,
            seeds: tuple[int, int] = (REAL_LIKE_SEED, HARD_SEED)) -> CellData:
    """The cells of ``real_like`` + ``hard`` photos (module docstring; ``all_grids``: of every
    right hypothesis; ``seeds``: the first real-like and hard photo's), read in ``workers``
    processes; the order, and so the data, does not depend on ``workers``."""
    jobs = [("real-like", seeds[0] + i, all_grids) for i in range(real_like)] + [
        ("hard", seeds[1] + i, all_grids) for i in range(hard)]
    xs, ys, ids = [], [], []
    bar = _Ticker(len(jobs), "photos", progress)
    results = in_order(_scene_cells, jobs, workers, lambda _: bar.update(), chunksize=4)
    for k, res in enumerate(results):
        if res is not None:
            xs.append(res[0])
            ys.append(res[1])
            ids.append(np.full(len(res[1]), k))
    if not xs:
        return CellData(np.zeros((0, N_INPUTS), np.float32), np.zeros(0, np.int64), np.zeros(0, np.int64), 0,
                        len(jobs))
    return CellData(np.concatenate(xs), np.concatenate(ys), np.concatenate(ids), len(xs), len(jobs))


def load_or_collect(path: str | Path, real_like: int, hard: int, workers: int = 2, progress: bool = True,
                    all_grids: bool = False) -> CellData:
    """The cells of :func:`collect`, kept in ``path`` (.npz): read back when the file holds the
    cells of the same photos (counts, input width and ``all_grids``), else collected and written
    (atomically).
    The cells are what the reader of the time saw: after changing the reader, delete the file.
    A file that is not such a cache is a :class:`~kinegym.configs.io.FileError` naming it."""
    from kinegym.configs.io import FileError, read_bytes, write_atomic

    p = Path(path)
    if p.exists():
        raw = read_bytes(p, _MAX_CACHE_BYTES, "cell cache (.npz)")
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                a = {key: z[key] for key in z.files}
            # caches from before --all-grids (the first grid found) lack "all_grids"
            key = (int(a["real_like"]), int(a["hard"]), int(a["x"].shape[1]), int(a.get("all_grids", 0)))
            data = CellData(a["x"].astype(np.float32), a["y"].astype(np.int64), a["photo"].astype(np.int64),
                            int(a["kept"]), int(a["photos"]))
        except (KeyError, ValueError, OSError, EOFError, IndexError) as err:
            raise FileError(p, f"not a cell cache ({err})", "an .npz written by --cells") from None
        if key == (real_like, hard, N_INPUTS, int(all_grids)):
            return data
        if progress:
            print(f"  {p} holds the cells of {key[0]} real-like + {key[1]} hard photos ({key[2]} inputs"
                  f"{', every right grid' if key[3] else ', first grids'}); collecting {real_like} + {hard} "
                  f"({N_INPUTS}{', every right grid' if all_grids else ', first grids'}) anew",
                  file=sys.stderr)
    data = collect(real_like, hard, workers, progress, all_grids)
    buf = io.BytesIO()
    np.savez_compressed(buf, x=data.x, y=data.y, photo=data.photo, kept=data.kept, photos=data.photos,
                        real_like=real_like, hard=hard, all_grids=int(all_grids))
    write_atomic(p, buf.getvalue(), suffixes=(".npz",), what="cell cache")
    return data


def expected_calibration_error(p: np.ndarray, y: np.ndarray, bins: int = 10) -> float:
    """ECE: over bins of the top probability, the cell-weighted gap between it and the accuracy."""
    top, hit = p.max(axis=1), (p.argmax(axis=1) == y)
    which = np.minimum((top * bins).astype(int), bins - 1)
    gap = 0.0
    for b in range(bins):
        sel = which == b
        if sel.any():
            gap += sel.sum() * abs(float(top[sel].mean()) - float(hit[sel].mean()))
    return gap / max(len(y), 1)


def fit(x: np.ndarray, y: np.ndarray, hidden: int = 128, epochs: int = 15, lr: float = 3e-3, decay: float = 1e-3,
        seed: int = 0, progress: bool = True, convs: tuple[int, int, int] = CONVS) -> CellModel:
    """Fit the network (temperature 1) in torch, one thread (so the same arguments give the same
    weights): AdamW with weight decay on softmax cross-entropy, a one-cycle learning rate peaking
    at ``lr``, each batch's windows turned and mirrored at random (an X turned is still an X).
    ``convs``: the three convolutions' channels. The weights are handed to the numpy
    :class:`CellModel`, which is what reads."""
    import torch
    from torch import nn

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        gen = torch.Generator().manual_seed(seed)
        torch.manual_seed(seed)
        chans, scalars = channels(x), np.asarray(x, np.float32)[:, WIN * WIN:]
        cmean, cscale = chans.mean(axis=(0, 2, 3)), np.maximum(chans.std(axis=(0, 2, 3)), 1e-3)
        smean, sscale = scalars.mean(axis=0), np.maximum(scalars.std(axis=0), 1e-3)
        ct = torch.from_numpy(((chans - cmean[:, None, None]) / cscale[:, None, None]).astype(np.float32))
        st = torch.from_numpy(((scalars - smean) / sscale).astype(np.float32))
        yt = torch.from_numpy(np.asarray(y, np.int64))
        c1, c2, c3 = convs
        feats = nn.Sequential(nn.Conv2d(N_CHANNELS, c1, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
                              nn.Conv2d(c1, c2, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
                              nn.Conv2d(c2, c3, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2), nn.Flatten())
        head = nn.Sequential(nn.Linear(c3 * (WIN // 8) ** 2 + N_SCALARS, hidden), nn.ReLU(), nn.Linear(hidden, 3))
        params = [*feats.parameters(), *head.parameters()]
        opt = torch.optim.AdamW(params, lr, weight_decay=decay)
        batch = 256
        steps = max(1, epochs * -(-len(yt) // batch))
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, lr, total_steps=steps)
        bar = _Ticker(epochs, "epochs", progress)
        for _ in range(epochs):
            order = torch.randperm(len(yt), generator=gen)
            for i in range(0, len(yt), batch):
                idx = order[i:i + batch]
                c = torch.rot90(ct[idx], int(torch.randint(0, 4, (), generator=gen)), (2, 3))
                if bool(torch.rand((), generator=gen) < 0.5):
                    c = torch.flip(c, (3,))
                logits = head(torch.cat([feats(c), st[idx]], dim=1))
                loss = nn.functional.cross_entropy(logits, yt[idx])
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
            bar.update()
        w = [p.detach().numpy().astype(np.float32) for p in params]
    finally:
        torch.set_num_threads(threads)
    return CellModel(cmean.astype(np.float32), cscale.astype(np.float32), smean.astype(np.float32),
                     sscale.astype(np.float32), w[0], w[1], w[2], w[3], w[4], w[5], w[6].T.copy(), w[7],
                     w[8].T.copy(), w[9])


def fit_temperature(model: CellModel, x: np.ndarray, y: np.ndarray) -> float:
    """The temperature (0.25..8) with the least negative log-likelihood on ``x``, ``y``, with
    the model's rule weight."""
    best, best_nll = 1.0, np.inf
    logits, rule = model.logits(x), rule_probs(x)  # the network runs once; only the temperature varies
    for t in np.exp(np.linspace(np.log(0.25), np.log(8.0), 97)):
        model.temperature = float(t)
        p = model.calibrated(logits, rule)
        nll = -float(np.mean(np.log(np.maximum(p[np.arange(len(y)), y], 1e-12))))
        if nll < best_nll:
            best, best_nll = float(t), nll
    model.temperature = best
    return best


def recalibrate(model: CellModel, data: CellData, rule_weight: float, seeds: tuple[int, int] | None = None
                ) -> dict[str, object]:
    """Give ``model`` the hand rule's prior at ``rule_weight`` and fit its temperature anew on
    ``data`` (cells of photos it was not trained on; ``seeds``, recorded when given: their first
    real-like and hard seeds). The network stays: it was fit without the prior, which only joins
    its logits at reading. Returns the record, also stored in the model's ``info`` under
    ``"recalibrated"`` (``"rule_weight"`` and ``"temperature"`` there become the new ones)."""
    if len(data.y) < 50:
        raise ValueError(f"{len(data.y)} cells from {data.photos} photos; expected at least 50 (render more photos)")
    if not 0 <= rule_weight <= 10:
        raise ValueError(f"rule weight {rule_weight}; expected 0..10")
    before = model.probs(data.x)
    old = (model.rule_weight, model.temperature)
    model.rule_weight = float(rule_weight)
    fit_temperature(model, data.x, data.y)
    after = model.probs(data.x)
    record: dict[str, object] = {
        "photos": data.photos, "photos_with_right_grid": data.kept, "cells": int(len(data.y)),
        **({} if seeds is None else {"seeds": list(seeds)}),
        "rule_weight_before": old[0], "temperature_before": round(old[1], 4),
        "rule_weight": model.rule_weight, "temperature": round(model.temperature, 4),
        "accuracy_before": round(float((before.argmax(1) == data.y).mean()), 5),
        "accuracy_after": round(float((after.argmax(1) == data.y).mean()), 5),
        "ece_before": round(expected_calibration_error(before, data.y), 5),
        "ece_after": round(expected_calibration_error(after, data.y), 5)}
    info = json.loads(model.info or "{}")
    info.update(rule_weight=model.rule_weight, temperature=record["temperature"], recalibrated=record)
    model.info = json.dumps(info)
    return record


def train(real_like: int = REAL_LIKE_PHOTOS, hard: int = HARD_PHOTOS, held_out: float = 0.2, workers: int = 2,
          hidden: int = 128, epochs: int = 15, decay: float = 1e-3, rule_weight: float = RULE_WEIGHT, seed: int = 0,
          progress: bool = True, cells: str | Path | None = None, convs: tuple[int, int, int] = CONVS,
          all_grids: bool = False
          ) -> tuple[CellModel, dict[str, object]]:
    """Collect (or reuse ``cells``, see :func:`load_or_collect`; ``all_grids``: the cells of
    every right hypothesis), fit, calibrate (module docstring): the model and its report."""
    data = (load_or_collect(cells, real_like, hard, workers, progress, all_grids) if cells
            else collect(real_like, hard, workers, progress, all_grids))
    if len(data.y) < 50:
        raise ValueError(f"{len(data.y)} cells from {data.photos} photos; expected at least 50 (render more photos)")
    rng = np.random.default_rng(seed)
    photos = np.unique(data.photo)
    test = np.isin(data.photo, rng.choice(photos, max(1, int(round(held_out * len(photos)))), replace=False))
    model = fit(data.x[~test], data.y[~test], hidden, epochs, decay=decay, seed=seed, progress=progress,
                convs=convs)
    model.rule_weight = float(rule_weight)
    xt, yt = data.x[test], data.y[test]
    before = model.probs(xt)
    fit_temperature(model, xt, yt)
    after = model.probs(xt)
    rule = rule_probs(xt)
    report: dict[str, object] = {
        "photos": data.photos, "photos_with_right_grid": data.kept, "cells_train": int((~test).sum()),
        "cells_held_out": int(test.sum()), "real_like": real_like, "hard": hard, "all_grids": all_grids,
        "convs": list(convs), "hidden": hidden, "epochs": epochs,
        "decay": decay, "rule_weight": rule_weight, "seed": seed, "temperature": round(model.temperature, 4),
        "held_out_accuracy": round(float((after.argmax(1) == yt).mean()), 5),
        "held_out_accuracy_rule": round(float((rule.argmax(1) == yt).mean()), 5),
        "ece_before": round(expected_calibration_error(before, yt), 5),
        "ece_after": round(expected_calibration_error(after, yt), 5),
        "ece_rule": round(expected_calibration_error(rule, yt), 5)}
    model.info = json.dumps(report)
    return model, report


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m kinegym.agents.train_cells", description=__doc__.split("\n\n")[0])
    ap.add_argument("--real-like", type=int, default=REAL_LIKE_PHOTOS,
                    help=f"real-like photos (default {REAL_LIKE_PHOTOS})")
    ap.add_argument("--hard", type=int, default=HARD_PHOTOS, help=f"hard rendered photos (default {HARD_PHOTOS})")
    ap.add_argument("--convs", default=",".join(map(str, CONVS)),
                    help=f"channels of the three convolutions (default {','.join(map(str, CONVS))})")
    ap.add_argument("--hidden", type=int, default=128, help="hidden units (default 128)")
    ap.add_argument("--epochs", type=int, default=15, help="passes over the data (default 15)")
    ap.add_argument("--decay", type=float, default=1e-3, help="weight decay (default 0.001)")
    ap.add_argument("--rule-weight", type=float, default=RULE_WEIGHT,
                    help=f"weight of the hand rule's log-probabilities, a prior (default {RULE_WEIGHT}; 0..10)")
    ap.add_argument("--workers", type=int, default=2, help="processes rendering photos (default 2)")
    ap.add_argument("--seed", type=int, default=0, help="split and initialisation seed (default 0)")
    ap.add_argument("--cells", default=None, help="keep the collected cells in this .npz and reuse them when it "
                    "holds the same photos' (default: not kept; delete it after changing the reader)")
    ap.add_argument("--all-grids", action="store_true", help="keep the cells of every grid hypothesis whose grid is "
                    "right, not only the first grid found's (the shipped ensemble's second model)")
    ap.add_argument("--out", default=None, help="the model file (.npz; default: the shipped first-grid model, the "
                    "every-right-grid one being vision/data/cell_model_all_grids.npz; with --recalibrate: that file)")
    ap.add_argument("--recalibrate", default=None, metavar="NPZ", help="keep this model's network, set --rule-weight "
                    "and fit its temperature on --real-like + --hard photos not trained on (module docstring)")
    args = ap.parse_args(argv)
    for name in ("real_like", "hard", "hidden", "epochs", "workers"):
        value = getattr(args, name)
        if not 0 <= value <= (100_000 if name in ("real_like", "hard") else 1_000):
            top = 100_000 if name in ("real_like", "hard") else 1000
            ap.error(f"--{name.replace('_', '-')} {value}; expected 0..{top}")
    from kinegym.configs.io import write_atomic

    for name, hi in (("decay", 1.0), ("rule_weight", 10.0)):
        value = getattr(args, name)
        if not 0 <= value <= hi:
            ap.error(f"--{name.replace('_', '-')} {value}; expected 0..{hi:g}")
    try:
        convs = tuple(int(v) for v in args.convs.split(","))
    except ValueError:
        convs = ()
    if len(convs) != 3 or not all(1 <= v <= 256 for v in convs):
        ap.error(f"--convs {args.convs}; expected three channel counts in 1..256, like {','.join(map(str, CONVS))}")
    if args.recalibrate is not None:
        model = CellModel.load(args.recalibrate)
        seeds = (RECAL_REAL_LIKE_SEED, RECAL_HARD_SEED)
        data = collect(args.real_like, args.hard, max(1, args.workers), True, args.all_grids, seeds)
        try:
            report = recalibrate(model, data, args.rule_weight, seeds)
        except ValueError as err:
            ap.error(str(err))
        path = write_atomic(args.out or args.recalibrate, model.to_bytes(), suffixes=(".npz",), what="cell model")
        print(json.dumps(report, indent=1))
        print(f"wrote {path}")
        return 0
    model, report = train(args.real_like, args.hard, workers=max(1, args.workers), hidden=max(1, args.hidden),
                          epochs=args.epochs, decay=args.decay, rule_weight=args.rule_weight, seed=args.seed,
                          cells=args.cells, convs=convs, all_grids=args.all_grids)  # type: ignore[arg-type]
    path = write_atomic(args.out or SHIPPED_MODEL, model.to_bytes(), suffixes=(".npz",), what="cell model")
    print(json.dumps(report, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
