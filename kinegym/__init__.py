"""kinegym: simulation suite for a wall-climbing robot and a tic-tac-toe writing arm.

This is the front door: the ``kinegym`` command line (:mod:`kinegym.cli`) and, as the
environments land, their registration with Gymnasium (``gymnasium.make("kinegym/...")``).
Importing it is cheap: it never imports pymunk, pygame, OpenCV or torch.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
