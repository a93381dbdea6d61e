"""The vectorised gait kernel (``envs/sim/gait_kernel.py``) pinned equal to its scalar
reference (``plan_move``, ``min_enclosing_circle``), and the half-turn swing rule both share."""

import math

import numpy as np
import pytest

from kinegym.envs.climb_task import candidate_holes, start_stances
from kinegym.envs.sim import gait as C
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move, rest_pose
from kinegym.envs.sim.gait_kernel import enclosing_circles, feasible_moves
from kinegym.kinematics import HoleMap


def _walk_stances(model: ClimberModel, wall: HoleMap, rng: np.random.Generator, count: int) -> list[list[int]]:
    """Stances a climber reaches by random feasible-looking moves from its start stances."""
    starts = start_stances(model, wall)
    out = []
    while len(out) < count:
        st = list(starts[int(rng.integers(len(starts)))])
        for _ in range(int(rng.integers(0, 6))):
            near = candidate_holes(wall, st, 8, 40.0)
            st[int(rng.integers(3))] = near[int(rng.integers(len(near)))]
        if len(set(st)) == 3:
            out.append(st)
    return out


@pytest.mark.parametrize("robot", ["climber", "climber_long"])
def test_feasible_moves_equals_plan_move_move_for_move(robot: str) -> None:
    model = ClimberModel.from_config(robot)
    rng = np.random.default_rng(11)
    moves = feasible = 0
    for w in range(4):
        wall = HoleMap.grid(8, 12, float(rng.uniform(11, 16)), float(rng.uniform(0, 2)), 0.05, seed=w)
        for heading in (0.0, 0.3):
            for st in _walk_stances(model, wall, rng, 25):
                cand = candidate_holes(wall, st, 8, 40.0) + [st[0]]  # an already held hole too
                arms, targets = np.repeat([0, 1, 2], len(cand)), np.tile(cand, 3)
                got = feasible_moves(model, wall, st, arms, targets, heading)
                rest = rest_pose(model, wall, st, heading)
                want = [isinstance(plan_move(model, wall, st, int(a), int(h), heading, rest=rest), MovePlan)
                        for a, h in zip(arms, targets)]
                assert got.tolist() == want, (robot, w, heading, st)
                moves += len(want)
                feasible += sum(want)
    assert moves > 3000 and 0.05 * moves < feasible < 0.5 * moves  # both answers well represented


def test_a_half_turn_takes_the_lighter_side_in_both() -> None:
    # arm 1 moves between holes that are the diameter of the four holes' circle: its shoulder
    # (at the body centre on this robot) lies half-way between them (402 such moves from this
    # wall's start stances alone)
    model = ClimberModel.from_config("climber")
    wall, st, hole = HoleMap.grid(8, 12, 15.0, 1.0, 0.05, seed=0), (0, 1, 11), 12
    plan = plan_move(model, wall, st, 0, hole)
    assert isinstance(plan, MovePlan) and plan.turn in (1.0, -1.0)
    cx, cy, _ = plan.pose_to
    ox, oy = model.offsets(0.0)[0]
    shoulder, old, new = (cx + ox, cy + oy), tuple(wall.xy[0]), tuple(wall.xy[hole])
    assert abs(C._turn_angle(shoulder, old, new)) > C.HALF_TURN
    # the two sides mirror each other about the shoulder; the way back retraces the way there
    ccw, cw = C._around(shoulder, old, new, 0.5, 1.0), C._around(shoulder, old, new, 0.5, -1.0)
    assert math.hypot(ccw[0] + cw[0] - 2 * shoulder[0], ccw[1] + cw[1] - 2 * shoulder[1]) < 1e-9
    there, back = C._around(shoulder, old, new, 0.5, plan.turn), C._around(shoulder, new, old, 0.5, -plan.turn)
    assert math.dist(there, back) < 1e-9
    # a turn only chooses the side of a half turn: other swings keep the shorter way
    near = (old[0], old[1] + 1.0)
    assert C._around(shoulder, old, near, 0.5, 1.0) == C._around(shoulder, old, near, 0.5)
    # the plan's side is the lighter one
    hands = [tuple(wall.xy[h]) for h in (hole, st[1], st[2])]
    q = [tuple(v) for v in plan.q_to]
    sides = {t: C._swing_statics(model, plan.pose_to, hands, q, 0, shoulder, old, t, 1) for t in (1.0, -1.0)}
    assert plan.torque_ratio == min(v[0] for v in sides.values() if not isinstance(v[0], str))
    for heading in (0.0, 1e-13, -1e-13):  # rounding noise must not change the answer
        want = isinstance(plan_move(model, wall, st, 0, hole, heading), MovePlan)
        assert feasible_moves(model, wall, st, [0], [hole], heading).tolist() == [want]


def test_enclosing_circles_equals_the_scalar_circle() -> None:
    rng = np.random.default_rng(3)
    for n in (2, 3, 4):
        pts = rng.uniform(-10, 10, (400, n, 2))
        pts[:50, -1] = pts[:50, 0]  # repeated points
        pts[50:100, :, 1] = 2.0 * pts[50:100, :, 0]  # collinear points
        cx, cy, r = enclosing_circles(pts)
        for i in range(len(pts)):
            assert (cx[i], cy[i], r[i]) == C.min_enclosing_circle([tuple(p) for p in pts[i]])


def test_feasible_moves_edge_cases_are_plain() -> None:
    model = ClimberModel.from_config("climber")
    wall = HoleMap.grid(6, 6, 15.0, 0.0, seed=0)
    st = start_stances(model, wall)[0]
    assert feasible_moves(model, wall, st, [], []).shape == (0,)
    assert not feasible_moves(model, wall, st, [0, 1, 2], list(st)).any()  # held holes
    assert not feasible_moves(model, wall, st, [0], [7], rest="no rest pose").any()
    with pytest.raises(ValueError, match="differ in length"):
        feasible_moves(model, wall, st, [0, 1], [7])


def test_minimax_line_finds_the_least_worst_split() -> None:
    """``_minimax_line`` (the best load split, run by the physics controller at 60 Hz): the
    worst ``|a + b t|`` at its ``t`` is the exact minimum over ``t``, which lies where two
    terms cross or where one term is zero, on random sets of 2-6 lines with
    flat, repeated and mirrored terms."""
    rng = np.random.default_rng(7)
    for _ in range(3000):
        n = int(rng.integers(2, 7))
        a = rng.uniform(-3, 3, n)
        b = np.where(rng.random(n) < 0.15, 0.0, rng.uniform(-2, 2, n))
        if rng.random() < 0.2:
            a[-1], b[-1] = -a[0], -b[0]
        lines = list(zip(a.tolist(), b.tolist()))
        t = C._minimax_line(lines)
        cand = [0.0] + [-a[i] / b[i] for i in range(n) if b[i] != 0.0] + [
            -(a[j] + s * a[i]) / (b[j] + s * b[i]) for i in range(n) for j in range(i + 1, n) for s in (1, -1)
            if abs(b[j] + s * b[i]) > 1e-12]
        exact = min(float(np.max(np.abs(a + b * c))) for c in cand)
        assert float(np.max(np.abs(a + b * t))) <= exact + 1e-7 * (1 + exact)


def test_a_move_the_kernel_judged_ends_where_its_plan_ends_bit_for_bit() -> None:
    # the env's step moves without judging again what the kernel found feasible: the stance,
    # pose and joints after it must be plan_move's own
    from kinegym.envs.sim.climber import KinematicClimber

    model = ClimberModel.from_config("climber")
    rng = np.random.default_rng(5)
    wall = HoleMap.grid(7, 12, 14.0, 1.0, 0.05, seed=3)
    quick, full = KinematicClimber(model), KinematicClimber(model)
    start = start_stances(model, wall)[0]
    quick.reset(wall, start)
    full.reset(wall, start)
    moved = 0
    for _ in range(60):
        st = quick.stance
        cand = candidate_holes(wall, st, 8, 40.0)
        arms, targets = np.repeat([0, 1, 2], len(cand)), np.tile(cand, 3)
        ok = np.flatnonzero(feasible_moves(model, wall, st, arms, targets))
        if not len(ok):
            break
        i = int(rng.choice(ok))
        a, h = int(arms[i]), int(targets[i])
        got, want = quick.move(a, h, judged=True), full.move(a, h)
        assert got.ok and want.ok and got.plan is None and want.plan is not None
        assert got.stance == want.stance and np.array_equal(got.pose, want.pose)
        assert np.array_equal(quick.q, full.q) and np.array_equal(quick.pose, full.pose)
        moved += 1
    assert moved >= 30
