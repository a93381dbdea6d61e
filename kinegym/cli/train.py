"""``kinegym train gait``, ``kinegym evaluate gait`` and ``kinegym tune gait`` (see
:mod:`kinegym.agents.train`). Registered on the main parser by :func:`add_parsers`."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from kinegym.cli.common import EXIT_OK, UsageError, add_json, add_no_loop_guard, emit, out_dir
from kinegym.configs import load_yaml

__all__ = ["add_parsers"]


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


def _say(args: argparse.Namespace, text: str) -> None:
    """A line about the cost of what follows (stderr, so --json output stays one document)."""
    if not args.json:
        print(text, file=sys.stderr, flush=True)


def _evaluate_cost(policy_kwargs: dict[str, Any], episodes: int, modes: tuple[str, ...],
                   planner_weight: float = 2.0) -> tuple[float, str]:
    """Rough seconds for ``evaluate`` (both agents, every mode) and how it was measured."""
    from kinegym.agents import train as T

    total, parts = 0.0, []
    for mode in modes:
        sps = T.steps_per_second({**policy_kwargs, "mode": mode}, steps=12 if mode == "physics" else 40, planner=True,
                                 planner_weight=planner_weight)
        total += 2 * episodes * T.TYPICAL_CLIMB / sps
        parts.append(f"{mode} {sps:.0f} steps/s")
    return total, ", ".join(parts)


def cmd_train(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T
    from kinegym.progress import Progress

    show = not args.json and not args.no_progress
    if args.minutes is not None and not args.minutes > 0:
        raise UsageError(f"--minutes {args.minutes}; expected > 0")
    verbose = 1 if args.verbose else 0
    if args.resume:
        if not Path(args.resume).is_dir():
            raise UsageError(f"--resume {args.resume!r} is not a run directory")
        with Progress(args.timesteps or 1, "train (resumed)", enabled=show and bool(args.timesteps)) as bar:
            run = T.resume(args.resume, args.timesteps, progress=bar.update, command=["kinegym", *sys.argv[1:]],
                           minutes=args.minutes, verbose=verbose, mode=args.mode)
    else:
        if args.timesteps is not None and args.timesteps < 1:
            raise UsageError(f"--timesteps {args.timesteps}; expected >= 1")
        if args.n_envs is not None and not 1 <= args.n_envs <= 64:
            raise UsageError(f"--n-envs {args.n_envs}; expected 1..64")
        cfg = T.load_train_config(args.config)
        if args.n_envs is not None:
            cfg["n_envs"] = args.n_envs
        if args.mode is not None:
            cfg["env_kwargs"] = {**cfg["env_kwargs"], "mode": args.mode}
        steps = args.timesteps or cfg["n_timesteps"]
        if not args.json:
            sps = T.steps_per_second(cfg["env_kwargs"])
            est = T.estimate_train_s(cfg, sps, steps)
            limit = f", stopped at {args.minutes:g} min (--minutes)" if args.minutes else ""
            _say(args, f"train: {steps:,} env steps on {cfg['n_envs']} envs, an evaluation of "
                       f"{cfg['eval_episodes']} walls every {cfg['eval_freq']:,} steps: about "
                       f"{_minutes(est)} here ({sps:.0f} env steps/s measured){limit}")
            if cfg["bc_episodes"]:
                k = cfg["warm_start_workers"]  # processes sharing the climbs
                bc_s, dg_s = T.estimate_warm_start_s(cfg)
                _say(args, f"warm start: the planner climbs {cfg['bc_episodes']:,} training tasks first"
                           f"{f' in {k} processes' if k > 1 else ''} and the policy is fitted to its moves "
                           f"(about {_minutes(bc_s)}, inside --minutes)")
                if cfg["dagger_rounds"]:
                    _say(args, f"then DAgger ({cfg['dagger_rounds']} x {cfg['dagger_episodes']:,} climbs): the policy "
                               f"climbs training tasks, the planner labels the states it reaches and the policy is "
                               f"fitted again (about {_minutes(dg_s)})")
        with Progress(steps, "train", enabled=show) as bar:
            run = T.train(args.config, args.timesteps, args.seed, args.n_envs, args.out, progress=bar.update,
                          command=["kinegym", *sys.argv[1:]], minutes=args.minutes, verbose=verbose,
                          mode=args.mode)
    files = sorted(str(p.relative_to(run)) for p in run.rglob("*") if p.is_file() and "tb" not in p.parts)
    lines = [f"run directory: {run}"] + [f"  {f}" for f in files if not f.startswith("monitor/")]
    pre = run / "pretrain.yaml"
    if pre.is_file():
        got = load_yaml(pre)
        lines.append(f"warm start: {got['climbed']:,} planner climbs, {got['moves']:,} moves cloned in "
                     f"{got['demo_seconds'] + got['clone_seconds']:.0f} s; the policy then chose the planner's move "
                     f"on {got['agreement']:.0%} of them")
        for r, rd in enumerate(got.get("dagger", []), 1):
            lines.append(f"DAgger round {r}: the policy climbed {rd['climbed']:,} of its tasks; the planner chose "
                         f"otherwise in {rd['differed']:,} of {rd['states']:,} states; {rd['rows']:,} rows, "
                         f"{rd['agreement']:.0%} agreement, {rd['seconds']:.0f} s")
    curve = run / "learning_curve.png"
    if curve.is_file():
        lines.append(f"learning curve: {curve}")
    best = run / "best" / "best_model.zip"
    final = run / "final_model.zip"
    policy = final if final.is_file() else best
    if policy.is_file():
        quick = f"kinegym evaluate gait --policy {policy} --mode kinematic --episodes 20"
        lines.append(f"evaluate it: {quick}  (kinematic walls only; --mode both --episodes 50 adds physics, "
                     "which takes minutes to tens of minutes: it says how long before it starts)")
        if best.is_file() and policy != best:
            lines.append(f"the best on validation walls: {best}")
    emit(args, {"run": str(run), "files": files}, "\n".join(lines))
    return EXIT_OK


def cmd_evaluate(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T
    from kinegym.agents.evaluation import check_planner_weight, evaluate
    from kinegym.progress import Progress

    if not Path(args.policy).is_file():
        raise UsageError(f"--policy {args.policy!r} is not a model file (.zip)")
    if args.episodes < 1:
        raise UsageError(f"--episodes {args.episodes}; expected >= 1")
    try:
        check_planner_weight(args.planner_weight, "--planner-weight ")
    except ValueError as err:
        raise UsageError(str(err)) from None
    modes = ("kinematic", "physics") if args.mode == "both" else (args.mode,)
    if not args.json:
        from kinegym.agents.policies import policy_env_kwargs

        est, how = _evaluate_cost(policy_env_kwargs(args.policy), args.episodes, modes, args.planner_weight)
        _say(args, f"evaluate: {args.episodes} walls x {len(modes)} mode(s) x 2 agents: about {_minutes(est)} here "
                   f"({how}; --mode kinematic and fewer --episodes are quicker)")
    import torch

    # one observation a decision: more threads only contend (two evaluations side by side on 2
    # cores, each on torch's default 2 threads: 11.7 ms a policy move instead of 0.5)
    torch.set_num_threads(1)
    with Progress(args.episodes * len(modes), "evaluate (policy and planner on the same walls)",
                  enabled=not args.json) as bar:
        rows = evaluate(args.policy, args.episodes, modes, args.walls, progress=bar.update,
                        planner_weight=args.planner_weight, loop_guard=not args.no_loop_guard)

    def f(v: float, fmt: str) -> str:
        return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)

    base = T.HELD_OUT_SEED if args.walls == "held-out" else T.VALIDATION_SEED
    guard = "off (--no-loop-guard)" if args.no_loop_guard else "on"
    lines = [f"HoleClimb-v0, {args.episodes} {args.walls} walls (wall i = reset(seed={base} + i)), deterministic, "
             f"the policy's loop guard {guard}",
             f"{'agent':<40} {'mode':<10} {'success':>8} {'falls':>6} {'moves':>7} {'vs planner':>11} {'ms/move':>8}"]
    for r in rows:
        name = r.agent if len(r.agent) <= 40 else "..." + r.agent[-37:]
        lines.append(f"{name:<40} {r.mode:<10} {r.success:>8.1%} {r.falls:>6} {f(r.mean_moves, '.1f'):>7} "
                     f"{f(r.moves_vs_planner, '.2f') + 'x':>11} {r.decision_ms:>8.2f}"
                     + (f"  (the loop guard changed {r.guarded} decisions)" if r.guarded else ""))
    emit(args, {"walls": args.walls, "episodes": args.episodes, "loop_guard": not args.no_loop_guard,
                "rows": [r.as_dict() for r in rows]},
          "\n".join(lines))
    return EXIT_OK


def cmd_tune(args: argparse.Namespace) -> int:
    from kinegym.agents import train as T

    if args.trials < 1:
        raise UsageError(f"--trials {args.trials}; expected >= 1")
    if not 64 <= args.timesteps <= 10**9:
        raise UsageError(f"--timesteps {args.timesteps}; expected 64..1e9 env steps per trial")
    if args.eval_episodes is not None and not 1 <= args.eval_episodes <= 10_000:
        raise UsageError(f"--eval-episodes {args.eval_episodes}; expected 1..10000 walls per evaluation")
    if args.n_envs is not None and not 1 <= args.n_envs <= 64:
        raise UsageError(f"--n-envs {args.n_envs}; expected 1..64")
    from kinegym.agents.tune import open_storage, tune

    cfg = T.load_train_config(args.config)  # a bad config is named before any trial starts (not inside one)
    open_storage(args.storage)  # so is a bad storage
    cfg.update({k: v for k, v in (("eval_episodes", args.eval_episodes), ("n_envs", args.n_envs)) if v is not None})
    cfg["eval_freq"] = max(64, args.timesteps // 4)
    if not args.json:
        sps = T.steps_per_second(cfg["env_kwargs"])
        per = T.estimate_train_s(cfg, sps, args.timesteps)
        _say(args, f"tune: {args.trials} trials x ({args.timesteps:,} env steps on {cfg['n_envs']} envs + 4 "
                   f"evaluations of {cfg['eval_episodes']} walls): about {_minutes(per)} a trial, "
                   f"{_minutes(per * args.trials)} in all here ({sps:.0f} env steps/s; pruned trials stop early; "
                   "--eval-episodes and --timesteps lower it)")

    def on_trial(t: dict[str, Any]) -> None:
        value = "-" if t["value"] is None else f"{t['value']:.3f}"
        secs = "" if t["seconds"] is None else f" in {t['seconds']:.0f} s"
        params = ", ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in t["params"].items())
        _say(args, f"trial {t['number']}: {t['state']}, validation success {value}{secs} ({params})")

    res = tune(args.trials, args.storage, args.study, args.timesteps, args.config, args.out, args.seed,
               eval_episodes=args.eval_episodes, n_envs=args.n_envs, on_trial=on_trial)
    lines = [f"study {res['study']} on {res['storage']}: {res['trials']} trials ({res['complete']} complete, "
             f"{res['pruned']} pruned)", f"best validation success {res['best_value']}, params {res['best_params']}"]
    emit(args, res, "\n".join(lines))
    return EXIT_OK


def cmd_selfplay(args: argparse.Namespace) -> int:
    from kinegym.agents.selfplay import selfplay
    from kinegym.progress import Progress

    if not 1 <= args.timesteps <= 10_000_000:
        raise UsageError(f"--timesteps {args.timesteps}; expected 1..10000000")
    if not 1 <= args.eval_games <= 10_000:
        raise UsageError(f"--eval-games {args.eval_games}; expected 1..10000")
    if args.swap_every < 1:
        raise UsageError(f"--swap-every {args.swap_every}; expected >= 1")
    games = 2 * 2 * 2 * args.eval_games  # before and after, two opponents, two sides
    _say(args, f"selfplay: {args.timesteps:,} steps of the drawn 3x3 game and {games} evaluation games: about "
               f"{_minutes(0.05 * (args.timesteps + 4 * games))} (the camera and the reader cost ~45 ms a step)")
    with Progress(args.timesteps, "selfplay", enabled=not args.json) as bar:
        res = selfplay(args.timesteps, args.seed, args.swap_every, args.eval_games, out_dir(args.out),
                       progress=bar.update)
    lines = [f"{'opponent':<16} {'before (win/draw/loss)':>24} {'after':>20}"]
    for key in res.before:
        b, a = res.before[key], res.after[key]
        lines.append(f"{key:<16} {' / '.join(f'{v:.2f}' for v in b):>24} {' / '.join(f'{v:.2f}' for v in a):>20}")
    lines.append(f"model: {res.model_path}")
    emit(args, {"before": res.before, "after": res.after, "model": str(res.model_path)}, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    tr = sub.add_parser("train", help="train a policy (MaskablePPO) for the climber's gait")
    tr.add_argument("what", choices=("gait",), help="what to learn (the climber's gait sequencing)")
    tr.add_argument("--config", default="hole_climb_maskable_ppo", help="configs/train name or YAML path")
    tr.add_argument("--timesteps", type=int, default=None, help="total env steps (default: the config's)")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--n-envs", type=int, default=None, help="parallel envs (SubprocVecEnv when > 1)")
    tr.add_argument("--out", default="runs", help="folder for run directories")
    tr.add_argument("--resume", default=None,
                    help="continue this run directory's furthest model (last checkpoint or final model)")
    tr.add_argument("--mode", default=None, choices=("kinematic", "physics"),
                    help="the training envs' mode (default: the config's env_kwargs.mode; with --resume a "
                         "physics fine-tuning phase)")
    tr.add_argument("--minutes", type=float, default=None,
                    help="stop after this much wall time (final model saved; default: no limit)")
    tr.add_argument("--no-progress", action="store_true", help="no progress bar")
    tr.add_argument("--verbose", action="store_true",
                    help="print SB3's training metrics after every update (success, episode length, losses, fps)")
    add_json(tr)
    tr.set_defaults(func=cmd_train)

    ev = sub.add_parser("evaluate", help="a trained gait policy against the planner on held-out walls")
    ev.add_argument("what", choices=("gait",))
    ev.add_argument("--policy", required=True, help="a MaskablePPO model .zip")
    ev.add_argument("--episodes", type=int, default=50)
    ev.add_argument("--walls", default="held-out", choices=("held-out", "validation"))
    ev.add_argument("--mode", default="both", choices=("kinematic", "physics", "both"))
    ev.add_argument("--planner-weight", type=float, default=2.0,
                    help="the planner's A* weight (default 2, its own; 1.1: within about 1%% of the shortest routes, "
                         "the training config's teacher)")
    add_no_loop_guard(ev)
    add_json(ev)
    ev.set_defaults(func=cmd_evaluate)

    tu = sub.add_parser("tune", help="hyper-parameter search on Optuna (many workers may share one storage)")
    tu.add_argument("what", choices=("gait",))
    tu.add_argument("--trials", type=int, default=10, help="trials this worker runs")
    tu.add_argument("--storage", required=True,
                    help="sqlite:///study.db, postgresql://user:pw@host/db, or journal:/shared/path/study.log")
    tu.add_argument("--study", required=True, help="study name (workers with the same name cooperate)")
    tu.add_argument("--timesteps", type=int, default=50_000, help="env steps per trial")
    tu.add_argument("--eval-episodes", type=int, default=None,
                    help="validation walls per evaluation, 4 evaluations a trial (default: the config's)")
    tu.add_argument("--n-envs", type=int, default=None, help="parallel envs per trial (default: the config's)")
    tu.add_argument("--config", default="hole_climb_maskable_ppo")
    tu.add_argument("--out", default="runs/tune")
    tu.add_argument("--seed", type=int, default=0)
    add_json(tu)
    tu.set_defaults(func=cmd_tune)

    sp = sub.add_parser("selfplay", help="MaskablePPO learns the drawn 3x3 game against its frozen self")
    sp.add_argument("--timesteps", type=int, default=6_000, help="env steps (both sides together)")
    sp.add_argument("--swap-every", type=int, default=1_000, help="steps between refreshes of the frozen opponent")
    sp.add_argument("--eval-games", type=int, default=10, help="games per opponent and side, before and after")
    sp.add_argument("--seed", type=int, default=0)
    sp.add_argument("--out", default="runs/selfplay", help="folder for selfplay_model.zip")
    add_json(sp)
    sp.set_defaults(func=cmd_selfplay)
