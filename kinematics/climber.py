"""Kinematics of the three-armed wall-climbing robot of seed 000, batched with numpy.

The robot is a body (centre ``(x, y)``, heading ``theta``) and three labelled arms of two
links each, moving in the wall plane. Arm ``i`` has its shoulder at ``shoulder_offset[i]``
in the body frame (the seed puts all three at the centre), an upper link ``l1[i]`` and a
lower link ``l2[i]`` (the seed: 10 cm each).

Joint convention (seed 000, section 5.1.1), per arm ``q = (s, e)`` in radians:

* ``s`` - shoulder angle of the upper link from the body's x axis (counter-clockwise);
* ``e`` - elbow angle *between* the two links (``pi`` = arm stretched). The hand is

  ``hand = shoulder + l1 (cos s, sin s) + l2 (cos(s - e + pi), sin(s - e + pi))``.

Arrays of joint angles have shape ``(..., 3, 2)`` (arm, [shoulder, elbow]); points
``(..., 3, 2)`` (arm, [x, y]) in cm; poses ``(..., 3)`` = ``(x, y, heading)``.

Two-link IK has two branches per arm: ``branch=+1`` puts the elbow angle in
``[0, pi]`` (the seed's choice, e.g. its inverse example), ``-1`` in ``[pi, 2 pi]``.
Hands outside the annulus ``|l1 - l2| <= |hand - shoulder| <= l1 + l2`` raise
:class:`~kinematics.errors.UnreachableError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import kinegym.configs as _configs

from .errors import InvalidInputError, UnreachableError, as_array

__all__ = [
    "ClimberGeometry",
    "CLIMBER_SCHEMA",
    "arm_ik_one",
    "hand_positions",
    "elbow_positions",
    "arm_ik",
    "body_to_wall",
    "wall_to_body",
    "inverse_program",
]

_ARM_SCHEMA = {
    "upper_link_cm": _configs.Number(lo=0.0, lo_open=True, default=10.0),
    "lower_link_cm": _configs.Number(lo=0.0, lo_open=True, default=10.0),
    "shoulder_offset_cm": _configs.Vector(length=2, default=[0.0, 0.0]),
}

CLIMBER_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(default="climber"),
    "description": _configs.Text(default=""),
    "arms": _configs.ListOf(item=_configs.Section(fields=_ARM_SCHEMA), min_len=3, max_len=3,
                            doc="three arms in label order"),
    "elbow_limits_deg": _configs.Vector(length=2, default=[0.0, 360.0],
                                        item=_configs.Number(lo=0.0, hi=360.0),
                                        doc="allowed elbow angle (between the links)"),
    "sensor_sigma_deg": _configs.Number(lo=0.0, default=0.5, doc="encoder noise, 1 sigma"),
    "physics": _configs.Opaque(default={}, doc="masses, servos, grippers, encoders: validated by kinegym.envs.sim"),
}


@dataclass(frozen=True)
class ClimberGeometry:
    """Link lengths (cm) and shoulder offsets (cm, body frame) of the three arms."""

    l1: np.ndarray = field(default_factory=lambda: np.full(3, 10.0))
    l2: np.ndarray = field(default_factory=lambda: np.full(3, 10.0))
    shoulders: np.ndarray = field(default_factory=lambda: np.zeros((3, 2)))
    elbow_limits: tuple[float, float] = (0.0, 2 * math.pi)
    sensor_sigma: float = math.radians(0.5)
    name: str = "climber"

    def __post_init__(self) -> None:
        for key, shape in (("l1", (3,)), ("l2", (3,)), ("shoulders", (3, 2))):
            arr = as_array(key, getattr(self, key), shape)
            if arr.shape != shape:
                raise InvalidInputError(f"{key} has shape {arr.shape}; expected {shape}")
            object.__setattr__(self, key, arr)
        if np.any(self.l1 <= 0) or np.any(self.l2 <= 0):
            raise InvalidInputError(
                f"link lengths l1={self.l1.tolist()}, l2={self.l2.tolist()}; expected > 0 cm"
            )

    @classmethod
    def uniform(cls, link: float = 10.0) -> ClimberGeometry:
        """All six links ``link`` cm, shoulders at the centre (the seed's robot)."""
        if not (isinstance(link, (int, float)) and math.isfinite(link) and link > 0):
            raise InvalidInputError(f"link={link!r}; expected a length > 0 cm")
        return cls(l1=np.full(3, float(link)), l2=np.full(3, float(link)))

    @classmethod
    def from_config(cls, name_or_path: str | Path = "climber") -> ClimberGeometry:
        """Load ``configs/robots/<name>.yaml`` (or a path); raises ``configs.ConfigError``."""
        cfg = _configs.load("robots", name_or_path, CLIMBER_SCHEMA)
        return cls.from_dict(cfg, str(_configs.resolve("robots", name_or_path)))

    @classmethod
    def from_dict(cls, cfg: dict, source: str = "<config>") -> ClimberGeometry:
        """From a robot config already validated against :data:`CLIMBER_SCHEMA` (``source``
        names the file in errors): what a caller that also needs the physics section uses,
        so that the file is read once."""
        lo, hi = cfg["elbow_limits_deg"]
        if lo >= hi:
            raise _configs.ConfigError(source, "elbow_limits_deg", [lo, hi], "[low, high] with low < high")
        arms = cfg["arms"]
        return cls(
            l1=np.array([a["upper_link_cm"] for a in arms]),
            l2=np.array([a["lower_link_cm"] for a in arms]),
            shoulders=np.array([a["shoulder_offset_cm"] for a in arms]),
            elbow_limits=(math.radians(lo), math.radians(hi)),
            sensor_sigma=math.radians(cfg["sensor_sigma_deg"]),
            name=cfg["name"],
        )

    @property
    def reach(self) -> np.ndarray:
        """``(3, 2)``: inner and outer radius of each arm's reachable annulus (cm)."""
        return np.stack([np.abs(self.l1 - self.l2), self.l1 + self.l2], axis=-1)


def _q(q: object) -> np.ndarray:
    return as_array("joint angles q", q, (3, 2))


def elbow_positions(q: object, geom: ClimberGeometry | None = None) -> np.ndarray:
    """Elbow points in the body frame, ``(..., 3, 2)`` cm."""
    g = geom or ClimberGeometry()
    qa = _q(q)
    s = qa[..., 0]
    return g.shoulders + g.l1[:, None] * np.stack([np.cos(s), np.sin(s)], axis=-1)


def hand_positions(q: object, geom: ClimberGeometry | None = None) -> np.ndarray:
    """Hand points in the body frame, ``(..., 3, 2)`` cm (seed 000 part 1, any batch shape)."""
    g = geom or ClimberGeometry()
    qa = _q(q)
    s, e = qa[..., 0], qa[..., 1]
    lower = s - e + np.pi
    return (g.shoulders
            + g.l1[:, None] * np.stack([np.cos(s), np.sin(s)], axis=-1)
            + g.l2[:, None] * np.stack([np.cos(lower), np.sin(lower)], axis=-1))


def arm_ik_one(l1: float, l2: float, dx: float, dy: float, branch: int = 1) -> tuple[float, float]:
    """Two-link IK of one arm for one hand, in plain floats: ``(shoulder, elbow)`` (seed convention).

    ``(dx, dy)`` is the hand relative to the shoulder (body frame); a hand out of reach is
    clamped onto the nearest reachable circle (callers check reach first). The scalar twin of
    :func:`arm_ik` for the simulation's inner loops; ``tests/test_climber.py`` pins the two equal.
    """
    d = math.hypot(dx, dy)
    ce = max(-1.0, min(1.0, (l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2)))
    e = math.acos(ce)
    ca = max(-1.0, min(1.0, (l1 * l1 + d * d - l2 * l2) / (2 * l1 * max(d, 1e-12))))
    s = math.atan2(dy, dx) - branch * math.acos(ca)
    if branch < 0:
        e = 2 * math.pi - e
    return math.remainder(s, 2 * math.pi), e


def arm_ik(hands: object, geom: ClimberGeometry | None = None, branch: int | object = 1) -> np.ndarray:
    """Closed-form IK of all three arms: body-frame hands ``(..., 3, 2)`` -> ``q (..., 3, 2)``.

    ``branch`` is +1 (elbow angle in [0, pi], the seed's), -1, or an array broadcastable to
    ``(..., 3)`` choosing per arm. Shoulder angles are wrapped to (-pi, pi], elbows to
    [0, 2 pi).

    Raises:
        UnreachableError: a hand lies outside its arm's annulus (names the arm, distance
            and the valid interval).
    """
    g = geom or ClimberGeometry()
    h = as_array("hands", hands, (3, 2))
    br = np.asarray(branch)
    if not np.all(np.isin(br, (-1, 1))):
        raise InvalidInputError(f"branch={branch!r}; expected +1 or -1 (per arm or for all)")
    rel = h - g.shoulders
    dist = np.hypot(rel[..., 0], rel[..., 1])
    lo, hi = g.reach[:, 0], g.reach[:, 1]
    tol = 1e-9 * (1 + hi)
    bad = (dist < lo - tol) | (dist > hi + tol)
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        arm = int(idx[-1])
        d = float(dist[tuple(idx)])
        raise UnreachableError(
            f"hand of arm {arm + 1} is {d:.4g} cm from its shoulder; reachable: "
            f"{lo[arm]:.4g}..{hi[arm]:.4g} cm",
            arm=arm + 1, distance_cm=d, reach_cm=[float(lo[arm]), float(hi[arm])],
        )
    l1, l2 = g.l1, g.l2
    # elbow angle between the links from the law of cosines: d^2 = l1^2 + l2^2 - 2 l1 l2 cos e
    cos_e = np.clip((l1 * l1 + l2 * l2 - dist * dist) / (2 * l1 * l2), -1.0, 1.0)
    e = np.arccos(cos_e)  # in [0, pi]
    bearing = np.arctan2(rel[..., 1], rel[..., 0])
    # angle at the shoulder between the upper link and the shoulder->hand line
    cos_a = np.clip((l1 * l1 + dist * dist - l2 * l2) / (2 * l1 * np.maximum(dist, 1e-300)), -1, 1)
    alpha = np.arccos(cos_a)
    s = bearing - br * alpha
    e = np.where(br > 0, e, 2 * np.pi - e)
    s = np.mod(s + np.pi, 2 * np.pi) - np.pi
    return np.stack([s, np.broadcast_to(e, s.shape)], axis=-1)


def _pose(pose: object) -> np.ndarray:
    return as_array("pose", pose, (3,))


def body_to_wall(points: object, pose: object) -> np.ndarray:
    """Body-frame points ``(..., k, 2)`` to the wall frame for poses ``(..., 3)``."""
    p = as_array("points", points, (2,))
    ps = _pose(pose)
    c, s = np.cos(ps[..., 2]), np.sin(ps[..., 2])
    c, s = c[..., None], s[..., None]
    x = ps[..., None, 0] + c * p[..., 0] - s * p[..., 1]
    y = ps[..., None, 1] + s * p[..., 0] + c * p[..., 1]
    return np.stack([x, y], axis=-1)


def wall_to_body(points: object, pose: object) -> np.ndarray:
    """Wall-frame points ``(..., k, 2)`` to the body frame for poses ``(..., 3)``."""
    p = as_array("points", points, (2,))
    ps = _pose(pose)
    c, s = np.cos(ps[..., 2]), np.sin(ps[..., 2])
    c, s = c[..., None], s[..., None]
    dx, dy = p[..., 0] - ps[..., None, 0], p[..., 1] - ps[..., None, 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


def inverse_program(
    holes: object,
    centre: object,
    heading: float | object = 0.0,
    geom: ClimberGeometry | None = None,
    branch: int | object = 1,
) -> np.ndarray:
    """Seed 000's "inverse program": three held holes + wanted centre -> six joint angles.

    Args:
        holes: ``(..., 3, 2)`` wall coordinates (cm) of the holes of arms 1, 2, 3.
        centre: ``(..., 2)`` wanted body centre (cm).
        heading: body heading (rad), scalar or ``(...)``.
        branch: elbow branch, as in :func:`arm_ik`.

    Returns:
        ``(..., 3, 2)`` shoulder and elbow angles (rad).
    """
    c = as_array("centre", centre, (2,))
    hd = np.asarray(heading, dtype=np.float64)
    if not np.all(np.isfinite(hd)):
        raise InvalidInputError(f"heading={heading!r} holds NaN or infinity; expected radians")
    pose = np.concatenate([c, np.broadcast_to(hd, c.shape[:-1])[..., None]], axis=-1)
    return arm_ik(wall_to_body(as_array("holes", holes, (3, 2)), pose), geom, branch)
