"""The training configuration: its schema, RL Zoo's spellings, and the one loader.

A training YAML holds one section per env id, RL-Zoo style (``configs/train/*.yaml``; the
shipped Zoo file :data:`kinegym.zoo.ZOO_CONFIG` is read the same way). :func:`load_train_config`
validates the whole section on load, naming file, key and value, and returns it in kinegym's
spelling (``memory`` / ``hints`` in ``env_kwargs``, whatever id the section was written for).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import kinegym.configs as _configs
from kinegym.agents.policies import GAIT_ENV_ID as ENV_ID

__all__ = ["TRAIN_SCHEMA", "POLICY_KWARGS_SCHEMA", "ACTIVATIONS", "DEFAULT_CONFIG", "load_train_config",
           "validate_train", "parse_schedule", "parse_zoo_dict"]

DEFAULT_CONFIG = "hole_climb_maskable_ppo"


@dataclass(frozen=True)
class _Schedule(_configs.Spec):
    """A positive number or ``lin_<start>`` (linear decay to 0 over training)."""

    def check(self, value: Any, source: str, key: str) -> Any:
        try:
            parse_schedule(value)
        except ValueError:
            raise _configs.ConfigError(source, key, value, "a number > 0 or 'lin_<number>' (e.g. lin_3e-4)") from None
        return value


@dataclass(frozen=True)
class _NetArch(_configs.Spec):
    """SB3's ``net_arch``: a list of 1..8 layer widths (1..4096), or ``{pi: [...], vf: [...]}``."""

    def check(self, value: Any, source: str, key: str) -> Any:
        widths = _configs.ListOf(item=_configs.Number(lo=1, hi=4096, integer=True), min_len=1, max_len=8)
        if isinstance(value, dict):
            return _configs.validate(value, {"pi": widths, "vf": widths}, source, prefix=key)
        if isinstance(value, (list, tuple)):
            return widths.check(value, source, key)
        raise _configs.ConfigError(source, key, value, "a list of layer widths like [128, 128], or {pi: [...], "
                                   "vf: [...]}")


#: ``activation_fn`` names -> ``torch.nn`` classes
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU"}
POLICY_KWARGS_SCHEMA: dict[str, _configs.Spec] = {
    "net_arch": _NetArch(default=None),
    "activation_fn": _configs.Text(choices=tuple(ACTIVATIONS), default=None),
    "ortho_init": _configs.Flag(default=None),
    "share_features_extractor": _configs.Flag(default=None),
}


@dataclass(frozen=True)
class _Section(_configs.Spec):
    """A mapping of the keys in ``fields`` only (absent keys stay absent: the consumer's defaults)."""

    fields: Any = None

    def check(self, value: Any, source: str, key: str) -> Any:
        if not isinstance(value, dict):
            raise _configs.ConfigError(source, key, value, "a mapping")
        fields = self.fields() if callable(self.fields) else self.fields
        out = _configs.validate(value, fields, source, prefix=key)
        return {k: v for k, v in out.items() if k in value}


@dataclass(frozen=True)
class _PolicyKwargs(_Section):
    """SB3's ``policy_kwargs`` as a mapping, or as RL Zoo writes them, a string like
    ``"dict(net_arch=[64, 64], activation_fn=nn.ReLU)"`` - read as data (:func:`parse_zoo_dict`),
    never evaluated."""

    def check(self, value: Any, source: str, key: str) -> Any:
        if isinstance(value, str):
            try:
                value = parse_zoo_dict(value)
            except ValueError as exc:
                want = f"a mapping or RL Zoo's 'dict(key=value, ...)' ({exc})"
                raise _configs.ConfigError(source, key, value, want) from None
        return super().check(value, source, key)


def parse_zoo_dict(text: str) -> dict[str, Any]:
    """RL Zoo's ``"dict(net_arch=[64, 64], activation_fn=nn.ReLU, ortho_init=False)"`` as a
    dict of plain values (``nn.ReLU`` -> ``"relu"``), read with :mod:`ast`, nothing evaluated;
    ``ValueError`` for anything else."""
    import ast

    if len(text) > 2000:
        raise ValueError("longer than 2,000 characters")
    try:
        node = ast.parse(text.strip(), mode="eval").body
    except SyntaxError:
        raise ValueError("not a Python expression") from None
    if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict"
            and not node.args):
        raise ValueError("expected dict(key=value, ...)")
    names = {v.lower(): k for k, v in ACTIVATIONS.items()}
    out: dict[str, Any] = {}
    for kw in node.keywords:
        v = kw.value
        if isinstance(v, ast.Attribute) and v.attr.lower() in names:  # nn.ReLU, th.nn.Tanh
            out[str(kw.arg)] = names[v.attr.lower()]
            continue
        try:
            out[str(kw.arg)] = ast.literal_eval(v)
        except ValueError:
            known = ", ".join(f"nn.{v}" for v in ACTIVATIONS.values())
            raise ValueError(f"{kw.arg}={ast.unparse(v)} is not a literal or one of {known}") from None
    return out


def _env_kwargs_schema() -> dict[str, _configs.Spec]:
    from kinegym.envs.hole_climb import ENV_KWARGS_SCHEMA

    return ENV_KWARGS_SCHEMA


_N = _configs.Number
TRAIN_SCHEMA: dict[str, _configs.Spec] = {
    "algo": _configs.Text(choices=("maskable_ppo", "ppo_mask"), default="maskable_ppo", doc="ppo_mask: RL Zoo's name"),
    "n_envs": _N(lo=1, hi=64, integer=True, default=2),
    "n_timesteps": _N(lo=1, integer=True, default=500_000),
    "policy": _configs.Text(choices=("MlpPolicy",), default="MlpPolicy"),
    "policy_kwargs": _PolicyKwargs(default={}, fields=POLICY_KWARGS_SCHEMA, doc="SB3 policy_kwargs (net_arch, ...)"),
    "env_kwargs": _Section(default={}, fields=_env_kwargs_schema, doc="gymnasium.make keyword arguments"),
    "learning_rate": _Schedule(default=3e-4),
    "clip_range": _Schedule(default=0.2),
    "n_steps": _N(lo=8, integer=True, default=1024, doc="steps per env per update"),
    "batch_size": _N(lo=8, integer=True, default=256),
    "n_epochs": _N(lo=1, integer=True, default=10),
    "gamma": _N(lo=0.0, hi=1.0, default=0.99),
    "gae_lambda": _N(lo=0.0, hi=1.0, default=0.95),
    "ent_coef": _N(lo=0.0, default=0.01),
    "vf_coef": _N(lo=0.0, default=0.5),
    "max_grad_norm": _N(lo=0.0, lo_open=True, default=0.5),
    "normalize": _configs.Flag(default=False, doc="VecNormalize the observations"),
    "eval_freq": _N(lo=64, integer=True, default=20_000, doc="env steps (all envs) between evaluations"),
    "eval_episodes": _N(lo=1, integer=True, default=40),
    "checkpoint_freq": _N(lo=1, integer=True, default=50_000, doc="env steps (all envs) between checkpoints"),
    "torch_threads": _N(lo=1, hi=64, integer=True, default=1),
    "bc_episodes": _N(lo=0, hi=100_000, integer=True, default=0,
                      doc="planner climbs cloned into the policy before PPO starts (0: none; agents.pretrain)"),
    "bc_epochs": _N(lo=1, hi=1000, integer=True, default=10, doc="passes over the planner's climbs when cloning them"),
    "dagger_rounds": _N(lo=0, hi=100, integer=True, default=0,
                        doc="after cloning: rounds of the policy climbing, the planner labelling (agents.pretrain)"),
    "dagger_episodes": _N(lo=1, hi=100_000, integer=True, default=300, doc="policy climbs labelled per round"),
    "dagger_epochs": _N(lo=1, hi=1000, integer=True, default=10, doc="passes over all rows after each round"),
    "warm_start_workers": _N(lo=1, hi=64, integer=True, default=1,
                             doc="processes that share the warm start's and DAgger's climbs (agents.pretrain)"),
    "teacher_weight": _N(lo=1.0, hi=10.0, default=2.0,
                         doc="A* weight of the planner that demonstrates and labels (1 = shortest routes, slower)"),
}


def parse_schedule(value: Any) -> float | Callable[[float], float]:
    """``3e-4`` -> 3e-4; ``"lin_3e-4"`` -> ``f(progress_remaining) = 3e-4 * progress_remaining``."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if value > 0 and math.isfinite(value):
            return float(value)
        raise ValueError(f"schedule {value!r}: expected > 0")
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        if start > 0 and math.isfinite(start):
            return lambda p: start * p
    raise ValueError(f"schedule {value!r}: expected a number > 0 or 'lin_<number>'")


_TRAINED_ID = "kinegym/HoleClimbMemoryHints-v0"  # what kinegym train gait trains by default


def load_train_config(path: str | Path = DEFAULT_CONFIG, env_id: str | None = None) -> dict[str, Any]:
    """The validated section of a training YAML (a ``configs/train`` name or a path) for
    ``env_id``, or (None) for the one HoleClimb id it has a section for - or, in a file with
    several (RL Zoo's ``kinegym/zoo/ppo_mask.yml``), the section of ``kinegym/HoleClimbMemoryHints-v0``,
    the id ``kinegym train gait`` trains.

    Both spellings are read: kinegym's (``kinegym/HoleClimb-v0`` with ``env_kwargs: {memory:
    true, hints: true}``) and RL Zoo's (a section per registered id, e.g.
    ``kinegym/HoleClimbMemoryHints-v0``, Zoo's ``policy_kwargs`` strings, ``algo`` absent or
    ``ppo_mask``, ``n_timesteps: !!float 1e6``). The result uses kinegym's: ``memory`` and
    ``hints`` in ``env_kwargs``."""
    from kinegym.envs.variants import HOLE_CLIMB

    src = _configs.resolve("train", path)
    data = _configs.load_yaml(src)
    ids = [env_id] if env_id is not None else list(HOLE_CLIMB)
    found = [i for i in ids if isinstance(data, dict) and i in data]
    if env_id is None and len(found) > 1 and _TRAINED_ID in found:  # RL Zoo's file: a section for every id
        found = [_TRAINED_ID]
    if len(found) != 1:
        keys = sorted(map(str, data)) if isinstance(data, dict) else data
        want = f"a section for {env_id}" if env_id else "one section for a HoleClimb id: " + ", ".join(HOLE_CLIMB)
        raise _configs.ConfigError(str(src), found[1] if len(found) > 1 else (env_id or "<top>"), keys, want)
    return validate_train(data[found[0]], str(src), found[0])


def validate_train(section: Any, source: str, env_id: str = ENV_ID) -> dict[str, Any]:
    """The whole training section checked before anything is built: SB3's arguments, the
    policy's and the env's keyword arguments (their keys, types and ranges); a Zoo-style
    section's id becomes ``memory`` / ``hints`` in ``env_kwargs``."""
    from kinegym.envs.variants import HOLE_CLIMB

    if isinstance(section, dict):
        section = dict(section)
        for key in ("n_timesteps", "n_envs", "n_steps", "batch_size", "n_epochs", "eval_freq", "eval_episodes",
                    "checkpoint_freq"):  # Zoo writes !!float 1e6
            v = section.get(key)
            if isinstance(v, float) and math.isfinite(v) and v.is_integer():
                section[key] = int(v)
    cfg = _configs.validate(section, TRAIN_SCHEMA, source, prefix=env_id)
    kw = cfg["env_kwargs"]
    fixed = HOLE_CLIMB.get(env_id, HOLE_CLIMB[ENV_ID])
    if env_id != ENV_ID:
        for key in ("memory", "hints"):
            if key in kw and bool(kw[key]) != fixed[key]:
                raise _configs.ConfigError(source, f"{env_id}.env_kwargs.{key}", kw[key],
                                           f"{fixed[key]} (the id fixes it) or absent")
        cfg["env_kwargs"] = {**kw, "memory": fixed["memory"], "hints": fixed["hints"]}
    if "candidates" in kw and kw["candidates"] != 8:
        raise _configs.ConfigError(source, f"{env_id}.env_kwargs.candidates", kw["candidates"],
                                   "8 (the registered ids fix it) or absent")
    cfg["algo"] = "maskable_ppo"
    return cfg
