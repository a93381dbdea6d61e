"""The bench scripts' own options, run small: the figures are the benches' business, not a test's.

* ``bench/bench_envs.py --budget``: where a HoleClimb step's time goes, part by part. The parts
  are timed where the env calls them; a renamed method would leave a part at zero or break the
  sums, and the parts, each a difference of nested timers, are never negative and add up to no
  more than the steps' own time.
* ``bench/bench_vision.py --real-like-from``: the real-like set drawn from other seeds (the
  reader was tuned on 20,000 on; 40,000 on is a held-out draw) reads the seeds asked for.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"


def _bench(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def bench_envs() -> ModuleType:
    return _bench("bench_envs")


@pytest.fixture(scope="module")
def bench_vision() -> ModuleType:
    return _bench("bench_vision")


def test_the_parts_of_a_step_are_all_found_and_add_up(bench_envs) -> None:
    rate, n, rows = bench_envs.step_parts(0.5, "kinegym/HoleClimbMemoryHints-v0", warm=0.2, wall_pool=3)
    assert n > 50 and rate > 0
    parts = dict(rows)
    assert len(parts) == 10
    assert all(v >= -1e-6 for v in parts.values()), parts
    for name in ("the gait kernel judging a new stance's 24 moves", "the move (kinematic climber, judged by the mask)",
                 "the localiser tracking the encoders", "the observation",
                 "resets: a new wall, proved climbable by the planner"):
        assert parts[name] > 0, name
    assert sum(parts.values()) <= 1e6 / rate * 1.001  # the bench's own action choice lies outside the parts


def test_the_budget_table_prints(bench_envs, capsys) -> None:
    bench_envs.step_budget(0.2)
    out = capsys.readouterr().out
    assert "| part of a step, us per step (x the budget) | HoleClimb-v0, a fresh wall every reset |" in out
    assert "| **a whole step** |" in out and "| the gait kernel judging a new stance's 24 moves |" in out


def test_the_real_like_set_starts_at_the_seed_asked_for(bench_vision, capsys, monkeypatch) -> None:
    from kinegym.envs.sim import scenes_real

    drawn: list[int] = []
    real = scenes_real.real_like_scene
    monkeypatch.setattr(scenes_real, "real_like_scene", lambda seed: drawn.append(seed) or real(seed))
    bench_vision.real_like(2, 40_000)
    out = capsys.readouterr().out
    assert drawn == [40_000, 40_001]
    assert "2 real-like photos (3 x 3, seeds 40,000 on)" in out
    assert "| all | 2 |" in out
