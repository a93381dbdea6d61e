"""``kinegym precision --errors`` and ``kinegym calibrate``: why the real Pincher of seed 002 missed.

``precision --errors E`` runs a measured table (``--points``, default seed 002's five points)
through the error model ``E`` (:mod:`kinegym.kinematics.arm_errors`): each point commanded
with the ideal IK, where the modelled pen goes, its error, and the error the real arm showed.
``calibrate --measured M`` fits the model's parameters to measured points, prints them with
the error before (ideal model) and after (the fit's residual), and writes them as YAML
(``--out``) for ``--errors``. Registered on the main parser by :func:`add_parsers`.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from kinegym.cli.common import EXIT_OK, UsageError, add_json, emit, rnd, write_text_atomic

__all__ = ["add_parsers", "cmd_calibrate", "precision_with_errors"]


def _commands(arm: Any, phi: float, desired: np.ndarray) -> np.ndarray:
    """The ideal IK's command for every desired point (pen pitch ``phi``), as the seed sent them."""
    return np.array([arm.ik([*d, phi]) for d in desired])


def precision_with_errors(args: argparse.Namespace) -> int:
    from kinegym.kinematics.arm_errors import ArmErrors, load_measurements, real_tip
    from kinegym.kinematics.writing_arm import WritingArm

    errors = ArmErrors.from_config(args.errors)
    arm_name, phi, desired, measured = load_measurements(args.points)
    if args.arm_given and args.arm != arm_name:
        raise UsageError(f"--points {args.points!r} was measured on arm {arm_name!r}, not --arm {args.arm!r}")
    arm = WritingArm.from_config(arm_name)
    q = _commands(arm, phi, desired)
    model = real_tip(arm, errors, q)
    err_model = np.linalg.norm(model - desired, axis=1)
    err_real = np.linalg.norm(measured - desired, axis=1)
    lines = [f"{arm.name} with errors '{errors.name}': {len(desired)} points of '{args.points}' commanded with the "
             f"ideal IK (phi {math.degrees(phi):g} deg), cm",
             f"{'desired':>22} {'modelled pen':>24} {'model err':>9} {'dz':>6} {'measured pen':>24} {'real err':>8}"]
    for d, m, em, meas, er in zip(desired, model, err_model, measured, err_real):
        lines.append(f"{_xyz(d):>22} {_xyz(m):>24} {em:9.3f} {m[2] - d[2]:+6.2f} {_xyz(meas):>24} {er:8.3f}")
    lines.append(f"mean error: model {err_model.mean():.3f} cm, measured {err_real.mean():.3f} cm "
                 f"({100 * (err_model.mean() / err_real.mean() - 1):+.1f} %); z low at "
                 f"{int(((model - desired)[:, 2] < 0).sum())}/{len(desired)} points in the model, "
                 f"{int(((measured - desired)[:, 2] < 0).sum())}/{len(desired)} measured")
    emit(args, {"arm": arm.name, "errors": errors.name, "points": [
        {"desired_cm": d.tolist(), "modelled_cm": rnd(m), "model_error_cm": float(em), "measured_cm": meas.tolist(),
         "measured_error_cm": float(er)} for d, m, em, meas, er in zip(desired, model, err_model, measured, err_real)],
        "mean_model_error_cm": float(err_model.mean()), "mean_measured_error_cm": float(err_real.mean())},
        "\n".join(lines))
    return EXIT_OK


def _xyz(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.2f}" for x in v) + ")"


def cmd_calibrate(args: argparse.Namespace) -> int:
    from kinegym.kinematics.arm_errors import PARAMETERS, calibrate, load_measurements
    from kinegym.kinematics.writing_arm import WritingArm

    if args.out and not args.out.lower().endswith((".yaml", ".yml")):
        raise UsageError(f"--out {args.out!r}: expected a .yaml file (what --errors reads back)")
    fit = [f.strip() for f in args.fit.split(",") if f.strip()]
    bad = [f for f in fit if f not in PARAMETERS]
    if bad or not fit:
        raise UsageError(f"--fit {args.fit!r}: expected a comma list of {', '.join(PARAMETERS)}")
    arm_name, phi, desired, measured = load_measurements(args.measured)
    arm = WritingArm.from_config(arm_name)
    q = _commands(arm, phi, desired)
    n_par = sum(PARAMETERS[f] for f in fit)
    if n_par > 3 * len(desired):
        raise UsageError(f"--fit asks for {n_par} parameters from {3 * len(desired)} measured coordinates")
    cal = calibrate(arm, q, measured, fit=fit)
    text = cal.errors.to_yaml()
    lines = [f"{arm.name}: {n_par} parameters ({', '.join(fit)}) fitted to {len(desired)} measured points "
             f"({3 * len(desired)} coordinates) in {cal.iterations} Gauss-Newton steps",
             f"error of the ideal model vs the measured pen: rms {cal.rms_before_cm:.3f} cm "
             f"(per point {', '.join(f'{v:.2f}' for v in cal.residual_before_cm)})",
             f"after calibration (the fitted model vs the measured pen): rms {cal.rms_after_cm:.3f} cm "
             f"(per point {', '.join(f'{v:.2f}' for v in cal.residual_after_cm)})", "", text.rstrip()]
    if args.out:
        lines.append(f"written: {write_text_atomic(args.out, text)}")
    emit(args, {"arm": arm.name, "fit": fit, "parameters": {k: getattr(cal.errors, k) for k in PARAMETERS},
                "rms_before_cm": cal.rms_before_cm, "rms_after_cm": cal.rms_after_cm,
                "residual_before_cm": rnd(cal.residual_before_cm), "residual_after_cm": rnd(cal.residual_after_cm),
                "out": args.out}, "\n".join(lines))
    return EXIT_OK


def add_parsers(sub: Any) -> None:
    """Add ``calibrate`` to the main parser's subcommands (``precision --errors`` lives in :mod:`.arm`)."""
    ca = sub.add_parser("calibrate", help="fit the writing arm's error model to measured points")
    ca.add_argument("--measured", default="pincher_seed002",
                    help="measurements: configs/measurements name or YAML path (default: seed 002's table)")
    ca.add_argument("--fit", default="base_offset_cm,base_tilt_deg,compliance_deg_per_ncm",
                    help="parameters to fit, comma-separated (default: frame offset and tilt, servo give)")
    ca.add_argument("--out", default=None, help="write the fitted errors as YAML here (for precision --errors)")
    add_json(ca)
    ca.set_defaults(func=cmd_calibrate)
