"""kinegym: simulation suite for a wall-climbing robot and a tic-tac-toe writing arm.

This is the front door: the ``kinegym`` command line (:mod:`kinegym.cli`) and the
registration of the environments with Gymnasium, so that after ``import kinegym``::

    env = gymnasium.make("kinegym/HoleClimb-v0")
    env = gymnasium.make("kinegym/TicTacToeDraw-v0")

works (or, without the import, ``gymnasium.make("kinegym:kinegym/HoleClimb-v0")``).
Importing it is cheap: the environments are registered by entry-point strings, so it
never imports pymunk, pygame, OpenCV or torch.
"""

from gymnasium.envs.registration import register, registry

from kinegym.envs.variants import HOLE_CLIMB, VARIANTS

__version__ = "0.1.0"
__all__ = ["__version__", "ENV_IDS", "ALL_ENV_IDS"]

#: The two main environment ids (one per robot).
ENV_IDS = ("kinegym/HoleClimb-v0", "kinegym/TicTacToeDraw-v0")
#: Every id this package registers: the main ids and their observation variants
#: (:mod:`kinegym.envs.variants`: each space is its own id).
ALL_ENV_IDS = tuple(VARIANTS)


def _register() -> None:
    from kinegym.factories import FACTORY_NAMES

    for env_id in VARIANTS:
        if env_id not in registry:
            register(id=env_id, entry_point=f"kinegym.factories:{FACTORY_NAMES[env_id]}",
                     max_episode_steps=200 if env_id in HOLE_CLIMB else None)


_register()
