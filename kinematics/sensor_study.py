"""Experiments on localisation: simulated grips and walks with encoder noise, and the sensor study.

The seed's "emulate with artificial errors": :class:`GripSimulator` draws random stances
and climbing walks on a wall and what noisy encoders would say; :func:`sensor_study` runs
global fixes, lost starts and tracking over them per noise level (``kinegym sensor-study``,
``bench/bench_localization.py``). Experiments, not localisation: nothing in the localiser
depends on this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .bayes import BayesLocalizer
from .climber import ClimberGeometry, inverse_program
from .errors import InvalidInputError
from .holes import HoleMap
from .localization import Localizer
from .pose_fit import AmbiguousFixError, Fix, NoFixError, NoiseModel, _fit_one
from .triangles import TriangleIndex

__all__ = ["Grip", "GripSimulator", "sensor_study"]


@dataclass(frozen=True)
class Grip:
    """One simulated grip: the truth and what the encoders said (rad)."""

    holes: tuple[int, int, int]
    pose: np.ndarray
    q_true: np.ndarray
    q_measured: np.ndarray
    moved_arm: int | None = None


class GripSimulator:
    """Random grips and climbing walks on a wall, with encoder noise - the seed's
    "emulate with artificial errors", used by the sensor study, the benchmark and the tests.

    Stances are drawn uniformly over the holdable triangles of the index, with a random arm
    assignment, a body centre uniform where every hole is within reach (``margin`` cm inside
    the annulus), a random heading and random elbow branches. Encoder readings get Gaussian
    noise ``sigma`` (rad) and are then rounded to ``quantum`` (rad, 0 = none).
    """

    def __init__(self, index: TriangleIndex, geom: ClimberGeometry, sigma: float, quantum: float = 0.0,
                 margin: float = 0.5, seed: int | None = 0) -> None:
        self.index, self.geom = index, geom
        self.holes = index.holes
        self.sigma, self.quantum, self.margin = float(sigma), float(quantum), float(margin)
        self.rng = np.random.default_rng(seed)
        self.r_out = geom.l1 + geom.l2 - margin
        self.r_in = np.abs(geom.l1 - geom.l2) + margin
        if len(index) == 0:
            raise InvalidInputError(f"map '{self.holes.name}' has no hole triangle the robot can hold")

    def _centre(self, p: np.ndarray) -> np.ndarray | None:
        """A body centre with hole i within [r_in, r_out] of shoulder i (heading 0 offsets ignored)."""
        rng = self.rng
        k = int(np.argmin(self.r_out))
        for _ in range(200):
            ang, rad = rng.uniform(0, 2 * math.pi), self.r_out[k] * math.sqrt(rng.uniform())
            c = p[k] + rad * np.array([math.cos(ang), math.sin(ang)])
            d = np.linalg.norm(p - c, axis=1)
            if np.all(d <= self.r_out) and np.all(d >= self.r_in):
                return c
        return None

    def _read(self, holes: Sequence[int], moved: int | None) -> Grip | None:
        p = self.holes.xy[list(holes)]
        c = self._centre(p)
        if c is None:
            return None
        heading = self.rng.uniform(-math.pi, math.pi)
        branch = self.rng.choice([-1, 1], size=3)
        q = inverse_program(p, c, heading, self.geom, branch)
        qm = q + self.rng.normal(0.0, self.sigma, q.shape) if self.sigma > 0 else q.copy()
        if self.quantum > 0:
            qm = np.round(qm / self.quantum) * self.quantum
        return Grip(tuple(int(v) for v in holes), np.array([c[0], c[1], heading]), q, qm, moved)  # type: ignore[arg-type]

    def grip(self) -> Grip:
        """A random stance anywhere on the wall."""
        tri = self.index.triangles
        while True:
            t = tri[self.rng.integers(len(tri))][self.rng.permutation(3)]
            g = self._read(t, None)
            if g is not None:
                return g

    def step(self, grip: Grip) -> Grip:
        """One climbing move: one arm lets go and grips another hole, the body re-centres."""
        rng = self.rng
        for arm in rng.permutation(3):
            kept = [grip.holes[i] for i in range(3) if i != arm]
            near = self.holes.within(self.holes.xy[kept[0]], 2 * float(self.r_out.max()))
            near = [int(j) for j in rng.permutation(near) if j not in grip.holes]
            for j in near:
                holes = list(grip.holes)
                holes[arm] = j
                g = self._read(holes, int(arm) + 1)
                if g is not None:
                    return g
        return self.grip()

    def walk(self, n: int) -> list[Grip]:
        """A lost start: a random stance and ``n - 1`` moves."""
        out = [self.grip()]
        while len(out) < n:
            out.append(self.step(out[-1]))
        return out


def _outcome(attempt: Callable[[], Fix], truth: tuple[int, int, int]) -> str:
    """Classify one localisation attempt: correct, wrong (unique but wrong), ambiguous or none."""
    try:
        return "correct" if attempt().holes == truth else "wrong"
    except AmbiguousFixError:
        return "ambiguous"
    except NoFixError:
        return "none"


def sensor_study(
    holes: HoleMap,
    sigmas_rad: Sequence[float],
    geom: ClimberGeometry | None = None,
    trials: int = 2000,
    walks: int = 100,
    max_grips: int = 10,
    map_sigma: float = 0.01,
    quantum: float = 0.0,
    seed: int = 0,
    progress: Callable[[int], None] | None = None,
) -> list[dict[str, float]]:
    """What encoders does the robot need on this wall? Simulated grips per noise level.

    For every ``sigma`` (rad): ``trials`` random grips localised globally, classified as
    correct (unique and right), ambiguous, none, or wrong (unique but wrong); how often the
    gate keeps the true holes; the centre error at the true holes (median, p99, cm); global
    and tracking times; and ``walks`` lost starts (random climbing walks, a Bayes filter
    over hypotheses) - grips needed until one hypothesis holds 0.999 (median, and the share
    localised correctly within 3 grips), plus tracking along the walks (correct / wrong).
    ``progress`` is called with the number of finished units (grips and walks).
    """
    import time

    g = geom or ClimberGeometry()
    index = TriangleIndex(holes, g)
    rows = []
    for k, sigma in enumerate(sigmas_rad):
        noise = NoiseModel(sigma_angle=float(sigma), sigma_map=map_sigma)
        loc = Localizer(holes, g, noise, index)
        sim = GripSimulator(index, g, float(sigma), quantum=quantum, seed=seed + 1000 * k)
        counts = {"correct": 0, "ambiguous": 0, "none": 0, "wrong": 0}
        kept, err, t_global = 0, [], []
        for _ in range(trials):
            grip = sim.grip()
            t0 = time.perf_counter()
            counts[_outcome(lambda g=grip, lc=loc: lc.localize(g.q_measured), grip.holes)] += 1
            t_global.append(time.perf_counter() - t0)
            hx, hy, _, w = loc.measure(grip.q_measured)
            v = grip.holes
            x, y, _, chi2, _ = _fit_one(loc.holes.xy[list(v), 0].tolist(), loc.holes.xy[list(v), 1].tolist(), hx, hy, w)
            kept += chi2 <= loc.noise.chi2_limit
            err.append(math.hypot(x - grip.pose[0], y - grip.pose[1]))
            if progress:
                progress(1)
        bayes = BayesLocalizer(loc)
        needed, within3, walk_wrong = [], 0, 0
        track = {"correct": 0, "ambiguous": 0, "none": 0, "wrong": 0}
        t_track = []
        for _ in range(walks):
            bayes.reset()
            path = sim.walk(max_grips)
            done = None
            for n, grip in enumerate(path, start=1):
                fix = bayes.observe(grip.q_measured, grip.moved_arm)
                if fix is not None and done is None:
                    done = n
                    walk_wrong += fix.holes != grip.holes
                    within3 += n <= 3 and fix.holes == grip.holes
                if n > 1:
                    t0 = time.perf_counter()
                    prev = path[n - 2].holes
                    track[_outcome(lambda g=grip, h=prev, lc=loc: lc.track(h, g.q_measured, g.moved_arm),
                                   grip.holes)] += 1
                    t_track.append(time.perf_counter() - t0)
            needed.append(done if done is not None else math.inf)
            if progress:
                progress(1)
        n_track = max(1, sum(track.values()))
        rows.append({
            "sigma_deg": math.degrees(float(sigma)),
            "grips": trials,
            "correct": counts["correct"] / trials,
            "ambiguous": counts["ambiguous"] / trials,
            "none": counts["none"] / trials,
            "wrong": counts["wrong"] / trials,
            "true_kept": kept / trials,
            "centre_err_median_cm": float(np.median(err)),
            "centre_err_p99_cm": float(np.percentile(err, 99)),
            "global_us_median": float(np.median(t_global) * 1e6),
            "walks": walks,
            "grips_needed_median": float(np.median(needed)),
            "lost_within_3": within3 / max(1, walks),
            "lost_wrong": walk_wrong / max(1, walks),
            "track_correct": track["correct"] / n_track,
            "track_wrong": track["wrong"] / n_track,
            "track_us_median": float(np.median(t_track) * 1e6) if t_track else float("nan"),
        })
    return rows
