"""Learning the climber's gait with stable-baselines3: train, resume, and tune
hyper-parameters on Optuna (evaluating against the planner: :mod:`kinegym.agents.evaluation`).

One readable script in the CleanRL spirit, behind ``kinegym train gait``, ``kinegym
evaluate gait`` and ``kinegym tune gait`` (also ``python -m kinegym train gait ...``):

* **Configuration**, RL-Zoo style: ``configs/train/hole_climb_maskable_ppo.yaml`` holds one
  section per env id (``n_envs``, ``n_timesteps``, ``policy``, ``policy_kwargs``,
  ``env_kwargs``, PPO's hyper-parameters; ``learning_rate`` / ``clip_range`` may be
  schedules such as ``lin_3e-4``), validated on load (file, key and bad value named).
* **Training**: sb3-contrib's MaskablePPO (masks through the env's ``action_masks()``), a
  ``SubprocVecEnv`` when ``n_envs > 1`` (forkserver workers: keep the ``__main__`` guard),
  ``torch.set_num_threads(1)`` by default (several times faster on 2 cores); ``--minutes M``
  stops after ``M`` minutes of wall time and saves the final model (a time budget instead
  of a step count; a schedule such as ``lin_2e-4`` then anneals over the time PPO has left).
* **A run directory** holds ``config.yaml`` (resolved), ``command.txt``, ``monitor/``
  (Monitor CSVs with ``is_success``), ``tb/`` (TensorBoard), ``checkpoints/`` (model,
  optimiser, step counter and normalisation statistics every ``checkpoint_freq`` steps),
  ``best/best_model.zip`` (by a masked evaluation on validation walls), ``final_model.zip``,
  ``evaluations.npz`` and ``learning_curve.png``. ``--resume RUN`` continues the furthest
  model of ``RUN`` (last checkpoint, or the final model of a ``--minutes`` stop) into a new
  directory ``RUN-resume<k>``; nothing of ``RUN`` is touched. ``--mode physics`` with it is a
  physics fine-tuning phase (the envs simulate every move in pymunk from then on).
* **Warm start** (``bc_episodes: N`` in the config, default 0): before PPO the planner climbs
  ``N`` training tasks and the policy and its critic are fitted to those climbs
  (:mod:`kinegym.agents.pretrain`; in kinematic mode, also for a physics run); with
  ``dagger_rounds: R`` the policy then climbs ``dagger_episodes`` tasks per round, the
  planner labels the states it reached, and it is fitted again (DAgger). The planner that
  does both runs at A* weight ``teacher_weight`` (1.1 in the config: near the shortest
  routes; the planner's own is 2). ``warm_start_workers`` processes share the climbs (2 in the
  config: the training envs wait meanwhile). The time counts against ``--minutes``.
* **Walls**: training envs draw walls from streams seeded ``seed, seed + 1, ...`` - or,
  with ``env_kwargs.wall_pool: N``, from a pool of ``N`` tasks made from the run's seed
  (fast: route checks and move judgements are kept); the evaluation callback uses fresh
  walls of the validation stream (seed ``VALIDATION_SEED``); ``evaluation.evaluate`` uses fresh
  held-out walls ``HELD_OUT_SEED + i``, each reset with its own seed - never seen in
  training or selection.
* **Tuning**: ``tune`` runs Optuna trials (TPE sampler, median pruner fed by the evaluation
  callback); any number of processes or machines pointing at the same ``--storage``
  (``sqlite:///file.db``, ``postgresql://...``, or ``journal:PATH`` for a journal file on a
  shared disk) cooperate on one study.
* **Environments** come from a factory, ``make_env(**env_kwargs) -> gymnasium.Env``, that
  every function takes (default :func:`make_env`: ``gymnasium.make(ENV_ID, ...)``, the id
  the ``kinegym`` package registers when any ``kinegym.*`` module is imported). Pass your
  own to train on a wrapped or modified env; it must be a module-level function when
  ``n_envs > 1`` or ``warm_start_workers > 1`` (the worker processes unpickle it).
"""

from __future__ import annotations

import shutil
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

import kinegym.configs as _configs
from kinegym.agents.policies import GAIT_ENV_ID as ENV_ID
from kinegym.agents.policies import POOL_KEYS as _POOL_KEYS
from kinegym.agents.policies import policy_env_kwargs
from kinegym.agents.train_config import (
    ACTIVATIONS,
    DEFAULT_CONFIG,
    TRAIN_SCHEMA,
    load_train_config,
    parse_schedule,
    validate_train,
)

__all__ = [
    "TRAIN_SCHEMA",
    "ENV_ID",
    "HELD_OUT_SEED",
    "VALIDATION_SEED",
    "load_train_config",
    "parse_schedule",
    "train",
    "resume",
    "policy_env_kwargs",
    "make_env",
    "EnvFactory",
    "StepHook",
    "steps_per_second",
    "estimate_train_s",
]


HELD_OUT_SEED = 1_000_000  # evaluate: wall i is reset(seed=HELD_OUT_SEED + i)
VALIDATION_SEED = 2_000_000  # the evaluation callback's wall stream
#: ``make_env(**env_kwargs)`` -> a HoleClimb env (see the module docstring)
EnvFactory = Callable[..., Any]


def make_env(**env_kwargs: Any) -> Any:
    """The registered HoleClimb id that ``memory`` / ``hints`` name (``kinegym/HoleClimb-v0``,
    ``...Memory-v0``, ``...MemoryHints-v0``), made with the other ``env_kwargs``, time limit included."""
    import gymnasium as gym

    from kinegym.envs.variants import split_space_kwargs

    env_id, rest = split_space_kwargs(ENV_ID, env_kwargs)
    return gym.make(env_id, **rest)


# ------------------------------------------------------------------ environments


def _make_vec(cfg: dict[str, Any], n_envs: int, seed: int, monitor_dir: Path | None, subproc: bool,
              make: EnvFactory, pool_seed: int | None = None) -> Any:
    """``n_envs`` training envs; with ``pool_seed`` None (evaluation) on fresh walls every
    reset, whatever ``wall_pool`` the config gives, else with the config's wall pool made
    from ``pool_seed`` (the run's seed) unless it names its own ``wall_pool_seed``."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    kwargs: dict[str, Any] = {}
    if subproc and n_envs > 1:
        kwargs = {"vec_env_cls": SubprocVecEnv, "vec_env_kwargs": {"start_method": "forkserver"}}
    else:
        kwargs = {"vec_env_cls": DummyVecEnv}
    env_kwargs = _pool_kwargs(cfg["env_kwargs"], pool_seed)
    return make_vec_env(make, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs,
                        monitor_dir=str(monitor_dir) if monitor_dir else None,
                        monitor_kwargs={"info_keywords": ("is_success",)}, **kwargs)


def _pool_kwargs(env_kwargs: dict[str, Any], pool_seed: int | None) -> dict[str, Any]:
    """``env_kwargs`` for fresh walls (``pool_seed`` None: the pool keys dropped) or for the
    config's wall pool made from ``pool_seed`` unless the config names its own ``wall_pool_seed``."""
    out = dict(env_kwargs)
    if pool_seed is None:
        for key in _POOL_KEYS:
            out.pop(key, None)
    elif out.get("wall_pool"):
        out.setdefault("wall_pool_seed", int(pool_seed))
    return out


def _model_kwargs(cfg: dict[str, Any]) -> dict[str, Any]:
    keys = ("n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "ent_coef", "vf_coef", "max_grad_norm")
    out = {k: cfg[k] for k in keys}
    out["learning_rate"] = parse_schedule(cfg["learning_rate"])
    out["clip_range"] = parse_schedule(cfg["clip_range"])
    pk = dict(cfg["policy_kwargs"])
    if "activation_fn" in pk:
        import torch

        pk["activation_fn"] = getattr(torch.nn, ACTIVATIONS[pk["activation_fn"]])
    out["policy_kwargs"] = pk
    return out


def _new_run_dir(base: Path, stem: str) -> Path:
    for k in range(10_000):
        d = base / (stem if k == 0 else f"{stem}-{k}")
        if not d.exists():
            try:
                d.mkdir(parents=True)
            except OSError as err:
                raise _configs.FileError(base, f"a run folder cannot be made there ({err.strerror or err})",
                                         "a writable folder for run directories (--out)") from None
            return d
    raise RuntimeError(f"no free run directory under {base}")


def _time_limit(minutes: float | None, start: float | None = None) -> list[Any]:
    """A callback that ends training cleanly (final model saved) after ``minutes`` of wall
    time counted from ``start`` (a ``time.monotonic()`` reading; None: when learning starts),
    so that a warm start counts against the budget too; none for None. Meanwhile the model's
    schedules (``lin_2e-4``) run over the time left to learning, not over ``n_timesteps``
    (:attr:`~kinegym.agents.atomic_save.AtomicMaskablePPO.time_budget`)."""
    if minutes is None:
        return []
    if not minutes > 0:
        raise ValueError(f"minutes={minutes!r}; expected > 0 (or None for no time limit)")
    from stable_baselines3.common.callbacks import BaseCallback

    class TimeLimit(BaseCallback):
        def _on_training_start(self) -> None:
            self.deadline = (time.monotonic() if start is None else start) + 60.0 * float(minutes)
            if hasattr(self.model, "time_budget"):  # the schedules run over what is left of the budget
                self.model.time_budget = (time.monotonic(), self.deadline)

        def _on_training_end(self) -> None:
            if hasattr(self.model, "time_budget"):
                self.model.time_budget = None

        def _on_step(self) -> bool:
            return time.monotonic() < self.deadline

    return [TimeLimit()]


def _callbacks(cfg: dict[str, Any], run: Path, n_envs: int, make: EnvFactory, extra: Sequence[Any] = ()) -> list[Any]:
    from stable_baselines3.common.callbacks import CheckpointCallback

    from kinegym.agents.atomic_save import AtomicEvalCallback

    eval_env = _make_vec(cfg, 1, VALIDATION_SEED, None, subproc=False, make=make)
    if cfg["normalize"]:
        from stable_baselines3.common.vec_env import VecNormalize

        eval_env = VecNormalize(eval_env, training=False, norm_reward=False)  # never saved
    every = max(1, cfg["eval_freq"] // n_envs)
    # the eval env is a DummyVecEnv of one, the training env a SubprocVecEnv: that is meant
    warnings.filterwarnings("ignore", message="Training and eval env are not of the same type")
    ev = AtomicEvalCallback(eval_env, n_eval_episodes=cfg["eval_episodes"], eval_freq=every,
                              best_model_save_path=str(run / "best"), log_path=str(run), deterministic=True,
                              callback_after_eval=extra[0] if extra else None, verbose=0)
    ck = CheckpointCallback(save_freq=max(1, cfg["checkpoint_freq"] // n_envs), save_path=str(run / "checkpoints"),
                            name_prefix="model", save_vecnormalize=cfg["normalize"])
    return [ck, ev]


def _check_mode(mode: str) -> str:
    if mode not in ("kinematic", "physics"):
        raise ValueError(f"mode={mode!r}; expected 'kinematic' or 'physics'")
    return mode


def _set_threads(n: int) -> None:
    import torch

    torch.set_num_threads(int(n))


#: ``progress(n)``: called with the env steps taken since the last call (the CLI's bar)
StepHook = Callable[[int], None]


def _step_hook(progress: StepHook | None) -> list[Any]:
    """A callback that passes the steps taken to ``progress`` (none if it is None)."""
    if not callable(progress):
        return []
    from stable_baselines3.common.callbacks import BaseCallback

    class Steps(BaseCallback):
        def _on_step(self) -> bool:
            progress(self.training_env.num_envs)
            return True

    return [Steps()]


def train(config: str | Path = DEFAULT_CONFIG, timesteps: int | None = None, seed: int = 0, n_envs: int | None = None,
          out: str | Path = "runs", progress: StepHook | None = None, overrides: dict[str, Any] | None = None,
          trial_callback: Any = None, command: Sequence[str] | None = None, minutes: float | None = None,
          make_env: EnvFactory = make_env, verbose: int = 0, mode: str | None = None) -> Path:
    """Train MaskablePPO on HoleClimb-v0; returns the run directory (see the module docstring).
    ``mode`` overrides the config's ``env_kwargs.mode`` for the training envs.
    ``minutes`` stops training after that much wall time (the final model is saved);
    ``progress(n)`` hears of every ``n`` env steps; ``verbose=1`` prints SB3's metrics table
    after every update (rollout success and lengths, losses, fps)."""
    from kinegym.agents.atomic_save import AtomicMaskablePPO, AtomicVecNormalize

    limit = _time_limit(minutes, start=time.monotonic())  # (checks minutes before anything is made)
    cfg = load_train_config(config)
    cfg.update(overrides or {})
    if timesteps is not None:
        if timesteps < 1:
            raise ValueError(f"timesteps={timesteps!r}; expected >= 1")
        cfg["n_timesteps"] = int(timesteps)
    if n_envs is not None:
        if not 1 <= n_envs <= 64:
            raise ValueError(f"n_envs={n_envs!r}; expected 1..64")
        cfg["n_envs"] = int(n_envs)
    if mode is not None:
        cfg["env_kwargs"] = {**cfg["env_kwargs"], "mode": _check_mode(mode)}
    _set_threads(cfg["torch_threads"])
    run = _new_run_dir(Path(out), f"gait-seed{seed}")
    _configs.write_atomic(run / "config.yaml", yaml.safe_dump({ENV_ID: cfg, "seed": seed}, sort_keys=False))
    _configs.write_atomic(run / "command.txt", " ".join(command if command is not None else sys.argv) + "\n")
    env = _make_vec(cfg, cfg["n_envs"], seed, run / "monitor", subproc=True, make=make_env, pool_seed=seed)
    if cfg["normalize"]:

        env = AtomicVecNormalize(env, norm_reward=False)
    try:
        model = AtomicMaskablePPO(cfg["policy"], env, seed=seed, verbose=verbose, tensorboard_log=str(run / "tb"),
                                  device="cpu", **_model_kwargs(cfg))
        if cfg["bc_episodes"]:
            _warm_start(model, cfg, seed, make_env, run)
            model.save(run / "warm_start_model.zip")  # the cloned (and DAgger-fitted) policy, before PPO
        cbs = (_callbacks(cfg, run, cfg["n_envs"], make_env, [trial_callback] if trial_callback else []) + limit
               + _step_hook(progress))
        model.learn(total_timesteps=cfg["n_timesteps"], callback=cbs, tb_log_name="run")
        model.save(run / "final_model.zip")
        if cfg["normalize"]:
            env.save(str(run / "vecnormalize.pkl"))
    finally:
        env.close()
    learning_curve(run)
    return run


def _warm_start(model: Any, cfg: dict[str, Any], seed: int, make: EnvFactory, run: Path) -> dict[str, Any]:
    """Clone ``cfg["bc_episodes"]`` planner climbs on the training tasks into ``model``'s policy
    (:mod:`kinegym.agents.pretrain`); what it measured goes to ``run/pretrain.yaml``."""
    from kinegym.agents.pretrain import GreedyPolicy, clone, planner_demos, policy_labels

    t0 = time.monotonic()
    # the training envs' tasks, climbed in kinematic mode even for a physics run (the same
    # observations and moves; physics would make the demonstrations a hundred times slower)
    env_kwargs = {**_pool_kwargs(cfg["env_kwargs"], seed), "mode": "kinematic"}
    workers = cfg["warm_start_workers"]
    demos = planner_demos(make, env_kwargs, cfg["bc_episodes"], seed=seed + _BC_SEED_OFFSET, gamma=cfg["gamma"],
                          weight=cfg["teacher_weight"], workers=workers)
    t1 = time.monotonic()
    stats = clone(model.policy, demos, epochs=cfg["bc_epochs"], batch_size=cfg["batch_size"],
                  vf_coef=cfg["vf_coef"], max_grad_norm=cfg["max_grad_norm"], seed=seed)
    out: dict[str, Any] = {"workers": workers, "episodes": demos.episodes, "climbed": demos.climbed,
                           "moves": len(demos), "demo_seconds": round(t1 - t0, 1),
                           "clone_seconds": round(time.monotonic() - t1, 1),
                           **{k: round(float(v), 4) for k, v in stats.items() if k != "moves"}}

    rounds = []
    for r in range(cfg["dagger_rounds"]):  # DAgger: the planner labels the states the policy reaches
        t2 = time.monotonic()
        # the policy as it is evaluated (greedy, masked), copied to the workers as it is now
        labelled, seen = policy_labels(make, env_kwargs, GreedyPolicy(model.policy), cfg["dagger_episodes"],
                                       seed=seed + _DAGGER_SEED + r, weight=cfg["teacher_weight"], workers=workers)
        demos = demos.joined(labelled)
        fit = clone(model.policy, demos, epochs=cfg["dagger_epochs"], batch_size=cfg["batch_size"],
                    vf_coef=cfg["vf_coef"], max_grad_norm=cfg["max_grad_norm"], seed=seed + 1 + r)
        rounds.append({**seen, "rows": len(demos), "agreement": round(fit["agreement"], 4),
                       "seconds": round(time.monotonic() - t2, 1)})
    if rounds:
        out["dagger"] = rounds
    _configs.write_atomic(run / "pretrain.yaml", yaml.safe_dump(out, sort_keys=False))
    return out


#: about what one demonstration climb costs on a training task (the default teacher, A* weight 1.1; env; a pool
#: task made): for estimates
BC_SECONDS_PER_EPISODE = 0.2

#: the planner's demonstration climbs reset their env from ``seed + _BC_SEED_OFFSET`` (the
#: training envs use ``seed`` and ``seed + 1``: another draw of the same pool's tasks), DAgger's
#: round ``r`` from ``seed + _DAGGER_SEED + r``
_BC_SEED_OFFSET = 7919
_DAGGER_SEED = 2 * 7919

#: about what one DAgger climb costs (the policy climbing, the default teacher labelling every state)
DAGGER_SECONDS_PER_EPISODE = 0.36


def _saved_steps(model_zip: Path) -> int:
    """``num_timesteps`` of a saved model, read from its JSON record (nothing unpickled)."""
    from kinegym.agents.policies import read_archive

    _, meta = read_archive(model_zip)
    try:
        return int(meta["num_timesteps"])
    except (KeyError, ValueError, TypeError):
        raise _configs.FileError(model_zip, "an SB3 archive without a step counter",
                                 "a model saved by kinegym train") from None


def _last_checkpoint(run: Path) -> tuple[Path, int]:
    """The run's furthest model: its last checkpoint, or its final model when that went
    further (a ``--minutes`` stop saves the final model between checkpoints)."""
    cks = sorted((int(p.stem.split("_")[1]), p) for p in (run / "checkpoints").glob("model_*_steps.zip"))
    final = run / "final_model.zip"
    if final.is_file():
        cks.append((_saved_steps(final), final))
        cks.sort(key=lambda c: c[0])
    if not cks:
        raise _configs.FileError(run, "no checkpoints/model_*_steps.zip and no final_model.zip",
                                 "a run with a checkpoint to resume from")
    steps, path = cks[-1]
    return path, steps


def resume(run_dir: str | Path, timesteps: int | None = None, progress: StepHook | None = None,
           command: Sequence[str] | None = None, minutes: float | None = None,
           make_env: EnvFactory = make_env, verbose: int = 0, mode: str | None = None) -> Path:
    """Continue ``run_dir``'s furthest model (step counter, optimiser state, normalisation
    statistics) in a new directory ``<run_dir>-resume<k>`` up to ``timesteps`` in total
    (default: the run's ``n_timesteps``). ``mode`` (``"kinematic"`` / ``"physics"``) sets the
    training envs' mode from here on (a physics fine-tuning phase); default: the run's."""
    from kinegym.agents.atomic_save import AtomicMaskablePPO
    from kinegym.agents.policies import load_maskable

    limit = _time_limit(minutes)
    src = Path(run_dir)
    if not (src / "config.yaml").is_file():
        raise _configs.FileError(src, "not a run directory (no config.yaml)", "a folder that kinegym train made")
    saved = _configs.load_yaml(src / "config.yaml")
    if not isinstance(saved, dict) or not isinstance(saved.get(ENV_ID), dict):
        raise _configs.ConfigError(str(src / "config.yaml"), ENV_ID, None, "the run's training section")
    cfg = validate_train(saved[ENV_ID], str(src / "config.yaml"))
    seed = int(saved.get("seed", 0))
    ck, steps = _last_checkpoint(src)
    total = cfg["n_timesteps"] if timesteps is None else int(timesteps)
    if total <= steps:
        raise _configs.ConfigError(str(ck), "--timesteps", total,
                                   f"more than the {steps} steps the checkpoint is already at")
    cfg["n_timesteps"] = total
    if mode is not None:
        cfg["env_kwargs"] = {**cfg["env_kwargs"], "mode": _check_mode(mode)}
    _set_threads(cfg["torch_threads"])
    k = 1
    while (src.parent / f"{src.name}-resume{k}").exists():
        k += 1
    run = _new_run_dir(src.parent, f"{src.name}-resume{k}")
    _configs.write_atomic(run / "config.yaml", yaml.safe_dump({ENV_ID: cfg, "seed": seed, "resumed_from": str(ck),
                                                     "resumed_steps": steps}, sort_keys=False))
    _configs.write_atomic(run / "command.txt", " ".join(command if command is not None else sys.argv) + "\n")
    env = _make_vec(cfg, cfg["n_envs"], seed + 7919 * k, run / "monitor", subproc=True, make=make_env,
                    pool_seed=seed)
    if cfg["normalize"]:
        from kinegym.agents.atomic_save import load_vecnormalize

        stats = ck.parent / f"model_vecnormalize_{steps}_steps.pkl"
        if not stats.is_file():
            stats = src / "vecnormalize.pkl"
        env = load_vecnormalize(stats, env)
    try:
        model = load_maskable(ck, env.observation_space, env.action_space, env=env, cls=AtomicMaskablePPO,
                              learning_rate=parse_schedule(cfg["learning_rate"]),
                              clip_range=parse_schedule(cfg["clip_range"]), tensorboard_log=str(run / "tb"))
        model.verbose = verbose
        cbs = _callbacks(cfg, run, cfg["n_envs"], make_env) + limit + _step_hook(progress)
        model.learn(total_timesteps=total - model.num_timesteps, callback=cbs, reset_num_timesteps=False,
                    tb_log_name="run")
        model.save(run / "final_model.zip")
        if cfg["normalize"]:
            env.save(str(run / "vecnormalize.pkl"))
    finally:
        env.close()
    best = src / "best" / "best_model.zip"
    if best.is_file() and not (run / "best" / "best_model.zip").is_file():
        (run / "best").mkdir(exist_ok=True)
        shutil.copy2(best, run / "best" / "best_model.zip")
    learning_curve(run, earlier=[src])
    return run


# ------------------------------------------------------------------ pictures
def _monitor_rows(run: Path) -> tuple[np.ndarray, np.ndarray]:
    """(cumulative env steps, success) per finished training episode, in time order."""
    rows = []
    for f in sorted((run / "monitor").glob("*.monitor.csv")):
        with f.open() as fh:
            fh.readline()  # the JSON header line
            header = fh.readline().strip().split(",")
            for line in fh:
                vals = dict(zip(header, line.strip().split(",")))
                try:  # a run killed mid-line leaves a partial last row: skip it
                    row = (float(vals["t"]), int(vals["l"]), float(vals.get("is_success", "0") in ("True", "1", "1.0")))
                except (KeyError, ValueError):
                    continue
                rows.append(row)
    if not rows:
        return np.zeros(0), np.zeros(0)
    rows.sort()
    steps = np.cumsum([r[1] for r in rows])
    return steps.astype(float), np.array([r[2] for r in rows])


def learning_curve(run: Path, earlier: Sequence[Path] = ()) -> Path | None:
    """``learning_curve.png``: validation success (evaluation callback) and the rolling
    training success over env steps (earlier runs of a resumed chain included)."""
    from kinegym.envs.charts import line_chart
    from kinegym.envs.draw import save_rgb

    series: dict[str, tuple[Any, Any]] = {}
    xs, ys = [], []
    for r in [*earlier, run]:
        ev = r / "evaluations.npz"
        if ev.is_file():
            with np.load(ev) as d:
                if "successes" in d and len(d["successes"]):
                    xs += d["timesteps"].tolist()
                    ys += d["successes"].mean(axis=1).tolist()
    if xs:
        order = np.argsort(xs)
        series["validation success (deterministic, masked)"] = (np.asarray(xs)[order], np.asarray(ys)[order])
    steps, succ = _monitor_rows(run)
    if len(steps) > 10:
        w = max(5, len(succ) // 50)
        roll = np.convolve(succ, np.ones(w) / w, mode="valid")
        offset = 0.0
        if earlier:
            try:
                offset = float(_configs.load_yaml(run / "config.yaml").get("resumed_steps", 0))
            except Exception:  # noqa: BLE001 - the curve is a convenience
                offset = 0.0
        sx = steps[w - 1:] + offset
        k = max(1, len(sx) // 300)
        series[f"training success (rolling {w} episodes)"] = (sx[::k], roll[::k])
    if not series:
        return None
    img = line_chart(series, "HoleClimb-v0: MaskablePPO learning curve", "env steps", "success rate",
                     size=(820, 420), ylim=(0.0, 1.02), markers=False)
    return save_rgb(img, run / "learning_curve.png")


# ------------------------------------------------------------------ costs, announced before long work
#: a rough episode length for training's estimates (a policy still learning wanders; a stuck one uses all 200)
TYPICAL_EPISODE = 100
#: a held-out climb, for ``evaluate``'s estimate (the planner's mean: 16.2 moves; a trained policy's 1.1-1.2x)
TYPICAL_CLIMB = 18


def steps_per_second(env_kwargs: dict[str, Any], steps: int = 40, make_env: EnvFactory = make_env,
                     planner: bool = False, planner_weight: float = 2.0) -> float:
    """This machine's env steps per second for ``env_kwargs`` (masked random moves on one env,
    fresh walls; with ``planner`` the planner's moves at A* weight ``planner_weight``, as
    ``evaluate`` runs: in physics a climb's moves take longer than random ones): what the
    estimates of long commands scale from."""
    from kinegym.agents.gait_planner import PlannerAgent

    kw = {k: v for k, v in env_kwargs.items() if k not in _POOL_KEYS}
    env = make_env(**kw)
    rng = np.random.default_rng(0)
    agent = PlannerAgent(planner_weight) if planner else None
    try:
        obs, _ = env.reset(seed=VALIDATION_SEED)
        t0, n = time.perf_counter(), 0
        while n < steps:
            mask = env.get_wrapper_attr("action_masks")()
            a = agent.act(env.unwrapped, obs) if agent is not None else None  # (None: no route, a random move)
            obs, _, term, trunc, _ = env.step(a if a is not None else int(rng.choice(np.flatnonzero(mask)))
                                              if mask.any() else 0)
            n += 1
            if term or trunc:
                obs, _ = env.reset()
        return n / max(time.perf_counter() - t0, 1e-9)
    finally:
        env.close()


def estimate_train_s(cfg: dict[str, Any], sps: float, timesteps: int | None = None) -> float:
    """Rough seconds to train ``cfg`` (``timesteps`` or its own): the env steps on the envs
    that run in parallel, the policy and PPO's updates (measured: about 1.5x the env time on top),
    the validation evaluations."""
    steps = cfg["n_timesteps"] if timesteps is None else timesteps
    evals = steps // max(cfg["eval_freq"], 1)
    return 2.5 * steps / (sps * _parallel(cfg["n_envs"])) + evals * cfg["eval_episodes"] * TYPICAL_EPISODE / sps


def estimate_warm_start_s(cfg: dict[str, Any]) -> tuple[float, float]:
    """Rough seconds of ``cfg``'s warm start: the planner's demonstrations, then the DAgger
    rounds, shared by ``warm_start_workers`` processes on as many cores as there are."""
    k = _parallel(cfg["warm_start_workers"])
    return (BC_SECONDS_PER_EPISODE * cfg["bc_episodes"] / k,
            DAGGER_SECONDS_PER_EPISODE * cfg["dagger_episodes"] * cfg["dagger_rounds"] / k)


def _parallel(processes: int) -> int:
    """How many of ``processes`` run at once: no more than this machine's cores."""
    import os

    return max(1, min(processes, os.cpu_count() or 1))
