"""Prove the built wheel in a user's project: run from a folder that holds its own ``configs/``,
``envs/`` and ``agents/`` packages, with kinegym installed from the wheel (core extras only).

Called by ``.ci/run`` as ``python wheel_smoke.py`` from that folder. Exits non-zero (with the
reason) when the user's packages shadow ours or ours shadow theirs, an environment cannot be
made, reset and stepped, the opening book or the reader's cell model or grid arbiter is missing
from the wheel, or the CLI fails.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

here = Path.cwd()
sys.path.insert(0, str(here))  # the user's own packages come first, as in their scripts

for name in ("configs", "envs", "agents"):  # what a user's project has; ours must not get in the way
    pkg = here / name
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text(f"OWNER = 'user'\nNAME = {name!r}\n")

import gymnasium as gym  # noqa: E402

import agents  # noqa: E402
import configs  # noqa: E402
import envs  # noqa: E402
import kinegym  # noqa: E402

for mod in (configs, envs, agents):
    assert getattr(mod, "OWNER", None) == "user", f"{mod.__name__} is not the user's own: {mod.__file__}"
site = Path(kinegym.__file__).resolve().parent
assert site != here / "kinegym" and "site-packages" in str(site), f"kinegym not from the wheel: {site}"

import kinegym.agents.book as book  # noqa: E402
from kinegym.envs.game import THESIS  # noqa: E402

assert book.load(THESIS) is not None, "the wheel lacks the 5x5x4 opening book"

for env_id in kinegym.ENV_IDS:
    env = gym.make(env_id)
    obs, info = env.reset(seed=0)
    action = int(info["action_mask"].nonzero()[0][0])  # the first action the mask allows
    obs, reward, term, trunc, info = env.step(action)
    assert env.observation_space.contains(obs), f"{env_id}: observation outside its space"
    env.close()
    print(f"{env_id}: made, reset and stepped (reward {reward:.3f})")

exe = Path(sys.executable).with_name("kinegym")
t0 = time.perf_counter()
out = subprocess.run([str(exe), "solve", "|".join(["....."] * 5), "--json"], capture_output=True, text=True,
                     timeout=60, env={**os.environ, "PYTHONPATH": ""})
secs = time.perf_counter() - t0
assert out.returncode == 0, f"kinegym solve failed ({out.returncode}): {out.stderr}"
got = json.loads(out.stdout)
assert got["source"] == "book" and secs < 20, f"kinegym solve on the empty 5x5 board: {got['source']}, {secs:.1f} s"
print(f"kinegym solve, empty 5x5: {got['outcome']} for X from the {got['source']} in {secs:.1f} s")

from kinegym.envs.sim.scenes import random_scene  # noqa: E402
from kinegym.vision.board_reader import BoardReader  # noqa: E402

scene = random_scene(7, n=3, difficulty="default")
reader = BoardReader(size=3)  # loads the trained cell model and grid arbiter shipped in the wheel
assert reader.model is not None and reader.arbiter is not None
read = reader.read(scene.photo.image)
assert (read.cells == scene.cells).all(), f"the wheel's reader misread a lab board: {read.text()}"
print(f"board reader with the shipped cell model and grid arbiter: read {read.text()}")

out = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=60)
assert out.returncode == 0 and "demo" in out.stdout, f"kinegym --help failed: {out.stderr}"
print("kinegym --help: ok")
print("wheel smoke: 5 passed, 0 failed")
