"""Beacon localisation benchmark (seed 001): grid search, coarse-to-fine and particle filter.

Run::

    taskset -c 0 python bench/bench_beacons.py [--poses 1000] [--scene seed001]

1. Time per localisation on the seed's settings (a window of radius 5 at step 0.05: 40,000
   points): the vectorised grid search, coarse-to-fine and the particle filter, each as a
   ratio to the seed's double loop (the anchor, timed in the same run) and in ms.
2. Accuracy over ``--poses`` random true poses in the scene's field (range noise of the
   scene): position error median / p95 / max and time per fix, side by side.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from kinegym.kinematics.beacons import ParticleFilter, coarse_to_fine, grid_search, grid_search_loop
from kinegym.kinematics.mobile import load_scene


def _median_ms(fn, repeat: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000 * statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=1000)
    ap.add_argument("--scene", default="seed001")
    ap.add_argument("--particles", type=int, default=2000)
    args = ap.parse_args()
    scene = load_scene(args.scene)
    model = scene.model
    centre = scene.targets.mean(0)
    rng = np.random.default_rng(0)
    true = np.array([*centre + 0.3, 0.0])
    z = model.sample(true, rng)

    def pf() -> object:
        return ParticleFilter(model, args.particles, np.random.default_rng(1)).localize(z, centre, 5.0)

    loop_ms = _median_ms(lambda: grid_search_loop(model, z, centre, 5.0, 0.05), 3)
    rows = [("seed's loop (anchor)", loop_ms, 40_000),
            ("grid_search", _median_ms(lambda: grid_search(model, z, centre, 5.0, 0.05), 50), 40_000),
            ("grid_search, no image", _median_ms(lambda: grid_search(model, z, centre, 5.0, 0.05, image=False), 50),
             40_000),
            ("coarse_to_fine", _median_ms(lambda: coarse_to_fine(model, z, centre, 5.0, 0.05), 50),
             coarse_to_fine(model, z, centre, 5.0, 0.05).evaluations),
            (f"particle filter ({args.particles} x 8 rounds)",
             _median_ms(pf, 20), args.particles * 8)]
    print(f"scene {scene.name}: {len(model.beacons)} beacons, range noise {model.sigma_range:g}; "
          "window radius 5, step 0.05\n")
    print("| method | evaluations | ms per fix (median) | x the seed's loop |")
    print("|---|---|---|---|")
    for name, ms, ev in rows:
        print(f"| {name} | {ev:,} | {ms:.2f} | {ms / loop_ms:.5f} |")

    lo, hi = scene.targets.min(0), scene.targets.max(0)
    truths = np.column_stack([rng.uniform(lo[0], hi[0], args.poses), rng.uniform(lo[1], hi[1], args.poses),
                              np.zeros(args.poses)])
    zs = [model.sample(t, rng) for t in truths]
    methods = {
        "grid_search": lambda z: grid_search(model, z, centre, 5.0, 0.05, image=False),
        "coarse_to_fine": lambda z: coarse_to_fine(model, z, centre, 5.0, 0.05),
        "particle filter": lambda z: ParticleFilter(model, args.particles, np.random.default_rng(1)).localize(
            z, centre, 5.0),
    }
    print(f"\n{args.poses} random poses in the targets' box, each localised from one noisy measurement\n")
    print("| method | error median | p95 | max | ms per fix (mean) | same point as the grid |")
    print("|---|---|---|---|---|---|")
    grid_pts = None
    for name, fn in methods.items():
        t0 = time.perf_counter()
        est = np.array([fn(z).pose[:2] for z in zs])
        ms = 1000 * (time.perf_counter() - t0) / args.poses
        err = np.hypot(*(est - truths[:, :2]).T)
        if grid_pts is None:
            grid_pts = est
        same = float(np.mean(np.hypot(*(est - grid_pts).T) < 0.025))
        print(f"| {name} | {np.median(err):.4f} | {np.percentile(err, 95):.4f} | {err.max():.4f} | {ms:.2f} | "
              f"{same:.1%} |", flush=True)


if __name__ == "__main__":
    main()
