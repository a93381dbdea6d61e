"""kinegym in RL Baselines3 Zoo: ``python -m kinegym.zoo train|enjoy|record_video ...``.

RL Zoo (``rl_zoo3``) knows no masked algorithm and evaluates with plain ``predict``. This
entry point runs Zoo's own scripts with three things added, for the duration of the run only
(:func:`zoo_scope`; nothing stays patched after it returns):

* ``ppo_mask``: sb3-contrib's MaskablePPO in Zoo's algorithm table;
* masks in Zoo's evaluation: training's evaluation callback is sb3-contrib's
  ``MaskableEvalCallback``; ``enjoy`` and ``record_video`` pass each step's
  ``action_masks`` (from the env they made) to ``predict``;
* kinegym's defaults: ``--gym-packages kinegym`` (the ids are registered in every process),
  ``--conf-file`` this package's ``ppo_mask.yml`` (:data:`ZOO_CONFIG`) and, for HoleClimb ids,
  ``--eval-env-kwargs wall_pool:0`` (training's evaluation) and ``--env-kwargs wall_pool:0``
  (``enjoy``, ``record_video``): policies are judged on fresh walls, not the training pool.
  Each is added only when you give none.

Everything else is Zoo's: its arguments, its ``logs/`` layout, its plots. Examples::

    python -m kinegym.zoo train --algo ppo_mask --env kinegym/HoleClimbMemoryHints-v0 -n 20000
    python -m kinegym.zoo enjoy --algo ppo_mask --env kinegym/HoleClimbMemoryHints-v0 -f logs --no-render
    python -m kinegym.zoo record_video --algo ppo_mask --env kinegym/HoleClimbMemoryHints-v0 -f logs -n 200

Needs the ``zoo`` extra (``pip install "kinegym[zoo,train]"``).
"""

from __future__ import annotations

import contextlib
import runpy
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

__all__ = ["ZOO_CONFIG", "SCRIPTS", "main", "zoo_scope", "zoo_argv"]

#: the Zoo-format hyper-parameter file shipped for kinegym's ids
ZOO_CONFIG = Path(__file__).with_name("ppo_mask.yml")
#: the Zoo scripts this entry point runs
SCRIPTS = ("train", "enjoy", "record_video")


def _has(argv: Sequence[str], *flags: str) -> bool:
    return any(a == f or a.startswith(f + "=") for a in argv for f in flags)


def zoo_argv(script: str, argv: Sequence[str]) -> list[str]:
    """Zoo's arguments with kinegym's defaults added where the user gave none."""
    out = list(argv)
    if script != "record_video" and not _has(out, "--gym-packages"):  # record_video has no such option
        out += ["--gym-packages", "kinegym"]
    climb = "HoleClimb" in next((out[i + 1] for i, a in enumerate(out[:-1]) if a == "--env"), "")
    if script == "train":
        if not _has(out, "--conf-file", "-conf"):
            out += ["--conf-file", str(ZOO_CONFIG)]
        if climb and not _has(out, "--eval-env-kwargs"):
            out += ["--eval-env-kwargs", "wall_pool:0"]
    elif climb and not _has(out, "--env-kwargs"):  # judge on fresh walls, not the training pool
        out += ["--env-kwargs", "wall_pool:0"]
    return out


@contextlib.contextmanager
def zoo_scope() -> Iterator[dict[str, Any]]:
    """rl_zoo3 with ``ppo_mask`` and masked evaluation, restored on exit. Yields the scope's
    state (``env``: the last env Zoo made for ``enjoy`` / ``record_video``)."""
    import rl_zoo3.enjoy
    import rl_zoo3.exp_manager
    import rl_zoo3.utils
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.callbacks import MaskableEvalCallback
    from sb3_contrib.common.maskable.utils import get_action_masks, is_masking_supported

    scope: dict[str, Any] = {"env": None}
    original = rl_zoo3.utils.create_test_env

    def create_test_env(*args: Any, **kwargs: Any) -> Any:
        scope["env"] = original(*args, **kwargs)
        return scope["env"]

    class ZooMaskablePPO(MaskablePPO):
        """MaskablePPO whose ``predict`` asks the env Zoo made for the masks it was not given."""

        def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                    deterministic: bool = False, action_masks: Any = None) -> Any:
            env = scope["env"]  # (predict's own "state" is the recurrent one)
            if action_masks is None and env is not None and is_masking_supported(env):
                action_masks = get_action_masks(env)
            return super().predict(observation, state, episode_start, deterministic, action_masks)

    ZooMaskablePPO.__name__ = ZooMaskablePPO.__qualname__ = "MaskablePPO"
    patches = [(rl_zoo3.utils.ALGOS, "ppo_mask", ZooMaskablePPO, True),
               (rl_zoo3.exp_manager, "EvalCallback", MaskableEvalCallback, False),
               (rl_zoo3.utils, "create_test_env", create_test_env, False),
               (rl_zoo3.enjoy, "create_test_env", create_test_env, False)]
    saved = []
    for target, name, value, is_dict in patches:
        saved.append(target.get(name, _MISSING) if is_dict else getattr(target, name, _MISSING))
        if is_dict:
            target[name] = value
        else:
            setattr(target, name, value)
    try:
        yield scope
    finally:
        for (target, name, _, is_dict), old in zip(patches, saved):
            if is_dict:
                target.pop(name, None) if old is _MISSING else target.__setitem__(name, old)
            else:
                setattr(target, name, old)


_MISSING = object()


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m kinegym.zoo SCRIPT [Zoo's arguments]``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help") or args[0] not in SCRIPTS:
        print(__doc__.split("\n\n")[0] + "\n\nusage: python -m kinegym.zoo {" + ",".join(SCRIPTS) + "} [RL Zoo's "
              "arguments; SCRIPT --help lists them]", file=sys.stderr if args and args[0] not in ("-h", "--help")
              else sys.stdout)
        if args and args[0] not in ("-h", "--help"):
            print(f"kinegym.zoo: unknown script {args[0]!r}; expected one of {', '.join(SCRIPTS)}", file=sys.stderr)
            return 2
        return 0
    try:
        import rl_zoo3  # noqa: F401
    except ImportError:
        print("kinegym.zoo needs RL Zoo: pip install 'kinegym[zoo,train]'", file=sys.stderr)
        return 2
    script, rest = args[0], zoo_argv(args[0], args[1:])
    old_argv = sys.argv
    sys.argv = [f"rl_zoo3.{script}", *rest]
    try:
        with zoo_scope():
            if script == "train":
                from rl_zoo3.train import train

                train()
            elif script == "enjoy":
                from rl_zoo3.enjoy import enjoy

                enjoy()
            else:
                runpy.run_module("rl_zoo3.record_video", run_name="__main__")
    except SystemExit as exc:  # argparse's errors and --help
        return int(exc.code or 0) if not isinstance(exc.code, str) else 2
    finally:
        sys.argv = old_argv
    return 0
