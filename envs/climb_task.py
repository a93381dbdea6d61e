"""What a climb asks of the robot: walls, start and goal, the route proof, the reward, the hints.

The task half of HoleClimb-v0 (panda-gym's split: a task and a robot joined by a thin env).
:class:`ClimbTask` makes walls (generated from the env's seeded generator, a fixed wall from
``configs/walls``, or a pool of tasks made once), puts the start among the lowest holes and
the goal in the top row, accepts a wall only if its ``route_finder`` proves a route, scores
moves (:meth:`ClimbTask.reward`) and keeps the map's hints. The wall-graph helpers are shared
with the planner: :func:`candidate_holes` (the holes an agent may choose from, a function of
the stance alone, so that a planner and the environment offer the same moves),
:func:`hop_counts` and :func:`stance_hops` (the map's lower bound on the moves left) and
:func:`start_stances` (where the robot can rest at the bottom of a wall).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

import kinegym.configs as _configs
from kinegym.envs.errors import NoRouteError
from kinegym.envs.sim.climber_model import ClimberModel
from kinegym.envs.sim.gait import rest_pose
from kinegym.kinematics.holes import HoleMap

__all__ = ["ClimbTask", "RouteFinder", "WALL_DEFAULTS", "candidate_holes", "hop_counts", "moved_hops", "stance_hops",
           "start_stances"]

#: ``(model, holes, start, goal, candidates) -> moves or None``: how walls are checked for a
#: route (``agents.gait_planner.find_route`` when made with ``gymnasium.make``).
RouteFinder = Callable[[ClimberModel, HoleMap, Sequence[int], int, int], "list[tuple[int, int]] | None"]

WALL_DEFAULTS: dict[str, Any] = {"cols": (5, 8), "rows": (8, 14), "spacing_cm": 15.0, "jitter_cm": 1.0,
                                 "missing": 0.08}


#: Bounds of the generated walls' settings: (lowest, highest) per key; "missing" is a share.
WALL_LIMITS: dict[str, tuple[float, float]] = {"cols": (3, 60), "rows": (3, 120), "spacing_cm": (1.0, 200.0),
                                               "jitter_cm": (0.0, 50.0), "missing": (0.0, 0.5)}


def _check_wall_kwargs(kw: dict[str, Any]) -> None:
    """Each generated-wall setting a number or a ``(lo, hi)`` range within :data:`WALL_LIMITS`
    (a 10,000 x 10,000 wall or one with every hole missing would never yield a route)."""
    for key, (lo, hi) in WALL_LIMITS.items():
        v = kw[key]
        vals = list(v) if isinstance(v, (tuple, list)) else [v]
        integer = key in ("cols", "rows")
        ok = len(vals) in (1, 2) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and lo <= x <= hi
            and (not integer or float(x).is_integer()) for x in vals) and vals[0] <= vals[-1]
        if not ok:
            kind = "integers" if integer else "numbers"
            raise ValueError(f"wall_kwargs[{key!r}]={v!r}; expected {kind} in {lo:g}..{hi:g}, one value or a "
                             "[lo, hi] range")
    if max(np.atleast_1d(kw["jitter_cm"])) >= 0.5 * min(np.atleast_1d(kw["spacing_cm"])):
        raise ValueError(f"wall_kwargs jitter_cm={kw['jitter_cm']!r} must stay below half the spacing "
                         f"({kw['spacing_cm']!r} cm): holes would swap places")


class WallKwargsSpec(_configs.Spec):
    """``wall_kwargs`` in a YAML file: known keys (:data:`WALL_DEFAULTS`), values in :data:`WALL_LIMITS`."""

    def check(self, value: Any, source: str, key: str) -> Any:
        if not isinstance(value, dict):
            raise _configs.ConfigError(source, key, value, "a mapping of wall settings")
        unknown = sorted(set(map(str, value)) - set(WALL_DEFAULTS))
        if unknown:
            raise _configs.ConfigError(source, f"{key}.{unknown[0]}", value[unknown[0]],
                                       "no such key; known keys: " + ", ".join(WALL_DEFAULTS))
        try:
            _check_wall_kwargs({**WALL_DEFAULTS, **value})
        except ValueError as err:
            raise _configs.ConfigError(source, key, value, str(err).split("; expected ", 1)[-1]) from None
        return dict(value)


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


def moved_hops(hops: Sequence[int], stance: Sequence[int], holes: Sequence[int]) -> list[list[int]]:
    """:func:`stance_hops` of each stance one move from ``stance`` leads to - arm ``a`` to
    ``holes[k]`` at ``[a][k]`` (a hole < 0: none, 0) - from the stance's hop counts with one
    arm's replaced: the same integers as calling it on each, without building the stances."""
    hs = [hops[h] for h in stance]
    over = [max(0, v - 1) for v in hs]
    base = sum(over)
    stay = (min(hs[1], hs[2]), min(hs[0], hs[2]), min(hs[0], hs[1]))  # the two arms that keep their holes
    return [[base - over[a] + max(0, hops[h] - 1) + (0 if min(hops[h], stay[a]) == 0 else 1) if h >= 0 else 0
             for h in holes] for a in range(3)]


def start_stances(model: ClimberModel, holes: HoleMap, rows: float = 1.5,
                  limit: int | None = None) -> list[tuple[int, int, int]]:
    """Stances near the bottom of the wall the robot can rest in (:func:`~kinegym.envs.sim.gait.rest_pose`:
    its three holes within reach, none under the body), lowest first: the holes within ``rows``
    spacings of the lowest hole. ``limit``: only the lowest ``limit`` of them (the same first
    ``limit`` entries; candidates are tried lowest first, so the rest are never judged)."""
    xy = holes.xy
    y0 = float(xy[:, 1].min())
    low = [i for i in range(len(holes)) if xy[i, 1] <= y0 + rows * holes.spacing]
    reach = min(model.reach[1])
    out = []
    low_set = set(low)
    # only triples whose holes are pairwise within two reaches can fit (a wall's bottom row of a
    # hundred holes would otherwise be a million permutations)
    near = {i: [j for j in holes.within(xy[i], 2.0 * reach + 1e-9).tolist() if j in low_set and j != i] for i in low}
    triples = sorted(((i, j, k) for i in low for j, k in itertools.permutations(near[i], 2) if k in near[j]),
                     key=lambda s: (sum(xy[h, 1] for h in s), s))
    for st in triples:  # the robot can rest there: the pose every move starts from
        if not isinstance(rest_pose(model, holes, st), str):
            out.append(st)
            if limit is not None and len(out) >= limit:
                break
    return out


class ClimbTask:
    """Walls, start, goal and reward of one HoleClimb env (see the env's docstring for the
    arguments). :meth:`new_episode` draws the next wall; afterwards ``holes``, ``start``,
    ``goal``, ``planner_moves``, ``hops`` (hop counts to the goal, when ``hints``) and
    ``stance_cache`` (per believed stance on this wall: candidates and action mask, kept with
    the wall) describe it."""

    def __init__(self, model: ClimberModel, robot_name: str, wall: str | HoleMap, wall_kwargs: dict[str, Any] | None,
                 candidates: int, route_finder: RouteFinder | None, hints: bool, wall_pool: int,
                 wall_pool_seed: int) -> None:
        unknown = set(wall_kwargs or {}) - set(WALL_DEFAULTS)
        if unknown:
            raise ValueError(f"wall_kwargs {sorted(unknown)} unknown; expected keys {sorted(WALL_DEFAULTS)}")
        if not (isinstance(wall_pool, int) and wall_pool >= 0):
            raise ValueError(f"wall_pool={wall_pool!r}; expected an integer >= 0 (0 = a new wall every reset)")
        if wall_pool and wall != "generated":
            raise ValueError(f"wall_pool={wall_pool} needs wall='generated', not {wall!r}")
        if not isinstance(wall_pool_seed, int):
            raise ValueError(f"wall_pool_seed={wall_pool_seed!r}; expected an integer")
        self.model, self.robot_name, self.K = model, robot_name, candidates
        self.route_finder, self.hints = route_finder, hints
        self.wall_pool, self.wall_pool_seed = wall_pool, wall_pool_seed
        self.wall_kwargs = {**WALL_DEFAULTS, **(wall_kwargs or {})}
        _check_wall_kwargs(self.wall_kwargs)
        self.reach = float(np.max(model.geom.l1 + model.geom.l2))
        self.fixed_wall: HoleMap | None = None
        if isinstance(wall, HoleMap):
            self.fixed_wall = wall
        elif wall != "generated":
            self.fixed_wall = HoleMap.from_config(wall)
        # pool index -> (holes, start, goal, planner moves, hop counts, stance cache)
        self._pool: dict[int, tuple[HoleMap, tuple[int, int, int], int, int, list[int], dict]] = {}
        self.holes: HoleMap | None = None
        self.stance_cache: dict[tuple[int, int, int], tuple[list[int], np.ndarray]] = {}
        self.hops: list[int] = []

    def new_episode(self, rng: np.random.Generator) -> None:
        """The next wall, start and goal, drawn from ``rng`` (the env's ``np_random``)."""
        if self.wall_pool:
            i = int(rng.integers(self.wall_pool))
            task = self._pool.get(i)
            if task is None:
                holes, start, goal, moves = self._make_wall(np.random.default_rng([self.wall_pool_seed, i]))
                task = self._pool[i] = (holes, start, goal, moves, hop_counts(holes, goal, 2.0 * self.reach), {})
            self.holes, self.start, self.goal, self.planner_moves, self.hops, self.stance_cache = task
            return
        previous = self.holes
        self.holes, self.start, self.goal, self.planner_moves = self._make_wall(rng)
        if self.holes is not previous:
            self.stance_cache = {}
        self.hops = hop_counts(self.holes, self.goal, 2.0 * self.reach) if self.hints else []

    def reward(self, prev_dist: float, dist: float, success: bool, fell: bool) -> float:
        """``0.05`` per cm closer to the goal, ``-0.1`` per move, ``+10`` at the goal, ``-10`` for a fall."""
        reward = 0.05 * (prev_dist - dist) - 0.1
        if success:
            reward += 10.0
        if fell:
            reward -= 10.0
        return float(reward)

    def goal_distance(self, pose: Sequence[float]) -> float:
        """Distance (cm) from a body pose to the goal hole."""
        g = self.holes.xy[self.goal]  # type: ignore[union-attr]
        return float(math.hypot(g[0] - pose[0], g[1] - pose[1]))

    def _draw_range(self, key: str, rng: np.random.Generator) -> float:
        v = self.wall_kwargs[key]
        if isinstance(v, (tuple, list)):
            lo, hi = v
            if isinstance(lo, int):
                return int(rng.integers(lo, hi + 1))
            return float(rng.uniform(lo, hi))
        return v

    def _make_wall(self, rng: np.random.Generator) -> tuple[HoleMap, tuple[int, int, int], int, int]:
        """A wall with a start stance, a goal hole and the route finder's route length
        (-1 without a route finder: the wall is then not checked), all drawn from ``rng``."""
        for _ in range(30):
            if self.fixed_wall is not None:
                holes = self.fixed_wall
            else:
                cols, rows = int(self._draw_range("cols", rng)), int(self._draw_range("rows", rng))
                holes = HoleMap.grid(cols, rows, float(self._draw_range("spacing_cm", rng)),
                                     float(self._draw_range("jitter_cm", rng)), float(self._draw_range("missing", rng)),
                                     seed=int(rng.integers(2**31)), name=f"generated {cols}x{rows}")
            starts = start_stances(self.model, holes, limit=12)
            if not starts:
                if self.fixed_wall is not None:
                    break
                continue
            start = starts[int(rng.integers(len(starts)))]  # one of the 12 lowest
            ys = holes.xy[:, 1]
            top = np.flatnonzero(ys >= ys.max() - 0.5 * holes.spacing)
            first = int(rng.integers(len(top)))
            goals = [int(top[first])] + ([int(g) for g in top if int(g) != int(top[first])]
                                         if self.fixed_wall is not None else [])
            for goal in goals:  # a fixed wall: the other top holes before giving up
                if self.route_finder is None:
                    return holes, start, goal, -1
                route = self.route_finder(self.model, holes, start, goal, self.K)
                if route is not None:
                    return holes, start, goal, len(route)
            if self.fixed_wall is not None:
                break
        name = getattr(self.fixed_wall, "name", "generated")
        raise NoRouteError(f"no route from the bottom to the top of wall '{name}' for robot '{self.robot_name}' "
                           f"(reach {self.reach:g} cm, spacing {(self.fixed_wall or holes).spacing:.1f} cm); "
                           f"a longer-armed robot (robot='climber_long') or a denser wall is needed")
