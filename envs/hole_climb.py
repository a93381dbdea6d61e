"""HoleClimb-v0: the three-armed climber of seed 000 climbs a wall of holes to a goal hole.

## Description

The robot hangs from three holes of a vertical wall (gravity along -y). Each step it moves
one arm to another hole with the seed's gait - shift the body with all three hands
gripping, release one hand, swing it round the body to the new hole, grip
(:mod:`kinegym.envs.sim.gait`). It sees only what its six joint encoders and the localiser
(:class:`kinegym.kinematics.localization.Localizer`, tracking after every move) tell it: an
estimated body pose with its uncertainty and which holes it believes it holds. An episode
ends when an arm grips the goal hole, or when the robot falls.

``mode="kinematic"`` (default) judges moves analytically (microseconds); ``mode="physics"``
simulates each move in pymunk with torque-limited servos and grippers that let go.

As panda-gym splits robot and task, the env is a thin join of :class:`~kinegym.envs.climb_task.ClimbTask`
(walls, start, goal, route proof, reward, hints) and :class:`~kinegym.envs.climb_robot.ClimbRobot`
(simulation, encoders, localiser -> believed stance and the moves it offers).

## Action Space

``Discrete(3 * K)`` (``K = candidates``, default 8): action ``a`` moves arm ``a // K``
(0, 1, 2 = arms 1, 2, 3) to candidate ``a % K`` - the ``K`` holes nearest the centroid of
the holes the robot believes it holds, nearest first
(:func:`kinegym.envs.climb_task.candidate_holes`). Actions the robot's own gait
model judges infeasible, and moves that already failed from the believed stance this
episode (a failed move leaves the robot on its holes; it remembers the failure and looks for
another way), are masked: ``action_masks()`` and ``info["action_mask"]``.
A masked action, an action out of range or of the wrong type (a string, a float, a bool)
raises :class:`~kinegym.envs.errors.InvalidActionError` naming the valid actions;
``masked="fail"`` instead lets a masked move be tried (it fails as ``unreachable`` and
costs a move, and the observation flags it). ``step()`` before ``reset()`` or after the
episode ended raises :class:`~kinegym.envs.errors.ResetNeededError`.

## Observation Space

``Box(-20, 20, (N,), float32)`` with ``N = 14 + 6 K + 6`` (68 for K = 8); lengths in units of the
arm reach ``R`` (l1 + l2, 20 cm for the seed robot), all relative to the *estimated* body:

| index | part (:func:`observation_layout`) | observation | unit |
|---|---|---|---|
| 0, 1 | `goal` | goal hole minus estimated centre, x and y | R |
| 2 | `goal_distance` | distance from the estimated centre to the goal | R |
| 3, 4 | `heading` | cos and sin of the estimated heading | - |
| 5, 6, 7 | `uncertainty` | 1-sigma uncertainty of the estimate: x, y, heading | cm, cm, deg |
| 8 - 13 | `held` | held hole of arm 1, 2, 3 minus estimated centre (x, y each) | R |
| 14 - 14+2K-1 | `candidates` | candidate hole k minus estimated centre (x, y each); 0 if absent | R |
| 14+2K - 14+3K-1 | `candidate_exists` | candidate k exists (1) or not (0) | - |
| 14+3K - 14+6K-1 | `action_mask` | action mask: arm j to candidate k feasible (index j K + k) | - |
| 14+6K - 14+6K+5 | `last_outcome` | last move's outcome, one-hot: ok, unreachable, torque_limit, missed_hole, |  |
|  |  | grip_lost, fell (:data:`OUTCOMES`) | - |

With ``memory=True`` (what the training config uses) ``3 K + 1`` entries follow (93 in all
for K = 8; parts `visits_here`, `visits_next`): how many times this episode the robot believed
itself in its current stance, then per action ``j K + k`` in the stance that move leads to - each
``min(count, 4) / 4`` (:data:`VISITS_SEEN` = 4).
A deterministic policy without them can only cycle once it has looped (they are what the
gait policy needs to break cycles; see the README's training section).

With ``hints=True`` ``6 K + 1`` entries follow (142 in all for K = 8 with ``memory``; parts
`hops_now`, `hops_change`, `failed_here`): the
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

Terminated when an arm grips the goal hole (``info["is_success"] = True``), when the robot
falls (fewer than two grips; ``info["reason"]`` says what gave way), or when no move is left
to try from where the robot believes it is (the action mask is all False: every move the
gait model allows from this stance already failed this episode, or it allows none;
``info["stuck"] = True``). Truncated by ``max_episode_steps`` (200 moves when made with
``gymnasium.make``).

## Arguments

``gymnasium.make("kinegym/HoleClimb-v0", mode="kinematic", wall="generated", robot="climber",
wall_kwargs=None, wall_pool=0, wall_pool_seed=0, masked="raise", render_mode=None)``. ``memory``,
``hints`` and ``candidates`` change the observation space, so each variant is its own id
(:mod:`kinegym.envs.variants`): ``kinegym/HoleClimbMemory-v0`` (``memory=True``) and
``kinegym/HoleClimbMemoryHints-v0`` (both; what training uses). ``HoleClimbEnv(...)`` made
directly takes every value of them, and a
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

## Version History

* v0 (kinegym 0.1): the first release. Within v0, before 1.0: the observation variants
  became their own ids (``kinegym/HoleClimbMemory-v0``, ``kinegym/HoleClimbMemoryHints-v0``;
  ``memory``/``hints`` are no longer ``gymnasium.make`` arguments of this id), and
  ``action_masks()`` before ``reset()`` raises ``ResetNeededError``. Then (issue 17) the gait
  rests on its three holes between moves and its model checks the whole motion (shift paths,
  the statics along the swing), so masks and poses changed; a move that failed is masked
  from that stance for the episode, and no move left ends the episode as ``terminated``
  (``info["stuck"]``; it was ``truncated``).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

import kinegym.configs as _configs
from kinegym.envs.climb_robot import ClimbRobot
from kinegym.envs.climb_task import WALL_DEFAULTS, ClimbTask, RouteFinder, WallKwargsSpec, moved_hops, stance_hops
from kinegym.envs.errors import ResetNeededError, check_action
from kinegym.envs.sim.climber_model import OUTCOMES, ClimberModel
from kinegym.kinematics.holes import HoleMap

__all__ = ["HoleClimbEnv", "WALL_DEFAULTS", "RouteFinder", "observation_layout", "VISITS_SEEN"]

#: Visit counts in the observation (``memory=True``) are ``min(count, VISITS_SEEN) / VISITS_SEEN``.
VISITS_SEEN = 4

_CLIP = 20.0


def observation_layout(candidates: int = 8, memory: bool = False, hints: bool = False) -> dict[str, slice]:
    """Where each part of the observation lies, in order (the table above, for any ``K``)."""
    K = candidates
    parts = [("goal", 2), ("goal_distance", 1), ("heading", 2), ("uncertainty", 3), ("held", 6),
             ("candidates", 2 * K), ("candidate_exists", K), ("action_mask", 3 * K), ("last_outcome", len(OUTCOMES))]
    if memory:
        parts += [("visits_here", 1), ("visits_next", 3 * K)]
    if hints:
        parts += [("hops_now", 1), ("hops_change", 3 * K), ("failed_here", 3 * K)]
    out, start = {}, 0
    for name, n in parts:
        out[name] = slice(start, start + n)
        start += n
    return out


#: What ``gymnasium.make(ENV_ID, ...)`` accepts from a YAML file (training configs): every
#: keyword of :class:`HoleClimbEnv` but ``render_mode`` and ``route_finder`` (objects, not data).
ENV_KWARGS_SCHEMA: dict[str, _configs.Spec] = {
    "mode": _configs.Text(choices=("kinematic", "physics"), default="kinematic"),
    "wall": _configs.Text(default="generated", doc="'generated' or a wall config name / YAML path"),
    "robot": _configs.Text(default="climber", doc="robot config name or YAML path"),
    "candidates": _configs.Number(lo=1, hi=32, integer=True, default=8),
    "wall_kwargs": WallKwargsSpec(default={}, doc="generated walls' settings: cols, rows, spacing_cm, ..."),
    "memory": _configs.Flag(default=False),
    "hints": _configs.Flag(default=False),
    "wall_pool": _configs.Number(lo=0, hi=1_000_000, integer=True, default=0),
    "wall_pool_seed": _configs.Number(lo=0, hi=2**32 - 1, integer=True, default=0),
    "masked": _configs.Text(choices=("raise", "fail"), default="raise"),
}


class HoleClimbEnv(gym.Env[np.ndarray, np.int64]):
    """The climber on a wall of holes (see the module docstring for the tables)."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(self, render_mode: str | None = None, mode: str = "kinematic", wall: str | HoleMap = "generated",
                 robot: str = "climber", candidates: int = 8, wall_kwargs: dict[str, Any] | None = None,
                 route_finder: RouteFinder | None = None, memory: bool = False, hints: bool = False,
                 wall_pool: int = 0, wall_pool_seed: int = 0, masked: str = "raise") -> None:
        if masked not in ("raise", "fail"):
            raise ValueError(f"masked={masked!r}; expected 'raise' (a masked action is an error) or 'fail'")
        self.masked = masked
        self._done = True
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r}; expected one of {self.metadata['render_modes']} or None")
        if mode not in ("kinematic", "physics"):
            raise ValueError(f"mode={mode!r}; expected 'kinematic' or 'physics'")
        if not (isinstance(candidates, int) and 1 <= candidates <= 32):
            raise ValueError(f"candidates={candidates!r}; expected an integer 1..32")
        self.render_mode, self.mode, self.K = render_mode, mode, candidates
        self.memory, self.hints = bool(memory), bool(hints)
        self.robot_name = robot
        self.model = ClimberModel.from_config(robot)
        self.task = ClimbTask(self.model, robot, wall, wall_kwargs, candidates, route_finder, self.hints, wall_pool,
                              wall_pool_seed)
        self.robot = ClimbRobot(self.model, mode)
        self.reach = self.task.reach
        self.layout = observation_layout(candidates, self.memory, self.hints)
        n_obs = next(reversed(self.layout.values())).stop
        self.observation_space = spaces.Box(-_CLIP, _CLIP, (n_obs,), np.float32)
        self.action_space = spaces.Discrete(3 * candidates)
        self._window = None
        self.holes: HoleMap | None = None

    # ------------------------------------------------------------------ the parts, by their old names
    @property
    def sim(self) -> Any:
        """The robot's simulation (true pose ``sim.pose``, true stance ``sim.stance``)."""
        return self.robot.sim

    @property
    def goal(self) -> int:
        return self.task.goal

    @property
    def planner_moves(self) -> int:
        return self.task.planner_moves

    @property
    def fix(self) -> Any:
        return self.robot.fix

    @property
    def _hops(self) -> list[int]:
        return self.task.hops

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self._episode_rng = self.np_random.bit_generator.state  # to rebuild the episode after unpickling
        return self._begin_episode()

    def _begin_episode(self) -> tuple[np.ndarray, dict]:
        self.task.new_episode(self.np_random)
        self.holes = self.task.holes
        self.robot.reset(self.holes, self.task.start, self.np_random)
        self.moves, self.last_outcome, self.last_reason = 0, "ok", "start"
        self._prev_dist = self.task.goal_distance(self.sim.pose)
        self._history: list[int] = []
        self._visits: dict[tuple[int, int, int], int] = {self.believed_stance: 1}  # believed stances this episode
        self._failed: set[tuple[tuple[int, int, int], int, int]] = set()  # (stance, arm, hole) that failed
        self.cand, self.mask = self._options()
        self._done = False
        return self._obs(), self._info()

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self.holes is None or getattr(self, "_done", False):
            raise ResetNeededError("step() without a live episode: call reset() first (the episode ended or "
                                   "never began)")
        a = check_action(action, 3 * self.K, self.mask if self.masked == "raise" else None)
        self._history.append(a)
        arm, k = divmod(a, self.K)
        hole = self.cand[k]
        self.moves += 1
        if hole < 0:
            outcome, reason = "unreachable", f"there is no candidate {k}"
        else:
            outcome, reason = self.robot.move(arm, hole, offered=bool(self.mask[a]))
        self.last_outcome, self.last_reason = outcome, reason
        if outcome != "ok":
            self._failed.add((self.believed_stance, arm, hole))
        fell = outcome == "fell"
        if not fell:
            ok = outcome == "ok"
            self.robot.relocalise(arm + 1 if ok else None, self.np_random, hole if ok else None)
            self._visits[self.believed_stance] = self._visits.get(self.believed_stance, 0) + 1
        dist = self.task.goal_distance(self.sim.pose)
        success = self.goal in self.sim.stance and not fell
        reward = self.task.reward(self._prev_dist, dist, success, fell)
        self._prev_dist = dist
        self.cand, self.mask = self._options()
        obs = self._obs()
        stuck = not fell and not success and not self.mask.any()  # no move left to try from here
        self._done = bool(success or fell or stuck)
        if self.render_mode == "human":
            self.render()
        info = self._info(success)
        if stuck:
            info["stuck"] = True
        return obs, reward, self._done, False, info

    def _options(self) -> tuple[list[int], np.ndarray]:
        """This stance's candidates and mask: the robot's gait model, less the moves that
        already failed from this (believed) stance this episode - the robot remembers them."""
        cand, mask = self.robot.options(self.K, self.reach, self.task.stance_cache)
        stance = self.believed_stance
        for st, arm, hole in self._failed:
            if st == stance and hole in cand:
                mask[arm * self.K + cand.index(hole)] = False
        return cand, mask

    # ------------------------------------------------------------------ observation and info
    def _obs(self) -> np.ndarray:
        K, R, lay = self.K, self.reach, self.layout
        est = self.robot.est_pose()
        xy = self.holes.xy  # type: ignore[union-attr]
        obs = np.zeros(self.observation_space.shape, dtype=np.float64)
        g = xy[self.goal]
        obs[lay["goal"]] = (g[0] - est[0]) / R, (g[1] - est[1]) / R
        obs[lay["goal_distance"]] = math.hypot(*obs[lay["goal"]])
        obs[lay["heading"]] = math.cos(est[2]), math.sin(est[2])
        if self.fix is not None:
            std = np.sqrt(np.clip(np.diag(self.fix.covariance), 0.0, None))
            obs[lay["uncertainty"]] = std[0], std[1], math.degrees(std[2])
        else:
            obs[lay["uncertainty"]] = _CLIP
        stance = self.believed_stance
        obs[lay["held"]] = ((xy[list(stance)] - est[:2]) / R).ravel()
        cands, exists = lay["candidates"].start, lay["candidate_exists"].start
        for k, h in enumerate(self.cand):
            if h >= 0:
                obs[cands + 2 * k], obs[cands + 2 * k + 1] = (xy[h, 0] - est[0]) / R, (xy[h, 1] - est[1]) / R
                obs[exists + k] = 1.0
        obs[lay["action_mask"]] = self.mask
        obs[lay["last_outcome"].start + OUTCOMES.index(self.last_outcome)] = 1.0
        if self.memory:  # how often this episode the robot believed itself in each stance a move leads to
            visits = self._visits
            obs[lay["visits_here"]] = min(visits.get(stance, 0), VISITS_SEEN) / VISITS_SEEN
            seen = [0.0] * (3 * K)
            for k, h in enumerate(self.cand):
                if h >= 0:
                    for arm in range(3):
                        nxt = stance[:arm] + (h,) + stance[arm + 1:]
                        seen[arm * K + k] = min(visits.get(nxt, 0), VISITS_SEEN) / VISITS_SEEN  # type: ignore[arg-type]
            obs[lay["visits_next"]] = seen
        if self.hints:  # the map's lower bound on the moves left, now and per move; moves failed here
            obs[lay["hops_now"].start:lay["failed_here"].stop] = self._hints(stance)
        return np.clip(obs, -_CLIP, _CLIP).astype(np.float32)

    def _hints(self, stance: tuple[int, int, int]) -> list[float]:
        """The ``hints`` part of the observation (``hops_now``, ``hops_change``, ``failed_here``)."""
        K, hops = self.K, self.task.hops
        now = stance_hops(hops, stance)
        after = moved_hops(hops, stance, self.cand)
        failed = {(arm, h) for st, arm, h in self._failed if st == stance}
        change, fail = [0.0] * (3 * K), [0.0] * (3 * K)
        for k, h in enumerate(self.cand):
            if h >= 0:
                for arm in range(3):
                    change[arm * K + k] = max(-2, min(2, after[arm][k] - now)) / 2.0
                    fail[arm * K + k] = float((arm, h) in failed)
        return [min(now, 20) / 10.0, *change, *fail]

    def _info(self, success: bool = False) -> dict[str, Any]:
        ids = self.holes.ids  # type: ignore[union-attr]
        return {
            "is_success": bool(success),
            "action_mask": self.mask.copy(),
            "outcome": self.last_outcome,
            "reason": self.last_reason,
            "moves": self.moves,
            "true_pose": np.asarray(self.sim.pose, dtype=float).copy(),
            "estimated_pose": self.robot.est_pose(),
            "stance": tuple(tuple(int(v) for v in ids[h]) for h in self.sim.stance),
            "goal": tuple(int(v) for v in ids[self.goal]),
            "planner_moves": self.planner_moves,
            "wall": self.holes.name,  # type: ignore[union-attr]
        }

    @property
    def believed_stance(self) -> tuple[int, int, int]:
        """The holes (map rows) the robot believes it holds - what its localiser says."""
        return self.robot.est_holes

    @property
    def failed_moves(self) -> frozenset[tuple[tuple[int, int, int], int, int]]:
        """``(believed stance, arm, hole)`` of every move that failed this episode (masked there)."""
        return frozenset(self._failed)

    @property
    def candidates(self) -> list[int]:
        """This step's candidate holes (map rows; -1 where there are fewer than K)."""
        return list(self.cand)

    def action_for(self, arm: int, hole: int) -> int | None:
        """The action that moves ``arm`` (0..2) to ``hole`` (map row), None if not offered."""
        return arm * self.K + self.cand.index(hole) if hole in self.cand else None

    def action_masks(self) -> np.ndarray:
        """Feasible actions (sb3-contrib's MaskablePPO calls this). Through ``gymnasium.make``'s
        wrappers: ``env.get_wrapper_attr("action_masks")()``; on an SB3 vector env:
        ``sb3_contrib.common.maskable.utils.get_action_masks(vec_env)``. Before the first
        ``reset()`` there is no wall: :class:`~kinegym.envs.errors.ResetNeededError`."""
        if self.holes is None:
            raise ResetNeededError("action_masks() before reset(): the feasible moves depend on the wall and "
                                   "stance that reset() makes; call reset() first")
        return self.mask.copy()

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None
        if self.mode == "physics":
            # pymunk does not replay bit-identically from a copied space: the copy rebuilds
            # it by replaying this episode from its seeded start instead
            robot = state["robot"] = object.__new__(ClimbRobot)
            robot.__dict__.update({**self.robot.__dict__, "sim": None})
            state["_replay"] = (getattr(self, "_episode_rng", None), list(getattr(self, "_history", [])))
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        replay = state.pop("_replay", None)
        self.__dict__.update(state)
        if self.mode == "physics":
            self.robot.sim = self.robot.new_sim()
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

        frame = draw_climb(self.holes, self.goal, self.sim.pose, self.sim.q, self.model.geom, self.robot.est_pose(),
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
