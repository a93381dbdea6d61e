"""Gait planner for the climber: weighted A* over stances, one-arm moves as edges.

A *stance* is which hole each arm holds, ``(h1, h2, h3)`` (map rows, arms labelled). An
edge moves one arm to another hole and exists when the gait model
(:func:`kinegym.envs.sim.gait.plan_move`) finds it feasible: one body pose within reach of the
four holes involved, elbows within limits, and the servos and grippers able to hold the
body while the arm swings. The goal is a hole: any arm gripping it.

The heuristic is admissible: in one move an arm's old and new holes both lie within the
move's circle (radius at most the reach), so its hop count to the goal - through holes at
most one arm span (twice the reach) apart - falls by at most one per move; every arm must
end within one hop of the goal and one arm on it (see :meth:`GaitPlanner.heuristic`). Weighted A* (``f = g + w h``,
``w >= 1``) returns a route at most ``w`` times the shortest; with the search space
exhausted it proves that no route exists (the stance graph of a wall is finite). Edges are
generated only towards holes within one span of all three held holes (a spatial hash), and
move judgements are cached per planner, so replanning on the same wall is cheap.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from kinegym.envs.climb_task import candidate_holes, hop_counts, stance_hops, start_stances
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move
from kinegym.envs.sim.gait_kernel import feasible_moves
from kinegym.kinematics.holes import HoleMap

__all__ = ["GaitPlanner", "Route", "start_stances", "find_route", "PlannerAgent"]

Stance = tuple[int, int, int]


@dataclass
class Route:
    """A planner's answer: the moves ``[(arm, hole), ...]`` (empty if the start already holds
    the goal), the stances passed, whether a route was ``found``, whether the search
    ``exhausted`` the reachable stances (then "not found" is a proof), and the stances
    ``expanded``."""

    moves: list[tuple[int, int]] = field(default_factory=list)
    stances: list[Stance] = field(default_factory=list)
    found: bool = False
    exhausted: bool = False
    expanded: int = 0

    @property
    def proven_impossible(self) -> bool:
        return not self.found and self.exhausted


class GaitPlanner:
    """Plans climbs of one robot on one wall.

    Args:
        model: the robot (reach, servos, grippers).
        holes: the wall.
        weight: A* weight ``w >= 1`` (1 = shortest routes, larger = faster search).
        heading: body heading the gait keeps (rad).
        candidates: only moves to the ``candidates`` holes nearest the held holes
            (:func:`kinegym.envs.climb_task.candidate_holes`, the environment's action set); None
            allows every hole within reach.
    """

    def __init__(self, model: ClimberModel, holes: HoleMap, weight: float = 2.0, heading: float = 0.0,
                 candidates: int | None = None) -> None:
        if not weight >= 1.0:
            raise ValueError(f"weight={weight!r}; expected >= 1 (1 = optimal routes)")
        if candidates is not None and candidates < 1:
            raise ValueError(f"candidates={candidates!r}; expected >= 1 or None (every hole within reach)")
        self.model, self.holes, self.weight, self.heading = model, holes, float(weight), float(heading)
        self.candidates = candidates
        self.span = 2.0 * max(model.reach[1])
        self._moves: dict[Stance, list[tuple[int, int, Stance, MovePlan]]] = {}
        self._succ: dict[Stance, list[tuple[int, int, Stance]]] = {}
        self._hops: dict[int, list[int]] = {}

    def moves(self, stance: Sequence[int]) -> list[tuple[int, int, Stance, MovePlan]]:
        """Every feasible move from ``stance``: ``(arm, hole, next stance, plan)``."""
        st: Stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        got = self._moves.get(st)
        if got is None:
            got = []
            for arm, hole, nxt in self.successors(st):
                plan = plan_move(self.model, self.holes, st, arm, hole, self.heading)
                if not isinstance(plan, MovePlan):  # tests pin the two equal; say so loudly if they part
                    raise RuntimeError(f"feasible_moves and plan_move disagree on stance {st}, arm {arm}, hole "
                                       f"{hole}: {plan}")
                got.append((arm, hole, nxt, plan))
            self._moves[st] = got
        return got

    def successors(self, stance: Sequence[int]) -> list[tuple[int, int, Stance]]:
        """Every feasible move from ``stance`` without its plan: ``(arm, hole, next stance)``
        (judged all at once by :func:`~kinegym.envs.sim.gait_kernel.feasible_moves`)."""
        st: Stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        got = self._succ.get(st)
        if got is not None:
            return got
        xy = self.holes.xy
        if self.candidates is not None:  # the moves an agent in HoleClimb-v0 is offered
            targets = sorted(candidate_holes(self.holes, st, self.candidates, self.span))
        else:
            near = None
            for h in st:  # holes within one span of all three held holes
                ids = set(self.holes.within(xy[h], self.span).tolist())
                near = ids if near is None else near & ids
            targets = sorted((near or set()) - set(st))
        arms = np.tile(np.arange(3), len(targets))
        holes = np.repeat(np.array(targets, dtype=np.intp), 3)
        ok = feasible_moves(self.model, self.holes, st, arms, holes, self.heading)
        got = []
        for arm, hole in zip(arms[ok].tolist(), holes[ok].tolist()):
            nxt = list(st)
            nxt[arm] = hole
            got.append((arm, hole, (nxt[0], nxt[1], nxt[2])))
        self._succ[st] = got
        return got

    def forbid(self, stance: Sequence[int], arm: int, hole: int) -> None:
        """Drop a move that failed when tried (physics disagreed with the gait model)."""
        st: Stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        self._succ[st] = [m for m in self.successors(st) if (m[0], m[1]) != (arm, hole)]
        if st in self._moves:
            self._moves[st] = [m for m in self._moves[st] if (m[0], m[1]) != (arm, hole)]

    def hops(self, goal: int) -> list[int]:
        """Per hole: hops to ``goal`` through holes at most one arm span apart
        (:func:`kinegym.envs.climb_task.hop_counts`)."""
        got = self._hops.get(goal)
        if got is None:
            got = self._hops[goal] = hop_counts(self.holes, goal, self.span)
        return got

    def heuristic(self, stance: Stance, goal: int) -> float:
        """Admissible lower bound on the moves left (:func:`kinegym.envs.climb_task.stance_hops`)."""
        return float(stance_hops(self.hops(goal), stance))

    def plan(self, start: Sequence[int], goal: int, max_expansions: int = 20_000) -> Route:
        """A route from stance ``start`` until some arm holds hole ``goal`` (map row)."""
        s0: Stance = (int(start[0]), int(start[1]), int(start[2]))
        if not 0 <= goal < len(self.holes):
            raise ValueError(f"goal hole {goal}; the wall has holes 0..{len(self.holes) - 1}")
        counter = itertools.count()
        openq = [(self.weight * self.heuristic(s0, goal), next(counter), 0, s0)]
        parent: dict[Stance, tuple[Stance, int, int] | None] = {s0: None}
        best_g = {s0: 0}
        closed: set[Stance] = set()
        expanded = 0
        while openq:
            _, _, g, st = heapq.heappop(openq)
            if st in closed:
                continue
            if goal in st:
                return self._route(parent, st, expanded)
            closed.add(st)
            expanded += 1
            if expanded > max_expansions:
                return Route(found=False, exhausted=False, expanded=expanded)
            for arm, hole, nxt in self.successors(st):
                ng = g + 1
                if ng < best_g.get(nxt, 1 << 30):
                    best_g[nxt] = ng
                    parent[nxt] = (st, arm, hole)
                    heapq.heappush(openq, (ng + self.weight * self.heuristic(nxt, goal), next(counter), ng, nxt))
        return Route(found=False, exhausted=True, expanded=expanded)

    @staticmethod
    def _route(parent: dict[Stance, tuple[Stance, int, int] | None], end: Stance, expanded: int) -> Route:
        moves, stances = [], [end]
        st = end
        while parent[st] is not None:
            prev, arm, hole = parent[st]  # type: ignore[misc]
            moves.append((arm, hole))
            stances.append(prev)
            st = prev
        return Route(moves[::-1], stances[::-1], True, False, expanded)


def find_route(model: ClimberModel, holes: HoleMap, start: Sequence[int], goal: int, candidates: int | None,
               max_expansions: int = 3000) -> list[tuple[int, int]] | None:
    """The moves of a route from ``start`` until an arm holds ``goal``, or None (the route
    finder HoleClimb-v0 filters its walls with; a module-level function so envs pickle)."""
    route = GaitPlanner(model, holes, candidates=candidates).plan(start, goal, max_expansions)
    return route.moves if route.found else None


class PlannerAgent:
    """The planner as a HoleClimb-v0 policy (the baseline learned policies are compared
    with): at every step it plans from the stance the robot believes it holds, through the
    moves the env offers, and takes the first move. Moves that failed this episode (the env's
    ``failed_moves``, which it masks) are dropped from its graph: it replans round them.

    ``act(env, obs=None)`` takes the (unwrapped) env; ``None`` when no route exists from here.
    """

    def __init__(self, weight: float = 2.0, max_expansions: int = 3000) -> None:
        self.weight, self.max_expansions = weight, max_expansions
        self._planner: GaitPlanner | None = None
        self._forbidden: set[tuple[tuple[int, int, int], int, int]] = set()

    def act(self, env: object, obs: object = None) -> int | None:
        holes, model = env.holes, env.model  # type: ignore[attr-defined]
        if self._planner is None or self._planner.holes is not holes or self._planner.model is not model:
            self._planner = GaitPlanner(model, holes, self.weight, candidates=env.K)  # type: ignore[attr-defined]
            self._forbidden = set()
        for move in env.failed_moves - self._forbidden:  # type: ignore[attr-defined]
            self._planner.forbid(*move)  # it failed there (the env masks it): plan round it
            self._forbidden.add(move)
        stance = env.believed_stance  # type: ignore[attr-defined]
        route = self._planner.plan(stance, env.goal, self.max_expansions)  # type: ignore[attr-defined]
        if not route.found or not route.moves:
            return None
        arm, hole = route.moves[0]
        return env.action_for(arm, hole)  # type: ignore[attr-defined]
