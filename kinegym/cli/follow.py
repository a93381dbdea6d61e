"""``kinegym follow``: seed 001's mobile robot - localise from beacons, follow target points,
relocalise when the measurements disagree with the belief (:mod:`kinegym.kinematics.mobile`).

Prints how far the real path strayed from the believed one (max and mean, the seed's units),
the targets reached, the steps and the relocalisations; writes the first fix's error map (a
heat map with the beacons, the real and the estimated robot, as the seed's figure 3.3) and,
with ``--gif``, the run as an animation. Registered on the main parser by :func:`add_parsers`.
"""

from __future__ import annotations

import argparse
import math
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_OK, UsageError, add_json, emit, parse_floats, rnd

__all__ = ["add_parsers", "cmd_follow"]


def _points(text: str, option: str) -> np.ndarray:
    groups = [g for g in text.split(";") if g.strip()]
    if not groups or len(groups) > 1000:
        raise UsageError(f"{option} {text!r}; expected 1..1000 points like 'x,y;x,y'")
    return np.array([parse_floats(g, 2, option) for g in groups])


def _beacons(text: str, targets: np.ndarray, start: np.ndarray) -> np.ndarray | None:
    """``targets`` (the seed's choice), ``grid:NxM`` over the field, or a scene YAML's beacons."""
    if text == "scene":
        return None
    if text == "targets":
        return targets.copy()
    m = re.fullmatch(r"grid:(\d+)x(\d+)", text)
    if m:
        nx, ny = int(m[1]), int(m[2])
        if not (1 <= nx <= 50 and 1 <= ny <= 50 and nx * ny >= 1):
            raise UsageError(f"--beacons {text!r}; expected grid:NxM with 1 <= N, M <= 50")
        pts = np.vstack([targets, start[None, :2]])
        lo, hi = pts.min(0) - 0.5, pts.max(0) + 0.5
        gx = np.linspace(lo[0], hi[0], nx) if nx > 1 else np.array([(lo[0] + hi[0]) / 2])
        gy = np.linspace(lo[1], hi[1], ny) if ny > 1 else np.array([(lo[1] + hi[1]) / 2])
        return np.array([[x, y] for y in gy for x in gx])
    from kinegym.kinematics.mobile import load_scene

    if not (text.endswith((".yaml", ".yml")) or Path(text).exists()):
        raise UsageError(f"--beacons {text!r}; expected targets, grid:NxM, scene, or a scene YAML file")
    return load_scene(text).model.beacons


def cmd_follow(args: argparse.Namespace) -> int:
    from kinegym.kinematics.beacons import BeaconModel
    from kinegym.kinematics.mobile import MotionModel, follow, load_scene, noise_threshold

    scene = load_scene(args.scene)
    targets = scene.targets if args.targets is None else _points(args.targets, "--targets")
    start = scene.start.copy()
    if args.start is not None:
        x, y, h = parse_floats(args.start, 3, "--start")
        start = np.array([x, y, math.radians(h)])
    beacons = _beacons(args.beacons, targets, start)
    sig_r = scene.model.sigma_range if args.sigma_range is None else args.sigma_range
    if not (math.isfinite(sig_r) and 0 <= sig_r <= 10):
        raise UsageError(f"--sigma-range {sig_r!r}; expected 0..10 (the seed: 0.1)")
    model = BeaconModel(scene.model.beacons if beacons is None else beacons, bearings=scene.model.bearings,
                        sigma_range=sig_r, sigma_bearing=scene.model.sigma_bearing)
    if not (math.isfinite(args.forward_noise) and 0 <= args.forward_noise <= 1):
        raise UsageError(f"--forward-noise {args.forward_noise!r}; expected a share of the step 0..1")
    if not (math.isfinite(args.turn_noise_deg) and 0 <= args.turn_noise_deg <= 90):
        raise UsageError(f"--turn-noise-deg {args.turn_noise_deg!r}; expected 0..90")
    if not (1 <= args.max_steps <= 100_000):
        raise UsageError(f"--max-steps {args.max_steps!r}; expected 1..100000")
    if args.seed < 0:
        raise UsageError(f"--seed {args.seed!r}; expected an integer >= 0")
    motion = MotionModel(kind=args.model, length=args.length, turn_in_place=args.turn_in_place,
                         forward_noise=args.forward_noise, turn_noise=math.radians(args.turn_noise_deg))
    if args.threshold == "auto":
        threshold = noise_threshold(model) if sig_r > 0 else 0.1
    else:
        try:
            threshold = float(args.threshold)
        except ValueError:
            threshold = float("nan")
        if not (math.isfinite(threshold) and threshold > 0):
            raise UsageError(f"--threshold {args.threshold!r}; expected auto or a number > 0 (the seed: 0.1)")
    t0 = time.perf_counter()
    res = follow(model, targets, start, motion, np.random.default_rng(args.seed), threshold=threshold,
                 max_steps=args.max_steps)
    secs = time.perf_counter() - t0
    out = Path(args.out)
    pictures = _pictures(args, res, model, targets, out)
    fix_err = float(np.hypot(*(res.first_fix.pose[:2] - start[:2])))
    lines = [f"scene {scene.name}: {len(model.beacons)} beacons, {len(targets)} targets, {motion.kind} robot, "
             f"range noise {sig_r:g}, odometry noise {100 * motion.forward_noise:g} % / {args.turn_noise_deg:.2f} deg",
             f"first fix: {res.first_fix.evaluations} grid points, {fix_err:.3f} from the true start",
             f"targets reached: {res.reached}/{len(targets)} in {len(res.ideal) - 1} steps ({secs:.2f} s)",
             f"path error (believed vs real): max {res.max_path_error:.3f}, mean {res.mean_path_error:.3f}",
             f"relocalisations: {len(res.relocalisations)} (threshold {threshold:.3f}"
             f"{', noise 99 %' if args.threshold == 'auto' else ''})"]
    lines += [f"{k}: {v}" for k, v in pictures.items()]
    emit(args, {"scene": scene.name, "model": motion.kind, "beacons": rnd(model.beacons), "targets": rnd(targets),
                "start": rnd(start), "threshold": threshold, "seed": args.seed, "first_fix": rnd(res.first_fix.pose),
                "first_fix_error": fix_err, "reached": res.reached, "steps": len(res.ideal) - 1,
                "max_path_error": res.max_path_error, "mean_path_error": res.mean_path_error,
                "relocalisations": len(res.relocalisations), "seconds": secs, **pictures}, "\n".join(lines))
    return EXIT_OK


def _pictures(args: argparse.Namespace, res: Any, model: Any, targets: np.ndarray, out: Path) -> dict[str, str]:
    from kinegym.envs.draw import save_gif, save_rgb
    from kinegym.envs.draw_beacons import error_map, field_canvas, follow_frame

    files = {}
    ny, nx = res.first_fix.image.shape
    img = error_map(res.first_fix, model.beacons, res.real[0], caption=[f"first fix: error over {nx} x {ny} points"])
    files["error_map"] = str(save_rgb(img, out / "follow_error_map.png"))
    relocs = [k for k, _ in res.relocalisations]
    canvas = field_canvas(np.vstack([model.beacons, targets, res.ideal[:, :2], res.real[:, :2]]))
    n = len(res.ideal)
    final = follow_frame(canvas, model.beacons, targets, res.ideal, res.real, [
        f"{n - 1} steps, {len(relocs)} relocalisations, max path error {res.max_path_error:.3f}"], relocs)
    files["path"] = str(save_rgb(final, out / "follow_path.png"))
    if args.gif:
        stride = max(1, n // 120)
        frames = [follow_frame(canvas, model.beacons, targets, res.ideal[: k + 1], res.real[: k + 1],
                               [f"step {k}"], [r for r in relocs if r <= k]) for k in range(0, n, stride)]
        frames.append(final)
        files["gif"] = str(save_gif(frames, args.gif, fps=20))
    return files


def add_parsers(sub: Any) -> None:
    """Add ``follow`` to the main parser's subcommands."""
    fo = sub.add_parser("follow", help="seed 001's mobile robot: beacon localisation, target following")
    fo.add_argument("--scene", default="seed001", help="scene name or YAML (beacons, targets, start, noise)")
    fo.add_argument("--beacons", default="scene",
                    help="scene (its own), targets (the seed's choice), grid:NxM over the field, or a scene YAML")
    fo.add_argument("--model", choices=["holonomic", "tricycle"], default="holonomic", help="motion model")
    fo.add_argument("--length", type=float, default=0.2, help="tricycle steering length (default 0.2)")
    fo.add_argument("--turn-in-place", action="store_true", help="turn standing while the bearing is off")
    fo.add_argument("--targets", default=None, help="points to visit 'x,y;x,y;...' instead of the scene's")
    fo.add_argument("--start", default=None, help="real start 'x,y,heading_deg' instead of the scene's")
    fo.add_argument("--sigma-range", type=float, default=None, help="range noise (default: the scene's)")
    fo.add_argument("--forward-noise", type=float, default=0.01, help="odometry noise, share of each step")
    fo.add_argument("--turn-noise-deg", type=float, default=math.degrees(0.01), help="turn noise per step, deg")
    fo.add_argument("--threshold", default="auto",
                    help="relocalise above this measurement error; auto = the noise's 99 %% (the seed: 0.1)")
    fo.add_argument("--max-steps", type=int, default=1000, help="steps in all (the seed: 1000)")
    fo.add_argument("--seed", type=int, default=0, help="noise seed")
    fo.add_argument("--out", default="kinegym-out", help="folder for the pictures")
    fo.add_argument("--gif", default=None, help="animate the run (.gif, or .mp4 with kinegym[video])")
    add_json(fo)
    fo.set_defaults(func=cmd_follow)
