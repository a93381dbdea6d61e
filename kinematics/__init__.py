"""Analytic and numeric kinematics of the kinegym robots (pure numpy, no physics engine).

* :mod:`kinegym.kinematics.climber` - three-armed climber: FK, closed-form IK, seed 000's inverse program;
* :mod:`kinegym.kinematics.holes` - hole maps of walls (ids, positions, a spatial hash);
* :mod:`kinegym.kinematics.localization` - which holes the climber holds and where it is
  (:mod:`~kinegym.kinematics.pose_fit` fits and gates, :mod:`~kinegym.kinematics.triangles`
  the triangle index, :mod:`~kinegym.kinematics.bayes` lost starts,
  :mod:`~kinegym.kinematics.seed_search` the seed's own search as a baseline,
  :mod:`~kinegym.kinematics.sensor_study` simulated grips and the sensor study);
* :mod:`kinegym.kinematics.chains` - Denavit-Hartenberg and product-of-exponentials chains, Jacobians;
* :mod:`kinegym.kinematics.ik` - numeric IK (CCD, Levenberg-Marquardt DLS) with one result type;
* :mod:`kinegym.kinematics.writing_arm` - the 4-DOF writing arm: FK, every closed-form IK branch;
* :mod:`kinegym.kinematics.errors` - the named exceptions.

Lengths in cm, angles in radians.
"""

from .chains import DHChain, DHLink, PoEChain
from .climber import ClimberGeometry, arm_ik, hand_positions, inverse_program
from .errors import (
    InvalidInputError,
    JointLimitError,
    KinematicsError,
    UnreachableError,
)
from .holes import HoleMap
from .ik import IKResult, ccd, dls, solve_arm
from .writing_arm import WritingArm

__all__ = [
    "ClimberGeometry", "DHChain", "DHLink", "HoleMap", "IKResult", "InvalidInputError",
    "JointLimitError", "KinematicsError", "PoEChain", "UnreachableError", "WritingArm",
    "arm_ik", "ccd", "dls", "hand_positions", "inverse_program", "solve_arm",
]
