"""What a climb asks of the robot: the wall as a graph of holes, starts, goals and the moves on offer.

:func:`candidate_holes` (the holes an agent may choose from, a function of the stance
alone, so that a planner and the environment offer the same moves), :func:`hop_counts` and
:func:`stance_hops` (the map's lower bound on the moves left) and :func:`start_stances`
(where the robot can rest at the bottom of a wall).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import min_enclosing_circle
from kinegym.kinematics.holes import HoleMap

__all__ = ["candidate_holes", "hop_counts", "stance_hops", "start_stances"]


def candidate_holes(holes: HoleMap, stance: Sequence[int], k: int, radius: float) -> list[int]:
    """The ``k`` holes nearest the centroid of the held holes (within ``radius`` cm) that the
    stance does not hold, nearest first (ties by row): the moves an agent may choose from.
    A function of the stance alone, so a planner and the environment offer the same moves."""
    xy = holes.xy_list
    cx = (xy[stance[0]][0] + xy[stance[1]][0] + xy[stance[2]][0]) / 3.0
    cy = (xy[stance[0]][1] + xy[stance[1]][1] + xy[stance[2]][1]) / 3.0
    near = [h for h in holes.within((cx, cy), radius).tolist() if h not in stance]
    near.sort(key=lambda h: ((xy[h][0] - cx) ** 2 + (xy[h][1] - cy) ** 2, h))
    return near[:k]


def hop_counts(holes: HoleMap, goal: int, span: float) -> list[int]:
    """Per hole: hops to hole ``goal`` through holes at most ``span`` cm apart (breadth-first;
    ``1 << 20`` where no chain of such hops reaches the goal)."""
    far = 1 << 20
    got = [far] * len(holes)
    got[goal] = 0
    frontier = [goal]
    while frontier:
        nxt = []
        for h in frontier:
            for j in holes.within(holes.xy[h], span).tolist():
                if got[j] == far:
                    got[j] = got[h] + 1
                    nxt.append(j)
        frontier = nxt
    return got


def stance_hops(hops: Sequence[int], stance: Sequence[int]) -> int:
    """A lower bound on the moves from ``stance`` until an arm holds the goal, from
    :func:`hop_counts` with ``span`` = one arm span (twice the reach). A move changes one
    arm's hole, and its old and new holes both lie within the move's circle (radius at most
    the reach), so one move lowers one arm's hop count by at most one; at the end one arm
    holds the goal (0 hops) and the others lie within one span of it (at most 1 hop): so at
    least ``sum_k max(0, hops_k - 1)`` moves, plus one if no arm holds the goal yet."""
    hs = [hops[h] for h in stance]
    return sum(max(0, v - 1) for v in hs) + (0 if min(hs) == 0 else 1)


def start_stances(model: ClimberModel, holes: HoleMap, rows: float = 1.5) -> list[tuple[int, int, int]]:
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
