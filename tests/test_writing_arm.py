"""Writing arm (seeds 002, 003): every IK branch reproduces its target; the seeds' tables checked."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinegym.kinematics import InvalidInputError, JointLimitError, UnreachableError, WritingArm
from kinegym.kinematics.writing_arm import BRANCHES

ARMS = {name: WritingArm.from_config(name) for name in ("pincher", "thesis_rrrr")}


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.mod(a + math.pi, 2 * math.pi) - math.pi


def world_phi(arm: WritingArm, q: np.ndarray) -> np.ndarray:
    """The pen pitch read off the geometry alone, as seed 002 defines it: the wrist-to-tip
    direction's elevation, measured from the horizontal that points away from the base axis
    (through the tip), less the arm's own zero. Independent of :meth:`WritingArm.fk`'s formula."""
    pts = arm.joint_positions(q)
    d = pts[..., 4, :] - pts[..., 3, :]
    out = pts[..., 4, :2] - np.asarray(arm.base_xy)
    outward = np.where(np.sum(d[..., :2] * out, axis=-1) >= -1e-12, 1.0, -1.0)
    pitch = np.arctan2(d[..., 2], outward * np.hypot(d[..., 0], d[..., 1]))
    return _wrap(pitch - arm.pitch_offset)


@pytest.mark.parametrize("name", sorted(ARMS))
@given(seed=st.integers(0, 2**32 - 1))
def test_every_branch_reproduces_its_target(name: str, seed: int) -> None:
    arm = ARMS[name]
    rng = np.random.default_rng(seed)
    q = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (1000, 4))
    target = arm.fk(q)
    qs, reachable, in_limits = arm.ik_all(target)
    assert reachable.any(axis=1).all() and in_limits.any(axis=1).all()
    f = arm.fk(np.where(reachable[..., None], qs, 0.0))
    err_pos = np.linalg.norm(f[..., :3] - target[:, None, :3], axis=-1)
    err_phi = np.abs(_wrap(f[..., 3] - target[:, None, 3]))
    assert np.where(reachable, err_pos, 0).max() < 1e-9
    assert np.where(reachable, err_phi, 0).max() < 1e-9
    # ... and the pen really points that way in the world (read off the geometry, every branch)
    err_dir = np.abs(_wrap(world_phi(arm, np.where(reachable[..., None], qs, 0.0)) - target[:, None, 3]))
    assert np.where(reachable, err_dir, 0).max() < 1e-9
    np.testing.assert_allclose(world_phi(arm, q), target[:, 3], atol=1e-9)
    # the configuration we started from is one of the branches
    dq = np.abs(_wrap(qs - q[:, None, :])).max(axis=-1)
    assert (np.nanmin(dq, axis=1) < 1e-6).all()
    # in-limit branches really are inside the limits
    assert arm.within_limits(np.where(in_limits[..., None], qs, arm.limits[:, 0]), tol=1e-9).all()


@pytest.mark.parametrize("name", sorted(ARMS))
def test_ik_nearest_branch_and_scalar_paths(name: str) -> None:
    arm = ARMS[name]
    rng = np.random.default_rng(7)
    for q in rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (300, 4)):
        t = arm.fk(q)
        near = arm.ik(t, current=q)
        np.testing.assert_allclose(near, q, atol=1e-7)  # nearest to where we are: where we are
        first = arm.ik(t)
        np.testing.assert_allclose(arm.fk(first)[:3], t[:3], atol=1e-9)
        assert abs(_wrap(world_phi(arm, first) - t[3])) < 1e-9
        assert arm.within_limits(first)
        fast = arm.ik_fast(*t.tolist(), tuple(q))
        np.testing.assert_allclose(fast, near, atol=1e-12)
        np.testing.assert_allclose(arm.fk_one(*q), t, atol=1e-12)


def test_ik_errors() -> None:
    arm = ARMS["pincher"]
    with pytest.raises(UnreachableError, match=r"out of reach.*0\.2\.\.21\.2 cm"):
        arm.ik([60, 0, 5, -math.pi / 2])
    with pytest.raises(InvalidInputError, match="NaN"):
        arm.ik([1, 2, float("nan"), 0])
    with pytest.raises(InvalidInputError, match=r"shape \(3,\)"):
        arm.ik([1, 2, 3])
    with pytest.raises(InvalidInputError, match="branch"):
        arm.ik([15, 0, 7, -math.pi / 2], branch=7)
    tight = WritingArm(name="tight", base_xy=(0, 0), shoulder_height=14.5, upper_arm=10.7,
                       forearm=10.5, tool=9.5, limits=np.radians([[-10, 10], [0, 5], [-5, 5], [-5, 5]]))
    with pytest.raises(JointLimitError, match="only outside its joint limits"):
        tight.ik([15, 0, 7, -math.pi / 2])


def test_seed002_task62_rows_1_2_4_are_physical_row_3_is_a_sign_error() -> None:
    """Seed 002 task 6.2 printed findJointAngles (servo convention, phi = 0: pen horizontal,
    pointing outward). Rows 1, 2 (facing the target) and 4 (reaching back over the base) reach
    the point with the pen outward; row 1 lies outside the +-150 deg servo limits; row 3 flips
    the signs of q3 / q4 and misses the point by 18-39 cm. Our four branches are rows 1, 2, 4
    and row 3 done right."""
    tables = {
        (-13, -13, 4): [[-0.7854, 3.2931, -1.7297, 0.0074], [-0.7854, 1.5856, 1.7297, -1.7444],
                        [2.3562, -3.2931, -1.7297, -0.0074], [2.3562, -1.5856, -1.7297, 1.7444]],
        (13, -5, 4): [[1.2036, 3.7310, -2.0067, -0.1535], [1.2036, 1.7539, 2.0067, -2.1898],
                      [4.3452, -3.7310, -2.0067, 0.1535], [4.3452, -1.7539, -2.0067, 2.1898]],
        (10, 12, 6): [[2.4469, 3.5550, -2.1082, 0.1240], [2.4469, 1.4800, 2.1082, -2.0174],
                      [-0.6947, -3.5550, -2.1082, -0.1240], [-0.6947, -1.4800, -2.1082, 2.0174]],
        (-5, 4, 10): [[4.0376, -1.2639, -2.6207, -0.8278], [4.0376, 2.4694, 2.6207, 2.7639],
                      [0.8961, 1.2639, -2.6207, 0.8278], [0.8961, -2.4694, -2.6207, -2.7639]],
    }
    arm = ARMS["pincher"]
    for target, rows in tables.items():
        q = arm.from_servo(np.array(rows))
        f = arm.fk(q)
        miss = np.linalg.norm(f[:, :3] - np.array(target), axis=1)
        valid = [0, 1, 3]
        assert (miss[valid] < 2e-3).all()            # rows 1, 2, 4: right to the printed 4 decimals
        assert np.abs(_wrap(f[valid, 3])).max() < 1e-3 and np.abs(world_phi(arm, q[valid])).max() < 1e-3
        assert miss[2] > 10                          # row 3: a sign error
        assert not arm.within_limits(q[0])           # row 1: beyond the servo limits
        # our four branches all hit (x, y, z, phi = 0), pen outward; rows 1, 2, 4 are among them
        qs, ok, _ = arm.ik_all([*target, 0.0])
        assert ok.all()
        g = arm.fk(qs)
        np.testing.assert_allclose(g[:, :3], np.broadcast_to(target, (4, 3)), atol=1e-9)
        np.testing.assert_allclose(_wrap(g[:, 3]), 0, atol=1e-9)
        np.testing.assert_allclose(world_phi(arm, qs), 0, atol=1e-9)
        for row in np.array(rows)[valid]:
            assert np.abs(_wrap(arm.to_servo(qs) - row)).max(axis=1).min() < 2e-3


def test_an_impossible_pen_pose_is_refused_not_mislabelled() -> None:
    """At (-5, 4, 10) with the pen horizontal outward, the old joint-relative pitch returned
    a pose whose pen pointed back at the base. Whatever ik() returns now points outward."""
    arm = ARMS["pincher"]
    for target in ([-5, 4, 10, 0.0], [-13, -13, 4, 0.0], [13, -5, 4, 0.0], [10, 12, 6, 0.0]):
        try:
            q = arm.ik(target)
        except JointLimitError:
            continue
        d = arm.pen_direction(q)
        out = np.array(target[:2]) - np.asarray(arm.base_xy)
        assert np.dot(d[:2], out / np.linalg.norm(out)) > 1 - 1e-9 and abs(d[2]) < 1e-9
    # seed 002's row 4 for (-13, -13, 4): reaching back, inside the limits, pen outward
    q = arm.ik([-13, -13, 4, 0.0], current=arm.from_servo([2.3562, -1.5856, -1.7297, 1.7444]))
    np.testing.assert_allclose(arm.to_servo(q), [2.3562, -1.5856, -1.7297, 1.7444], atol=2e-3)


def test_seed002_task64_optimal_solutions_are_among_our_branches() -> None:
    printed = {(12, 7, 5): [2.0989, 0.7254, 1.7125, 0.7037], (-10, 8, 10): [0.8961, -0.3444, -1.7305, -1.0667],
               (-13, -13, 4): [-0.7854, 1.1118, 1.0374, 0.9924], (8, -12, 6): [0.5880, 0.6912, 1.6409, 0.8095],
               (15, 0, 7): [1.5708, 0.6716, 1.5518, 0.9182]}
    arm = ARMS["pincher"]
    for target, servo in printed.items():
        qs, _, in_limits = arm.ik_all([*target, -math.pi / 2])
        ours = arm.to_servo(qs[in_limits])
        assert np.abs(_wrap(ours - np.array(servo))).max(axis=1).min() < 1e-3


def test_seed003_matrices_vs_printed_closed_form() -> None:
    arm = ARMS["thesis_rrrr"]
    big_l1, big_l2, big_l3, big_l4 = 25.0, 15.0, 15.0, 8.0
    lf = 3.0

    def rx_link(q: float, length: float, xoff: float = 0.0) -> np.ndarray:
        c, s = math.cos(q), math.sin(q)
        return np.array([[1, 0, 0, xoff], [0, c, -s, length * s], [0, s, c, -length * c], [0, 0, 0, 1]])

    rng = np.random.default_rng(9)
    for q1, q2, q3, q4 in rng.uniform(-2, 2, (200, 4)):
        c, s = math.cos(q1), math.sin(q1)
        t10 = np.array([[c, -s, 0, -lf], [s, c, 0, 0], [0, 0, 1, big_l1], [0, 0, 0, 1]])  # eq. 3.20
        t40 = t10 @ rx_link(q2, big_l2) @ rx_link(q3, big_l3) @ rx_link(q4, big_l4, lf)  # 3.17-3.21
        ours = arm.fk([q1, q2, q3, q4])
        np.testing.assert_allclose(ours[:3], t40[:3, 3], atol=1e-9)
        # eq. 3.27 is the joint-relative pitch: the world pitch where the arm faces its
        # target, turned round (its own zero is pen down) where it reaches back
        rel = math.atan2(t40[2, 1], t40[2, 2])
        assert math.isclose(abs(_wrap(np.array(ours[3] - rel))), 0, abs_tol=1e-9) or math.isclose(
            abs(_wrap(np.array(ours[3] + rel))), 0, abs_tol=1e-9)
        assert abs(_wrap(world_phi(arm, np.array([q1, q2, q3, q4])) - ours[3])) < 1e-9
    # the printed eq. 3.23 (y with "- L2 cos q1 sin q2") disagrees with the matrices
    q1, q2, q3, q4 = 0.3, 0.8, -0.5, 0.2
    y_printed = (lf * math.sin(q1) - big_l2 * math.cos(q1) * math.sin(q2)
                 - big_l4 * math.cos(q1) * math.sin(q2 + q3 + q4) - big_l3 * math.cos(q1) * math.sin(q2 + q3))
    assert abs(y_printed - arm.fk([q1, q2, q3, q4])[1]) > 1.0


def test_branch_names() -> None:
    assert len(BRANCHES) == 4
