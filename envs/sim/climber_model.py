"""The climber as the simulations see it: geometry plus masses, servos, grippers and encoders.

:class:`ClimberModel` joins the kinematics' :class:`~kinegym.kinematics.climber.ClimberGeometry`
and :class:`ClimberPhysics` (the ``physics:`` section of ``configs/robots/*.yaml``, whose
defaults and ranges are declared once, on its fields); :meth:`ClimberModel.from_config`
reads the robot file once and validates both parts. :data:`OUTCOMES` names what a move
can end in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import kinegym.configs as _configs
from kinegym.kinematics.climber import CLIMBER_SCHEMA, ClimberGeometry

__all__ = ["OUTCOMES", "ClimberPhysics", "ClimberModel", "PHYSICS_SCHEMA", "G"]


#: Move outcomes, in the order the observation encodes them.
OUTCOMES = ("ok", "unreachable", "torque_limit", "missed_hole", "grip_lost", "fell")
G = 9.81  # m/s^2: weights in N from masses in kg
_G_CM = 981.0  # cm/s^2 for pymunk (cm, kg, s)


def _spec(default: float, lo: float = 0.0, lo_open: bool = True, hi: float | None = None, doc: str = "") -> float:
    """A field of :class:`ClimberPhysics` whose default, bounds and meaning live in one place
    (the YAML schema :data:`PHYSICS_SCHEMA` is read off these fields)."""
    spec = _configs.Number(lo=lo, lo_open=lo_open, hi=hi, default=default, doc=doc)
    return field(default=default, metadata={"spec": spec})  # type: ignore[return-value]


@dataclass(frozen=True)
class ClimberPhysics:
    """Masses, servos, grippers and encoders of the climber (``physics:`` in its YAML).

    Units in the names: kg, cm, N, N cm, deg, s. Every field's default and valid range is
    declared once, here; :data:`PHYSICS_SCHEMA` validates the YAML against them."""

    body_mass_kg: float = _spec(0.6)
    upper_link_mass_kg: float = _spec(0.08)
    lower_link_mass_kg: float = _spec(0.06)
    hand_mass_kg: float = _spec(0.06, lo_open=False)
    body_radius_cm: float = _spec(5.0)
    shoulder_torque_ncm: float = _spec(200.0)
    elbow_torque_ncm: float = _spec(200.0)
    servo_gain_per_s: float = _spec(12.0, doc="position loop gain (1/s)")
    servo_stiffness_ncm_per_deg: float = _spec(40.0, doc="torque a servo may use per degree of error")
    servo_speed_dps: float = _spec(90.0, doc="servo speed limit (deg/s)")
    servo_floor_share: float = _spec(0.15, lo_open=False, hi=1.0, doc="a servo holds this share of its torque "
                                                                     "without deflecting; above it, it gives "
                                                                     "servo_stiffness_ncm_per_deg")
    load_feedforward: float = _spec(1.0, lo_open=False, hi=1.0, doc="share of the planned load split the holding "
                                                                  "servos are commanded as torque while a hand is "
                                                                  "free (0: the position loop alone)")
    feedforward_floor_share: float = _spec(0.02, lo_open=False, hi=1.0, doc="a servo's torque at zero position "
                                                                           "error while the load is fed forward")
    capture_radius_cm: float = _spec(0.8)
    holding_force_n: float = _spec(40.0)
    grip_release_s: float = _spec(0.3, lo_open=False, doc="a gripper opens over this long: its force ramps to zero (s)")
    reach_margin_cm: float = _spec(0.5, lo_open=False)
    torque_safety: float = _spec(0.995, hi=2.0)
    stall_s: float = _spec(0.5, doc="a servo at its limit this long stalls (s)")
    sag_abort_cm: float = _spec(2.5, doc="a swing stops when a holding hand's servo targets miss its hole by "
                                         "this much (the body is sagging)")
    shift_speed_cm_s: float = _spec(4.0)
    shift_servo_share: float = _spec(0.6, hi=1.0, doc="a body shift asks no joint for more than this share of "
                                                      "the servo speed")
    swing_speed_cm_s: float = _spec(8.0)
    encoder_step_deg: float = _spec(0.05, lo_open=False, doc="quantisation step (0 = none)")
    physics_hz: float = _spec(240.0, lo=30.0, lo_open=False, hi=5000.0)


#: The ``physics:`` section of a robot YAML, read off :class:`ClimberPhysics`'s fields.
PHYSICS_SCHEMA: dict[str, _configs.Spec] = {f.name: f.metadata["spec"] for f in fields(ClimberPhysics)}


@dataclass(frozen=True)
class ClimberModel:
    """Geometry (:class:`ClimberGeometry`) and physics (:class:`ClimberPhysics`) of one robot."""

    geom: ClimberGeometry = field(default_factory=ClimberGeometry)
    phys: ClimberPhysics = field(default_factory=ClimberPhysics)

    @classmethod
    def from_config(cls, name_or_path: str | Path = "climber") -> ClimberModel:
        """``configs/robots/<name>.yaml``: geometry as for the kinematics, masses and servos
        from its ``physics:`` section (defaults where absent)."""
        cfg = _configs.load("robots", name_or_path, CLIMBER_SCHEMA)
        source = str(_configs.resolve("robots", name_or_path))
        phys = _configs.validate(cfg["physics"], PHYSICS_SCHEMA, source, prefix="physics")
        return cls(ClimberGeometry.from_dict(cfg, source), ClimberPhysics(**phys))

    def __post_init__(self) -> None:
        g, m = self.geom, self.phys.reach_margin_cm
        object.__setattr__(self, "_reach", ([float(abs(g.l1[i] - g.l2[i])) + m for i in range(3)],
                                            [float(g.l1[i] + g.l2[i]) - m for i in range(3)]))
        object.__setattr__(self, "_links", [(float(g.l1[i]), float(g.l2[i])) for i in range(3)])
        object.__setattr__(self, "_offsets", [(float(g.shoulders[i, 0]), float(g.shoulders[i, 1])) for i in range(3)])

    @property
    def reach(self) -> tuple[list[float], list[float]]:
        """Per arm: inner and outer reach (cm) less the safety margin."""
        return self._reach  # type: ignore[attr-defined]

    def offsets(self, heading: float) -> list[tuple[float, float]]:
        """Shoulder offsets in the wall frame for a body ``heading`` (cm)."""
        if heading == 0.0:
            return self._offsets  # type: ignore[attr-defined]
        c, s = math.cos(heading), math.sin(heading)
        return [(c * ox - s * oy, s * ox + c * oy) for ox, oy in self._offsets]  # type: ignore[attr-defined]
