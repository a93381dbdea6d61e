"""Seed 001's mobile robot: holonomic or tricycle motion, the target-following controller, odometry
noise and relocalisation from beacons.

Two robots run side by side as in the seed: the *ideal* one is what the robot believes
(odometry without noise), the *real* one moves with the same commands plus noise. The
controller steers the ideal robot to each target in turn: turn rate ``w`` = the bearing to
the target relative to the heading, clipped to ``+-w_max``; speed ``v`` = the distance,
clipped to ``[0, v_max]`` (both per step); with ``turn_in_place`` the robot turns standing
while ``|w| > 0.01``. Motion models:

* ``holonomic`` (the seed's ``move(turn, forward)``): turn by ``w``, then drive ``v`` along
  the new heading;
* ``tricycle`` (the seed's ``move_triciclo(turn, forward, length)``): a steered front wheel
  ``length`` ahead of the rear axle, steering angle ``w``; the heading turns by
  ``v sin(w) / length`` while the body moves ``v cos(w)``.

The real robot adds Gaussian noise to each step's turn and distance (``turn_noise`` rad,
``forward_noise`` as a share of the distance). Whenever the real robot's measurement differs
from what the ideal one would measure by more than ``threshold``, the robot relocalises: a
grid search (:func:`~kinegym.kinematics.beacons.grid_search`) in a window of ``reloc_radius``
around its belief (the seed: 5 at the start, 0.2 when relocalising, step 0.05), and the
ideal robot jumps there - keeping its own heading (the seed copied the real robot's).

Departures from the seed's script, whose indentation breaks it: once a target lies inside the
tricycle's tightest turning circle, it drives straight until the target is a turning diameter
away (the seed's controller circled such a target until the step limit: 1 run in 100 of the
seed001 scene, 2 in 1,000 with this rule); it ran the tricycle model in
holonomic mode and did not move at all otherwise, used the target points as beacons, and
added the path length and time outside the loop. Here each mode runs its own model, the
beacons are their own list, and the trajectories record every step.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from kinegym.configs import Flag, Matrix, Number, Spec, Text, Vector, load

from .beacons import BeaconModel, Estimate, grid_search
from .errors import InvalidInputError, as_array

__all__ = ["MotionModel", "FollowResult", "Scene", "follow", "load_scene", "noise_threshold", "step_pose", "steer"]


@dataclass(frozen=True)
class MotionModel:
    """How the robot moves: ``kind`` ``"holonomic"`` or ``"tricycle"`` (steering ``length``),
    per-step limits ``v_max`` and ``w_max`` (rad), ``turn_in_place``, and the real robot's noise."""

    kind: str = "holonomic"
    length: float = 0.2
    v_max: float = 0.07
    w_max: float = math.radians(14.0)
    turn_in_place: bool = False
    forward_noise: float = 0.01
    turn_noise: float = 0.01

    def __post_init__(self) -> None:
        if self.kind not in ("holonomic", "tricycle"):
            raise InvalidInputError(f"kind={self.kind!r}; expected 'holonomic' or 'tricycle'")
        for name, lo, hi in (("length", 1e-3, 1e3), ("v_max", 1e-6, 1e3), ("w_max", 1e-6, math.pi / 2 - 1e-6)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise InvalidInputError(f"{name}={v!r}; expected a value in {lo:g}..{hi:g}")
        for name in ("forward_noise", "turn_noise"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InvalidInputError(f"{name}={v!r}; expected a finite value >= 0")


def noise_threshold(model: BeaconModel, quantile: float = 0.99) -> float:
    """The measurement error that noise alone stays under with probability ``quantile`` when the
    belief is exact: ``sigma * sqrt(chi2_quantile(size))`` (Wilson-Hilferty's chi-square
    quantile; ranges and bearings weighted by their own noise through the larger of the two).

    The seed relocalised whenever the error exceeded ``EPSILON = 0.1``; with range noise 0.1 on
    four beacons the error of an *exact* belief is ~0.2, so the seed relocalised at nearly
    every step. This threshold only fires when the belief has drifted."""
    if not (isinstance(quantile, float) and 0.5 <= quantile < 1.0):
        raise InvalidInputError(f"quantile={quantile!r}; expected 0.5 <= quantile < 1")
    sig = max(model.sigma_range if model.ranges else 0.0, model.sigma_bearing if model.bearings else 0.0)
    if sig == 0:
        raise InvalidInputError("a noise-free BeaconModel has no noise threshold; give the threshold yourself")
    k = model.size
    # the standard normal quantile by bisection on erf (no scipy)
    lo, hi = 0.0, 10.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if 0.5 * (1 + math.erf(mid / math.sqrt(2))) < quantile else (lo, mid)
    z = 0.5 * (lo + hi)
    chi2 = k * (1 - 2 / (9 * k) + z * math.sqrt(2 / (9 * k))) ** 3
    return sig * math.sqrt(chi2)


def step_pose(pose: Sequence[float], w: float, v: float, motion: MotionModel) -> np.ndarray:
    """One step of the motion model from ``pose (x, y, heading)`` with command ``(w, v)``."""
    x, y, th = (float(p) for p in pose)
    if motion.kind == "holonomic":
        th += w
        x, y = x + v * math.cos(th), y + v * math.sin(th)
    else:
        th += v * math.sin(w) / motion.length
        x, y = x + v * math.cos(w) * math.cos(th), y + v * math.cos(w) * math.sin(th)
    return np.array([x, y, math.remainder(th, 2 * math.pi)])


def steer(pose: Sequence[float], target: Sequence[float], motion: MotionModel) -> tuple[float, float]:
    """The seed's controller: ``(w, v)`` toward ``target`` within the limits."""
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    w = max(-motion.w_max, min(motion.w_max, math.remainder(math.atan2(dy, dx) - pose[2], 2 * math.pi)))
    v = max(0.0, min(motion.v_max, math.hypot(dx, dy)))
    if motion.turn_in_place and abs(w) > 0.01:
        v = 0.0
    return w, v


@dataclass
class FollowResult:
    """Both trajectories ``(steps + 1, 3)``, the targets reached, every relocalisation (step and
    estimate), the first (global) fix, and the path error: per step the distance between the
    ideal and the real robot."""

    ideal: np.ndarray
    real: np.ndarray
    reached: int
    relocalisations: list[tuple[int, Estimate]]
    first_fix: Estimate
    path_error: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def max_path_error(self) -> float:
        return float(self.path_error.max()) if len(self.path_error) else 0.0

    @property
    def mean_path_error(self) -> float:
        return float(self.path_error.mean()) if len(self.path_error) else 0.0


def follow(model: BeaconModel, targets: object, start: Sequence[float], motion: MotionModel | None = None,
           rng: np.random.Generator | None = None, epsilon: float = 0.1, threshold: float | None = None,
           start_radius: float = 5.0, reloc_radius: float = 0.2, step: float = 0.05, max_steps: int = 1000,
           on_step: Callable[[np.ndarray, np.ndarray], None] | None = None) -> FollowResult:
    """Seed 001's experiment: localise globally (a window of ``start_radius`` around ``start``),
    then steer to each target until the ideal robot is within ``epsilon`` of it (at most
    ``max_steps`` steps in all), relocalising whenever the measurement error exceeds
    ``threshold`` (default ``epsilon``, as the seed)."""
    motion = motion or MotionModel()
    rng = rng if rng is not None else np.random.default_rng(0)
    tg = as_array("targets", targets, (2,))
    if tg.ndim != 2 or len(tg) == 0:
        raise InvalidInputError(f"targets has shape {tg.shape}; expected (N, 2) with N >= 1 points")
    limit = epsilon if threshold is None else threshold
    if not (math.isfinite(limit) and limit > 0 and math.isfinite(epsilon) and epsilon > 0):
        raise InvalidInputError(f"epsilon={epsilon!r}, threshold={threshold!r}; expected values > 0")
    real = np.asarray(start, float).copy()
    # the robot starts lost: a global fix from a guess at the window's centre
    first = grid_search(model, model.sample(real, rng), real[:2], start_radius, step, heading=float(real[2]))
    ideal = first.pose.copy()
    tray_i, tray_r, relocs, reached = [ideal.copy()], [real.copy()], [], 0
    escaping = False
    for target in tg:
        while math.dist(ideal[:2], target) > epsilon and len(tray_i) <= max_steps:
            w, v = steer(ideal, target, motion)
            if motion.kind == "tricycle":
                # the seed's controller circles a target inside the tightest turning circle for
                # ever: drive straight away until the target is a turning diameter off, then turn
                d = math.dist(ideal[:2], target)
                bearing = math.atan2(target[1] - ideal[1], target[0] - ideal[0])
                alpha = math.remainder(bearing - ideal[2], 2 * math.pi)
                r_min = motion.length / math.tan(motion.w_max)
                if d < 2 * r_min * abs(math.sin(alpha)):
                    escaping = True
                if escaping and d < 2 * r_min:
                    w = 0.0
                else:
                    escaping = False
            ideal = step_pose(ideal, w, v, motion)
            noisy_w = w + rng.normal(0.0, motion.turn_noise) if motion.turn_noise else w
            noisy_v = v * (1.0 + rng.normal(0.0, motion.forward_noise)) if motion.forward_noise else v
            real = step_pose(real, noisy_w, noisy_v, motion)
            z = model.sample(real, rng)
            if float(model.error(ideal, z)) > limit:  # the seed's relocalisation rule
                est = grid_search(model, z, ideal[:2], reloc_radius, step, heading=float(ideal[2]), image=False)
                ideal = est.pose.copy()
                relocs.append((len(tray_i), est))
            tray_i.append(ideal.copy())
            tray_r.append(real.copy())
            if on_step is not None:
                on_step(ideal, real)
        if math.dist(ideal[:2], target) <= epsilon:
            reached += 1
    ti, tr = np.array(tray_i), np.array(tray_r)
    return FollowResult(ti, tr, reached, relocs, first, np.hypot(*(ti[:, :2] - tr[:, :2]).T))


#: A scene file's keys (``configs/beacons/*.yaml``); positions in the seed's units (m).
SCENE_SCHEMA: dict[str, Spec] = {
    "name": Text(doc="scene name"),
    "description": Text(default=""),
    "beacons": Matrix(cols=2, default=None, doc="beacon positions (x, y); default: the targets, as the seed"),
    "targets": Matrix(cols=2, doc="points to visit in order (x, y)"),
    "start": Vector(length=3, doc="the real robot's start: x, y, heading_deg"),
    "sigma_range": Number(default=0.1, lo=0.0, doc="range noise (std)"),
    "sigma_bearing_deg": Number(default=2.0, lo=0.0, doc="bearing noise (std, deg)"),
    "bearings": Flag(default=False, doc="also measure bearings"),
}


@dataclass(frozen=True)
class Scene:
    """Beacons, targets and the start pose of one following experiment."""

    name: str
    model: BeaconModel
    targets: np.ndarray
    start: np.ndarray

    @classmethod
    def from_config(cls, name_or_path: str) -> Scene:
        return load_scene(name_or_path)


def load_scene(name_or_path: str) -> Scene:
    """A built-in scene (``"seed001"``) or a YAML path, validated (:class:`~kinegym.configs.ConfigError`)."""
    d = load("beacons", name_or_path, SCENE_SCHEMA)
    where = f"{name_or_path}"
    if not d["targets"]:
        raise InvalidInputError(f"{where}: targets is empty; expected at least one (x, y)")
    beacons = d["targets"] if d["beacons"] is None else d["beacons"]
    if not beacons:
        raise InvalidInputError(f"{where}: beacons is empty; expected at least one (x, y)")
    model = BeaconModel(np.array(beacons, float), bearings=d["bearings"], sigma_range=d["sigma_range"],
                        sigma_bearing=math.radians(d["sigma_bearing_deg"]))
    x, y, hdeg = d["start"]
    return Scene(d["name"], model, np.array(d["targets"], float), np.array([x, y, math.radians(hdeg)]))
