"""The robot half of HoleClimb-v0: the climber as it knows itself.

:class:`ClimbRobot` joins a simulation (:class:`~kinegym.envs.sim.climber.KinematicClimber`
or the pymunk :class:`~kinegym.envs.sim.climber.PhysicsClimber`), its six noisy encoders and
the localiser (:class:`~kinegym.kinematics.localization.Localizer`, tracking after every
move) into the robot's belief: which holes it holds and where its body is. From that belief
it offers its moves - the task's candidate holes, each masked by its own gait model
(:func:`~kinegym.envs.sim.gait.plan_move`, judged many at once by
:func:`~kinegym.envs.sim.gait_kernel.feasible_moves`). It never sees its true pose; the env reads that
from ``sim`` only for the reward and the pictures.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kinegym.envs.climb_task import candidate_holes
from kinegym.envs.sim.climber import KinematicClimber, PhysicsClimber
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait_kernel import feasible_moves
from kinegym.kinematics.holes import HoleMap
from kinegym.kinematics.localization import Localizer
from kinegym.kinematics.pose_fit import AmbiguousFixError, Fix, NoFixError, NoiseModel

__all__ = ["ClimbRobot"]


class ClimbRobot:
    """Simulation + encoders + localiser -> believed stance (``est_holes``) and pose estimate (``fix``)."""

    def __init__(self, model: ClimberModel, mode: str) -> None:
        if mode not in ("kinematic", "physics"):
            raise ValueError(f"mode={mode!r}; expected 'kinematic' or 'physics'")
        self.model, self.mode = model, mode
        self.sim = self.new_sim()
        self._localizers: dict[int, Localizer] = {}
        self.fix: Fix | None = None
        self.est_holes: tuple[int, int, int] = (0, 1, 2)

    def new_sim(self) -> KinematicClimber | PhysicsClimber:
        """A fresh simulation of the robot (pymunk spaces are rebuilt, never copied)."""
        return KinematicClimber(self.model) if self.mode == "kinematic" else PhysicsClimber(self.model)

    def reset(self, holes: HoleMap, start: tuple[int, int, int], rng: np.random.Generator) -> None:
        """Hang the robot on ``start`` (an operator tells it where: from then on it knows only
        what tracking its encoders says) and take the first reading."""
        self.sim.reset(holes, start)
        self.loc = self._localizer(holes)
        self.fix = None
        self.est_holes = (int(start[0]), int(start[1]), int(start[2]))
        self.relocalise(None, rng)

    def move(self, arm: int, hole: int, offered: bool = False) -> tuple[str, str]:
        """Move ``arm`` (0..2) to ``hole`` (map row); the outcome and its reason. ``offered``:
        :meth:`options` offered the move from the believed stance; when that is the true one
        the kinematic climber need not judge it again."""
        if offered and self.mode == "kinematic" and self.est_holes == self.sim.stance:
            res = self.sim.move(arm, hole, judged=True)  # type: ignore[call-arg]
        else:
            res = self.sim.move(arm, hole)
        return res.outcome, res.reason

    def relocalise(self, moved_arm: int | None, rng: np.random.Generator, hole: int | None = None) -> None:
        """Read the encoders and track the fix (the robot's own view of its pose).

        ``moved_arm`` (1..3) moved and gripped map row ``hole``. When the reading fails the
        tracking gate (a noisy reading: once in the 12,904 moves of 800 planner climbs), the robot still knows
        which hole its gripper closed on, so the pose is fitted on that stance, and if that
        fails too the stance is believed without a pose (before, it kept believing the old
        hole and judged every later move from a stance it had left)."""
        q = self.sim.encoders(rng)
        prev = self.est_holes
        expected = prev
        if moved_arm is not None and hole is not None:
            held = list(prev)
            held[moved_arm - 1] = int(hole)
            expected = (held[0], held[1], held[2])
        try:
            self.fix = self.loc.track(prev, q, moved_arm)
        except (NoFixError, AmbiguousFixError):
            try:
                self.fix = self.loc.track(expected, q, None) if moved_arm is not None else self.loc.localize(q)
            except (NoFixError, AmbiguousFixError):
                self.fix = None  # lost: believe the stance it knows of, report a large uncertainty
        self.est_holes = self.fix.holes if self.fix is not None else expected

    def est_pose(self) -> np.ndarray:
        """The estimated body pose ``(x, y, heading)``; the centroid of the believed holes when lost."""
        if self.fix is not None:
            return self.fix.pose.copy()
        xy = self.sim.holes.xy[list(self.est_holes)]
        return np.array([xy[:, 0].mean(), xy[:, 1].mean(), 0.0])

    def options(self, k: int, reach: float, cache: dict[Any, tuple[list[int], np.ndarray]]
                ) -> tuple[list[int], np.ndarray]:
        """The ``k`` holes nearest the believed stance (-1 where there are fewer) and which arm
        may go to each (``(3 k,)`` mask, the robot's own gait model judged on its belief);
        memoised per stance in ``cache`` (the task keeps one per wall)."""
        stance = self.est_holes
        got = cache.get(stance)
        if got is None:
            holes = self.sim.holes
            near = candidate_holes(holes, stance, k, 2.0 * reach)
            cand = (near + [-1] * k)[:k]
            targets = np.array(cand * 3)
            arms = np.repeat(np.arange(3), k)
            mask = np.zeros(3 * k, dtype=bool)
            real = targets >= 0
            mask[real] = feasible_moves(self.model, holes, stance, arms[real], targets[real])
            got = cache[stance] = (cand, mask)
        return list(got[0]), got[1].copy()

    def _localizer(self, holes: HoleMap) -> Localizer:
        key = id(holes)
        loc = self._localizers.get(key)
        if loc is None or loc.holes is not holes:
            step = math.radians(self.model.phys.encoder_step_deg)
            sigma = math.hypot(self.model.geom.sensor_sigma, step / math.sqrt(12.0))
            loc = Localizer(holes, self.model.geom, NoiseModel(sigma_angle=max(sigma, 1e-4), sigma_map=0.01))
            self._localizers = {key: loc}
        return loc
