"""Kill-and-resume: training killed with SIGKILL at random moments resumes cleanly.

Run::

    python bench/kill_resume.py [--points 20] [--seed 0] [--json]

For each kill point: start ``kinegym train gait`` (a small config, one env, a checkpoint every
256 steps) in a fresh process, wait until its first checkpoint exists, wait a random further
0-4 s (so kills land during rollouts, updates, evaluations and checkpoint writes alike),
SIGKILL it, then check

* every file the killed run left (temporary ``.*.tmp`` files of an interrupted write aside)
  is whole: YAML parses, every model ``.zip`` loads (``load_maskable``), ``evaluations.npz``
  opens;
* ``kinegym train gait --resume RUN`` exits 0 and its final model's step counter reaches the
  target, starting from the last checkpoint (``resumed_steps`` in its ``config.yaml``);
* the killed run's files are byte-identical before and after the resume.

Prints one line per kill point and a summary (``--json``: one object).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import yaml

SMALL = {"n_envs": 1, "n_timesteps": 4096, "n_steps": 64, "batch_size": 64, "n_epochs": 2, "eval_freq": 512,
         "eval_episodes": 2, "checkpoint_freq": 256, "policy_kwargs": {"net_arch": [32, 32]},
         "bc_episodes": 0}  # kills land in PPO's saves, not in the warm start


def _config(folder: Path) -> Path:
    from kinegym.agents import train as T
    from kinegym.configs import CONFIG_DIR

    base = yaml.safe_load((CONFIG_DIR / "train" / f"{T.DEFAULT_CONFIG}.yaml").read_text())
    (section,) = base.values()  # the one section, whichever id it is written for
    section.update(SMALL)
    p = folder / "small.yaml"
    p.write_text(yaml.safe_dump(base))
    return p


def _digest(run: Path) -> dict[str, str]:
    return {str(p.relative_to(run)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(run.rglob("*")) if p.is_file()}


def _whole(run: Path) -> list[str]:
    """Files of ``run`` that are damaged (empty list: all whole)."""
    from kinegym.agents.policies import load_maskable
    from kinegym.configs import load_yaml
    from kinegym.envs.hole_climb import HoleClimbEnv

    probe = HoleClimbEnv(**{k: v for k, v in yaml.safe_load((run / "config.yaml").read_text())
                            ["kinegym/HoleClimb-v0"]["env_kwargs"].items() if k not in ("wall_pool_seed",)})
    bad = []
    for p in sorted(run.rglob("*")):
        if not p.is_file() or p.name.startswith("."):
            continue
        try:
            if p.suffix == ".yaml":
                load_yaml(p)
            elif p.suffix == ".zip":
                load_maskable(p, probe.observation_space, probe.action_space)
            elif p.suffix == ".npz":
                with np.load(p) as d:
                    _ = {k: d[k] for k in d.files}
        except (Exception, zipfile.BadZipFile) as err:  # noqa: BLE001 - any failure is a damaged file
            bad.append(f"{p.relative_to(run)}: {type(err).__name__}: {err}"[:200])
    return bad


def kill_point(folder: Path, rng: np.random.Generator, cfg: Path) -> dict[str, object]:
    out = folder / "runs"
    cmd = [sys.executable, "-m", "kinegym", "train", "gait", "--config", str(cfg), "--out", str(out),
           "--no-progress", "--seed", "0"]
    env = {**os.environ, "CI": "true"}
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, start_new_session=True)
    run = out / "gait-seed0"
    t0 = time.monotonic()
    while not list((run / "checkpoints").glob("model_*_steps.zip")) and proc.poll() is None:
        if time.monotonic() - t0 > 300:
            break
        time.sleep(0.05)
    delay = float(rng.uniform(0.0, 4.0))
    time.sleep(delay)
    finished = proc.poll() is not None
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    leftovers = sorted(p.name for p in run.rglob(".*.tmp"))
    damaged = _whole(run)
    before = _digest(run)
    cks = sorted(int(p.stem.split("_")[1]) for p in (run / "checkpoints").glob("model_*_steps.zip"))
    r = subprocess.run([sys.executable, "-m", "kinegym", "train", "gait", "--resume", str(run), "--no-progress",
                        "--json"], capture_output=True, text=True, env=env, timeout=900)
    resumed = {}
    if r.returncode == 0:
        resumed_dir = Path(json.loads(r.stdout.strip().splitlines()[-1])["run"])
        saved = yaml.safe_load((resumed_dir / "config.yaml").read_text())
        with zipfile.ZipFile(resumed_dir / "final_model.zip") as zf:
            final_steps = int(json.loads(zf.read("data"))["num_timesteps"])
        resumed = {"from_steps": saved["resumed_steps"], "final_steps": final_steps}
    clean = (r.returncode == 0 and not damaged and before == _digest(run) and bool(cks)
             and resumed.get("from_steps") == cks[-1] and resumed.get("final_steps", 0) >= SMALL["n_timesteps"])
    return {"delay_s": round(delay, 2), "finished_before_kill": finished, "checkpoints": len(cks),
            "last_checkpoint": cks[-1] if cks else None, "leftover_tmp": leftovers, "damaged": damaged,
            "resume_exit": r.returncode, "resume_error": r.stderr.strip().splitlines()[-1:] if r.returncode else [],
            **resumed, "clean": clean}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    with tempfile.TemporaryDirectory(prefix="kinegym-kill-") as tmp:
        cfg = _config(Path(tmp))
        for i in range(args.points):
            folder = Path(tmp) / f"k{i}"
            folder.mkdir()
            row = kill_point(folder, rng, cfg)
            rows.append(row)
            if not args.json:
                print(f"kill {i + 1:2d}: after {row['delay_s']:4.2f} s, {row['checkpoints']} checkpoints, "
                      f"tmp left {len(row['leftover_tmp'])}, damaged {len(row['damaged'])}, resume exit "
                      f"{row['resume_exit']} from {row.get('from_steps')} to {row.get('final_steps')}: "
                      f"{'clean' if row['clean'] else 'NOT CLEAN ' + str(row['damaged'] or row['resume_error'])}",
                      flush=True)
    summary = {"points": len(rows), "clean": sum(bool(r["clean"]) for r in rows),
               "damaged_files": sum(len(r["damaged"]) for r in rows),  # type: ignore[arg-type]
               "killed_mid_write": sum(bool(r["leftover_tmp"]) for r in rows), "rows": rows}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{summary['points']} kill points: {summary['clean']} clean resumes, {summary['damaged_files']} "
              f"damaged files, {summary['killed_mid_write']} killed during a write (temporary file left)")


if __name__ == "__main__":
    main()
