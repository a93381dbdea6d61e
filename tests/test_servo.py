"""The writing arm's servo loops: the thesis's step figures, tuning on the simulated plant, the CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from kinegym.cli import main
from kinegym.envs.sim.arm import ArmSim
from kinegym.envs.sim.servo_tune import step_run, tune_joint, tuned_config


def test_q1_meets_the_thesis_step_figures() -> None:
    """Seed 003, 3.2.1: a 1 rad step on q1 is within 0.007 rad after 0.5 s and settles in about
    a second. With the drive speed the thesis implies (300 deg/s) the simulated q1 is within
    0.015 rad at 0.5 s and settled by 1 s; at the 90 deg/s assumed before it was 0.21 rad off."""
    run = step_run("thesis_rrrr", 0, 1.0)
    assert run.error_at_half_s < 0.015 and run.metrics.settling_s < 1.0
    assert run.peak_torque_ratio <= 1.0 + 1e-9 and run.metrics.overshoot < 0.02
    assert run.t[0] == 0.0 and len(run.t) == len(run.q) == len(run.speed) == len(run.torque)


def test_tuning_settles_faster_within_the_torque_limit(tmp_path: Path) -> None:
    res = tune_joint("thesis_rrrr", 0, math.radians(10.0), max_evals=12)
    assert res.evaluations <= 12
    assert res.after.itae < res.before.itae and res.after.metrics.settling_s < res.before.metrics.settling_s
    assert res.after.peak_torque_ratio <= 1.0 + 1e-9 and res.after.metrics.overshoot <= 0.02 + 1e-9
    # the tuned gains go into a YAML the simulation reads back
    path = tmp_path / "tuned.yaml"
    path.write_text(tuned_config("thesis_rrrr", [res]))
    sim = ArmSim(str(path))
    assert (sim.joints[0].kp, sim.joints[0].kv, sim.joints[0].ki) == pytest.approx(res.after.gains, rel=1e-3)
    assert sim.joints[1].kp == ArmSim("thesis_rrrr").joints[1].kp


def test_cli_servo_step_and_tune(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["servo", "step", "--joint", "1", "--deg", "20", "--out", str(tmp_path), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert Path(got["plot"]).is_file() and got["joint"] == 1 and got["settling_s"] < 1.0
    out = tmp_path / "arm.yaml"
    assert main(["servo", "tune", "--joints", "2", "--evals", "6", "--out", str(out), "--json"]) == 0
    tuned = json.loads(capsys.readouterr().out)
    assert tuned["joints"][0]["joint"] == 2 and out.is_file()  # q2 sits near its limit at park: stepped down
    assert main(["servo", "step", "--arm", str(out), "--joint", "2", "--deg", "-10", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    for bad in (["servo", "step", "--joint", "5"], ["servo", "step", "--deg", "0"],
                ["servo", "step", "--joint", "2", "--deg", "60"], ["servo", "tune", "--joints", "1,1"],
                ["servo", "tune", "--evals", "1"], ["servo", "step", "--gains", "1,2"]):
        assert main(bad) == 2, bad
        assert capsys.readouterr().err.startswith("kinegym:")
