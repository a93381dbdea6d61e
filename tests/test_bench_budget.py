"""``bench/bench_envs.py --budget``: where a HoleClimb-v0 step's time goes, part by part.

The parts are timed where the env calls them; this pins that the bench still finds every part
it times (a renamed method would leave a part at zero or break the sums) and that the parts,
each a difference of nested timers, are never negative and add up to no more than the steps'
own time. Speeds themselves are the bench's business, not a test's.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench" / "bench_envs.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_envs", BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_parts_of_a_step_are_all_found_and_add_up(bench) -> None:
    rate, n, rows = bench.step_parts(0.5, "kinegym/HoleClimbMemoryHints-v0", warm=0.2, wall_pool=3)
    assert n > 50 and rate > 0
    parts = dict(rows)
    assert len(parts) == 10
    assert all(v >= -1e-6 for v in parts.values()), parts
    for name in ("the gait kernel judging a new stance's 24 moves", "the move (kinematic climber, judged by the mask)",
                 "the localiser tracking the encoders", "the observation",
                 "resets: a new wall, proved climbable by the planner"):
        assert parts[name] > 0, name
    assert sum(parts.values()) <= 1e6 / rate * 1.001  # the bench's own action choice lies outside the parts


def test_the_budget_table_prints(bench, capsys) -> None:
    bench.step_budget(0.2)
    out = capsys.readouterr().out
    assert "| part of a step, us per step (x the budget) | HoleClimb-v0, a fresh wall every reset |" in out
    assert "| **a whole step** |" in out and "| the gait kernel judging a new stance's 24 moves |" in out
