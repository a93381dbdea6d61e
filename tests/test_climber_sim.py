"""The climber's gait model and its pymunk twin: statics checked against the physics, the
two modes agreeing on which moves succeed, the planner proving routes and their absence."""

import itertools
import math

import numpy as np
import pytest

from kinegym.agents.gait_planner import GaitPlanner, start_stances
from kinegym.envs.sim import gait as C
from kinegym.envs.sim.climber import KinematicClimber, PhysicsClimber
from kinegym.envs.sim.climber_model import OUTCOMES, ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move
from kinegym.kinematics import HoleMap
from kinegym.kinematics.climber import body_to_wall, hand_positions

MODEL = ClimberModel.from_config("climber")
WALL = HoleMap.grid(8, 8, 15.0, 0.5, seed=2)


def resting_stances(wall: HoleMap, model: ClimberModel, count: int, seed: int) -> list[tuple[int, int, int]]:
    xy = wall.xy
    reach = min(model.reach[1])
    all_st = [s for s in itertools.permutations(range(len(xy)), 3)
              if C.min_enclosing_circle([tuple(xy[i]) for i in s])[2] < reach - 1.0]
    rng = np.random.default_rng(seed)
    return [all_st[i] for i in rng.choice(len(all_st), count, replace=False)]


def test_min_enclosing_circle_holds_every_point_and_is_minimal() -> None:
    rng = np.random.default_rng(0)
    for _ in range(300):
        pts = [tuple(p) for p in rng.uniform(-10, 10, (int(rng.integers(2, 5)), 2))]
        cx, cy, r = C.min_enclosing_circle(pts)
        assert all(math.hypot(px - cx, py - cy) <= r + 1e-9 for px, py in pts)
        # no smaller circle around a nearby centre holds them all
        for dx, dy in ((0.01, 0), (-0.01, 0), (0, 0.01), (0, -0.01)):
            assert max(math.hypot(px - cx - dx, py - cy - dy) for px, py in pts) >= r - 1e-9


def test_a_planned_move_puts_every_hand_on_its_hole() -> None:
    for st in resting_stances(WALL, MODEL, 40, 1):
        for arm, hole in itertools.product(range(3), range(len(WALL))):
            plan = plan_move(MODEL, WALL, st, arm, hole)
            if isinstance(plan, MovePlan):
                new = list(st)
                new[arm] = hole
                hands = body_to_wall(hand_positions(plan.q_to, MODEL.geom), np.array(plan.pose_to))
                assert np.abs(hands - WALL.xy[new]).max() < 1e-9
                assert plan.torque_ratio <= MODEL.phys.torque_safety
                assert plan.grip_force_n <= MODEL.phys.holding_force_n
            else:
                assert plan[0] in OUTCOMES and plan[1]


def test_static_torques_match_the_physics() -> None:
    """The physics' servo torques while two arms hold the body are one member of the
    model's one-parameter family of load splits (within 1 N cm of 60)."""
    sim = PhysicsClimber(MODEL)
    free = 0
    for st in resting_stances(WALL, MODEL, 200, 3):  # one the two other arms can hold easily
        kin = KinematicClimber(MODEL)
        kin.reset(WALL, st)
        hands = [tuple(WALL.xy[h]) for h in st]
        if C.swing_loads(MODEL, tuple(kin.pose), hands, [tuple(v) for v in kin.q], free)[0] < 0.5:
            break
    sim.reset(WALL, st)
    sim._release(free)
    sim._run(int(1.5 / sim.dt), lambda t: None, stall=False)
    dt = sim.dt
    # the compliant servos hum about their equilibrium: average over two seconds
    acc, qs = np.zeros(4), []
    steps = int(2.0 / dt)
    for _ in range(steps):
        sim._run(1, lambda t: None, stall=False)
        acc += [m.impulse / dt / 100.0 for k in (1, 2) for m in sim.motors[k]]
        qs.append(np.concatenate([sim.pose, sim.q.ravel()]))
    phys = list(np.abs(acc / steps))
    mean = np.mean(qs, axis=0)
    pose_mean, q_mean = mean[:3], mean[3:].reshape(3, 2)
    captured: dict[str, list[tuple[float, float]]] = {}
    orig = C._minimax_line

    def capture(lines: list[tuple[float, float]]) -> float:
        captured["lines"] = lines
        return orig(lines)

    C._minimax_line = capture
    try:
        C.swing_loads(MODEL, tuple(pose_mean), hands, [tuple(v) for v in q_mean], free)
    finally:
        C._minimax_line = orig
    limits = [MODEL.phys.shoulder_torque_ncm, MODEL.phys.elbow_torque_ncm] * 2
    lines = [(a * lim, b * lim) for (a, b), lim in zip(captured["lines"], limits)]
    best = math.inf
    for signs in itertools.product((1, -1), repeat=4):
        A = np.array([[b] for _, b in lines])
        y = np.array([s * v - a for s, v, (a, _) in zip(signs, phys, lines)])
        t = np.linalg.lstsq(A, y, rcond=None)[0][0]
        best = min(best, max(abs(abs(a + b * t) - v) for (a, b), v in zip(lines, phys)))
    assert best < 1.0


def test_a_gripper_opens_over_its_release_time_and_hands_its_load_on() -> None:
    """``_let_go`` ramps the grip's force cap from what it carries to zero over
    ``grip_release_s`` (the other two arms take the load while the hand is still on its
    hole), then removes the grip; with a release time of 0 the grip goes at once."""
    import dataclasses

    st = (0, 1, 8)
    sim = PhysicsClimber(MODEL)
    sim.reset(WALL, st)
    grip = sim.grips[0]
    carried = abs(grip.impulse) / sim.dt
    caps = []
    step = sim.space.step

    def stepped(dt: float) -> None:
        caps.append(grip.max_force)
        step(dt)

    sim.space.step = stepped  # type: ignore[method-assign]
    assert sim._let_go(0) is None
    assert sim.grips[0] is None and sim.grips[1] is not None and sim.grips[2] is not None
    assert len(caps) == round(MODEL.phys.grip_release_s * MODEL.phys.physics_hz)
    assert caps[0] == pytest.approx(carried) and caps[-1] < carried / len(caps) + 1e-9
    assert all(a >= b for a, b in zip(caps, caps[1:]))  # it only ever opens
    instant = dataclasses.replace(MODEL, phys=dataclasses.replace(MODEL.phys, grip_release_s=0.0))
    sim = PhysicsClimber(instant)
    sim.reset(WALL, st)
    before = sim.total_steps
    assert sim._let_go(0) is None and sim.grips[0] is None and sim.total_steps == before


def test_physics_holds_still_and_the_encoders_are_noisy_but_close() -> None:
    sim = PhysicsClimber(MODEL)
    st = (0, 1, 8)
    sim.reset(WALL, st)
    kin = KinematicClimber(MODEL)
    kin.reset(WALL, st)
    assert np.abs(sim.pose[:2] - kin.pose[:2]).max() < 0.3  # compliant servos sag a little
    q = sim.encoders(np.random.default_rng(0))
    assert 0 < np.abs(q - sim.q).max() < math.radians(3)


def test_physics_and_kinematic_modes_agree_on_most_moves() -> None:
    """Moves the robot would try (reach allows them): does each succeed? The kinematic
    judgement (statics with a 15 % torque margin) against the pymunk run."""
    rng = np.random.default_rng(1)
    sim = PhysicsClimber(MODEL)
    agree = total = 0
    for st in resting_stances(WALL, MODEL, 25, 2):
        moves = [(a, h) for a, h in itertools.product(range(3), range(len(WALL)))
                 if not (isinstance(p := plan_move(MODEL, WALL, st, a, h), tuple) and p[0] == "unreachable")]
        for i in rng.choice(len(moves), min(2, len(moves)), replace=False):
            arm, hole = moves[int(i)]
            predicted = isinstance(plan_move(MODEL, WALL, st, arm, hole), MovePlan)
            sim.reset(WALL, st)
            res = sim.move(arm, hole)
            agree += predicted == res.ok
            total += 1
            if res.ok:
                assert hole in res.stance and res.steps > 0
    assert total >= 40 and agree / total >= 0.8, f"{agree}/{total}"


def test_physics_replays_bit_identically() -> None:
    runs = []
    for _ in range(2):
        sim = PhysicsClimber(MODEL)
        sim.reset(WALL, (0, 1, 8))
        res = sim.move(0, 2)
        runs.append((res.outcome, sim.pose.tobytes(), sim.q.tobytes()))
    assert runs[0] == runs[1]


def test_planner_routes_work_and_impossible_walls_are_proven() -> None:
    wall = HoleMap.grid(6, 9, 15.0, 0.8, missing=0.05, seed=5)
    starts = start_stances(MODEL, wall)
    assert len(starts) > 12 and start_stances(MODEL, wall, limit=12) == starts[:12]  # lowest first, judged lazily
    heights = [sum(wall.xy[h, 1] for h in s) for s in starts]
    assert heights == sorted(heights)
    goal = int(np.argmax(wall.xy[:, 1]))
    route = GaitPlanner(MODEL, wall).plan(starts[0], goal)
    assert route.found and route.moves
    kin = KinematicClimber(MODEL)
    kin.reset(wall, starts[0])
    for arm, hole in route.moves:
        assert kin.move(arm, hole).ok
    assert goal in kin.stance
    # weight 1 gives a route no longer than weighted A*'s
    assert len(GaitPlanner(MODEL, wall, weight=1.0).plan(starts[0], goal).moves) <= len(route.moves)
    # the seed robot on the seed wall: no route out of the first block, and a proof of it
    seed = HoleMap.from_config("seed_4x4")
    top = int(np.argmax(seed.xy[:, 1]))
    res = GaitPlanner(MODEL, seed).plan(start_stances(MODEL, seed)[0], top)
    assert res.proven_impossible
    longer = ClimberModel.from_config("climber_long")
    assert GaitPlanner(longer, seed).plan(start_stances(longer, seed)[0], top).found


def test_kinematic_moves_are_fast_enough_to_count() -> None:
    """Not a timing test: the move cache must make a repeated judgement a lookup."""
    kin = KinematicClimber(MODEL)
    kin.reset(WALL, (0, 1, 8))
    a = kin.judge(0, 2)
    assert kin.judge(0, 2) is a


def test_bad_inputs() -> None:
    with pytest.raises(ValueError, match="weight"):
        GaitPlanner(MODEL, WALL, weight=0.5)
    with pytest.raises(ValueError, match="goal hole"):
        GaitPlanner(MODEL, WALL).plan((0, 1, 8), 10_000)
    kin = KinematicClimber(MODEL)
    with pytest.raises(ValueError, match="reach"):
        kin.reset(WALL, (0, 7, 63))


def test_holding_torques_are_the_best_split_of_swing_loads() -> None:
    """:func:`holding_torques` is the split :func:`swing_loads` judges: its worst holding
    servo over its limit is the best split's ratio, and the free arm's row holds its own
    weight."""
    rng = np.random.default_rng(4)
    checked = 0
    for st in resting_stances(WALL, MODEL, 60, 7):
        kin = KinematicClimber(MODEL)
        kin.reset(WALL, st)
        hands = [tuple(WALL.xy[h]) for h in st]
        free = int(rng.integers(3))
        q = [tuple(v) for v in kin.q]
        tq = C.holding_torques(MODEL, tuple(kin.pose), hands, q, free)
        lim = np.array([MODEL.phys.shoulder_torque_ncm, MODEL.phys.elbow_torque_ncm])
        ratio, _ = C.swing_loads(MODEL, tuple(kin.pose), hands, q, free)
        held = [k for k in range(3) if k != free]
        assert math.isclose(max(np.max(np.abs(tq[held]) / lim), np.max(np.abs(tq[free]) / lim)), ratio, rel_tol=1e-6)
        checked += 1
    assert checked == 60


def test_the_split_fed_forward_carries_the_load_and_holds_a_move_the_position_loops_alone_stall_on() -> None:
    """While a hand is free the holding servos are commanded the best split's torques: the
    motors' own corrections stay small beside them. A move whose best split needs 94 % of a
    servo's torque succeeds with the split fed forward (the default) and stalls with
    ``load_feedforward: 0``, where the compliant servos share the load by their errors."""
    import dataclasses

    wall = HoleMap.grid(6, 14, 15.0, 1.0, 0.08, seed=290117535)  # from the agreement bench's walk
    stance, arm, hole = (25, 24, 50), 1, 40
    sim = PhysicsClimber(MODEL)
    sim.reset(wall, stance)
    assert sim._let_go(arm) is None and sim._ff is not None
    sim._run(int(1.0 / sim.dt), lambda t: None, stall=False)
    fed = np.abs(np.array(sim._ff))
    motors = np.array([[abs(m.impulse) / sim.dt / 100.0 for m in pair] for pair in sim.motors])
    held = [k for k in range(3) if k != arm]
    assert fed[held].max() > 30.0  # N cm: a heavy stance
    assert motors[held].max() < 0.2 * fed[held].max(), (fed, motors)

    plan = plan_move(MODEL, wall, stance, arm, hole)
    assert isinstance(plan, MovePlan) and 0.9 < plan.torque_ratio <= MODEL.phys.torque_safety
    sim.reset(wall, stance)
    assert sim.move(arm, hole).ok
    alone = ClimberModel(MODEL.geom, dataclasses.replace(MODEL.phys, load_feedforward=0.0))
    sim = PhysicsClimber(alone)
    sim.reset(wall, stance)
    res = sim.move(arm, hole)
    assert res.outcome == "torque_limit" and res.phase == "swing", res
