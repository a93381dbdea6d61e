"""``kinegym climb``: run HoleClimb-v0 episodes with the planner or a trained policy, print
success, moves and falls, and write a GIF of the climb.

Registered on the main parser by :func:`add_parsers`; conventions in :mod:`kinegym.cli.common`.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_NO_ANSWER, EXIT_OK, UsageError, add_json, add_no_loop_guard, emit

__all__ = ["add_parsers", "cmd_climb", "load_policy"]


def load_policy(spec: str, loop_guard: bool = True) -> Any:
    """``"planner"`` or a MaskablePPO ``.zip`` (acting with its loop guard unless ``loop_guard``
    is False): an object with ``act(env) -> action``."""
    from kinegym.agents.gait_planner import PlannerAgent

    if spec == "planner":
        return PlannerAgent()
    path = Path(spec)
    if not path.is_file():
        raise UsageError(f"--policy {spec!r} is neither 'planner' nor an existing model file (.zip)")
    from kinegym.agents.policies import MaskedPolicyAgent

    return MaskedPolicyAgent(path, loop_guard=loop_guard)


def cmd_climb(args: argparse.Namespace) -> int:
    import gymnasium as gym

    import kinegym  # noqa: F401  (registers the ids)
    from kinegym.agents.rollout import run_episode
    from kinegym.envs.draw import save_gif
    from kinegym.progress import Progress

    if args.episodes < 1:
        raise UsageError(f"--episodes {args.episodes} must be >= 1")
    agent = load_policy(args.policy, loop_guard=not args.no_loop_guard)
    kwargs: dict[str, Any] = {"mode": args.mode, "robot": args.robot, "wall": args.wall}
    if args.policy != "planner":  # the env as the policy was trained on it (e.g. memory=True)
        from kinegym.agents.train import policy_env_kwargs

        kwargs = {**policy_env_kwargs(args.policy), **kwargs}
    try:
        from kinegym.envs.variants import split_space_kwargs

        env_id, kwargs = split_space_kwargs("kinegym/HoleClimb-v0", kwargs)  # memory/hints name their own id
        env = gym.make(env_id, render_mode="rgb_array" if args.gif else None, **kwargs)
        env.reset(seed=args.seed)
    except RuntimeError as err:  # no route on a fixed wall for this robot
        emit(args, {"error": "NoRoute", "message": str(err)}, f"kinegym: {err}")
        return EXIT_NO_ANSWER
    rows, frames = [], []
    t0 = time.perf_counter()
    with Progress(args.episodes, f"climb ({args.policy}, {args.mode})", enabled=not args.json) as bar:
        for i in range(args.episodes):
            ep = run_episode(env, agent, seed=args.seed + i, frames=bool(args.gif) and i == 0)
            frames += ep.frames
            rows.append({"episode": i, "seed": args.seed + i, "success": ep.success, "moves": ep.moves,
                         "planner_moves": int(ep.info["planner_moves"]), "falls": ep.falls,
                         "return": round(ep.ret, 3), "wall": ep.info["wall"], "seconds": ep.seconds})
            bar.update()
    secs = time.perf_counter() - t0
    gif = str(save_gif(frames, args.gif, env.unwrapped.metadata["render_fps"])) if args.gif else None
    env.close()
    ok = sum(r["success"] for r in rows)
    lines = [f"HoleClimb-v0 ({args.mode}, robot {args.robot}, wall {args.wall}): policy {args.policy}, "
             f"{len(rows)} episodes in {secs:.1f} s",
             f"{'ep':>3} {'seed':>6} {'success':>8} {'moves':>6} {'planner':>8} {'falls':>6} {'return':>8}  wall"]
    for r in rows:
        lines.append(f"{r['episode']:>3} {r['seed']:>6} {str(r['success']):>8} {r['moves']:>6} "
                     f"{r['planner_moves']:>8} {r['falls']:>6} {r['return']:>8.2f}  {r['wall']}")
    moves = [r["moves"] for r in rows if r["success"]]
    lines.append(f"success {ok}/{len(rows)}" + (f", mean moves {np.mean(moves):.1f}" if moves else ""))
    if gif:
        lines.append(f"gif: {gif}")
    emit(args, {"policy": args.policy, "mode": args.mode, "episodes": rows, "success_rate": ok / len(rows),
                 "gif": gif, "seconds": secs}, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    cl = sub.add_parser("climb", help="run HoleClimb-v0 episodes with the planner or a trained policy")
    cl.add_argument("--wall", default="generated",
                    help="'generated' (a new seeded wall per episode), a wall config name or a YAML path")
    cl.add_argument("--robot", default="climber", help="robot config (climber_long for the seed's 20 cm wall)")
    cl.add_argument("--policy", default="planner", help="'planner' or a MaskablePPO model .zip")
    cl.add_argument("--mode", default="kinematic", choices=("kinematic", "physics"))
    add_no_loop_guard(cl)
    cl.add_argument("--episodes", type=int, default=5)
    cl.add_argument("--seed", type=int, default=0, help="seed of the first episode (then +1 per episode)")
    cl.add_argument("--gif", default=None, help="animate the first episode (.gif, or .mp4 with kinegym[video])")
    add_json(cl)
    cl.set_defaults(func=cmd_climb)
