"""HoleClimb-v0: the three-armed climber of seed 000 climbs a wall of holes to a goal hole.

## Description

The robot hangs from three holes of a vertical wall (gravity along -y). Each step it moves
one arm to another hole with the seed's gait - shift the body with all three hands
gripping, release one hand, swing it round the body to the new hole, grip
(:mod:`kinegym.envs.sim.climber`). It sees only what its six joint encoders and the localiser
(:class:`kinegym.kinematics.localization.Localizer`, tracking after every move) tell it: an
estimated body pose with its uncertainty and which holes it believes it holds. An episode
ends when an arm grips the goal hole, or when the robot falls.

``mode="kinematic"`` (default) judges moves analytically (microseconds); ``mode="physics"``
simulates each move in pymunk with torque-limited servos and grippers that let go.

## Action Space

``Discrete(3 * K)`` (``K = candidates``, default 8): action ``a`` moves arm ``a // K``
(0, 1, 2 = arms 1, 2, 3) to candidate ``a % K`` - the ``K`` holes nearest the centroid of
the holes the robot believes it holds, nearest first
(:func:`kinegym.envs.climb_task.candidate_holes`). Actions the robot's own gait
model judges infeasible are masked: ``action_masks()`` and ``info["action_mask"]``
(a stepped masked action is not an error: it fails as ``unreachable`` and costs a move).

## Observation Space

``Box(-20, 20, (N,), float32)`` with ``N = 14 + 6 K + 6`` (68 for K = 8); lengths in units of the
arm reach ``R`` (l1 + l2, 20 cm for the seed robot), all relative to the *estimated* body:

| index | observation | unit |
|---|---|---|
| 0, 1 | goal hole minus estimated centre, x and y | R |
| 2 | distance from the estimated centre to the goal | R |
| 3, 4 | cos and sin of the estimated heading | - |
| 5, 6, 7 | 1-sigma uncertainty of the estimate: x, y, heading | cm, cm, deg |
| 8 - 13 | held hole of arm 1, 2, 3 minus estimated centre (x, y each) | R |
| 14 - 14+2K-1 | candidate hole k minus estimated centre (x, y each); 0 if absent | R |
| 14+2K - 14+3K-1 | candidate k exists (1) or not (0) | - |
| 14+3K - 14+6K-1 | action mask: arm j to candidate k feasible (index j K + k) | - |
| 14+6K - 14+6K+5 | last move's outcome, one-hot: ok, unreachable, torque_limit, missed_hole, grip_lost, fell | - |

With ``memory=True`` (what the training config uses) ``3 K + 1`` entries follow (93 in all
for K = 8): how many times this episode the robot believed itself in its current stance,
then per action ``j K + k`` in the stance that move leads to - each ``min(count, 4) / 4``.
A deterministic policy without them can only cycle once it has looped (they are what the
gait policy needs to break cycles; see the README's training section).

With ``hints=True`` ``6 K + 1`` entries follow (142 in all for K = 8 with ``memory``): the
map's lower bound on the moves left from the believed stance
(:func:`kinegym.envs.climb_task.stance_hops`: hops of the held holes to the goal through holes one
arm span apart) as ``min(h, 20) / 10``; per action ``j K + k`` how the move changes that
bound, clipped to [-2, 2] and halved; per action whether that move already failed from this
stance this episode (1) or not (0). The robot knows the map, so these are its own
knowledge, not the planner's answer: they say which moves head for the goal, not which
route gets there.

Values are clipped to [-20, 20].

## Rewards

Per move: ``0.05`` per cm the true body centre came closer to the goal hole (negative if it
went away), ``-0.1`` for the move itself, ``+10`` when an arm grips the goal, ``-10`` for a
fall. Plain Python floats.

## Starting State

On ``reset(seed=...)`` a wall is made (``wall="generated"``: a jittered grid with missing
holes, sizes from ``wall_kwargs``, all from the env's seeded generator; or a fixed wall from
``configs/walls``), the robot is put on a resting stance among the lowest holes, and the
goal is a hole in the top row. Walls are accepted only if the ``route_finder`` finds a route
through the actions the agent is offered (``gymnasium.make`` gives the env the gait planner,
:func:`kinegym.agents.gait_planner.find_route`); ``info["planner_moves"]`` says how many moves it needed.

## Episode End

Terminated when an arm grips the goal hole (``info["is_success"] = True``) or the robot
falls (fewer than two grips). Truncated by ``max_episode_steps`` (200 moves when made with
``gymnasium.make``).

## Arguments

``gymnasium.make("kinegym/HoleClimb-v0", mode="kinematic", wall="generated", robot="climber",
candidates=8, wall_kwargs=None, memory=False, hints=False, wall_pool=0, wall_pool_seed=0,
render_mode=None)``; ``HoleClimbEnv(...)`` made directly takes a
``route_finder`` (without one walls are not checked: the env package does not import agents).
``wall_kwargs`` (generated walls):
``cols`` (default (5, 8), an int or an inclusive range), ``rows`` ((8, 14)), ``spacing_cm``
(15.0), ``jitter_cm`` (1.0), ``missing`` (0.08 share of holes left out). The seed's 20 cm
wall needs ``robot="climber_long"`` (see the README: the seed robot's 10 cm links cannot
climb it with this gait).
``wall_pool=N`` (training): instead of a new wall every reset, each reset draws one of ``N``
tasks (wall, start, goal), task ``i`` made once from the seed ``(wall_pool_seed, i)``; a task
keeps its route check and its move judgements between episodes, which makes resets free and
steps about twice as fast. Evaluate on fresh walls (``wall_pool=0``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from kinegym.envs.climb_task import candidate_holes, hop_counts, stance_hops, start_stances
from kinegym.envs.sim.climber import KinematicClimber, PhysicsClimber
from kinegym.envs.sim.climber_model import OUTCOMES, ClimberModel
from kinegym.envs.sim.gait import MovePlan, plan_move
from kinegym.kinematics.holes import HoleMap
from kinegym.kinematics.localization import Localizer
from kinegym.kinematics.pose_fit import AmbiguousFixError, Fix, NoFixError, NoiseModel

__all__ = ["HoleClimbEnv", "WALL_DEFAULTS", "RouteFinder"]

#: ``(model, holes, start, goal, candidates) -> moves or None``: how walls are checked for a
#: route (``agents.gait_planner.find_route`` when made with ``gymnasium.make``).
RouteFinder = Callable[[ClimberModel, HoleMap, Sequence[int], int, int], "list[tuple[int, int]] | None"]

WALL_DEFAULTS: dict[str, Any] = {"cols": (5, 8), "rows": (8, 14), "spacing_cm": 15.0, "jitter_cm": 1.0,
                                 "missing": 0.08}
_CLIP = 20.0


class HoleClimbEnv(gym.Env[np.ndarray, np.int64]):
    """The climber on a wall of holes (see the module docstring for the tables)."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(self, render_mode: str | None = None, mode: str = "kinematic", wall: str | HoleMap = "generated",
                 robot: str = "climber", candidates: int = 8, wall_kwargs: dict[str, Any] | None = None,
                 route_finder: RouteFinder | None = None, memory: bool = False, hints: bool = False,
                 wall_pool: int = 0, wall_pool_seed: int = 0) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r}; expected one of {self.metadata['render_modes']} or None")
        if mode not in ("kinematic", "physics"):
            raise ValueError(f"mode={mode!r}; expected 'kinematic' or 'physics'")
        if not (isinstance(candidates, int) and 1 <= candidates <= 32):
            raise ValueError(f"candidates={candidates!r}; expected an integer 1..32")
        unknown = set(wall_kwargs or {}) - set(WALL_DEFAULTS)
        if unknown:
            raise ValueError(f"wall_kwargs {sorted(unknown)} unknown; expected keys {sorted(WALL_DEFAULTS)}")
        if not (isinstance(wall_pool, int) and wall_pool >= 0):
            raise ValueError(f"wall_pool={wall_pool!r}; expected an integer >= 0 (0 = a new wall every reset)")
        if wall_pool and wall != "generated":
            raise ValueError(f"wall_pool={wall_pool} needs wall='generated', not {wall!r}")
        if not isinstance(wall_pool_seed, int):
            raise ValueError(f"wall_pool_seed={wall_pool_seed!r}; expected an integer")
        self.render_mode, self.mode, self.K = render_mode, mode, candidates
        self.wall_pool, self.wall_pool_seed = wall_pool, wall_pool_seed
        # pool index -> (holes, start, goal, planner moves, hop counts, stance cache)
        self._pool: dict[int, tuple[HoleMap, tuple[int, int, int], int, int, list[int], dict]] = {}
        self.route_finder = route_finder
        self.robot_name = robot
        self.model = ClimberModel.from_config(robot)
        self.wall_spec = wall
        self.wall_kwargs = {**WALL_DEFAULTS, **(wall_kwargs or {})}
        self.reach = float(np.max(self.model.geom.l1 + self.model.geom.l2))
        self.sim = KinematicClimber(self.model) if mode == "kinematic" else PhysicsClimber(self.model)
        # believed stance -> (candidate holes, action mask): a function of the stance on one wall
        self._stance_cache: dict[tuple[int, int, int], tuple[list[int], np.ndarray]] = {}
        self.memory, self.hints = bool(memory), bool(hints)
        n_obs = (14 + 6 * candidates + len(OUTCOMES) + ((3 * candidates + 1) if self.memory else 0)
                 + ((6 * candidates + 1) if self.hints else 0))
        self.observation_space = spaces.Box(-_CLIP, _CLIP, (n_obs,), np.float32)
        self.action_space = spaces.Discrete(3 * candidates)
        self._fixed_wall: HoleMap | None = None
        if isinstance(wall, HoleMap):
            self._fixed_wall = wall
        elif wall != "generated":
            self._fixed_wall = HoleMap.from_config(wall)
        self._localizers: dict[int, Localizer] = {}
        self._window = None
        self.holes: HoleMap | None = None

    # ------------------------------------------------------------------ walls
    def _draw_range(self, key: str, rng: np.random.Generator) -> float:
        v = self.wall_kwargs[key]
        if isinstance(v, (tuple, list)):
            lo, hi = v
            if isinstance(lo, int):
                return int(rng.integers(lo, hi + 1))
            return float(rng.uniform(lo, hi))
        return v

    def _pool_task(self) -> tuple[HoleMap, tuple[int, int, int], int, int]:
        """One of the ``wall_pool`` tasks (wall, start, goal): task ``i`` is made once, from its
        own seed ``(wall_pool_seed, i)``, and keeps its move judgements between episodes."""
        i = int(self.np_random.integers(self.wall_pool))
        task = self._pool.get(i)
        if task is None:
            holes, start, goal, moves = self._make_wall(np.random.default_rng([self.wall_pool_seed, i]))
            task = self._pool[i] = (holes, start, goal, moves, hop_counts(holes, goal, 2.0 * self.reach), {})
        self._hops, self._stance_cache = task[4], task[5]
        return task[:4]

    def _make_wall(self, rng: np.random.Generator) -> tuple[HoleMap, tuple[int, int, int], int, int]:
        """A wall with a start stance, a goal hole and the route finder's route length
        (-1 without a route finder: the wall is then not checked), all drawn from ``rng``."""
        for _ in range(30):
            if self._fixed_wall is not None:
                holes = self._fixed_wall
            else:
                cols, rows = int(self._draw_range("cols", rng)), int(self._draw_range("rows", rng))
                holes = HoleMap.grid(cols, rows, float(self._draw_range("spacing_cm", rng)),
                                     float(self._draw_range("jitter_cm", rng)), float(self._draw_range("missing", rng)),
                                     seed=int(rng.integers(2**31)), name=f"generated {cols}x{rows}")
            starts = start_stances(self.model, holes)
            if not starts:
                if self._fixed_wall is not None:
                    break
                continue
            start = starts[int(rng.integers(min(len(starts), 12)))]
            ys = holes.xy[:, 1]
            top = np.flatnonzero(ys >= ys.max() - 0.5 * holes.spacing)
            first = int(rng.integers(len(top)))
            goals = [int(top[first])] + ([int(g) for g in top if int(g) != int(top[first])]
                                         if self._fixed_wall is not None else [])
            for goal in goals:  # a fixed wall: the other top holes before giving up
                if self.route_finder is None:
                    return holes, start, goal, -1
                route = self.route_finder(self.model, holes, start, goal, self.K)
                if route is not None:
                    return holes, start, goal, len(route)
            if self._fixed_wall is not None:
                break
        name = getattr(self._fixed_wall, "name", "generated")
        raise RuntimeError(f"no route from the bottom to the top of wall '{name}' for robot '{self.robot_name}' "
                           f"(reach {self.reach:g} cm, spacing {(self._fixed_wall or holes).spacing:.1f} cm); "
                           f"a longer-armed robot (robot='climber_long') or a denser wall is needed")

    def _localizer(self, holes: HoleMap) -> Localizer:
        key = id(holes)
        loc = self._localizers.get(key)
        if loc is None or loc.holes is not holes:
            step = math.radians(self.model.phys.encoder_step_deg)
            sigma = math.hypot(self.model.geom.sensor_sigma, step / math.sqrt(12.0))
            loc = Localizer(holes, self.model.geom, NoiseModel(sigma_angle=max(sigma, 1e-4), sigma_map=0.01))
            self._localizers = {key: loc}
        return loc

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self._episode_rng = self.np_random.bit_generator.state  # to rebuild the episode after unpickling
        return self._begin_episode()

    def _begin_episode(self) -> tuple[np.ndarray, dict]:
        if self.wall_pool:
            self.holes, start, self.goal, self.planner_moves = self._pool_task()
        else:
            previous = self.holes
            self.holes, start, self.goal, self.planner_moves = self._make_wall(self.np_random)
            if self.holes is not previous:
                self._stance_cache = {}
            self._hops = hop_counts(self.holes, self.goal, 2.0 * self.reach) if self.hints else []
        self.sim.reset(self.holes, start)
        self.loc = self._localizer(self.holes)
        # the robot is told where it starts (as an operator hangs it on the wall); from then
        # on it knows only what tracking its encoders says
        self.fix: Fix | None = None
        self.est_holes: tuple[int, int, int] = tuple(start)  # type: ignore[assignment]
        self._relocalise(None)
        self.moves, self.last_outcome, self.last_reason = 0, "ok", "start"
        self._prev_dist = self._true_goal_distance()
        self._history: list[int] = []
        self._visits: dict[tuple[int, int, int], int] = {self.est_holes: 1}  # believed stances this episode
        self._failed: set[tuple[tuple[int, int, int], int, int]] = set()  # (stance, arm, hole) that failed
        self._update_candidates()
        return self._obs(), self._info()

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self.holes is None:
            raise RuntimeError("call reset() before step()")
        a = int(action)
        if not 0 <= a < 3 * self.K:
            raise ValueError(f"action {action!r}; expected 0..{3 * self.K - 1}")
        self._history.append(a)
        arm, k = divmod(a, self.K)
        hole = self.cand[k]
        self.moves += 1
        if hole < 0:
            res_outcome, res_reason = "unreachable", f"there is no candidate {k}"
        else:
            res = self.sim.move(arm, hole)
            res_outcome, res_reason = res.outcome, res.reason
        self.last_outcome, self.last_reason = res_outcome, res_reason
        if res_outcome != "ok":
            self._failed.add((self.est_holes, arm, hole))
        fell = res_outcome == "fell"
        if not fell:
            self._relocalise(arm + 1 if res_outcome == "ok" else None)
            self._visits[self.est_holes] = self._visits.get(self.est_holes, 0) + 1
        dist = self._true_goal_distance()
        success = self.goal in self.sim.stance and not fell
        reward = 0.05 * (self._prev_dist - dist) - 0.1
        if success:
            reward += 10.0
        if fell:
            reward -= 10.0
        self._prev_dist = dist
        self._update_candidates()
        obs = self._obs()
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), bool(success or fell), False, self._info(success)

    # ------------------------------------------------------------------ internals
    def _relocalise(self, moved_arm: int | None) -> None:
        """Read the encoders and track the fix (the robot's own view of its pose)."""
        q = self.sim.encoders(self.np_random)
        prev = self.est_holes
        try:
            self.fix = self.loc.track(prev, q, moved_arm)
        except (NoFixError, AmbiguousFixError):
            try:
                self.fix = self.loc.track(prev, q, None) if moved_arm is not None else self.loc.localize(q)
            except (NoFixError, AmbiguousFixError):
                self.fix = None  # lost: keep the last belief, report a large uncertainty
        if self.fix is not None:
            self.est_holes = self.fix.holes

    def _est_pose(self) -> np.ndarray:
        if self.fix is not None:
            return self.fix.pose.copy()
        xy = self.holes.xy[list(self.est_holes)]  # type: ignore[union-attr]
        return np.array([xy[:, 0].mean(), xy[:, 1].mean(), 0.0])

    def _true_goal_distance(self) -> float:
        p = self.sim.pose
        g = self.holes.xy[self.goal]  # type: ignore[union-attr]
        return float(math.hypot(g[0] - p[0], g[1] - p[1]))

    def _update_candidates(self) -> None:
        """The K holes nearest the holes the robot believes it holds (not held), and which
        arm may go to each (the robot's own gait model, judged on that belief)."""
        stance = self.est_holes
        got = self._stance_cache.get(stance)
        if got is None:
            holes = self.holes
            near = candidate_holes(holes, stance, self.K, 2.0 * self.reach)  # type: ignore[arg-type]
            cand = (near + [-1] * self.K)[: self.K]
            mask = np.zeros(3 * self.K, dtype=bool)
            for k, h in enumerate(cand):
                if h >= 0:
                    for arm in range(3):
                        plan = plan_move(self.model, holes, stance, arm, h, 0.0)  # type: ignore[arg-type]
                        mask[arm * self.K + k] = isinstance(plan, MovePlan)
            got = self._stance_cache[stance] = (cand, mask)
        self.cand, self.mask = list(got[0]), got[1].copy()

    def _obs(self) -> np.ndarray:
        K, R = self.K, self.reach
        est = self._est_pose()
        xy = self.holes.xy  # type: ignore[union-attr]
        obs = np.zeros(self.observation_space.shape, dtype=np.float64)
        g = xy[self.goal]
        obs[0], obs[1] = (g[0] - est[0]) / R, (g[1] - est[1]) / R
        obs[2] = math.hypot(obs[0], obs[1])
        obs[3], obs[4] = math.cos(est[2]), math.sin(est[2])
        if self.fix is not None:
            cov = self.fix.covariance
            std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
            obs[5], obs[6], obs[7] = std[0], std[1], math.degrees(std[2])
        else:
            obs[5:8] = _CLIP
        for k in range(3):
            h = xy[self.est_holes[k]]
            obs[8 + 2 * k], obs[9 + 2 * k] = (h[0] - est[0]) / R, (h[1] - est[1]) / R
        base = 14
        for k, h in enumerate(self.cand):
            if h >= 0:
                obs[base + 2 * k], obs[base + 2 * k + 1] = (xy[h, 0] - est[0]) / R, (xy[h, 1] - est[1]) / R
                obs[base + 2 * K + k] = 1.0
        obs[base + 3 * K: base + 6 * K] = self.mask
        obs[base + 6 * K + OUTCOMES.index(self.last_outcome)] = 1.0
        if self.memory:  # how often this episode the robot believed itself in each stance a move leads to
            m = base + 6 * K + len(OUTCOMES)
            visits, stance = self._visits, self.est_holes
            obs[m] = min(visits.get(stance, 0), 4) / 4.0
            for k, h in enumerate(self.cand):
                if h < 0:
                    continue
                for arm in range(3):
                    nxt = stance[:arm] + (h,) + stance[arm + 1:]
                    obs[m + 1 + arm * K + k] = min(visits.get(nxt, 0), 4) / 4.0  # type: ignore[arg-type]
        if self.hints:  # the map's lower bound on the moves left, now and per move; moves failed here
            m = base + 6 * K + len(OUTCOMES) + ((3 * K + 1) if self.memory else 0)
            stance, hops = self.est_holes, self._hops
            now = stance_hops(hops, stance)
            obs[m] = min(now, 20) / 10.0
            for k, h in enumerate(self.cand):
                if h < 0:
                    continue
                for arm in range(3):
                    nxt = stance[:arm] + (h,) + stance[arm + 1:]
                    obs[m + 1 + arm * K + k] = max(-2, min(2, stance_hops(hops, nxt) - now)) / 2.0
                    obs[m + 1 + 3 * K + arm * K + k] = float((stance, arm, h) in self._failed)
        return np.clip(obs, -_CLIP, _CLIP).astype(np.float32)

    def _info(self, success: bool = False) -> dict[str, Any]:
        ids = self.holes.ids  # type: ignore[union-attr]
        return {
            "is_success": bool(success),
            "action_mask": self.mask.copy(),
            "outcome": self.last_outcome,
            "reason": self.last_reason,
            "moves": self.moves,
            "true_pose": np.asarray(self.sim.pose, dtype=float).copy(),
            "estimated_pose": self._est_pose(),
            "stance": tuple(tuple(int(v) for v in ids[h]) for h in self.sim.stance),
            "goal": tuple(int(v) for v in ids[self.goal]),
            "planner_moves": self.planner_moves,
            "wall": self.holes.name,  # type: ignore[union-attr]
        }

    @property
    def believed_stance(self) -> tuple[int, int, int]:
        """The holes (map rows) the robot believes it holds - what its localiser says."""
        return self.est_holes

    @property
    def candidates(self) -> list[int]:
        """This step's candidate holes (map rows; -1 where there are fewer than K)."""
        return list(self.cand)

    def action_for(self, arm: int, hole: int) -> int | None:
        """The action that moves ``arm`` (0..2) to ``hole`` (map row), None if not offered."""
        return arm * self.K + self.cand.index(hole) if hole in self.cand else None

    def action_masks(self) -> np.ndarray:
        """Feasible actions (sb3-contrib's MaskablePPO calls this)."""
        return self.mask.copy()

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None
        if self.mode == "physics":
            # pymunk does not replay bit-identically from a copied space: the copy rebuilds
            # it by replaying this episode from its seeded start instead
            state["sim"] = None
            state["_replay"] = (getattr(self, "_episode_rng", None), list(getattr(self, "_history", [])))
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        replay = state.pop("_replay", None)
        self.__dict__.update(state)
        if self.mode == "physics":
            self.sim = PhysicsClimber(self.model)
            if replay is not None and replay[0] is not None:
                start_state, history = replay
                now = self.np_random.bit_generator.state
                self.np_random.bit_generator.state = start_state
                self._begin_episode()
                for a in history:
                    self.step(a)
                self.np_random.bit_generator.state = now

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; make the env with render_mode='rgb_array'")
            return None
        if self.holes is None:
            raise RuntimeError("call reset() before render()")
        from kinegym.envs.draw import draw_climb

        frame = draw_climb(self.holes, self.goal, self.sim.pose, self.sim.q, self.model.geom, self._est_pose(),
                           [h for h in self.cand if h >= 0], self.mask, self.K,
                           [f"move {self.moves}: {self.last_outcome}", self.last_reason[:70]])
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from kinegym.envs.viewer import Window

            self._window = Window("kinegym HoleClimb-v0", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None
