"""Localisation (seed 000 done right): round trips from simulated grips, never silently wrong."""

import math

import numpy as np
import pytest

from kinegym.kinematics import ClimberGeometry, HoleMap, InvalidInputError
from kinegym.kinematics.bayes import BayesLocalizer
from kinegym.kinematics.climber import body_to_wall, hand_positions, inverse_program
from kinegym.kinematics.localization import Localizer
from kinegym.kinematics.pose_fit import AmbiguousFixError, NoFixError, NoiseModel, chi2_3_cdf, chi2_3_quantile
from kinegym.kinematics.seed_search import seed_adjacent_search
from kinegym.kinematics.sensor_study import GripSimulator, sensor_study
from kinegym.kinematics.triangles import TriangleIndex

GEOM = ClimberGeometry()
SEED_ANGLES = np.radians([[-24, 85], [78, 55], [-155, 103]])


def test_chi2_quantile_roundtrip() -> None:
    for p in (0.5, 0.9, 0.999, 0.9999):
        assert chi2_3_cdf(chi2_3_quantile(p)) == pytest.approx(p, abs=1e-10)
    assert chi2_3_quantile(0.95) == pytest.approx(7.8147, abs=1e-4)  # textbook value


def test_index_holds_only_holdable_triangles() -> None:
    wall = HoleMap.grid(6, 6, spacing=20, jitter=0.5, seed=1)
    index = TriangleIndex(wall, GEOM)
    p = wall.xy[index.triangles]
    u, v = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    assert (cross >= 0).all()  # stored counter-clockwise
    # brute force: every triple that fits in a disc of the reach is indexed
    from itertools import combinations
    n_brute = 0
    for t in combinations(range(len(wall)), 3):
        a, b, c = wall.xy[list(t)]
        ab, bc, ca = np.linalg.norm(a - b), np.linalg.norm(b - c), np.linalg.norm(c - a)
        longest = max(ab, bc, ca)
        area2 = abs((b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0])
        obtuse = 2 * longest**2 >= ab**2 + bc**2 + ca**2
        r = longest / 2 if obtuse else ab * bc * ca / (2 * area2)
        n_brute += r <= 20.0
    assert len(index) == n_brute


@pytest.mark.parametrize("sigma_deg", [0.0, 0.1, 0.5])
def test_roundtrip_from_simulated_grips(sigma_deg: float) -> None:
    wall = HoleMap.grid(8, 8, spacing=20, jitter=2.0, seed=4)  # strong jitter: shapes are distinct
    noise = NoiseModel(sigma_angle=math.radians(max(sigma_deg, 0.02)), sigma_map=0.005)
    loc = Localizer(wall, GEOM, noise)
    sim = GripSimulator(loc.index, GEOM, math.radians(sigma_deg), seed=5)
    unique = 0
    for _ in range(200):
        g = sim.grip()
        try:
            fix = loc.localize(g.q_measured)
        except AmbiguousFixError as err:
            assert g.holes in [c.holes for c in err.candidates]  # truth is among them
            continue
        unique += 1
        assert fix.holes == g.holes  # never silently wrong
        assert np.hypot(*(fix.centre - g.pose[:2])) < 0.05 + 2 * sigma_deg
        assert abs(math.remainder(fix.heading - g.pose[2], 2 * math.pi)) < 0.01 + math.radians(5 * sigma_deg)
    assert unique > 100


def test_mirror_image_is_rejected() -> None:
    # an asymmetric triangle of holes, and the hands of its mirror image
    holes = np.array([[0.0, 0.0], [22.0, 3.0], [5.0, 17.0]])
    mirror = holes * [1, -1] + [0, 60]
    wall = HoleMap(ids=np.array([[1, 1], [2, 1], [3, 1], [1, 2], [2, 2], [3, 2]]),
                   xy=np.concatenate([holes, mirror + [60, 0]]))
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(0.1), sigma_map=0.01))
    centre = holes.mean(0)
    q = inverse_program(holes, centre, 0.4, GEOM)
    fix = loc.localize(q)
    assert fix.holes == (0, 1, 2)  # the mirror copy (same side lengths) never matches
    # the seed's unoriented search accepts both
    found = {frozenset(t) for t in seed_adjacent_search(wall, q, GEOM, precision=0.05)}
    assert len(found) <= 2


def test_regular_grid_is_reported_ambiguous() -> None:
    wall = HoleMap.grid(6, 6, spacing=20, jitter=0.0)
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(0.1)))
    holes = wall.xy[[wall.index((2, 2)), wall.index((3, 2)), wall.index((2, 3))]]
    q = inverse_program(holes, holes.mean(0), 0.0, GEOM)
    with pytest.raises(AmbiguousFixError) as info:
        loc.localize(q)
    err = info.value
    assert err.count == len(err.candidates) > 10
    assert sum(c.likelihood for c in err.candidates) == pytest.approx(1.0)


@pytest.mark.parametrize("block", [1, 3, 64])
def test_dense_wall_ambiguity_is_proven_from_the_grip_cell(block: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """On a dense jittered wall a grip's own index cell holds many congruent triples; the
    probe screens it a block at a time and proves the ambiguity with two exact passes, which
    must be among the triples the full search finds passing."""
    import kinegym.kinematics.localization as loc_mod

    monkeypatch.setattr(loc_mod, "_PROBE_BLOCK", block)
    wall = HoleMap.grid(30, 30, spacing=20, jitter=0.5, seed=4)
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(0.1), sigma_map=0.01))
    sim = GripSimulator(loc.index, GEOM, math.radians(0.1), seed=5)
    proven = 0
    for _ in range(20):
        grip = sim.grip()
        hx, hy, cov, w = loc.measure(grip.q_measured)
        verdict = loc._probe_cell(hx, hy, cov, w)
        if verdict is None:
            continue
        proven += 1
        passing = {c.holes for c in verdict.candidates}
        assert len(passing) >= 2 and tuple(grip.holes) in passing
        _, _, chi2, _ = loc.search(grip.q_measured)
        assert (chi2 <= loc._limit).sum() == verdict.count
    assert proven >= 15


def test_seed_example_right_answer() -> None:
    wall = HoleMap.from_config("seed_4x4")
    # the seed's own way (fixed tolerance): unique, and not what the seed printed
    fix = Localizer(wall, GEOM, NoiseModel(tolerance=0.15)).localize(SEED_ANGLES)
    assert fix.ids == ((4, 3), (3, 3), (3, 2))
    assert fix.centre == pytest.approx([47.13, 34.07], abs=0.03)  # seed printed (35.0066, 28.7447)
    assert fix.ids != ((2, 3), (3, 3), (3, 2))  # the seed's mirror-image answer
    # with the angles' 1-degree rounding as noise: ambiguous, the right triple ranked first
    with pytest.raises(AmbiguousFixError) as info:
        Localizer(wall, GEOM, NoiseModel.from_degrees(0.289)).localize(SEED_ANGLES)
    assert info.value.candidates[0].ids == ((4, 3), (3, 3), (3, 2))
    # too strict a tolerance: no fix, and it says which candidate came closest
    with pytest.raises(NoFixError, match="no fix"):
        Localizer(wall, GEOM, NoiseModel(tolerance=0.05)).localize(SEED_ANGLES)


def test_tracking_and_lost_start() -> None:
    wall = HoleMap.grid(30, 30, spacing=20, jitter=0.5, seed=2)
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(0.1), sigma_map=0.01))
    sim = GripSimulator(loc.index, GEOM, math.radians(0.1), seed=9)
    bayes = BayesLocalizer(loc)
    localised = 0
    for _ in range(30):
        bayes.reset()
        path = sim.walk(6)
        for n, g in enumerate(path):
            if n:
                tf = loc.track(path[n - 1].holes, g.q_measured, g.moved_arm)
                assert tf.holes == g.holes
                # arrays made on first read, then the same array every time
                assert tf.pose.shape == (3,) and tf.pose is tf.pose and tf.pose.dtype == np.float64
                assert tf.best.residual_cm.shape == (3,) and np.all(tf.best.residual_cm < 0.1)
            fix = bayes.observe(g.q_measured, g.moved_arm)
            if fix is not None:
                assert fix.holes == g.holes
                localised += 1
                break
    assert localised >= 27


def test_noisy_fix_covariance_is_honest() -> None:
    wall = HoleMap.grid(8, 8, spacing=20, jitter=2.0, seed=4)
    noise = NoiseModel(sigma_angle=math.radians(0.5), sigma_map=0.0001)
    loc = Localizer(wall, GEOM, noise)
    g = GripSimulator(loc.index, GEOM, 0.0, seed=1).grip()
    rng = np.random.default_rng(0)
    errs, cov = [], None
    for _ in range(300):
        fix = loc.track(g.holes, g.q_true + rng.normal(0, noise.sigma_angle, (3, 2)), None)
        errs.append(fix.pose - g.pose)
        cov = fix.covariance
    std_emp = np.std(np.array(errs), axis=0)
    assert np.allclose(std_emp, np.sqrt(np.diag(cov)), rtol=0.3)


def test_sensor_study_small() -> None:
    rows = sensor_study(HoleMap.from_config("seed_4x4"), [math.radians(0.1), math.radians(1.0)],
                        trials=150, walks=10)
    assert rows[0]["wrong"] == 0 and rows[1]["wrong"] == 0
    assert rows[0]["correct"] > rows[1]["correct"]          # better encoders, more unique fixes
    assert rows[1]["centre_err_median_cm"] < 0.15           # per degree of sigma
    assert rows[0]["true_kept"] >= 0.99


def test_bad_inputs() -> None:
    wall = HoleMap.from_config("seed_4x4")
    loc = Localizer(wall, GEOM)
    with pytest.raises(InvalidInputError, match=r"shape \(2, 2\)"):
        loc.localize([[0, 1], [1, 1]])
    with pytest.raises(InvalidInputError, match="NaN"):
        loc.localize([[0, 1], [1, np.nan], [2, 2]])
    with pytest.raises(InvalidInputError, match="moved_arm"):
        loc.track((0, 1, 2), SEED_ANGLES, 4)
    for bad in [(0, 1.5, 2), (0, 1), "abc"]:  # a float row, two holes, not holes at all
        with pytest.raises(InvalidInputError, match="expected a Fix or 3 integer map rows"):
            loc.track(bad, SEED_ANGLES, 2)
    with pytest.raises(InvalidInputError, match=r"expected 3 map rows in 0\.\.15"):
        loc.track((0, 1, 16), SEED_ANGLES, 2)
    best = loc.candidates(SEED_ANGLES)[0]  # numpy integer rows are map rows too
    assert loc.track(np.array(best.holes, dtype=np.int64), SEED_ANGLES, None).holes == best.holes
    with pytest.raises(InvalidInputError, match="at least 3"):
        Localizer(HoleMap(ids=np.array([[1, 1]]), xy=np.array([[0.0, 0.0]])), GEOM)
    with pytest.raises(InvalidInputError, match="p_gate"):
        NoiseModel(p_gate=2.0)
    with pytest.raises(InvalidInputError, match=r"expected \(N, 2\)"):
        HoleMap(ids=np.zeros((0, 2), int), xy=np.zeros((0, 2)))
    assert body_to_wall(hand_positions(SEED_ANGLES), [0, 0, 0]).shape == (3, 2)


@pytest.mark.parametrize("sigma_deg", [0.1, 1.0])
def test_scalar_fit_matches_the_vectorised_fit(sigma_deg: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """The plain-Python variable-projection fit (tracking) and the numpy Gauss-Newton fit
    (global search), both run to convergence, reach the same weighted optimum; the default
    (at most two Newton steps, stopping at a step under 0.01 rad) is within 1e-3 of its
    chi-square."""
    from kinegym.kinematics import pose_fit
    from kinegym.kinematics.pose_fit import _fit, _fit_one

    monkeypatch.setattr(pose_fit, "_GN_STEPS", 8)

    wall = HoleMap.grid(12, 12, spacing=20, jitter=0.5, seed=5)
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(sigma_deg), sigma_map=0.01))
    sim = GripSimulator(loc.index, GEOM, math.radians(sigma_deg), seed=1)
    xy = wall.xy
    for k in range(200):
        g = sim.grip()
        hx, hy, cov, w = loc.measure(g.q_measured)
        v = list(g.holes)
        if k % 2:  # a neighbouring, wrong triple: a poor fit, but both must agree on it
            v[k % 3] = int(wall.within(xy[v[k % 3]], 25.0)[0])
        x, y, th, chi2, res = _fit_one(xy[v, 0].tolist(), xy[v, 1].tolist(), hx, hy, w, steps=8, tol=0.0)
        weights = np.array([[[c, -b], [-b, a]] for a, b, c in cov]) / np.array(
            [a * c - b * b for a, b, c in cov])[:, None, None]
        pose, chi2v, resv = _fit(xy[v][None], np.array([hx, hy]).T, weights)
        if chi2 < 50:  # a clear optimum (a bad triple may have several local ones)
            assert chi2v[0] == pytest.approx(chi2, rel=1e-9, abs=1e-9)
            assert np.allclose(pose[0, :2], [x, y], atol=1e-7)
            assert abs(math.remainder(pose[0, 2] - th, 2 * math.pi)) < 1e-8
            assert np.allclose(resv[0], res, atol=1e-7)
            fast = _fit_one(xy[v, 0].tolist(), xy[v, 1].tolist(), hx, hy, w, steps=2)
            assert chi2 - 1e-9 <= fast[3] <= chi2 + 1e-3


def test_tracking_runner_up_is_built_on_demand() -> None:
    wall = HoleMap.grid(30, 30, spacing=3, jitter=0.2, seed=2)  # dense: several holes near the prediction
    loc = Localizer(wall, GEOM, NoiseModel(sigma_angle=math.radians(0.5), sigma_map=0.01))
    sim = GripSimulator(loc.index, GEOM, math.radians(0.5), seed=4)
    seen = 0
    path = sim.walk(40)
    for prev, g in zip(path, path[1:]):
        fix = loc.track(prev.holes, g.q_measured, g.moved_arm)
        assert fix.holes == g.holes
        if fix.n_candidates > 1:
            r = fix.runner_up
            assert r is not None and r.holes != fix.holes and r.chi2 >= fix.best.chi2 and r is fix.runner_up
            seen += 1
    assert seen > 0
