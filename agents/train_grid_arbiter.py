"""Train the board reader's grid arbiter (:mod:`kinegym.vision.grid_choice`) on rendered photos.

``python -m kinegym.agents.train_grid_arbiter`` renders photos, makes every grid hypothesis
of each (:meth:`~kinegym.vision.board_reader.BoardReader.hypotheses`: the straight field and
the hand-drawn '#' at three ink thresholds, cells read by the shipped cell classifier, or by
the model(s) given with ``--model``) and
labels a hypothesis right when its whole board reads right. It then:

1. splits the photos (never the hypotheses of one photo) into training and held-out parts;
2. fits a logistic model of "this hypothesis reads the board right" over
   :data:`~kinegym.vision.grid_choice.FEATURES` (standardised, Newton's method with a small
   L2 penalty: no randomness, the same photos give the same arbiter bit for bit);
3. picks ``accept``, the probability at which the reader takes a hypothesis without making
   the rest: the lowest level whose held-out boards stay within one photo of making them all;
4. reports, on the held-out photos, boards right when the first grid found is read (the
   reader without an arbiter), with the arbiter, and with an oracle that always picks a right
   hypothesis when there is one (the ceiling of choosing), and the hypotheses made per photo.

Photos: real-like 3 x 3 boards (:func:`~kinegym.envs.sim.scenes_real.real_like_scene`, seeds
from 3,000,000) and hard rendered 3 x 3 and 5 x 5 boards
(:func:`~kinegym.envs.sim.scenes.random_scene`, seeds from 4,000,000, where the straight field
is right and must stay chosen); neither the benchmark's seeds (below 500,000) nor the cell
classifier's (1,000,000 and 2,000,000 on) are used. ``--data FILE`` keeps the collected
hypotheses and reuses them for the same photos (delete it after changing the reader).
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from kinegym.vision.board_reader import BoardReader, NoBoardError
from kinegym.vision.grid_choice import FEATURES, KINDS, SHIPPED_ARBITER, GridArbiter, features

from .parallel import in_order
from .train_cells import _Ticker

__all__ = ["collect", "fit", "choose", "train", "main"]

REAL_LIKE_SEED, HARD_SEED = 3_000_000, 4_000_000
_MAX_DATA_BYTES = 1 << 28
Photos = list[tuple[np.ndarray, np.ndarray]]  # per photo: features (k, F) and right (k,) of its hypotheses


def _scene_hypotheses(job: tuple[str, int, tuple[str, ...]]) -> tuple[np.ndarray, np.ndarray]:
    """Render one photo and make its hypotheses (cells read by the job's models: ``()`` the
    shipped ones): their features and whether each reads the board right."""
    kind, seed, models = job
    if kind == "real-like":
        from kinegym.envs.sim.scenes_real import real_like_scene

        sc = real_like_scene(seed)
        n, truth, image = 3, sc.cells, sc.image
    else:
        from kinegym.envs.sim.scenes import random_scene

        rng = np.random.default_rng(seed)
        n = int(rng.choice([3, 5]))
        hs = random_scene(rng, n=n, difficulty="hard", distractors=bool(rng.random() < 0.5))
        truth, image = hs.cells, hs.photo.image
    try:
        hyps = BoardReader(size=n, arbiter=None, model=list(models) if models else "shipped").hypotheses(image)
    except NoBoardError:
        hyps = []
    x = np.array([features(h) for h in hyps], np.float64).reshape(-1, len(FEATURES))
    right = np.array([h.probs.shape[:2] == truth.shape and bool((h.probs.argmax(-1) == truth).all())
                      for h in hyps], bool)
    return x, right


def collect(real_like: int, hard: int, workers: int = 2, progress: bool = True, models: Sequence[str] = ()
            ) -> Photos:
    """The hypotheses of ``real_like`` + ``hard`` photos (module docstring; cells read by the
    ensemble of ``models``, paths, or the shipped one), in ``workers`` processes; the order, and
    so the data, does not depend on ``workers``."""
    m = tuple(str(p) for p in models)
    jobs = [("real-like", REAL_LIKE_SEED + i, m) for i in range(real_like)] + [("hard", HARD_SEED + i, m)
                                                                              for i in range(hard)]
    bar = _Ticker(len(jobs), "photos", progress)
    return in_order(_scene_hypotheses, jobs, workers, lambda _: bar.update(), chunksize=4)


def _load_or_collect(path: str | None, real_like: int, hard: int, workers: int, progress: bool,
                     models: Sequence[str] = ()) -> Photos:
    """:func:`collect`, kept in ``path`` (.npz) and read back when it holds the same photos
    (delete it after changing the reader or the models)."""
    from kinegym.configs.io import FileError, read_bytes, write_atomic

    key = np.array([real_like, hard, len(FEATURES)])
    if path is not None and Path(path).exists():
        raw = read_bytes(path, _MAX_DATA_BYTES, "grid hypotheses (.npz)")
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                if np.array_equal(z["key"], key):
                    x, right, photo = z["x"], z["right"], z["photo"]
                    return [(x[photo == k], right[photo == k]) for k in range(real_like + hard)]
        except (KeyError, ValueError, OSError, EOFError) as err:
            raise FileError(Path(path), f"not a hypotheses file ({err})", "an .npz written by --data") from None
    photos = collect(real_like, hard, workers, progress, models)
    if path is not None:
        buf = io.BytesIO()
        np.savez_compressed(buf, key=key, x=np.concatenate([x for x, _ in photos]),
                            right=np.concatenate([r for _, r in photos]),
                            photo=np.concatenate([np.full(len(r), k) for k, (_, r) in enumerate(photos)]))
        write_atomic(path, buf.getvalue(), suffixes=(".npz",), what="grid hypotheses")
    return photos


def fit(x: np.ndarray, y: np.ndarray, l2: float = 1e-2, steps: int = 50) -> GridArbiter:
    """A logistic model of ``y`` (bool) over ``x`` (rows of :data:`FEATURES`), standardised,
    by Newton's method with an L2 penalty ``l2`` per sample on the weights (not the bias)."""
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    scale[scale < 1e-9] = 1.0  # a constant feature (a kind never seen) weighs nothing
    z = np.concatenate([(x - mean) / scale, np.ones((len(x), 1))], axis=1)
    w = np.zeros(z.shape[1])
    pen = np.full(z.shape[1], l2 * len(x))
    pen[-1] = 0.0
    t = y.astype(np.float64)
    for _ in range(steps):
        p = 1.0 / (1.0 + np.exp(-np.clip(z @ w, -50, 50)))
        grad = z.T @ (p - t) + pen * w
        hess = (z * (p * (1 - p))[:, None]).T @ z + np.diag(pen + 1e-9)
        step = np.linalg.solve(hess, grad)
        w -= step
        if np.abs(step).max() < 1e-10:
            break
    return GridArbiter(mean, scale, w[:-1].copy(), float(w[-1]), 1.0)


def choose(photos: Photos, arbiter: GridArbiter | None, accept: float = 1.0) -> tuple[int, float]:
    """Boards right and mean hypotheses made when the reader chooses as :meth:`BoardReader.read`
    does: ``arbiter`` None takes the first hypothesis; else hypotheses are made until one
    reaches ``accept`` and the most probable made is taken. (The reader's cap on a straight field
    framed on one side only, :meth:`GridArbiter.weigh`, is not simulated: the collected features do
    not hold the frame.)"""
    right = made = 0
    for x, ok in photos:
        if not len(x):
            continue
        if arbiter is None:
            right, made = right + int(ok[0]), made + 1
            continue
        p = arbiter.prob(x)
        hit = np.nonzero(p >= accept)[0]
        k = int(hit[0]) + 1 if len(hit) else len(p)
        right, made = right + int(ok[int(np.argmax(p[:k]))]), made + k
    return right, made / max(len(photos), 1)


def train(real_like: int, hard: int, workers: int = 2, l2: float = 1e-2, seed: int = 0, data: str | None = None,
          progress: bool = True, models: Sequence[str] = ()) -> tuple[GridArbiter, dict[str, object]]:
    """Collect (cells read by ``models``, or the shipped ensemble), split, fit, pick ``accept``
    (module docstring); the arbiter and its report."""
    photos = _load_or_collect(data, real_like, hard, workers, progress, models)
    order = np.random.default_rng(seed).permutation(len(photos))
    cut = int(round(0.75 * len(photos)))
    train_p, held = [photos[k] for k in order[:cut]], [photos[k] for k in order[cut:]]
    rows = [x for x, _ in train_p if len(x)]
    if not rows:
        raise ValueError(f"{real_like} + {hard} photos gave no grid hypothesis to train on; render more photos")
    x = np.concatenate(rows)
    y = np.concatenate([r for x_, r in train_p if len(x_)])
    arbiter = fit(x, y, l2)
    full, _ = choose(held, arbiter, 1.0)
    levels = [round(v, 2) for v in np.arange(0.5, 1.0, 0.02)]
    arbiter.accept = next((a for a in levels if choose(held, arbiter, a)[0] >= full - 1), 1.0)
    first, made_first = choose(held, None)
    chosen, made = choose(held, arbiter, arbiter.accept)
    oracle = sum(bool(r.any()) for _, r in held)
    report: dict[str, object] = {
        "photos": {"real_like": real_like, "hard": hard, "held_out": len(held)},
        "hypotheses_right_share": round(float(y.mean()), 4), "l2": l2, "seed": seed, "accept": arbiter.accept,
        "held_out_boards_right": {"first_grid_found": first, "arbiter": chosen, "arbiter_making_all": full,
                                  "oracle": oracle},
        "hypotheses_made_per_photo": {"first_grid_found": round(made_first, 3), "arbiter": round(made, 3)},
        "kinds": list(KINDS), "models": [Path(p).name for p in models] or "shipped"}
    arbiter.info = report
    return arbiter, report


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m kinegym.agents.train_grid_arbiter",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--real-like", type=int, default=1600, help="real-like photos (default 1600)")
    ap.add_argument("--hard", type=int, default=400, help="hard rendered photos (default 400)")
    ap.add_argument("--l2", type=float, default=1e-2, help="L2 penalty per photo hypothesis (default 0.01)")
    ap.add_argument("--workers", type=int, default=2, help="processes rendering photos (default 2)")
    ap.add_argument("--seed", type=int, default=0, help="split seed (default 0)")
    ap.add_argument("--data", default=None, help="keep the collected hypotheses in this .npz and reuse them "
                    "(default: not kept)")
    ap.add_argument("--model", action="append", default=[], metavar="NPZ",
                    help="a cell model whose calls the arbiter learns (repeat for an ensemble; default: the shipped "
                    "ensemble)")
    ap.add_argument("--out", default=str(SHIPPED_ARBITER), help="the arbiter file (.json; default: the shipped one)")
    args = ap.parse_args(argv)
    for name in ("real_like", "hard"):
        if not 0 <= getattr(args, name) <= 100_000:
            ap.error(f"--{name.replace('_', '-')} {getattr(args, name)}; expected 0..100000")
    if not 1 <= args.workers <= 64:
        ap.error(f"--workers {args.workers}; expected 1..64")
    if not 0 <= args.l2 <= 10:
        ap.error(f"--l2 {args.l2}; expected 0..10")
    from kinegym.configs.io import write_atomic

    for m in args.model:
        if not Path(m).is_file():
            ap.error(f"--model {m}: no such file; expected a cell model .npz (python -m kinegym.agents.train_cells)")
    arbiter, report = train(args.real_like, args.hard, args.workers, args.l2, args.seed, args.data,
                            progress=True, models=args.model)
    path = write_atomic(args.out, arbiter.to_json().encode(), suffixes=(".json",), what="grid arbiter")
    print(json.dumps(report, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
