"""DH and PoE chains: against naive matrix products, against each other, Jacobians by differences."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinegym.kinematics import DHChain, DHLink, InvalidInputError, PoEChain, WritingArm
from kinegym.kinematics.chains import dh_matrix, screw_exp

D = math.radians


def manipulator3() -> DHChain:
    """Seed 001's "manipulator 3": q = (l1, t2, l3, t4, t5); fingers 51/52 and EF branch at 4."""
    return DHChain([
        DHLink(kind="P", joint=0, name="1"),                                   # d = l1
        DHLink(theta=0.0, a=5, alpha=D(-90), joint=1, name="2"),                # th = t2
        DHLink(kind="F", theta=D(-90), alpha=D(-90), name="2'"),
        DHLink(kind="P", joint=2, name="3"),                                   # d = l3
        DHLink(alpha=D(90), joint=3, name="4"),                                # th = t4
        DHLink(theta=D(90), a=2, alpha=D(90), joint=4, scale=-1.0, parent=4, name="51"),
        DHLink(theta=D(90), a=2, alpha=D(90), joint=4, scale=1.0, parent=4, name="52"),
        DHLink(kind="F", theta=D(90), a=2, parent=4, name="EF"),
    ])


def manipulator3_reference(p: np.ndarray) -> dict[str, np.ndarray]:
    """Seed 001 figure 1.2/1.4 typed literally: matriz_T products."""
    l1, t2, l3, t4, t5 = p
    d = [l1, 0, 0, l3, 0, 0, 0, 0]
    th = [0, t2, D(-90), 0, t4, D(90) - t5, D(90) + t5, D(90)]
    a = [0, 5, 0, 0, 0, 2, 2, 2]
    al = [D(v) for v in (0, -90, -90, 0, 90, 90, 90, 0)]
    t = [dh_matrix(d[i], th[i], a[i], al[i]) for i in range(8)]
    t02 = t[0] @ t[1]
    t03 = t02 @ (t[2] @ t[3])
    t04 = t03 @ t[4]
    return {"1": t[0], "2": t02, "3": t03, "4": t04, "51": t04 @ t[5], "52": t04 @ t[6],
            "EF": t04 @ t[7]}


@given(st.lists(st.floats(-3, 3), min_size=5, max_size=5))
def test_manipulator3_matches_seed_products(p: list[float]) -> None:
    chain = manipulator3()
    q = np.array(p)
    ref = manipulator3_reference(q)
    frames = chain.frames(q)
    for name, t in ref.items():
        np.testing.assert_allclose(frames[chain.frame_index(name)], t, atol=1e-12)
    # fast scalar path agrees with the array path
    fast = chain.fk_fast(*p, frame=chain.frame_index("EF"))
    np.testing.assert_allclose(fast[9:], ref["EF"][:3, 3], atol=1e-12)


def test_manipulator3_fingers_open_symmetrically() -> None:
    chain = manipulator3()
    f = chain.frames([5, 0, 5, D(90), D(45)])
    p51, p52, pef = (f[chain.frame_index(n), :3, 3] for n in ("51", "52", "EF"))
    p4 = f[chain.frame_index("4"), :3, 3]
    assert np.linalg.norm(p51 - p4) == pytest.approx(2) and np.linalg.norm(p52 - p4) == pytest.approx(2)
    # fingers at +-45 deg about the EF direction: each 45 deg from EF
    for pf in (p51, p52):
        c = np.dot(pf - p4, pef - p4) / 4
        assert math.degrees(math.acos(c)) == pytest.approx(45)


def _numeric_jacobian(fk, q: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    t0 = fk(q)
    cols = []
    for j in range(len(q)):
        dq = np.zeros_like(q)
        dq[j] = eps
        tp, tm = fk(q + dq), fk(q - dq)
        v = (tp[:3, 3] - tm[:3, 3]) / (2 * eps)
        dr = (tp[:3, :3] - tm[:3, :3]) / (2 * eps) @ t0[:3, :3].T  # [w]x
        cols.append(np.concatenate([v, [dr[2, 1], dr[0, 2], dr[1, 0]]]))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("frame", ["EF", "51", "52", "3"])
def test_dh_jacobian_by_differences(frame: str) -> None:
    chain = manipulator3()
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = rng.uniform(-2, 2, 5)
        num = _numeric_jacobian(lambda x: chain.fk(x, frame), q)
        np.testing.assert_allclose(chain.jacobian(q, frame), num, atol=1e-6)


@pytest.mark.parametrize("frame", ["EF", "51"])
def test_dh_to_poe_agrees(frame: str) -> None:
    chain = manipulator3()
    poe = chain.to_poe(frame)
    q = np.random.default_rng(2).uniform(-3, 3, (500, 5))
    np.testing.assert_allclose(poe.fk(q), chain.fk(q, frame), atol=1e-9)
    np.testing.assert_allclose(poe.jacobian(q), chain.jacobian(q, frame), atol=1e-9)


@pytest.mark.parametrize("name", ["pincher", "thesis_rrrr"])
def test_arm_dh_poe_and_formula_agree(name: str) -> None:
    arm = WritingArm.from_config(name)
    q = np.random.default_rng(3).uniform(-4, 4, (2000, 4))
    dh, poe = arm.dh_chain(), arm.poe_chain()
    t_dh, t_poe = dh.fk(q), poe.fk(q)
    np.testing.assert_allclose(t_dh, t_poe, atol=1e-9)
    f = arm.fk(q)
    np.testing.assert_allclose(t_dh[:, :3, 3], f[:, :3], atol=1e-9)
    np.testing.assert_allclose(t_dh[:, :3, 0], arm.pen_direction(q), atol=1e-9)
    np.testing.assert_allclose(dh.jacobian(q), poe.jacobian(q), atol=1e-9)
    np.testing.assert_allclose(dh.jacobian(q)[:, :3], arm.jacobian(q)[:, :3], atol=1e-9)


def test_seed002_poe_as_written_matches_model_through_servo_map() -> None:
    # seed 002 getTsb/getZeroConf: arm straight up, joints about z then x, in servo angles
    l1, l2, l3, l4, l5 = 10, 4.5, 10.7, 10.5, 9.5
    x, z = np.array([1.0, 0, 0]), np.array([0, 0, 1.0])

    def screw(w: np.ndarray, q: list[float]) -> np.ndarray:
        return np.concatenate([w, np.cross(-w, q)])

    seed = PoEChain(
        screws=np.stack([screw(z, [0, 0, l1]), screw(x, [0, 0, l1 + l2]),
                         screw(x, [0, 0, l1 + l2 + l3]), screw(x, [0, 0, l1 + l2 + l3 + l4])]),
        home=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, l1 + l2 + l3 + l4 + l5], [0, 0, 0, 1.0]]),
    )
    arm = WritingArm.from_config("pincher")
    q = np.random.default_rng(4).uniform(-3, 3, (1000, 4))
    np.testing.assert_allclose(seed.fk(arm.to_servo(q))[:, :3, 3], arm.fk(q)[:, :3], atol=1e-9)


def test_screw_exp_prismatic_and_revolute() -> None:
    t = screw_exp([0, 0, 0, 1, 2, 3], 2.0)
    np.testing.assert_allclose(t[:3, 3], [2, 4, 6])
    r = screw_exp([0, 0, 1, 0, 0, 0], math.pi / 2)
    np.testing.assert_allclose(r[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-15)


def test_chain_input_errors() -> None:
    with pytest.raises(InvalidInputError, match="parent"):
        DHChain([DHLink(joint=0, parent=3)])
    with pytest.raises(InvalidInputError, match="kind"):
        DHChain([DHLink(kind="F", joint=0)])
    with pytest.raises(InvalidInputError, match="gaps"):
        DHChain([DHLink(joint=1)])
    chain = manipulator3()
    with pytest.raises(InvalidInputError, match=r"shape \(4,\)"):
        chain.fk([1, 2, 3, 4])
    with pytest.raises(InvalidInputError, match="NaN"):
        chain.fk([1, 2, 3, 4, np.nan])
    with pytest.raises(InvalidInputError, match="'wrist'"):
        chain.fk([0] * 5, "wrist")
