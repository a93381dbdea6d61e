"""Training the gait: config validation, a short MaskablePPO run with SubprocVecEnv, the
resume path, evaluation against the planner, and an Optuna study shared by two workers."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from kinegym.agents import train as T
from kinegym.agents.evaluation import evaluate
from kinegym.configs import ConfigError

SMALL = {"n_envs": 2, "n_timesteps": 1024, "n_steps": 64, "batch_size": 64, "n_epochs": 2,
         "eval_freq": 256, "eval_episodes": 2, "checkpoint_freq": 256, "policy_kwargs": {"net_arch": [32, 32]},
         "bc_episodes": 2, "bc_epochs": 1, "dagger_rounds": 1, "dagger_episodes": 2,
         "dagger_epochs": 1}  # the default's warm start and DAgger, cut down


def small_config(tmp_path: Path, **changes: object) -> Path:
    base = yaml.safe_load((Path(T.__file__).parents[1] / "configs" / "train" /
                           "hole_climb_maskable_ppo.yaml").read_text())
    (section,) = base.values()
    section.update({**SMALL, **changes})
    p = tmp_path / "small.yaml"
    p.write_text(yaml.safe_dump(base))
    return p


def test_config_reads_rl_zoo_spellings(tmp_path: Path) -> None:
    """A Zoo hyperparameter section (its id fixes memory/hints, policy_kwargs as a string,
    ppo_mask, !!float step counts) and kinegym's older spelling give the same config."""
    zoo = tmp_path / "zoo.yml"
    zoo.write_text("kinegym/HoleClimbMemoryHints-v0:\n  algo: ppo_mask\n  n_timesteps: !!float 2e5\n"
                   "  policy: MlpPolicy\n  policy_kwargs: \"dict(net_arch=[64, 64], activation_fn=nn.ReLU)\"\n"
                   "  env_kwargs: {wall_pool: 20}\n")
    old = tmp_path / "old.yml"
    old.write_text("kinegym/HoleClimb-v0:\n  n_timesteps: 200000\n  policy_kwargs: {net_arch: [64, 64], "
                   "activation_fn: relu}\n  env_kwargs: {memory: true, hints: true, wall_pool: 20}\n")
    a, b = T.load_train_config(zoo), T.load_train_config(old)
    assert a == b and a["env_kwargs"]["memory"] and a["n_timesteps"] == 200_000 and a["algo"] == "maskable_ppo"
    assert a["policy_kwargs"] == {"net_arch": [64, 64], "activation_fn": "relu"}
    bad = tmp_path / "bad.yml"
    bad.write_text("kinegym/HoleClimbMemory-v0:\n  env_kwargs: {hints: true}\n")
    with pytest.raises(ConfigError, match=r"HoleClimbMemory-v0.env_kwargs.hints"):
        T.load_train_config(bad)
    bad.write_text("kinegym/HoleClimb-v0:\n  policy_kwargs: \"dict(net_arch=__import__('os'))\"\n")
    with pytest.raises(ConfigError, match="policy_kwargs"):
        T.load_train_config(bad)


def test_config_is_validated_with_file_key_and_value(tmp_path: Path) -> None:
    cfg = T.load_train_config()
    assert cfg["algo"] == "maskable_ppo" and cfg["n_envs"] >= 1
    with pytest.raises(ConfigError, match=r"HoleClimbMemoryHints-v0.learning_rate: 'fast' is not valid"):
        T.load_train_config(small_config(tmp_path, learning_rate="fast"))
    with pytest.raises(ConfigError, match="n_envs"):
        T.load_train_config(small_config(tmp_path, n_envs=0))
    with pytest.raises(ConfigError, match="no such key"):
        T.load_train_config(small_config(tmp_path, learning_rat=1e-3))
    f = T.parse_schedule("lin_1e-3")
    assert f(1.0) == pytest.approx(1e-3) and f(0.5) == pytest.approx(5e-4)
    assert T.parse_schedule(3e-4) == 3e-4


def _digest(run: Path) -> dict[str, str]:
    return {str(p.relative_to(run)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(run.rglob("*")) if p.is_file()}


def test_train_smoke_resume_and_evaluate(tmp_path: Path) -> None:
    from sb3_contrib import MaskablePPO

    cfg = small_config(tmp_path)
    run = T.train(cfg, seed=0, out=tmp_path / "runs", progress=False, command=["test"])
    for f in ("config.yaml", "command.txt", "final_model.zip", "evaluations.npz", "learning_curve.png",
              "best/best_model.zip"):
        assert (run / f).is_file(), f
    assert len(list((run / "monitor").glob("*.monitor.csv"))) == 2  # two SubprocVecEnv workers
    assert list((run / "checkpoints").glob("model_*_steps.zip"))
    assert list((run / "tb").rglob("events.out.tfevents*"))
    first = MaskablePPO.load(run / "final_model.zip", device="cpu")
    assert first.num_timesteps >= 1024

    before = _digest(run)
    ck, steps = T._last_checkpoint(run)
    res = T.resume(run, timesteps=2048, progress=False, command=["test"])
    assert res.name == f"{run.name}-resume1" and _digest(run) == before  # nothing of the first run touched
    second = MaskablePPO.load(res / "final_model.zip", device="cpu")
    assert second.num_timesteps >= 2048
    # the step counter carried on from the checkpoint: the resumed run did the rest, not all
    ran = sum(int(line.split(",")[1]) for f in (res / "monitor").glob("*.csv")
              for line in f.read_text().splitlines()[2:])
    assert ran <= 2048 - steps + 2 * 200  # plus at most one unfinished episode per env
    saved = yaml.safe_load((res / "config.yaml").read_text())
    assert saved["resumed_steps"] == steps
    with pytest.raises(ValueError, match="already at"):
        T.resume(run, timesteps=steps, progress=False)

    # a --minutes stop leaves the final model beyond the last checkpoint: resume takes the final model
    cut = tmp_path / "cut"
    (cut / "checkpoints").mkdir(parents=True)
    shutil.copy2(run / "checkpoints" / "model_256_steps.zip", cut / "checkpoints" / "model_256_steps.zip")
    shutil.copy2(run / "final_model.zip", cut / "final_model.zip")
    assert T._last_checkpoint(cut) == (cut / "final_model.zip", first.num_timesteps)

    # a physics fine-tuning phase: one rollout of the resumed run in physics mode
    with pytest.raises(ValueError, match="mode='dynamic'"):
        T.resume(res, timesteps=second.num_timesteps + 128, progress=False, mode="dynamic")
    phys = T.resume(res, timesteps=second.num_timesteps + 128, progress=False, mode="physics")
    cfg_phys = yaml.safe_load((phys / "config.yaml").read_text())
    assert cfg_phys[T.ENV_ID]["env_kwargs"]["mode"] == "physics"
    assert cfg_phys["resumed_steps"] == second.num_timesteps
    assert MaskablePPO.load(phys / "final_model.zip", device="cpu").num_timesteps >= second.num_timesteps + 128

    rows = evaluate(res / "final_model.zip", episodes=2, modes=("kinematic",))
    by = {r.agent: r for r in rows}
    assert by["planner"].success == 1.0 and by["planner"].episodes == 2
    pol = next(r for r in rows if r.agent != "planner")
    assert 0.0 <= pol.success <= 1.0 and pol.decision_ms > 0
    # against the planner nearer the shortest routes (the training config's teacher): the same walls
    near = {r.agent: r for r in evaluate(res / "final_model.zip", episodes=2, modes=("kinematic",),
                                           planner_weight=1.1)}
    assert near["planner (weight 1.1)"].success == 1.0
    assert near["planner (weight 1.1)"].mean_moves <= by["planner"].mean_moves
    same = near[str(res / "final_model.zip")]  # the policy's climbs are the same
    assert same.success == pol.success and np.array_equal(same.mean_moves, pol.mean_moves, equal_nan=True)
    with pytest.raises(ValueError, match="planner_weight=0.5"):
        evaluate(res / "final_model.zip", episodes=1, planner_weight=0.5)


def test_tune_two_workers_share_one_study(tmp_path: Path) -> None:
    import optuna

    from kinegym.agents.tune import open_storage

    cfg = small_config(tmp_path, n_envs=1, eval_episodes=1)
    storage = f"journal:{tmp_path / 'study.log'}"
    cmd = [sys.executable, "-m", "kinegym", "tune", "gait", "--trials", "1", "--storage", storage, "--study", "s",
           "--timesteps", "256", "--config", str(cfg), "--out", str(tmp_path / "tune"), "--json"]
    procs = [subprocess.Popen([*cmd, "--seed", str(10 * i)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, cwd=Path(T.__file__).parents[1]) for i in range(2)]
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err[-2000:]
    study = optuna.load_study(study_name="s", storage=open_storage(storage))
    assert len(study.trials) == 2
    assert all(t.state in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED) for t in study.trials)
    assert len({t.params["learning_rate"] for t in study.trials}) == 2


def test_minutes_ends_training_cleanly_and_the_pool_stays_out_of_evaluation(tmp_path: Path) -> None:
    from sb3_contrib import MaskablePPO

    cfg = small_config(tmp_path, n_envs=1, eval_freq=10**9, checkpoint_freq=10**9,
                       env_kwargs={"mode": "kinematic", "memory": True, "hints": True, "wall_pool": 5})
    run = T.train(cfg, timesteps=10**7, seed=3, out=tmp_path / "runs", progress=False, command=["test"],
                  minutes=0.05)
    steps = MaskablePPO.load(run / "final_model.zip", device="cpu").num_timesteps
    assert 0 < steps < 10**7  # stopped by the clock after about 3 s, the final model saved
    saved = yaml.safe_load((run / "config.yaml").read_text())[T.ENV_ID]["env_kwargs"]
    assert saved["wall_pool"] == 5
    assert T.policy_env_kwargs(run / "final_model.zip") == {"memory": True, "hints": True}  # fresh walls
    with pytest.raises(ValueError, match="minutes=0"):
        T.train(cfg, minutes=0, out=tmp_path / "runs", progress=False)


def test_a_time_budget_anneals_the_schedules_and_is_never_saved(tmp_path: Path) -> None:
    """With ``--minutes`` SB3 would move ``lin_...`` by steps out of ``n_timesteps`` and never
    anneal; the budget's share of time left rules when it is less, and only while it runs."""
    import time

    import gymnasium as gym

    from kinegym.agents.atomic_save import AtomicMaskablePPO

    model = AtomicMaskablePPO("MlpPolicy", gym.make("CartPole-v1"), learning_rate=T.parse_schedule("lin_1e-3"),
                              n_steps=64, batch_size=32, device="cpu")
    model._update_current_progress_remaining(100, 1000)
    assert model._current_progress_remaining == pytest.approx(0.9)  # by steps, as SB3
    now = time.monotonic()
    model.time_budget = (now - 30.0, now + 10.0)  # three quarters of the budget spent
    model._update_current_progress_remaining(100, 1000)
    assert 0.2 < model._current_progress_remaining <= 0.25
    assert model.lr_schedule(model._current_progress_remaining) == pytest.approx(
        1e-3 * model._current_progress_remaining)
    model._update_current_progress_remaining(950, 1000)  # the steps end first: they rule
    assert model._current_progress_remaining == pytest.approx(0.05)
    model.time_budget = (now - 30.0, now - 1.0)  # past the deadline: the schedule's end, never below
    model._update_current_progress_remaining(0, 1000)
    assert model._current_progress_remaining == 0.0
    model.save(tmp_path / "m.zip")
    assert AtomicMaskablePPO.load(tmp_path / "m.zip", device="cpu").time_budget is None
    # the --minutes callback sets the budget from learning's start to the deadline, and clears it
    (limit,) = T._time_limit(2.0, start=now - 60.0)  # a warm start took a minute of the two
    model.time_budget = None
    limit.init_callback(model)
    limit.on_training_start({}, {})
    start, deadline = model.time_budget
    assert deadline == pytest.approx(now + 60.0) and start == pytest.approx(time.monotonic(), abs=5.0)
    limit.on_training_end()
    assert model.time_budget is None


@pytest.mark.slow
def test_a_run_killed_at_random_moments_resumes_cleanly() -> None:
    """bench/kill_resume.py at 2 random kill points (SIGKILL, then --resume): every file the
    killed run left is whole, the resume starts at its last checkpoint and reaches the target,
    and the killed run's files are unchanged. (The 20-point run is in the README.)"""
    import json

    script = Path(T.__file__).parents[1] / "bench" / "kill_resume.py"
    r = subprocess.run([sys.executable, str(script), "--points", "2", "--seed", "3", "--json"], capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["points"] == 2 and summary["clean"] == 2 and summary["damaged_files"] == 0, summary


def test_long_commands_announce_their_cost_and_report_per_trial(tmp_path: Path) -> None:
    """tune says what a trial costs before the first, takes --eval-episodes / --n-envs, and
    prints one line per finished trial; train --verbose prints SB3's metrics and names only
    files it wrote."""
    cfg = small_config(tmp_path, n_envs=2, eval_episodes=5)
    base = [sys.executable, "-m", "kinegym"]
    tune = subprocess.run([*base, "tune", "gait", "--trials", "1", "--storage", f"journal:{tmp_path / 's.log'}",
                           "--study", "c", "--timesteps", "256", "--config", str(cfg), "--out", str(tmp_path / "t"),
                           "--eval-episodes", "1", "--n-envs", "1"], capture_output=True, text=True, timeout=600,
                          cwd=tmp_path)
    assert tune.returncode == 0, tune.stderr[-2000:]
    assert "1 trials x (256 env steps on 1 envs + 4 evaluations of 1 walls): about" in tune.stderr
    assert "trial 0: complete, validation success" in tune.stderr or "trial 0: pruned" in tune.stderr
    train = subprocess.run([*base, "train", "gait", "--timesteps", "512", "--n-envs", "1", "--config", str(cfg),
                            "--out", str(tmp_path / "runs"), "--verbose"], capture_output=True, text=True,
                           timeout=600, cwd=tmp_path)
    assert train.returncode == 0, train.stderr[-2000:]
    assert "train: 512 env steps on 1 envs" in train.stderr and "env steps/s measured" in train.stderr
    assert "total_timesteps" in train.stdout  # SB3's table
    run = tmp_path / next(ln for ln in train.stdout.splitlines() if ln.startswith("run directory:")).split(": ")[1]
    for word in train.stdout.split():
        if word.endswith(".zip"):
            assert (tmp_path / word).is_file() or (run / word).is_file(), f"train names {word}, not written"


def test_zoo_hyperparameters_are_the_default_configs() -> None:
    """RL Zoo's gait section and kinegym's default training config name the same PPO run."""
    ours = T.load_train_config()
    zoo = T.load_train_config(Path(T.__file__).parents[1] / "kinegym" / "zoo" / "ppo_mask.yml")
    keys = ("n_envs", "n_timesteps", "policy", "policy_kwargs", "env_kwargs", "learning_rate", "clip_range", "n_steps",
            "batch_size", "n_epochs", "gamma", "gae_lambda", "ent_coef", "vf_coef", "max_grad_norm", "normalize")
    assert {k: zoo[k] for k in keys} == {k: ours[k] for k in keys}


def test_evaluate_measures_the_planner_it_will_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """``evaluate``'s estimate scales from the planner's own moves (``planner=True``): each step
    asks the planner; random masked moves, the training estimates' rate, ask it nothing. (In
    physics a climb's moves take longer than random ones: ``evaluate`` had said about 42 minutes
    for about 12.)"""
    from kinegym.agents import gait_planner
    from kinegym.agents import train as T

    asked: list[int] = []
    act = gait_planner.PlannerAgent.act

    def counted(self: gait_planner.PlannerAgent, env: object, obs: object = None) -> int | None:
        asked.append(1)
        return act(self, env, obs)

    monkeypatch.setattr(gait_planner.PlannerAgent, "act", counted)
    kw = {"memory": True, "hints": True, "mode": "kinematic"}
    assert T.steps_per_second(kw, steps=10) > 0 and not asked
    assert T.steps_per_second(kw, steps=10, planner=True) > 0 and len(asked) == 10
