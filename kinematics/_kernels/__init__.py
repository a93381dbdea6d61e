"""Fast paths, fenced off from the readable algorithms they speed up.

Each module here runs an algorithm whose readable reference lives where a reader looks for
it, and ``tests/test_kernels.py`` pins each kernel equal to that reference:

* :mod:`.dh` - DH chains compiled into straight-line FK (floats and arrays); reference
  :meth:`kinegym.kinematics.chains.DHChain.fk_reference` (a product of DH matrices).
* :mod:`.lm` - plain-Python Levenberg-Marquardt with generated straight-line solves;
  reference :func:`kinegym.kinematics.ik._lm_reference` (numpy).
* :mod:`.arm_lm` - the writing arm's fused LM descent, generated per arm and task mask;
  reference :func:`kinegym.kinematics.ik.dls` with ``fast=False`` on the arm's residual.
* :mod:`.arm_closed_form` - the writing arm's closed-form IK for one target, generated per
  arm; reference :meth:`kinegym.kinematics.writing_arm.WritingArm.ik`.

Nothing outside :mod:`kinegym.kinematics` imports from here.
"""
