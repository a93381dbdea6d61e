"""Numeric IK: LM/DLS and CCD on real chains, one result type, limits respected."""

import math

import numpy as np
import pytest

from kinegym.kinematics import DHChain, DHLink, IKResult, InvalidInputError, WritingArm, ccd, dls, solve_arm
from kinegym.kinematics.ik import ArmSeeds

PINCHER = WritingArm.from_config("pincher")
SEEDS = ArmSeeds(PINCHER)


@pytest.mark.parametrize("mask", ["position", "position+pitch"])
def test_dls_reaches_random_targets_within_limits(mask: str) -> None:
    rng = np.random.default_rng(11)
    q = rng.uniform(PINCHER.limits[:, 0], PINCHER.limits[:, 1], (300, 4))
    for target in PINCHER.fk(q):
        res = solve_arm(PINCHER, target, mask, seeds=SEEDS, rng=np.random.default_rng(0))
        assert isinstance(res, IKResult)
        assert res.success, res
        reached = PINCHER.fk(res.q)
        assert np.linalg.norm(reached[:3] - target[:3]) < 1e-4
        if mask == "position+pitch":
            assert abs(math.remainder(reached[3] - target[3], 2 * math.pi)) < 1e-4
        assert PINCHER.within_limits(res.q)


def test_dls_does_not_stall_on_a_limit() -> None:
    # start with the shoulder pressed against its lower limit, pulled further down by the
    # target's gradient at first: the active set frees the other joints and it converges
    target = PINCHER.fk([0.4, 0.2, -1.2, -0.9])
    lo = PINCHER.limits[:, 0]
    q0 = [0.4, lo[1], 0.0, 0.0]
    res = solve_arm(PINCHER, target, "position", q0=q0, restarts=0)
    assert res.success and res.restarts == 0, res


def test_dls_unreachable_reports_failure() -> None:
    res = solve_arm(PINCHER, [80, 0, 5, 0], "position", seeds=SEEDS, restarts=2)
    assert not res.success and res.error > 40
    assert res.reason in ("stalled", "max_iterations")
    assert PINCHER.within_limits(res.q)


def test_dls_generic_residual_reproducible() -> None:
    # a 2-link planar arm written as a residual function, with seeded restarts
    goal = (1.2, 0.7)

    def residual(q: list[float]) -> tuple[list[float], list[list[float]]]:
        a, b = q
        x = math.cos(a) + math.cos(a + b)
        y = math.sin(a) + math.sin(a + b)
        jac = [[-math.sin(a) - math.sin(a + b), -math.sin(a + b)],
               [math.cos(a) + math.cos(a + b), math.cos(a + b)]]
        return [goal[0] - x, goal[1] - y], jac

    r1 = dls(residual, [0.0, 0.0], rng=np.random.default_rng(3))
    r2 = dls(residual, [0.0, 0.0], rng=np.random.default_rng(3))
    assert r1.success and np.array_equal(r1.q, r2.q)


def test_ccd_seed001_planar_arm() -> None:
    # seed 001: three revolute links of 5, limits +-45, +-90, +-90 deg, target (5, 5)
    chain = DHChain([DHLink(a=5.0, joint=0), DHLink(a=5.0, joint=1), DHLink(a=5.0, joint=2)])
    limits = np.radians([[-45, 45], [-90, 90], [-90, 90]])
    res = ccd(chain, [5, 5, 0], limits=limits)
    assert res.success and res.error < 1e-3
    assert np.all(res.q >= limits[:, 0]) and np.all(res.q <= limits[:, 1])
    np.testing.assert_allclose(chain.fk(res.q)[:2, 3], [5, 5], atol=1e-3)


def test_ccd_with_prismatic_joint_and_limits() -> None:
    # revolute base, telescopic link (prismatic along x1 via a fixed frame), revolute tip
    chain = DHChain([
        DHLink(a=2.0, joint=0),
        DHLink(kind="F", theta=math.pi / 2, alpha=math.pi / 2),   # z now along the link
        DHLink(kind="P", d=1.0, joint=1),                          # slide along the link
        DHLink(kind="F", theta=-math.pi / 2, alpha=-math.pi / 2),  # back to the plane
        DHLink(a=3.0, joint=2),
    ])
    limits = [[-math.pi, math.pi], [0.0, 6.0], [-2.0, 2.0]]
    res = ccd(chain, [6.0, 4.0, 0.0], limits=limits, tol=1e-4, max_sweeps=500)
    assert res.success, res
    assert 0.0 <= res.q[1] <= 6.0
    np.testing.assert_allclose(chain.fk(res.q)[:3, 3], [6, 4, 0], atol=1e-4)


def test_ccd_on_pincher_chain() -> None:
    chain = PINCHER.dh_chain()
    target = PINCHER.fk([0.5, 0.9, -1.2, -0.8])[:3]
    res = ccd(chain, target, q0=[0, 0.5, -0.5, -0.5], limits=PINCHER.limits, tol=1e-4, max_sweeps=2000)
    assert res.success, res
    assert PINCHER.within_limits(res.q)


def test_ik_input_errors() -> None:
    with pytest.raises(InvalidInputError, match="mask"):
        solve_arm(PINCHER, [15, 0, 7, 0], "orientation")
    with pytest.raises(InvalidInputError, match="NaN"):
        solve_arm(PINCHER, [15, 0, float("nan"), 0])
    with pytest.raises(InvalidInputError, match="limits"):
        dls(lambda q: ([0.0], [[1.0]]), [0.0], limits=[[1.0, 0.0]])
    with pytest.raises(InvalidInputError, match=r"shape \(2,\)"):
        ccd(PINCHER.dh_chain(), [1, 2])
