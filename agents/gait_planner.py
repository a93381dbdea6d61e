"""Gait planner for the climber: weighted A* over stances, one-arm moves as edges.

A *stance* is which hole each arm holds, ``(h1, h2, h3)`` (map rows, arms labelled). An
edge moves one arm to another hole and exists when the gait model
(:func:`envs.sim.climber.plan_move`) finds it feasible: one body pose within reach of the
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
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from envs.sim.climber import ClimberModel, MovePlan, min_enclosing_circle, plan_move
from kinematics.localization import HoleMap

__all__ = ["GaitPlanner", "Route", "start_stances"]

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
    """

    def __init__(self, model: ClimberModel, holes: HoleMap, weight: float = 2.0, heading: float = 0.0) -> None:
        if not weight >= 1.0:
            raise ValueError(f"weight={weight!r}; expected >= 1 (1 = optimal routes)")
        self.model, self.holes, self.weight, self.heading = model, holes, float(weight), float(heading)
        self.span = 2.0 * max(model.reach[1])
        self._moves: dict[Stance, list[tuple[int, int, Stance, MovePlan]]] = {}
        self._hops: dict[int, list[int]] = {}

    def moves(self, stance: Sequence[int]) -> list[tuple[int, int, Stance, MovePlan]]:
        """Every feasible move from ``stance``: ``(arm, hole, next stance, plan)``."""
        st: Stance = (int(stance[0]), int(stance[1]), int(stance[2]))
        got = self._moves.get(st)
        if got is not None:
            return got
        xy = self.holes.xy
        near = None
        for h in st:  # holes within one span of all three held holes
            ids = set(self.holes.within(xy[h], self.span).tolist())
            near = ids if near is None else near & ids
        out = []
        for hole in sorted((near or set()) - set(st)):
            for arm in range(3):
                plan = plan_move(self.model, self.holes, st, arm, hole, self.heading)
                if isinstance(plan, MovePlan):
                    nxt = list(st)
                    nxt[arm] = hole
                    out.append((arm, hole, (nxt[0], nxt[1], nxt[2]), plan))
        self._moves[st] = out
        return out

    def hops(self, goal: int) -> list[int]:
        """Per hole: hops to ``goal`` through holes at most one arm span apart (breadth-first;
        a large number where no chain of such hops leads to the goal)."""
        got = self._hops.get(goal)
        if got is None:
            far = 1 << 20
            got = [far] * len(self.holes)
            got[goal] = 0
            frontier = [goal]
            while frontier:
                nxt = []
                for h in frontier:
                    for j in self.holes.within(self.holes.xy[h], self.span).tolist():
                        if got[j] == far:
                            got[j] = got[h] + 1
                            nxt.append(j)
                frontier = nxt
            self._hops[goal] = got
        return got

    def heuristic(self, stance: Stance, goal: int) -> float:
        """Admissible lower bound on the moves left. A move moves one arm, and its old and new
        holes both lie within the circle of the move (radius <= reach), so one move changes
        one arm's hop count by at most one. At the end one arm holds the goal (0 hops) and
        the others lie within one span of it (<= 1 hop): so at least
        ``sum_k max(0, hops_k - 1)`` moves, plus one if no arm holds the goal yet."""
        hop = self.hops(goal)
        hs = [hop[h] for h in stance]
        return float(sum(max(0, v - 1) for v in hs) + (0 if min(hs) == 0 else 1))

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
            for arm, hole, nxt, _ in self.moves(st):
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


def start_stances(model: ClimberModel, holes: HoleMap, rows: float = 1.5) -> list[Stance]:
    """Stances near the bottom of the wall the robot can rest in (its three holes fit in its
    reach), lowest first: the holes within ``rows`` spacings of the lowest hole."""
    xy = holes.xy
    y0 = float(xy[:, 1].min())
    low = [i for i in range(len(holes)) if xy[i, 1] <= y0 + rows * holes.spacing]
    reach = min(model.reach[1])
    clear = model.phys.body_radius_cm + model.phys.reach_margin_cm
    out = []
    for st in itertools.permutations(low, 3):
        pts = [tuple(xy[h]) for h in st]
        cx, cy, r = min_enclosing_circle(pts)
        if r <= reach and all(math.hypot(px - cx, py - cy) >= clear for px, py in pts):
            out.append((st[0], st[1], st[2]))
    out.sort(key=lambda s: (sum(xy[h, 1] for h in s), s))
    return out
