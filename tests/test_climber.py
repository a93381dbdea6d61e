"""Climber kinematics (seed 000): FK/IK round trips, the seed's examples, named errors."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinegym.kinematics import ClimberGeometry, InvalidInputError, UnreachableError, arm_ik
from kinegym.kinematics.climber import (
    body_to_wall,
    elbow_positions,
    hand_positions,
    inverse_program,
    wall_to_body,
)
from kinegym.kinematics.holes import HoleMap


def test_seed_inverse_example_reproduces_printed_angles() -> None:
    # seed 000, figure 59: holes (20,0), (0,20), (0,0), centre (6.6289, 7.7378), l = 10
    q = inverse_program([[20, 0], [0, 20], [0, 0]], [6.6289, 7.7378], 0.0, ClimberGeometry.uniform(10))
    printed = np.array([[-69.4851, 101.1454], [72.5795, 88.3680], [170.0409, 61.2544]])
    np.testing.assert_allclose(np.degrees(q), printed, atol=1e-3)


def test_seed_forward_formula_typed_from_the_seed() -> None:
    # seed 000 lines 20-34, typed independently: rdx = l cos(a1) + l cos(a1 - a2 + pi), ...
    angles = np.radians([[-24, 85], [78, 55], [-155, 103]])
    el = 10.0
    seed = [(el * math.cos(a) + el * math.cos(a - e + math.pi),
             el * math.sin(a) + el * math.sin(a - e + math.pi)) for a, e in angles]
    np.testing.assert_allclose(hand_positions(angles), seed, atol=1e-12)


@st.composite
def geometries(draw: st.DrawFn) -> ClimberGeometry:
    l1 = [draw(st.floats(3, 20)) for _ in range(3)]
    l2 = [draw(st.floats(3, 20)) for _ in range(3)]
    sh = [[draw(st.floats(-5, 5)), draw(st.floats(-5, 5))] for _ in range(3)]
    return ClimberGeometry(l1=l1, l2=l2, shoulders=sh)


@given(geometries(), st.integers(0, 2**32 - 1))
def test_fk_ik_roundtrip(geom: ClimberGeometry, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 1000
    q = np.stack([rng.uniform(-math.pi, math.pi, (n, 3)), rng.uniform(0.05, 2 * math.pi - 0.05, (n, 3))], -1)
    hands = hand_positions(q, geom)
    branch = np.where(q[..., 1] <= math.pi, 1, -1)
    q2 = arm_ik(hands, geom, branch)
    np.testing.assert_allclose(hand_positions(q2, geom), hands, atol=1e-9)
    dq = np.mod(q2 - q + math.pi, 2 * math.pi) - math.pi
    assert np.abs(dq).max() < 1e-6
    # the other branch reaches the same hands with a mirrored elbow
    q3 = arm_ik(hands, geom, -branch)
    np.testing.assert_allclose(hand_positions(q3, geom), hands, atol=1e-9)
    elbows = elbow_positions(q3, geom)
    np.testing.assert_allclose(np.linalg.norm(elbows - geom.shoulders, axis=-1), np.broadcast_to(geom.l1, (n, 3)))
    np.testing.assert_allclose(np.linalg.norm(hands - elbows, axis=-1), np.broadcast_to(geom.l2, (n, 3)))


@given(st.floats(-100, 100), st.floats(-100, 100), st.floats(-10, 10), st.integers(0, 1000))
def test_inverse_program_roundtrip_on_wall(x: float, y: float, heading: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    geom = ClimberGeometry()
    pose = np.array([x, y, heading])
    q = np.stack([rng.uniform(-math.pi, math.pi, 3), rng.uniform(0.3, math.pi, 3)], -1)
    holes = body_to_wall(hand_positions(q, geom), pose)
    q2 = inverse_program(holes, pose[:2], heading, geom)
    np.testing.assert_allclose(body_to_wall(hand_positions(q2, geom), pose), holes, atol=1e-9)


def test_batched_shapes_and_transforms() -> None:
    rng = np.random.default_rng(0)
    q = rng.uniform(0.2, 3.0, (4, 5, 3, 2))
    assert hand_positions(q).shape == (4, 5, 3, 2)
    poses = rng.normal(size=(4, 5, 3))
    pts = rng.normal(size=(4, 5, 3, 2))
    np.testing.assert_allclose(wall_to_body(body_to_wall(pts, poses), poses), pts, atol=1e-12)
    # a pure rotation by 90 degrees maps the x axis to the y axis
    np.testing.assert_allclose(body_to_wall([[1.0, 0.0]], [0, 0, math.pi / 2]), [[0.0, 1.0]], atol=1e-15)


def test_unreachable_names_arm_and_reach() -> None:
    with pytest.raises(UnreachableError, match=r"arm 2 .*25 cm.*0\.\.20 cm") as info:
        arm_ik([[5, 0], [25, 0], [0, 5]])
    assert info.value.details["arm"] == 2
    # inside the inner radius of unequal links
    geom = ClimberGeometry(l1=[10, 10, 10], l2=[4, 4, 4])
    with pytest.raises(UnreachableError, match="arm 1"):
        arm_ik([[1, 0], [10, 0], [10, 0]], geom)


@pytest.mark.parametrize(
    ("q", "match"),
    [([[0, 1], [0, 1]], r"shape \(2, 2\)"), ([[0, 1], [0, np.nan], [1, 1]], "NaN"), ("abc", "not numeric")],
)
def test_bad_joint_angles(q: object, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        hand_positions(q)


def test_bad_branch_and_geometry() -> None:
    with pytest.raises(InvalidInputError, match="branch"):
        arm_ik([[5, 0], [0, 5], [-5, 0]], branch=0)
    with pytest.raises(InvalidInputError, match="> 0 cm"):
        ClimberGeometry(l1=[10, 0, 10])
    with pytest.raises(InvalidInputError, match="heading"):
        inverse_program([[5, 0], [0, 5], [-5, 0]], [0, 0], float("nan"))


def test_hole_map_grid() -> None:
    g = HoleMap.grid(10, 8, spacing=20, jitter=0.5, missing=0.1, seed=3)
    again = HoleMap.grid(10, 8, spacing=20, jitter=0.5, missing=0.1, seed=3)
    np.testing.assert_array_equal(g.xy, again.xy)
    assert 0 < len(g) < 80
    ideal = (g.ids - 1) * 20.0
    assert np.abs(g.xy - ideal).max() <= 0.5
    with pytest.raises(KeyError, match=r"\(99, 99\)"):
        g.position((99, 99))
    with pytest.raises(InvalidInputError, match="jitter"):
        HoleMap.grid(3, 3, spacing=10, jitter=6)


def test_scalar_arm_ik_equals_the_vectorised_one() -> None:
    """The simulation's plain-float two-link IK is the same algorithm as :func:`arm_ik`."""
    from kinegym.kinematics.climber import arm_ik_one

    rng = np.random.default_rng(5)
    geom = ClimberGeometry(l1=np.array([10.0, 9.0, 12.0]), l2=np.array([10.0, 11.0, 8.0]))
    for branch in (1, -1):
        for _ in range(200):
            hands = np.array([[math.cos(a) * r, math.sin(a) * r] for a, r in zip(
                rng.uniform(-math.pi, math.pi, 3), rng.uniform(0.3, 0.99, 3) * (geom.l1 + geom.l2))])
            ref = arm_ik(hands, geom, branch)
            one = [arm_ik_one(float(geom.l1[k]), float(geom.l2[k]), *hands[k], branch) for k in range(3)]
            np.testing.assert_allclose(np.array(one), ref, atol=1e-9)
