"""The ``sim:`` section of an arm YAML (``configs/arms/*.yaml``): servo loops, encoders, pen,
sponge, board placement and drawing speeds, with their defaults and ranges, and the per-joint
parameters :class:`~kinegym.envs.sim.arm.ArmSim` runs on. Lengths cm, angles deg, masses kg,
torques N cm, speeds cm/s. The kinematics reads the same file's geometry and passes this
section through; it is validated here, where it is used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import kinegym.configs as _configs
from kinegym.kinematics.writing_arm import WritingArm

__all__ = ["ARM_SIM_SCHEMA", "JointParams", "joint_params"]

_N = _configs.Number
_JOINT_SIM_SCHEMA: dict[str, _configs.Spec] = {
    "kp_per_s": _N(lo=0.0, lo_open=True, default=12.0, doc="outer loop: speed command per rad of position error (1/s)"),
    "kv_ncm_s": _N(lo=0.0, lo_open=True, default=50.0, doc="inner loop: torque per rad/s of speed error (N cm s)"),
    "ki_ncm": _N(lo=0.0, default=500.0, doc="inner loop integral: torque per rad of speed error integral (N cm)"),
    "max_speed_deg_s": _N(lo=0.0, lo_open=True, default=90.0, doc="speed command limit (deg/s)"),
    "rotor_inertia_kgcm2": _N(lo=0.0, lo_open=True, default=20.0,
                              doc="motor and gear inertia reflected to the joint (kg cm^2)"),
    "friction_ncm": _N(lo=0.0, default=1.0, doc="Coulomb friction of the gear train (N cm)"),
    "backlash_deg": _N(lo=0.0, default=0.2, doc="gear play between motor (encoder) and link (deg)"),
    "encoder_step_deg": _N(lo=0.0, default=0.005, doc="encoder resolution at the joint (deg; 0 = ideal)"),
    "absolute": _configs.Flag(default=False, doc="absolute position sensor (a hobby servo): no homing"),
    "index_deg": _N(lo=-360.0, hi=360.0, default=0.0, doc="joint angle of the index switch (model deg)"),
    "homing_dir": _N(lo=-1, hi=1, integer=True, default=1, doc="first homing direction (+1 / -1)"),
    "homing_sweep_deg": _N(lo=0.0, default=0.0,
                           doc="turn back after this excursion without an index (0: only at a limit stop)"),
    "homing_speed_deg_s": _N(lo=0.0, lo_open=True, default=20.0),
    "homing_slowdown_s": _N(lo=0.0, default=0.0,
                            doc="homing speed falls as exp(-t / this) to a fifth (thesis drive 3, whose index "
                                "switch is its limit switch: hit it slowly); 0 = constant speed"),
    "homing_wait_deg": _N(lo=-360.0, hi=360.0, default=None,
                          doc="once homed, turn here and wait while the later joints home (thesis drive 1: "
                              "away from the board); absent = stay at the index"),
}

#: The ``sim:`` section of an arm YAML.
ARM_SIM_SCHEMA: dict[str, _configs.Spec] = {
    "control_hz": _N(lo=100.0, hi=10000.0, default=1000.0, doc="servo loop and physics rate (Hz)"),
    "speed_filter_hz": _N(lo=1.0, lo_open=False, default=60.0, doc="low-pass on the differentiated encoder (Hz)"),
    "base_inertia_kgcm2": _N(lo=0.0, default=20.0, doc="turntable inertia about the yaw axis (kg cm^2)"),
    "joints": _configs.ListOf(item=_configs.Section(fields=_JOINT_SIM_SCHEMA), min_len=4, max_len=4,
                              default=[{}, {}, {}, {}], doc="per joint q1..q4"),
    "park_cm": _configs.Vector(length=3, default=[0.0, 12.0, 8.0], doc="pen parked at (x, y, z), pen vertical"),
    "start_spread_deg": _N(lo=0.0, hi=90.0, default=15.0,
                           doc="homing starts up to this far from the park pose, per joint"),
    "stall_deg": _N(lo=0.0, lo_open=True, default=4.0,
                    doc="homing: command this far ahead of the encoder means a limit stop"),
    "pen": _configs.Section(default={}, fields={
        "width_cm": _N(lo=0.0, lo_open=True, default=0.12),
        "colour": _configs.Vector(length=3, default=[25, 60, 175], item=_N(lo=0, hi=255, integer=True),
                                  doc="RGB of the ink"),
        "spring_n_per_cm": _N(lo=0.0, lo_open=True, default=1.5, doc="pen holder spring (N/cm)"),
        "travel_cm": _N(lo=0.0, lo_open=True, default=0.5, doc="spring travel before the holder bottoms out"),
        "press_cm": _N(lo=0.0, default=0.15, doc="commanded depth below the board while drawing"),
        "lift_cm": _N(lo=0.0, lo_open=True, default=1.0, doc="pen height above the board between strokes"),
        "friction": _N(lo=0.0, default=0.3, doc="pen-on-board friction coefficient"),
    }),
    "sponge": _configs.Section(default={}, fields={
        "width_cm": _N(lo=0.0, lo_open=True, default=3.6),
        "offset_cm": _N(lo=0.0, default=1.5, doc="tool axis to sponge face (pen turned to phi = 90 deg)"),
        "press_cm": _N(lo=0.0, default=0.2),
        "efficiency": _N(lo=0.0, hi=1.0, default=0.995, doc="share of the ink one pass removes"),
        "pass_step_cm": _N(lo=0.0, lo_open=True, default=3.0, doc="offset between passes (thesis: 3 cm)"),
    }),
    "board": _configs.Section(default={}, fields={
        "canvas_origin_cm": _configs.Vector(length=2, default=[-10.0, 3.0],
                                            doc="arm-frame position of the canvas's lower-left corner"),
        "canvas_size_cm": _configs.Vector(length=2, default=[20.0, 20.0], item=_N(lo=1.0)),
        "field_origin_cm": _configs.Vector(length=2, default=[2.5, 2.0],
                                           doc="field's lower-left corner on the canvas"),
        "n": _N(lo=2, hi=9, integer=True, default=5, doc="cells per side"),
        "cell_cm": _N(lo=0.5, default=3.0, doc="cell side (thesis: 3 cm)"),
        "o_radius_ratio": _N(lo=0.05, hi=0.5, default=0.25, doc="O radius / cell (thesis: 1/4)"),
        "x_margin_ratio": _N(lo=0.0, hi=0.45, default=0.2, doc="X corner inset / cell (thesis: 1/5)"),
    }),
    "drawing": _configs.Section(default={}, fields={
        "speed_levels_cm_s": _configs.Vector(default=[1.0, 2.0, 3.0, 4.0, 6.0, 8.0], item=_N(lo=0.0, lo_open=True),
                                             doc="pen speed per GUI level 0..5"),
        "default_level": _N(lo=0, hi=5, integer=True, default=2),
        "travel_speed_cm_s": _N(lo=0.0, lo_open=True, default=8.0, doc="pen-up moves"),
        "accel_cm_s2": _N(lo=0.0, lo_open=True, default=30.0, doc="start / stop ramps of every move"),
        "settle_s": _N(lo=0.0, default=0.15, doc="dwell after lowering and before lifting"),
        "turn_height_cm": _N(lo=0.0, default=6.0, doc="pen height at which the tool turns to the sponge and back"),
    }),
}


@dataclass(frozen=True)
class JointParams:
    """One servo, in SI-free units: rad, rad/s, N cm, kg cm^2."""

    kp: float
    kv: float
    ki: float
    max_speed: float
    rotor_inertia: float
    friction: float
    backlash: float
    encoder_step: float
    absolute: bool
    index: float
    homing_dir: int
    homing_sweep: float
    homing_speed: float
    homing_slowdown: float
    homing_wait: float | None
    max_torque: float
    lo: float
    hi: float


def joint_params(cfg: dict, arm: WritingArm) -> list[JointParams]:
    out = []
    for j, jc in enumerate(cfg["joints"]):
        lo, hi = (float(v) for v in arm.limits[j])
        out.append(JointParams(
            kp=jc["kp_per_s"], kv=jc["kv_ncm_s"], ki=jc["ki_ncm"], max_speed=math.radians(jc["max_speed_deg_s"]),
            rotor_inertia=jc["rotor_inertia_kgcm2"], friction=jc["friction_ncm"],
            backlash=math.radians(jc["backlash_deg"]), encoder_step=math.radians(jc["encoder_step_deg"]),
            absolute=bool(jc["absolute"]), index=math.radians(jc["index_deg"]), homing_dir=int(jc["homing_dir"]) or 1,
            homing_sweep=math.radians(jc["homing_sweep_deg"]), homing_speed=math.radians(jc["homing_speed_deg_s"]),
            homing_slowdown=jc["homing_slowdown_s"],
            homing_wait=None if jc["homing_wait_deg"] is None else math.radians(jc["homing_wait_deg"]),
            max_torque=float(arm.max_torque[j]), lo=lo, hi=hi))
    return out
