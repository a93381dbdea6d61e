"""``kinegym train gait``, ``kinegym evaluate gait`` and ``kinegym tune gait`` (see
:mod:`kinegym.agents.train`). Registered on the main parser by :func:`add_parsers`."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from kinegym.cli.common import EXIT_OK, UsageError, add_json, emit

__all__ = ["add_parsers"]


def cmd_train(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T

    progress = not args.json and not args.no_progress
    if args.minutes is not None and not args.minutes > 0:
        raise UsageError(f"--minutes {args.minutes}; expected > 0")
    if args.resume:
        if not Path(args.resume).is_dir():
            raise UsageError(f"--resume {args.resume!r} is not a run directory")
        run = T.resume(args.resume, args.timesteps, progress=progress, command=["kinegym", *sys.argv[1:]],
                       minutes=args.minutes)
    else:
        if args.timesteps is not None and args.timesteps < 1:
            raise UsageError(f"--timesteps {args.timesteps}; expected >= 1")
        if args.n_envs is not None and not 1 <= args.n_envs <= 64:
            raise UsageError(f"--n-envs {args.n_envs}; expected 1..64")
        run = T.train(args.config, args.timesteps, args.seed, args.n_envs, args.out, progress=progress,
                      command=["kinegym", *sys.argv[1:]], minutes=args.minutes)
    files = sorted(str(p.relative_to(run)) for p in run.rglob("*") if p.is_file() and "tb" not in p.parts)
    lines = [f"run directory: {run}"] + [f"  {f}" for f in files if not f.startswith("monitor/")]
    curve = run / "learning_curve.png"
    if curve.is_file():
        lines.append(f"learning curve: {curve}")
    lines.append(f"evaluate it: kinegym evaluate gait --policy {run / 'final_model.zip'}"
                 f"  (the best on validation walls: {run / 'best' / 'best_model.zip'})")
    emit(args, {"run": str(run), "files": files}, "\n".join(lines))
    return EXIT_OK


def cmd_evaluate(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T
    from kinegym.progress import Progress

    if not Path(args.policy).is_file():
        raise UsageError(f"--policy {args.policy!r} is not a model file (.zip)")
    if args.episodes < 1:
        raise UsageError(f"--episodes {args.episodes}; expected >= 1")
    modes = ("kinematic", "physics") if args.mode == "both" else (args.mode,)
    with Progress(args.episodes * len(modes), "evaluate (policy and planner on the same walls)",
                  enabled=not args.json) as bar:
        rows = T.evaluate(args.policy, args.episodes, modes, args.walls, progress=bar.update)

    def f(v: float, fmt: str) -> str:
        return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)

    base = T.HELD_OUT_SEED if args.walls == "held-out" else T.VALIDATION_SEED
    lines = [f"HoleClimb-v0, {args.episodes} {args.walls} walls (wall i = reset(seed={base} + i)), deterministic",
             f"{'agent':<40} {'mode':<10} {'success':>8} {'falls':>6} {'moves':>7} {'vs planner':>11} {'ms/move':>8}"]
    for r in rows:
        name = r.agent if len(r.agent) <= 40 else "..." + r.agent[-37:]
        lines.append(f"{name:<40} {r.mode:<10} {r.success:>8.1%} {r.falls:>6} {f(r.mean_moves, '.1f'):>7} "
                     f"{f(r.moves_vs_planner, '.2f') + 'x':>11} {r.decision_ms:>8.2f}")
    emit(args, {"walls": args.walls, "episodes": args.episodes, "rows": [r.as_dict() for r in rows]},
          "\n".join(lines))
    return EXIT_OK


def cmd_tune(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T

    if args.trials < 1:
        raise UsageError(f"--trials {args.trials}; expected >= 1")
    if not 64 <= args.timesteps <= 10**9:
        raise UsageError(f"--timesteps {args.timesteps}; expected 64..1e9 env steps per trial")
    from kinegym.agents.tune import open_storage, tune

    T.load_train_config(args.config)  # a bad config is named before any trial starts (not inside one)
    open_storage(args.storage)  # so is a bad storage
    res = tune(args.trials, args.storage, args.study, args.timesteps, args.config, args.out, args.seed)
    lines = [f"study {res['study']} on {res['storage']}: {res['trials']} trials ({res['complete']} complete, "
             f"{res['pruned']} pruned)", f"best validation success {res['best_value']}, params {res['best_params']}"]
    emit(args, res, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    tr = sub.add_parser("train", help="train a policy (MaskablePPO) for the climber's gait")
    tr.add_argument("what", choices=("gait",), help="what to learn (the climber's gait sequencing)")
    tr.add_argument("--config", default="hole_climb_maskable_ppo", help="configs/train name or YAML path")
    tr.add_argument("--timesteps", type=int, default=None, help="total env steps (default: the config's)")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--n-envs", type=int, default=None, help="parallel envs (SubprocVecEnv when > 1)")
    tr.add_argument("--out", default="runs", help="folder for run directories")
    tr.add_argument("--resume", default=None, help="continue this run directory's last checkpoint")
    tr.add_argument("--minutes", type=float, default=None,
                    help="stop after this much wall time (final model saved; default: no limit)")
    tr.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_json(tr)
    tr.set_defaults(func=cmd_train)

    ev = sub.add_parser("evaluate", help="a trained gait policy against the planner on held-out walls")
    ev.add_argument("what", choices=("gait",))
    ev.add_argument("--policy", required=True, help="a MaskablePPO model .zip")
    ev.add_argument("--episodes", type=int, default=50)
    ev.add_argument("--walls", default="held-out", choices=("held-out", "validation"))
    ev.add_argument("--mode", default="both", choices=("kinematic", "physics", "both"))
    add_json(ev)
    ev.set_defaults(func=cmd_evaluate)

    tu = sub.add_parser("tune", help="hyper-parameter search on Optuna (many workers may share one storage)")
    tu.add_argument("what", choices=("gait",))
    tu.add_argument("--trials", type=int, default=10, help="trials this worker runs")
    tu.add_argument("--storage", required=True,
                    help="sqlite:///study.db, postgresql://user:pw@host/db, or journal:/shared/path/study.log")
    tu.add_argument("--study", required=True, help="study name (workers with the same name cooperate)")
    tu.add_argument("--timesteps", type=int, default=50_000, help="env steps per trial")
    tu.add_argument("--config", default="hole_climb_maskable_ppo")
    tu.add_argument("--out", default="runs/tune")
    tu.add_argument("--seed", type=int, default=0)
    add_json(tu)
    tu.set_defaults(func=cmd_tune)
