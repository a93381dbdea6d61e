"""Policies as agents for kinegym's environments, and the one way a saved model is read.

:func:`load_maskable` reads a MaskablePPO ``.zip`` through the bounded reader
(:func:`kinegym.configs.io.read_bytes`), checks it is an SB3 archive, and loads it **without
unpickling anything from the file**: SB3 keeps some attributes (the spaces, schedules, the
policy class, buffers) as cloudpickle blobs, which would run code from an untrusted file; each
one kinegym knows is supplied by the caller instead (``custom_objects``: the env's spaces, the
config's schedules, the policy class), and a file holding any other pickled object is refused
with a :class:`~kinegym.configs.io.FileError` that says so. The network weights are read by
torch with ``weights_only=True`` (SB3's own choice). A damaged, empty or foreign file is a
``FileError`` too, never a traceback from deep inside SB3.

:class:`MaskedPolicyAgent` puts a loaded model behind the same ``act(env, obs)`` interface as
the planner (:class:`kinegym.agents.gait_planner.PlannerAgent`).
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

import kinegym.configs as _configs
from kinegym.configs.io import FileError, read_bytes

__all__ = ["MaskedPolicyAgent", "loop_guard_mask", "load_maskable", "read_archive", "policy_env_kwargs", "GAIT_ENV_ID",
           "POOL_KEYS", "MAX_MODEL_BYTES", "SAFE_KEYS"]

GAIT_ENV_ID = "kinegym/HoleClimb-v0"
#: env_kwargs of a training wall pool (dropped when a policy is judged: fresh walls)
POOL_KEYS = ("wall_pool", "wall_pool_seed")

#: Largest model file read (the gait policies are ~1 MB).
MAX_MODEL_BYTES = 512 << 20
#: Attributes SB3 pickles that kinegym supplies itself instead of unpickling them.
SAFE_KEYS = ("policy_class", "learning_rate", "lr_schedule", "clip_range", "clip_range_vf", "observation_space",
             "action_space", "rollout_buffer_class", "rollout_buffer_kwargs", "_last_obs", "_last_original_obs",
             "_last_episode_starts", "ep_info_buffer", "ep_success_buffer")


def policy_env_kwargs(policy: str | Path) -> dict[str, Any]:
    """The ``env_kwargs`` a saved policy was trained with (from its run's ``config.yaml``, next
    to the model or one folder up - ``best/`` and ``checkpoints/``), without ``mode`` and the
    training wall pool (policies are judged on fresh walls); ``{}`` for a model outside a
    run directory."""
    p = Path(policy)
    for d in (p.parent, p.parent.parent):
        f = d / "config.yaml"
        if f.is_file():
            saved = _configs.load_yaml(f)
            if not isinstance(saved, dict):
                return {}
            kw = dict((saved.get(GAIT_ENV_ID) or {}).get("env_kwargs") or {})
            for key in ("mode", *POOL_KEYS):
                kw.pop(key, None)
            return kw
    return {}


def _zero(_: float) -> float:
    return 0.0


def read_archive(path: str | Path) -> tuple[bytes, dict[str, Any]]:
    """The bytes of an SB3 model archive and its JSON ``data`` record (nothing unpickled);
    :class:`FileError` for anything that is not one."""
    data = read_bytes(path, MAX_MODEL_BYTES, "model file (.zip)")
    expected = "a MaskablePPO model saved by kinegym train or SB3's model.save (.zip)"
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            names = set(zf.namelist())
            if not {"data", "policy.pth"} <= names:
                raise FileError(path, f"a zip without SB3's data and policy.pth (has {sorted(names)[:6]})", expected)
            meta = json.loads(zf.read("data").decode("utf-8"))
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError):
        raise FileError(path, "not a zip archive (damaged, empty or another format)", expected) from None
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise FileError(path, "an SB3 archive whose data record is not JSON", expected) from None
    if not isinstance(meta, dict):
        raise FileError(path, "an SB3 archive whose data record is not a mapping", expected)
    return data, meta


def load_maskable(path: str | Path, observation_space: Any, action_space: Any, env: Any = None,
                  learning_rate: Any = 0.0, clip_range: Any = 0.0, cls: Any = None, **kwargs: Any) -> Any:
    """A MaskablePPO model from ``path`` with the given spaces (and ``env`` to train on, with
    its ``learning_rate`` / ``clip_range`` as the config gives them); see the module docstring."""
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy

    data, meta = read_archive(path)
    pickled = sorted(k for k, v in meta.items() if isinstance(v, dict) and ":serialized:" in v)
    unknown = [k for k in pickled if k not in SAFE_KEYS]
    if unknown:
        raise FileError(path, f"pickled objects kinegym does not load from files ({', '.join(unknown)}); loading "
                        "them would run code from the file", "a MaskablePPO gait model (if you trust this file, "
                        "load it yourself with sb3_contrib.MaskablePPO.load)")
    custom = {"policy_class": MaskableActorCriticPolicy, "learning_rate": learning_rate, "lr_schedule": _zero,
              "clip_range": clip_range, "clip_range_vf": None, "observation_space": observation_space,
              "action_space": action_space, "rollout_buffer_class": None, "rollout_buffer_kwargs": {},
              "_last_obs": None, "_last_original_obs": None, "_last_episode_starts": None,
              "ep_info_buffer": None, "ep_success_buffer": None}
    try:
        return (cls or MaskablePPO).load(io.BytesIO(data), env=env, device="cpu",
                                custom_objects={k: custom[k] for k in pickled}, **kwargs)
    except FileError:
        raise
    except Exception as err:  # noqa: BLE001 - nothing is unpickled; any failure means a damaged or foreign file
        msg = " ".join(str(err).split())[:160]
        raise FileError(path, f"a model that does not fit this env or is damaged ({type(err).__name__}: {msg})",
                        "a model trained on an env with the same observation and action spaces") from None


def loop_guard_mask(obs: np.ndarray, mask: np.ndarray, layout: dict[str, slice] | None) -> np.ndarray:
    """``mask`` less the moves into stances the robot already believed itself in this episode
    (the observation's ``visits_next`` above 0), unless every offered move leads to such a
    stance; ``mask`` itself where ``layout`` (the env's
    :func:`~kinegym.envs.hole_climb.observation_layout`) has no visit counts (``memory=False``)."""
    part = (layout or {}).get("visits_next")
    if part is None:
        return mask
    seen = np.asarray(obs)[part] > 0.0
    keep = mask & ~seen
    return keep if keep.any() else mask


class MaskedPolicyAgent:
    """A saved sb3-contrib MaskablePPO model acting deterministically with the env's mask.

    ``env_kwargs`` (default: those of the model's run, from its ``config.yaml``) make the env
    whose spaces the model is loaded with.

    ``loop_guard`` (default on; it acts only on an env made with ``memory=True``, whose
    observation counts visits): a move back into a stance the robot already believed itself in
    this episode is left out of the mask whenever another offered move leads to a stance not
    yet visited (:func:`loop_guard_mask`). A shortest climb never enters a stance twice; a
    deterministic policy that does has begun a cycle, and once the observation's counts reach
    their cap (:data:`~kinegym.envs.hole_climb.VISITS_SEEN`) it cannot see the cycle and repeats
    it until the episode is truncated. The guard reads only the observation, and acts only where
    the policy's own choice is such a move: deterministically, it then takes the policy's most
    probable move among the rest; sampling, it draws from the policy's distribution over the
    rest (a draw that lands on a move back is drawn again from the rest)."""

    def __init__(self, path: str | Path, deterministic: bool = True, env_kwargs: dict[str, Any] | None = None,
                 loop_guard: bool = True) -> None:
        from kinegym.envs.hole_climb import HoleClimbEnv

        kw = policy_env_kwargs(path) if env_kwargs is None else dict(env_kwargs)
        probe = HoleClimbEnv(**kw)
        try:
            self.model = load_maskable(path, probe.observation_space, probe.action_space)
        finally:
            probe.close()
        self.deterministic = deterministic
        self.loop_guard = bool(loop_guard)
        self.guarded = 0  #: decisions the loop guard changed, since this agent was made

    def act(self, env: Any, obs: np.ndarray | None = None) -> int:
        if obs is None:
            raise ValueError("MaskedPolicyAgent.act needs the observation")
        mask = env.action_masks()
        action, _ = self.model.predict(obs, action_masks=mask, deterministic=self.deterministic)
        if self.loop_guard:
            keep = loop_guard_mask(np.asarray(obs), mask, getattr(env, "layout", None))
            if not keep[int(action)]:  # the policy chose a move back while a fresh stance is offered
                self.guarded += 1
                action, _ = self.model.predict(obs, action_masks=keep, deterministic=self.deterministic)
        return int(action)
