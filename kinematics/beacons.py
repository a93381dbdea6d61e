"""Beacon localisation of a mobile robot (seed 001, section 3), and a particle filter to compare.

The robot measures the distance (and, optionally, the bearing) to each of a set of beacons
with Gaussian noise (:class:`BeaconModel`). Seed 001 localises it by placing an "ideal"
robot at every point of a square grid around a guess and keeping the point whose ideal
measurements differ least from the real ones (its ``measurement_prob``, an error despite the
name: the root of the summed squared differences). Here that search is

* :func:`grid_search_loop` - the seed's double loop, kept as the readable reference;
* :func:`grid_search` - the same grid, the same error and the same best point (first in the
  seed's scan order on ties), evaluated for the whole grid at once with numpy;
* :func:`coarse_to_fine` - a coarse grid, then finer grids around its best point, down to the
  seed's step (an answer within one step of :func:`grid_search`'s, for a fraction of the cost);
* :class:`ParticleFilter` - the standard alternative, for comparison (``bench/bench_beacons.py``).

Every estimator returns an :class:`Estimate` (pose, error, evaluations, and the error image
over the window where there is one). Positions in metres as in the seed (any unit works),
angles in radians. Departures from the seed: the heading of the estimate is the robot's own
belief, never the true one (the seed set the ideal robot to ``real.orientacion`` after the
search - the truth it cannot know); ranges-only measurements do not see the heading at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InvalidInputError, as_array

__all__ = ["BeaconModel", "Estimate", "grid_search", "grid_search_loop", "coarse_to_fine", "ParticleFilter"]


@dataclass(frozen=True)
class BeaconModel:
    """Beacons ``(B, 2)`` and what the robot measures of them: ranges and/or bearings (relative
    to its heading) with Gaussian noise ``sigma_range`` (m) and ``sigma_bearing`` (rad)."""

    beacons: np.ndarray
    ranges: bool = True
    bearings: bool = False
    sigma_range: float = 0.1
    sigma_bearing: float = math.radians(2.0)

    def __post_init__(self) -> None:
        b = as_array("beacons", self.beacons, (2,))
        if b.ndim != 2 or len(b) == 0:
            raise InvalidInputError(f"beacons has shape {b.shape}; expected (B, 2) with B >= 1 beacons")
        object.__setattr__(self, "beacons", b)
        if not (self.ranges or self.bearings):
            raise InvalidInputError("a BeaconModel measures ranges, bearings or both; got neither")
        for name in ("sigma_range", "sigma_bearing"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InvalidInputError(f"{name}={v!r}; expected a finite value >= 0")

    @property
    def size(self) -> int:
        """Numbers per measurement."""
        return len(self.beacons) * (int(self.ranges) + int(self.bearings))

    def measure(self, pose: object) -> np.ndarray:
        """Noise-free measurements of poses ``(..., 3)``: ``(..., size)`` (ranges, then bearings)."""
        p = as_array("pose", pose, (3,))
        d = self.beacons - p[..., None, :2]
        out = []
        if self.ranges:
            out.append(np.hypot(d[..., 0], d[..., 1]))
        if self.bearings:
            out.append(_wrap(np.arctan2(d[..., 1], d[..., 0]) - p[..., 2:3]))
        return np.concatenate(out, axis=-1)

    def sample(self, pose: object, rng: np.random.Generator) -> np.ndarray:
        """A noisy measurement of one pose (what the real robot's sensors return)."""
        z = self.measure(pose)
        sig = np.concatenate([np.full(len(self.beacons), self.sigma_range)] * self.ranges
                             + [np.full(len(self.beacons), self.sigma_bearing)] * self.bearings)
        return z + rng.normal(0.0, 1.0, z.shape) * sig

    def error(self, pose: object, z: object) -> np.ndarray:
        """The seed's ``measurement_prob``: ``sqrt(sum((h(pose) - z)^2))`` per pose, ``(...,)``
        (bearing differences wrapped to (-pi, pi])."""
        zz = as_array("z", z, (self.size,))
        diff = self.measure(pose) - zz
        if self.bearings:
            nb = len(self.beacons)
            diff[..., -nb:] = _wrap(diff[..., -nb:])
        return np.sqrt(np.sum(diff * diff, axis=-1))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


@dataclass
class Estimate:
    """A localisation: ``pose (x, y, heading)``, the measurement error there, how many ideal
    robots were compared, the method, and - for grid searches - the error image over the
    window (rows from the bottom, ``y`` up) with its ``extent (x0, x1, y0, y1)``."""

    pose: np.ndarray
    error: float
    evaluations: int
    method: str
    image: np.ndarray | None = None
    extent: tuple[float, float, float, float] | None = None
    steps: list[float] = field(default_factory=list)


def _check_window(centre: object, radius: float, step: float) -> np.ndarray:
    c = as_array("centre", centre, (2,))
    if c.shape != (2,):
        raise InvalidInputError(f"centre has shape {c.shape}; expected (2,)")
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius > 0):
        raise InvalidInputError(f"radius={radius!r}; expected a window half-size > 0")
    if not (isinstance(step, (int, float)) and math.isfinite(step) and 0 < step <= radius):
        raise InvalidInputError(f"step={step!r}; expected 0 < step <= radius ({radius!r})")
    if (2 * radius / step) ** 2 > 25_000_000:
        raise InvalidInputError(f"a {2 * radius:g} wide window at step {step:g} is {(2 * radius / step) ** 2:.3g} "
                                "points; use coarse_to_fine or a larger step (at most 25 million)")
    return c


def grid_search_loop(model: BeaconModel, z: object, centre: object, radius: float, step: float = 0.05,
                     heading: float = 0.0) -> Estimate:
    """Seed 001's ``localizacion``: every grid point in turn, keeping the first smallest error."""
    c = _check_window(centre, radius, step)
    offsets = np.arange(-radius, radius, step)
    image, best, best_err = [], None, math.inf
    for i in offsets:
        row = []
        for j in offsets:
            x, y = c[0] + j, c[1] + i
            e = float(model.error([x, y, heading], z))
            row.append(e)
            if e < best_err:
                best_err, best = e, (x, y)
        image.append(row)
    ext = (c[0] - radius, c[0] + radius, c[1] - radius, c[1] + radius)
    return Estimate(np.array([best[0], best[1], heading]), best_err, len(offsets) ** 2, "grid loop",  # type: ignore[index]
                    np.array(image), ext, [step])


def grid_search(model: BeaconModel, z: object, centre: object, radius: float, step: float = 0.05,
                heading: float = 0.0, image: bool = True) -> Estimate:
    """:func:`grid_search_loop` for the whole grid at once: the same points, errors and best point."""
    c = _check_window(centre, radius, step)
    offsets = np.arange(-radius, radius, step)
    xs, ys = c[0] + offsets, c[1] + offsets
    zz = as_array("z", z, (model.size,))
    # ranges: |b - p|^2 expanded, one (n, B) block per axis, summed without a (n, n, B) cube
    err2 = np.zeros((len(ys), len(xs)))
    if model.ranges:
        nb = len(model.beacons)
        dx = model.beacons[:, 0][None, :] - xs[:, None]  # (nx, B)
        dy = model.beacons[:, 1][None, :] - ys[:, None]  # (ny, B)
        for k in range(nb):
            r = np.hypot(dy[:, k][:, None], dx[:, k][None, :])
            d = r - zz[k]
            err2 += d * d
    if model.bearings:
        nb = len(model.beacons)
        off = nb if model.ranges else 0
        for k in range(nb):
            a = np.arctan2((model.beacons[k, 1] - ys)[:, None], (model.beacons[k, 0] - xs)[None, :]) - heading
            d = _wrap(a - zz[off + k])
            err2 += d * d
    err = np.sqrt(err2)
    k = int(np.argmin(err))  # first in row-major order = the seed's scan order
    iy, ix = divmod(k, len(xs))
    ext = (c[0] - radius, c[0] + radius, c[1] - radius, c[1] + radius)
    return Estimate(np.array([xs[ix], ys[iy], heading]), float(err[iy, ix]), err.size, "grid",
                    err if image else None, ext, [step])


def coarse_to_fine(model: BeaconModel, z: object, centre: object, radius: float, step: float = 0.05,
                   heading: float = 0.0, factor: int = 8) -> Estimate:
    """A grid ``factor`` times coarser than ``step`` over the window, then windows of two coarse
    steps around the best point at ``factor`` times finer steps, down to ``step``; the error
    image is the coarse one."""
    if not (isinstance(factor, int) and factor >= 2):
        raise InvalidInputError(f"factor={factor!r}; expected an integer >= 2")
    c = _check_window(centre, radius, step)
    s = step
    while s * factor <= radius:
        s *= factor
    first = grid_search(model, z, c, radius, s, heading)
    best, evals, steps = first, first.evaluations, [s]
    while s > step * (1 + 1e-9):
        fine = max(step, s / factor)
        best = grid_search(model, z, best.pose[:2], 2 * s, fine, heading, image=False)
        evals += best.evaluations
        steps.append(fine)
        s = fine
    return Estimate(best.pose, best.error, evals, "coarse-to-fine", first.image, first.extent, steps)


class ParticleFilter:
    """A particle filter over ``(x, y)`` (the heading is the robot's belief, as for the grid):
    particles drawn in a window, weighted by ``exp(-error^2 / (2 s^2))`` with ``s`` the noise of
    one measurement, resampled systematically and jittered; ``predict`` moves them with
    odometry and its noise. Seeded: the same ``rng`` state gives the same estimate."""

    def __init__(self, model: BeaconModel, n: int = 2000, rng: np.random.Generator | None = None) -> None:
        if not (isinstance(n, int) and n >= 10):
            raise InvalidInputError(f"n={n!r}; expected at least 10 particles")
        self.model, self.n = model, n
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.particles = np.zeros((n, 2))
        self.heading = 0.0

    def reset(self, centre: object, radius: float, heading: float = 0.0) -> None:
        c = _check_window(centre, radius, radius)
        self.particles = c + self.rng.uniform(-radius, radius, (self.n, 2))
        self.heading = float(heading)

    def predict(self, dx: float, dy: float, dtheta: float = 0.0, noise: float = 0.0) -> None:
        self.particles += np.array([dx, dy]) + self.rng.normal(0.0, noise, self.particles.shape) * (noise > 0)
        self.heading += dtheta

    def update(self, z: object, jitter: float) -> Estimate:
        poses = np.column_stack([self.particles, np.full(self.n, self.heading)])
        err = self.model.error(poses, z)
        s = max(self.model.sigma_range if self.model.ranges else self.model.sigma_bearing, 1e-9)
        w = np.exp(-0.5 * (err * err - float(np.min(err * err))) / (s * s * self.model.size))
        w /= w.sum()
        est = w @ self.particles
        # systematic resampling, then a jitter that keeps the cloud from collapsing
        u = (self.rng.random() + np.arange(self.n)) / self.n
        idx = np.minimum(np.searchsorted(np.cumsum(w), u), self.n - 1)
        self.particles = self.particles[idx] + self.rng.normal(0.0, jitter, (self.n, 2))
        pose = np.array([est[0], est[1], self.heading])
        return Estimate(pose, float(self.model.error(pose, z)), self.n, "particle filter")

    def localize(self, z: object, centre: object, radius: float, heading: float = 0.0, rounds: int = 8) -> Estimate:
        """A global fix of one measurement: particles over the window, ``rounds`` updates with a
        shrinking jitter (from a tenth of the window to the range noise)."""
        self.reset(centre, radius, heading)
        est = None
        for k in range(rounds):
            jitter = max(self.model.sigma_range * 0.5, 0.2 * radius * 0.5 ** k)
            est = self.update(z, jitter)
        est.evaluations = self.n * rounds  # type: ignore[union-attr]
        return est  # type: ignore[return-value]
