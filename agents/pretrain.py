"""A warm start for the gait policy: behaviour cloning from the planner's climbs.

PPO from scratch spends most of a 15-minute budget learning what a climb looks like; the
planner (:class:`kinegym.agents.gait_planner.PlannerAgent`) already climbs every training
wall. ``kinegym train gait`` with ``bc_episodes: N`` in the config first lets the planner
climb ``N`` training tasks in the training env (same ids, same pool, same observations,
masks and rewards), then fits the MaskablePPO policy to those climbs before PPO starts:

* the action head by the masked log-likelihood of the planner's moves
  (``policy.evaluate_actions(obs, actions, action_masks)``, as MaskablePPO itself scores
  actions), so the policy starts out climbing;
* the value head by regression on each climb's discounted return (the config's ``gamma``),
  so PPO's first advantages are not measured against an untrained critic, which would
  undo the cloned moves in the first updates.

With ``dagger_rounds: R`` the clone is then corrected where it goes astray (DAgger, Ross,
Gordon and Bagnell 2011): each round the cloned policy climbs ``dagger_episodes`` training
tasks itself (deterministic moves, as it is evaluated), the planner labels every state the
policy visited with its own move from there (:func:`policy_labels`: it replans from the stance
the robot believes it holds), those rows join the clone set and the policy is fitted to it all
again. A cloned policy fails by cycling in states the planner's climbs never showed; labelled
there, it leaves them. The value head is fitted on the planner's climbs only (a labelled
state has no return of the planner's to learn).

With ``workers=k`` both are shared among ``k`` processes (forkserver, as the training envs):
the episodes are split into ``k`` runs of consecutive climbs, run ``j``'s first reset seeded
``seed + j * CHUNK_SEED``, and the rows joined in run order, so the result depends on ``k``
but not on which process finishes first (``k = 1``: one run seeded ``seed``, in this process).
The policy travels to the processes as :class:`GreedyPolicy` (its class, constructor
parameters and weights), each on one torch thread.

PPO then learns from there as usual; the planner is never consulted again (not in
training's later phase, not at evaluation: the policy acts from its observations alone).
The planner is weighted A*, so its climbs are good, not optimal: the policy can improve on
them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from .parallel import in_order


@dataclass
class Demos:
    """The planner's climbs as arrays: one row per move (observations, actions, the env's
    masks, and the discounted return from that move on)."""

    obs: np.ndarray
    actions: np.ndarray
    masks: np.ndarray
    returns: np.ndarray
    episodes: int
    climbed: int

    def __len__(self) -> int:
        return len(self.actions)

    def joined(self, other: Demos) -> Demos:
        """These rows and ``other``'s (episodes and climbs added up)."""
        return Demos(np.concatenate([self.obs, other.obs]), np.concatenate([self.actions, other.actions]),
                     np.concatenate([self.masks, other.masks]), np.concatenate([self.returns, other.returns]),
                     self.episodes + other.episodes, self.climbed + other.climbed)


#: run ``j`` of a job shared among processes has its first reset seeded ``seed + j * CHUNK_SEED``
CHUNK_SEED = 1_000_003


def _runs(episodes: int, seed: int, workers: int) -> list[tuple[int, int]]:
    """``(episodes, seed)`` of each process's run: ``episodes`` split as evenly as can be among
    ``min(workers, episodes)`` runs, the first ones one longer."""
    if episodes < 1:
        raise ValueError(f"episodes={episodes!r}; expected >= 1")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers={workers!r}; expected an integer >= 1")
    k = min(workers, episodes)
    return [(episodes // k + (j < episodes % k), int(seed) + j * CHUNK_SEED) for j in range(k)]


def _shared(job: Callable[..., Any], runs: Sequence[tuple[int, int]], args: tuple,
            progress: Callable[[int], None] | None) -> list[Any]:
    """``job(*args, run)`` for each ``run = (episodes, seed)``, in this process for one run (with
    ``progress``), else each in a forkserver process (:func:`kinegym.agents.parallel.in_order`);
    the results in run order (``progress(n)`` as each run of ``n`` ends)."""
    if len(runs) == 1:
        return [job(*args, runs[0], progress=progress)]
    done = None if progress is None else (lambda run: progress(run[0]))
    return in_order(partial(job, *args), runs, len(runs), done, start_method="forkserver")


class GreedyPolicy:
    """A MaskablePPO policy as :func:`policy_labels` calls it: ``act(obs, mask) -> move``, its
    greedy masked choice (as the policy is evaluated). Pickled, it travels as the policy's
    class, constructor parameters and weights and is rebuilt on the other side, on one torch
    thread (SB3's own policy ``save``/``load`` route, in memory)."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy

    def __call__(self, obs: np.ndarray, mask: np.ndarray) -> int:
        return int(self.policy.predict(obs, action_masks=mask, deterministic=True)[0])

    def __getstate__(self) -> dict[str, Any]:
        p = self.policy
        return {"cls": type(p), "params": p._get_constructor_parameters(),
                "weights": {k: v.detach().cpu() for k, v in p.state_dict().items()}}

    def __setstate__(self, state: dict[str, Any]) -> None:
        import torch as th

        th.set_num_threads(1)
        policy = state["cls"](**state["params"])
        policy.load_state_dict(state["weights"])
        policy.set_training_mode(False)
        self.policy = policy


class _Recorder:
    """An agent that lets ``inner`` act and keeps what it saw and chose (the observation,
    the env's action mask, the action) for every move it made."""

    def __init__(self, inner: Any, obs: list[np.ndarray], masks: list[np.ndarray], acts: list[int]) -> None:
        self.inner, self.obs, self.masks, self.acts = inner, obs, masks, acts

    def act(self, env: Any, obs: Any = None) -> int | None:
        a = self.inner.act(env, obs)
        if a is not None:
            self.obs.append(np.asarray(obs, dtype=np.float32))
            self.masks.append(np.asarray(env.action_masks(), dtype=bool))
            self.acts.append(int(a))
        return a


def planner_demos(make_env: Callable[..., Any], env_kwargs: dict[str, Any], episodes: int, seed: int, gamma: float,
                  progress: Callable[[int], None] | None = None, weight: float = 2.0, workers: int = 1) -> Demos:
    """``episodes`` climbs of the planner in ``make_env(**env_kwargs)``, played by the project's
    one episode loop (:func:`kinegym.agents.rollout.run_episode`), the first reset seeded
    ``seed`` (a pool env then draws its tasks from its own seeded generator, as in training).
    Episodes in which the planner finds no route from where the robot is are kept up to there
    (rare: walls are accepted only with a route). ``progress(1)`` after each episode (with several
    workers ``progress(n)`` as each process's ``n`` end). ``weight``:
    the planner's A* weight (:class:`~kinegym.agents.gait_planner.PlannerAgent`). ``workers``:
    processes sharing the climbs (module docstring; ``make_env`` then a module-level function)."""
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma={gamma!r}; expected 0..1")
    parts = _shared(_planner_run, _runs(episodes, seed, workers), (make_env, env_kwargs, gamma, weight), progress)
    return _joined(parts)


def _joined(parts: Sequence[Demos]) -> Demos:
    out = parts[0]
    for p in parts[1:]:
        out = out.joined(p)
    return out


def _planner_run(make_env: Callable[..., Any], env_kwargs: dict[str, Any], gamma: float, weight: float,
                 run: tuple[int, int], progress: Callable[[int], None] | None = None) -> Demos:
    """One process's share of :func:`planner_demos`: ``run = (episodes, seed)``."""
    from kinegym.agents.gait_planner import PlannerAgent
    from kinegym.agents.rollout import run_episode

    episodes, seed = run
    env = make_env(**env_kwargs)
    obs_rows: list[np.ndarray] = []
    acts: list[int] = []
    masks: list[np.ndarray] = []
    rets: list[float] = []
    climbed = 0
    try:
        for i in range(episodes):
            ep = run_episode(env, _Recorder(PlannerAgent(weight), obs_rows, masks, acts),
                             seed=int(seed) if i == 0 else None)
            climbed += ep.success
            g, back = 0.0, []
            for r in reversed(ep.rewards):
                g = r + gamma * g
                back.append(g)
            rets.extend(reversed(back))
            if progress is not None:
                progress(1)
    finally:
        env.close()
    n_obs = int(np.prod(env.observation_space.shape))
    return Demos(np.asarray(obs_rows, np.float32).reshape(-1, n_obs), np.asarray(acts, np.int64),
                 np.asarray(masks, bool).reshape(len(acts), -1), np.asarray(rets, np.float32), episodes, climbed)


class _Labeller:
    """An agent that lets ``act(obs, mask)`` choose the move and keeps, for every state it
    meets, the observation, the env's mask and the planner's move from there (none where the
    planner finds no route)."""

    def __init__(self, act: Callable[[np.ndarray, np.ndarray], int], rows: tuple[list, list, list],
                 stats: dict[str, int], weight: float = 2.0) -> None:
        from kinegym.agents.gait_planner import PlannerAgent

        self.choose, self.rows, self.stats, self.expert = act, rows, stats, PlannerAgent(weight)

    def act(self, env: Any, obs: Any = None) -> int:
        mask = np.asarray(env.action_masks(), dtype=bool)
        label = self.expert.act(env, obs)
        a = int(self.choose(np.asarray(obs, dtype=np.float32), mask))
        self.stats["states"] += 1
        if label is None:
            self.stats["no_route"] += 1
        else:
            self.rows[0].append(np.asarray(obs, dtype=np.float32))
            self.rows[1].append(mask)
            self.rows[2].append(int(label))
            self.stats["differed"] += int(label != a)
        return a


def policy_labels(make_env: Callable[..., Any], env_kwargs: dict[str, Any],
                  act: Callable[[np.ndarray, np.ndarray], int], episodes: int, seed: int,
                  progress: Callable[[int], None] | None = None, weight: float = 2.0,
                  workers: int = 1) -> tuple[Demos, dict[str, int]]:
    """One DAgger round's data: ``act(obs, mask) -> move`` climbs ``episodes`` tasks of
    ``make_env(**env_kwargs)`` (the first reset seeded ``seed``), played by the project's one
    episode loop; every state it visits is labelled with the planner's move from there. The
    rows' returns are NaN (no return of the planner's from there). Also: states visited, states
    without a route, states where the planner chose otherwise, and the climbs that succeeded.
    ``weight``: the labelling planner's A* weight. ``workers``: processes sharing the climbs
    (module docstring; ``act`` must then pickle, as :class:`GreedyPolicy` does)."""
    parts = _shared(_label_run, _runs(episodes, seed, workers), (make_env, env_kwargs, act, weight), progress)
    stats = {k: sum(p[1][k] for p in parts) for k in parts[0][1]}
    return _joined([p[0] for p in parts]), stats


def _label_run(make_env: Callable[..., Any], env_kwargs: dict[str, Any], act: Callable[[np.ndarray, np.ndarray], int],
               weight: float, run: tuple[int, int],
               progress: Callable[[int], None] | None = None) -> tuple[Demos, dict[str, int]]:
    """One process's share of :func:`policy_labels`: ``run = (episodes, seed)``."""
    from kinegym.agents.rollout import run_episode

    episodes, seed = run
    rows: tuple[list, list, list] = ([], [], [])
    stats = {"states": 0, "no_route": 0, "differed": 0, "climbed": 0}
    env = make_env(**env_kwargs)
    try:
        for i in range(episodes):
            ep = run_episode(env, _Labeller(act, rows, stats, weight), seed=int(seed) if i == 0 else None)
            stats["climbed"] += ep.success
            if progress is not None:
                progress(1)
    finally:
        env.close()
    n, n_obs = len(rows[2]), int(np.prod(env.observation_space.shape))
    return Demos(np.asarray(rows[0], np.float32).reshape(n, n_obs), np.asarray(rows[2], np.int64),
                 np.asarray(rows[1], bool).reshape(n, -1), np.full(n, np.nan, np.float32), episodes,
                 stats["climbed"]), stats


def clone(policy: Any, demos: Demos, epochs: int = 10, batch_size: int = 256, lr: float = 1e-3,
          vf_coef: float = 0.5, max_grad_norm: float = 0.5, seed: int = 0) -> dict[str, float]:
    """Fit a MaskablePPO ``policy`` to ``demos``: the masked negative log-likelihood of the
    planner's moves plus ``vf_coef`` times the squared error of the value head on the
    returns, ``epochs`` passes in shuffled batches (a seeded torch generator) with Adam, the
    gradient's norm clipped to ``max_grad_norm`` as PPO clips it.
    Rows whose return is NaN (:func:`policy_labels`) count for the action head only.
    Returns the last epoch's mean losses and the share of demo moves the policy's greedy
    (masked) choice now matches."""
    import torch as th

    if len(demos) == 0:
        raise ValueError("no demonstration moves to clone (the planner found no route on any task)")
    if epochs < 1 or batch_size < 1:
        raise ValueError(f"epochs={epochs!r}, batch_size={batch_size!r}; expected >= 1 each")
    dev = policy.device
    obs = th.as_tensor(demos.obs, device=dev)
    act = th.as_tensor(demos.actions, device=dev)
    has_ret = th.as_tensor(~np.isnan(demos.returns), device=dev)
    partial = not bool(has_ret.all())
    ret = th.as_tensor(np.nan_to_num(demos.returns), device=dev)
    masks = demos.masks
    opt = th.optim.Adam(policy.parameters(), lr=lr)
    gen = th.Generator().manual_seed(int(seed))
    n = len(demos)
    policy.set_training_mode(True)
    nll_sum = vf_sum = 0.0
    for _ in range(epochs):
        order = th.randperm(n, generator=gen)
        nll_sum = vf_sum = 0.0
        for i in range(0, n, batch_size):
            idx = order[i:i + batch_size]
            values, log_prob, _ = policy.evaluate_actions(obs[idx], act[idx], action_masks=masks[idx.numpy()])
            nll = -log_prob.mean()
            if partial:  # the squared error over the rows with a return only
                w = has_ret[idx].float()
                vf = (w * (values.flatten() - ret[idx]) ** 2).sum() / w.sum().clamp(min=1.0)
            else:
                vf = th.nn.functional.mse_loss(values.flatten(), ret[idx])
            loss = nll + vf_coef * vf
            opt.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(policy.parameters(), max_grad_norm)
            opt.step()
            nll_sum += nll.item() * len(idx)
            vf_sum += vf.item() * len(idx)
    policy.set_training_mode(False)
    with th.no_grad():
        dist = policy.get_distribution(obs, action_masks=masks)
        greedy = dist.get_actions(deterministic=True)
    return {"nll": nll_sum / n, "value_mse": vf_sum / n, "agreement": float((greedy == act).float().mean()),
            "moves": float(n)}
