"""Hyper-parameter search for the climber's gait on Optuna, behind ``kinegym tune gait``.

:func:`tune` runs trials of one study in a shared storage (many workers, processes or
machines may run it at once); each trial is a :func:`kinegym.agents.train.train` run with
sampled hyper-parameters, reported after every evaluation and pruned by the median rule.
:func:`open_storage` checks a storage URL before any trial: the folder of a file storage
exists, an existing file is what it claims, a server URL names a dialect SQLAlchemy has.
Database storages keep a heartbeat, so a worker killed mid-trial has its trial marked failed
and the study goes on.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import kinegym.configs as _configs
from kinegym.agents.train import DEFAULT_CONFIG, EnvFactory, make_env, train

__all__ = ["tune", "open_storage"]

_STORAGE_HELP = "sqlite:///study.db, postgresql://user:pw@host/db or journal:/shared/path/study.log"


def open_storage(url: str) -> Any:
    """An Optuna storage for ``url``, checked before any trial: the folder of a file storage
    exists, an existing file is what it claims (an SQLite database, a journal of JSON lines),
    a server URL names a dialect SQLAlchemy has and answers. Database storages keep a
    heartbeat: a worker killed mid-trial has its trial marked failed (after 3 minutes) when
    another worker next looks, and the study goes on."""
    import optuna

    if not isinstance(url, str) or not url.strip():
        raise _configs.FileError(repr(url), "an empty storage", _STORAGE_HELP)
    if url.startswith("journal:"):
        from optuna.storages.journal import JournalFileBackend, JournalStorage

        path = Path(url[len("journal:"):])
        _check_storage_file(url, path, b"{", "an Optuna journal (JSON lines)")
        return JournalStorage(JournalFileBackend(str(path)))
    if "://" not in url:
        raise _configs.FileError(url, "not a storage URL", _STORAGE_HELP)
    if url in ("sqlite://", "sqlite:///", "sqlite:///:memory:"):
        raise _configs.FileError(url, "an in-memory database (workers cannot share it, nothing is kept)",
                                 "sqlite:///study.db or another storage URL")
    if url.startswith("sqlite:///"):
        _check_storage_file(url, Path(url[len("sqlite:///"):]), b"SQLite format 3\x00", "an SQLite database")
    try:
        with warnings.catch_warnings():  # the heartbeat is "experimental" in Optuna, and what we need
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            return optuna.storages.RDBStorage(url, heartbeat_interval=60, grace_period=180)
    except Exception as err:  # noqa: BLE001 - SQLAlchemy raises many kinds (dialect, driver, connection)
        msg = " ".join(str(err).split())[:200]
        raise _configs.FileError(url, f"the storage cannot be opened ({type(err).__name__}: {msg})",
                                 _STORAGE_HELP) from None


def _check_storage_file(url: str, path: Path, magic: bytes, kind: str) -> None:
    if not path.parent.is_dir():
        raise _configs.FileError(url, f"folder {str(path.parent)!r} does not exist", f"{kind} in an existing folder")
    if path.exists():
        if not path.is_file():
            raise _configs.FileError(url, f"{str(path)!r} is not a file", kind)
        try:
            with path.open("rb") as fh:
                head = fh.read(len(magic))
        except OSError as err:
            raise _configs.FileError(url, f"{str(path)!r} cannot be read ({err.strerror or err})", kind) from None
        if head:
            if head != magic:
                raise _configs.FileError(url, f"{str(path)!r} is not {kind}", f"{kind} or a new file name")


def tune(trials: int, storage: str, study: str, timesteps: int = 50_000, config: str | Path = DEFAULT_CONFIG,
         out: str | Path = "runs/tune", seed: int = 0, progress: Any = None,
         make_env: EnvFactory = make_env, eval_episodes: int | None = None, n_envs: int | None = None,
         on_trial: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run ``trials`` Optuna trials of the study ``study`` in ``storage`` (created if missing);
    several processes or machines may run this at once on one storage. Returns a summary.

    Each trial trains ``timesteps`` env steps on ``n_envs`` envs (default: the config's) and is
    judged by 4 evaluations of ``eval_episodes`` validation walls each (default: the config's).
    ``on_trial(summary)`` hears of every finished trial: number, state, value, params, seconds."""
    import optuna
    from stable_baselines3.common.callbacks import BaseCallback

    st = open_storage(storage)
    s = optuna.create_study(study_name=study, storage=st, load_if_exists=True, direction="maximize",
                            sampler=optuna.samplers.TPESampler(seed=None),
                            pruner=optuna.pruners.MedianPruner(n_startup_trials=2, n_warmup_steps=1))

    class Report(BaseCallback):  # called after every evaluation: report and maybe prune
        def __init__(self, trial: optuna.Trial) -> None:
            super().__init__()
            self.trial, self.k, self.pruned = trial, 0, False

        def _on_step(self) -> bool:
            ev = self.parent
            value = float(np.mean(ev._is_success_buffer)) if ev._is_success_buffer else float(ev.last_mean_reward)
            self.k += 1
            self.trial.report(value, self.k)
            self.trial.set_user_attr("last_value", value)
            if self.trial.should_prune():
                self.pruned = True
                return False
            return True

    def objective(trial: optuna.Trial) -> float:
        over = {
            "learning_rate": trial.suggest_float("learning_rate", 5e-5, 2e-3, log=True),
            "ent_coef": trial.suggest_float("ent_coef", 1e-4, 5e-2, log=True),
            "gamma": trial.suggest_categorical("gamma", [0.97, 0.99, 0.995]),
            "n_steps": trial.suggest_categorical("n_steps", [256, 512, 1024]),
            "policy_kwargs": {"net_arch": [trial.suggest_categorical("width", [64, 128, 256])] * 2},
        }
        cb = Report(trial)
        if eval_episodes is not None:
            over["eval_episodes"] = int(eval_episodes)
        run = train(config, timesteps, seed + trial.number, n_envs=n_envs, out=out, progress=progress,
                    overrides={**over, "eval_freq": max(64, timesteps // 4)}, trial_callback=cb,
                    command=["kinegym", "tune", "gait", f"trial {trial.number} of study {study}"], make_env=make_env)
        trial.set_user_attr("run", str(run))
        if cb.pruned:
            raise optuna.TrialPruned()
        if "last_value" not in trial.user_attrs:
            raise RuntimeError(f"trial {trial.number}: no evaluation ran in {timesteps} steps; raise --timesteps")
        return float(trial.user_attrs["last_value"])

    def summary(study_: Any, t: Any) -> None:
        if on_trial is not None:
            secs = (t.datetime_complete - t.datetime_start).total_seconds() if t.datetime_complete else None
            on_trial({"number": t.number, "state": t.state.name.lower(), "value": t.value if t.value is not None
                      else t.user_attrs.get("last_value"), "params": t.params, "seconds": secs})

    s.optimize(objective, n_trials=trials, callbacks=[summary])
    done = [t for t in s.trials if t.state == optuna.trial.TrialState.COMPLETE]
    best = s.best_trial if done else None
    return {"study": study, "storage": storage, "trials": len(s.trials), "complete": len(done),
            "pruned": sum(t.state == optuna.trial.TrialState.PRUNED for t in s.trials),
            "best_value": None if best is None else best.value, "best_params": None if best is None else best.params}
