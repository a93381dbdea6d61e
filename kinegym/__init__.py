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

__version__ = "0.1.0"
__all__ = ["__version__", "ENV_IDS"]

#: The environment ids this package registers.
ENV_IDS = ("kinegym/HoleClimb-v0", "kinegym/TicTacToeDraw-v0")

if "kinegym/HoleClimb-v0" not in registry:
    register(id="kinegym/HoleClimb-v0", entry_point="kinegym.factories:hole_climb", max_episode_steps=200)
if "kinegym/TicTacToeDraw-v0" not in registry:
    register(id="kinegym/TicTacToeDraw-v0", entry_point="kinegym.factories:tictactoe_draw")
