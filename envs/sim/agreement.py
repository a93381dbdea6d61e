"""Does the climber's gait model agree with its physics? Random moves judged by both.

:func:`agreement` walks the robot over generated walls (the HoleClimb-v0 defaults) with
moves the gait model accepts, and at every stance it passes tries one random move that the
robot's geometry allows (not ``unreachable``: a body pose reaches all four holes) in a fresh
pymunk :class:`~kinegym.envs.sim.climber.PhysicsClimber` hung on that stance. Each tried
move lands in one cell of the confusion matrix (the kinematic model says ok / not, physics
succeeds / not), with the model's reason and the phase of the gait physics failed in
(:data:`~kinegym.envs.sim.gait.PHASES`). ``kinematic ok, physics fails`` is the costly cell:
a plan the model proves fails on the robot.

``bench/bench_climber.py`` runs it on 2,000 moves; ``tests/test_climber_agreement.py`` on a
few hundred.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from kinegym.envs.climb_task import WALL_DEFAULTS, candidate_holes, start_stances
from kinegym.envs.sim.climber import PhysicsClimber
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move
from kinegym.kinematics.holes import HoleMap

__all__ = ["Agreement", "agreement"]


@dataclass
class Agreement:
    """Counts of tried moves: ``cells[(kinematic_ok, physics_ok)]``; ``kin_no`` counts the
    model's reasons against the moves physics then made or failed; ``phys_fail`` counts
    ``(outcome, phase)`` of physics failures the model had accepted; ``falls`` lists the
    reasons of every fall."""

    cells: Counter = field(default_factory=Counter)
    kin_no: Counter = field(default_factory=Counter)  # (model's outcome, physics ok) -> n
    phys_fail: Counter = field(default_factory=Counter)  # (outcome, phase) -> n, model said ok
    falls: list[str] = field(default_factory=list)

    @property
    def moves(self) -> int:
        return sum(self.cells.values())

    @property
    def rate(self) -> float:
        """Share of moves on which the two agree."""
        return (self.cells[True, True] + self.cells[False, False]) / max(self.moves, 1)

    @property
    def false_ok(self) -> float:
        """Share of moves the model accepted that physics failed ("kinematic ok, physics fails")."""
        return self.cells[True, False] / max(self.moves, 1)

    def table(self) -> str:
        """The confusion matrix and its breakdown as Markdown."""
        c, n = self.cells, max(self.moves, 1)
        out = ["| | physics ok | physics fails |", "|---|---|---|",
               f"| **kinematic ok** | {c[True, True]} | {c[True, False]} ({100 * c[True, False] / n:.2f} %) |",
               f"| **kinematic no** | {c[False, True]} | {c[False, False]} |", "",
               f"{self.moves} moves, agreement {100 * self.rate:.2f} %."]
        for (outcome, phase), k in sorted(self.phys_fail.items()):
            out.append(f"- model ok, physics `{outcome}` in the `{phase}`: {k}")
        for (reason, ok), k in sorted(self.kin_no.items()):
            out.append(f"- model `{reason}`, physics {'ok' if ok else 'fails'}: {k}")
        for why, k in sorted(Counter(why.split(": ", 1)[0] for why in self.falls).items()):
            out.append(f"- falls, {why}: {k}")
        return "\n".join(out)


def _wall(rng: np.random.Generator) -> HoleMap:
    d = WALL_DEFAULTS
    cols, rows = int(rng.integers(d["cols"][0], d["cols"][1] + 1)), int(rng.integers(d["rows"][0], d["rows"][1] + 1))
    return HoleMap.grid(cols, rows, d["spacing_cm"], d["jitter_cm"], d["missing"], seed=int(rng.integers(2**31)),
                        name=f"generated {cols}x{rows}")


def agreement(model: ClimberModel | None = None, moves: int = 2000, seed: int = 0, walk: int = 30,
              candidates: int = 8, progress: Callable[[int], None] | None = None) -> Agreement:
    """Try ``moves`` random moves in physics and compare each with the gait model's verdict.

    Walls are drawn from ``seed``; on each the robot starts at the bottom and takes up to
    ``walk`` random model-feasible moves; at each stance one random move among the
    ``candidates`` nearest holes (the env's action set) that the geometry allows is tried in
    physics from a fresh robot resting on that stance. ``progress(1)`` is called per move."""
    model = model or ClimberModel.from_config()
    rng = np.random.default_rng(seed)
    span = 2.0 * max(model.reach[1])
    got = Agreement()
    sim = PhysicsClimber(model)
    while got.moves < moves:
        holes = _wall(rng)
        starts = start_stances(model, holes)
        if not starts:
            continue
        stance = starts[int(rng.integers(min(len(starts), 12)))]
        for _ in range(walk):
            if got.moves >= moves:
                break
            judged = {(arm, h): plan_move(model, holes, stance, arm, h)
                      for h in candidate_holes(holes, stance, candidates, span) for arm in range(3)}
            tryable = [m for m, p in judged.items() if isinstance(p, MovePlan) or p[0] != "unreachable"]
            feasible = [m for m, p in judged.items() if isinstance(p, MovePlan)]
            if tryable:
                arm, h = tryable[int(rng.integers(len(tryable)))]
                verdict = judged[arm, h]
                sim.reset(holes, stance)
                res = sim.move(arm, h)
                kin_ok = isinstance(verdict, MovePlan)
                got.cells[kin_ok, res.ok] += 1
                if not kin_ok:
                    got.kin_no[verdict[0], res.ok] += 1  # type: ignore[index]
                elif not res.ok:
                    got.phys_fail[res.outcome, res.phase] += 1
                if res.outcome == "fell":
                    got.falls.append(f"{'model ok' if kin_ok else 'model no'}: {res.reason}")
                if progress is not None:
                    progress(1)
            if not feasible:
                break
            arm, h = feasible[int(rng.integers(len(feasible)))]
            st = list(stance)
            st[arm] = h
            stance = (st[0], st[1], st[2])
    return got
