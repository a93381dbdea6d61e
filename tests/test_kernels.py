"""Every fast kernel in ``kinematics/_kernels`` equals the readable reference it speeds up."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinegym.kinematics import WritingArm, dls, solve_arm
from kinegym.kinematics._kernels.lm import lm_attempt
from kinegym.kinematics.ik import MASKS, _lm_reference, _solve_arm_generic

ARMS = {name: WritingArm.from_config(name) for name in ("pincher", "thesis_rrrr")}


def _planar(n: int, goal: tuple[float, float]):  # noqa: ANN202 - a residual function
    """An n-link planar arm of unit links reaching ``goal``: m = 2 rows, n columns."""

    def residual(q: list[float]) -> tuple[list[float], list[list[float]]]:
        s = np.cumsum(q)
        x, y = float(np.cos(s).sum()), float(np.sin(s).sum())
        jx = [-float(np.sin(s[i:]).sum()) for i in range(n)]
        jy = [float(np.cos(s[i:]).sum()) for i in range(n)]
        return [goal[0] - x, goal[1] - y], [jx, jy]

    return residual


@pytest.mark.parametrize("n", [2, 3, 5, 8])  # m >= n, m < n (push-through form), past the dense kernels
def test_lm_kernel_takes_the_reference_steps(n: int) -> None:
    rng = np.random.default_rng(n)
    lim = [(-2.5, 2.5)] * n
    for _ in range(40):  # reachable goals (the tip of a random pose), random starts inside the limits
        s = np.cumsum(rng.uniform(-2.0, 2.0, n))
        goal = (float(np.cos(s).sum()), float(np.sin(s).sum()))
        q0 = list(rng.uniform(-2.0, 2.0, n))
        fast = lm_attempt(_planar(n, goal), lim, 1e-3, 1e-9, 100)(q0)
        ref = _lm_reference(_planar(n, goal), lim, 1e-3, 1e-9, 100)(q0)
        assert fast[3] == ref[3], (fast, ref)  # stalled (the same)
        if not fast[3]:  # converged: step for step (a stall's last steps gain < 1e-9: rounding decides when)
            assert fast[2] == ref[2], (fast, ref)
        np.testing.assert_allclose(fast[0], ref[0], atol=1e-6)
        assert math.isclose(fast[1], ref[1], rel_tol=1e-4, abs_tol=1e-16)


def test_dls_fast_and_reference_agree_with_restarts() -> None:
    res = [dls(_planar(3, (2.2, 1.0)), [0.0, 0.0, 0.0], limits=[(-1, 1)] * 3, tol=1e-8, fast=fast,
               rng=np.random.default_rng(4)) for fast in (True, False)]
    assert res[0].success == res[1].success and res[0].restarts == res[1].restarts
    np.testing.assert_allclose(res[0].q, res[1].q, atol=1e-7)


@pytest.mark.parametrize("name", sorted(ARMS))
@pytest.mark.parametrize("mask", sorted(MASKS))
def test_fused_arm_kernel_equals_the_reference_lm(name: str, mask: str) -> None:
    arm = ARMS[name]
    rng = np.random.default_rng(7)
    targets = arm.fk(rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (150, 4)))
    starts = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (150, 4))
    for target, start in zip(targets, starts):
        fast = solve_arm(arm, target, mask, q0=start, restarts=0)
        ref = _solve_arm_generic(arm, tuple(map(float, target)), MASKS[mask], list(start), None, 1e-3, 1e-5, 100,
                                 0, None, fast=False)
        assert fast.success == ref.success, (target, fast, ref)
        if fast.success:  # converged: step for step (a stall's last steps gain < 1e-9: rounding decides when)
            assert fast.iterations == ref.iterations, (target, fast, ref)
        else:
            assert math.isclose(fast.error, ref.error, rel_tol=1e-6)
        np.testing.assert_allclose(fast.q, ref.q, atol=1e-5)


@pytest.mark.parametrize("name", sorted(ARMS))
def test_generated_closed_form_ik_equals_the_reference(name: str) -> None:
    arm = ARMS[name]
    rng = np.random.default_rng(3)
    q = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (300, 4))
    current = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (300, 4))
    for target, cur in zip(arm.fk(q), current):
        fast = arm.ik_fast(*map(float, target), tuple(cur))
        try:
            ref = arm.ik(target, current=cur)
        except Exception:  # noqa: BLE001 - the reference raises where the kernel returns None
            assert fast is None
            continue
        np.testing.assert_allclose(fast, ref, atol=1e-12)


def test_compiled_dh_fk_equals_the_product_of_dh_matrices() -> None:
    """The straight-line FK (floats and arrays) is the textbook product of DH transforms."""
    from kinegym.kinematics import DHChain, DHLink

    branched = DHChain([DHLink(a=5.0, joint=0), DHLink(d=2.0, a=3.0, alpha=0.7, joint=1, name="elbow"),
                        DHLink(a=1.5, theta=0.3, kind="P", joint=2), DHLink(a=4.0, alpha=-1.1, kind="F"),
                        DHLink(a=2.0, joint=3, scale=-2.0, parent=1, name="side")],
                       base=np.array([[0, -1, 0, 1.0], [1, 0, 0, 2.0], [0, 0, 1, 0.5], [0, 0, 0, 1]]))
    rng = np.random.default_rng(9)
    for chain in (ARMS["pincher"].dh_chain(), ARMS["thesis_rrrr"].dh_chain(), branched):
        qs = rng.uniform(-2.0, 2.0, (50, chain.n_joints))
        batch = chain.fk(qs)
        for q, pose in zip(qs, batch):
            for frame in range(chain.n_frames):
                ref = chain.fk_reference(q, frame)
                np.testing.assert_allclose(chain.fk(q, frame), ref, atol=1e-12)
                fast = chain.fk_fast(*q, frame=frame)
                np.testing.assert_allclose(np.array(fast[9:]), ref[:3, 3], atol=1e-12)
            np.testing.assert_allclose(pose, chain.fk_reference(q), atol=1e-12)
