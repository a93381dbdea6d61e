"""Serial (and branched) kinematic chains: Denavit-Hartenberg tables and product of exponentials.

Two descriptions of the same mechanism, both vectorised over leading batch dimensions:

* :class:`DHChain` - standard Denavit-Hartenberg links ``T = Rz(theta) Tz(d) Tx(a) Rx(alpha)``
  (seed 001's ``matriz_T``), revolute or prismatic, with fixed frames (no joint), joints
  that drive several frames with a coefficient (seed 001's two-finger gripper:
  ``theta = 90 deg -+ t5``) and branches (each link names its parent frame).
* :class:`PoEChain` - space-frame screw axes and a home pose ``M`` (seed 002):
  ``T(q) = exp([S1] q1) ... exp([Sn] qn) M``.

Both give the pose of any frame and the geometric Jacobian ``[v; w]`` (linear velocity of
the frame origin and angular velocity, base frame) with respect to the joint variables.

Speed: a :class:`DHChain` compiles its table into one straight-line Python function with
the constant parts folded (zero offsets vanish, ``alpha`` of 0 or +-90 deg become
permutations). The same code runs on floats (one configuration: a few microseconds) and
on numpy arrays (a batch: millions of configurations per second), see
``bench/bench_kinematics.py``.

Units: lengths in whatever unit the table uses (cm in this project), angles in radians.
Note on seed 001: its text defines ``d`` and ``a`` along the wrong axes; the code (and this
module) use the standard definitions: ``d``, ``theta`` along/about ``z_{i-1}``; ``a``,
``alpha`` along/about ``x_i``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ._kernels.dh import compile_dh
from .errors import InvalidInputError, as_array

__all__ = ["DHLink", "DHChain", "PoEChain", "dh_matrix", "screw_exp"]

_TOL = 1e-15


@dataclass(frozen=True)
class DHLink:
    """One standard DH transform from frame ``parent`` to a new frame.

    Args:
        d, theta, a, alpha: DH constants (length unit, radians). For a revolute link the
            joint value is added to ``theta``; for a prismatic link, to ``d``.
        kind: ``"R"`` revolute, ``"P"`` prismatic, ``"F"`` fixed (no joint).
        joint: index of the joint variable that drives this link (``None`` for fixed).
        scale: coefficient of the joint variable (``-1`` for a mirrored finger).
        parent: index of the parent frame (``-1`` = base). ``None`` = the previous link.
        name: optional frame name (``"tool"``, ``"finger1"``, ...).
    """

    d: float = 0.0
    theta: float = 0.0
    a: float = 0.0
    alpha: float = 0.0
    kind: Literal["R", "P", "F"] = "R"
    joint: int | None = None
    scale: float = 1.0
    parent: int | None = None
    name: str = ""


def dh_matrix(d: float, theta: float, a: float, alpha: float) -> np.ndarray:
    """The 4x4 standard DH transform ``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` (reference form)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


@dataclass
class DHChain:
    """A tree of DH links; frame ``i`` is the frame after link ``i`` (base is frame ``-1``).

    Attributes:
        links: the DH links in order (a parent always precedes its children).
        base: a constant 4x4 transform from the world to frame ``-1``.
    """

    links: Sequence[DHLink]
    base: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        self.links = tuple(self.links)
        if not self.links:
            raise InvalidInputError("a DHChain needs at least one link; got none")
        fixed: list[DHLink] = []
        for i, link in enumerate(self.links):
            parent = i - 1 if link.parent is None else link.parent
            if not -1 <= parent < i:
                raise InvalidInputError(
                    f"link {i} has parent {link.parent}; expected -1..{i - 1} (an earlier frame)"
                )
            if link.kind not in ("R", "P", "F"):
                raise InvalidInputError(f"link {i} has kind {link.kind!r}; expected 'R', 'P' or 'F'")
            if (link.kind == "F") != (link.joint is None):
                raise InvalidInputError(
                    f"link {i}: kind {link.kind!r} with joint={link.joint}; fixed links have no "
                    "joint and moving links need one"
                )
            fixed.append(DHLink(**{**link.__dict__, "parent": parent}))
        self.links = tuple(fixed)
        joints = sorted({lk.joint for lk in self.links if lk.joint is not None})
        if joints != list(range(len(joints))):
            raise InvalidInputError(f"joint indices {joints} must be 0..n-1 without gaps")
        self.n_joints = len(joints)
        self.base = np.asarray(self.base, dtype=np.float64)
        self._names = {lk.name: i for i, lk in enumerate(self.links) if lk.name}
        self._compiled = self._compile()

    # ------------------------------------------------------------------ structure
    @property
    def n_frames(self) -> int:
        return len(self.links)

    def frame_index(self, frame: int | str) -> int:
        """Index of a frame given by index (negative counts from the end) or by name."""
        if isinstance(frame, str):
            if frame not in self._names:
                raise InvalidInputError(
                    f"frame {frame!r} is not in this chain; named frames: {sorted(self._names)}"
                )
            return self._names[frame]
        idx = frame + self.n_frames if frame < 0 else frame
        if not 0 <= idx < self.n_frames:
            raise InvalidInputError(f"frame {frame} out of range; the chain has {self.n_frames}")
        return idx

    def path(self, frame: int | str) -> list[int]:
        """Link indices from the base to ``frame`` (inclusive), in order."""
        i = self.frame_index(frame)
        out = []
        while i >= 0:
            out.append(i)
            i = self.links[i].parent  # type: ignore[assignment]
        return out[::-1]

    def _compile(self) -> Callable[..., tuple]:
        """Straight-line FK of every frame (:mod:`kinegym.kinematics._kernels.dh`), run on floats
        by :meth:`fk_fast` and on arrays by :meth:`fk`; :meth:`fk_reference` is the readable form."""
        self.source, self._fk_scalar, self._fk_array = compile_dh(self.links, self.base, self.n_joints)
        return self._fk_scalar

    def fk_reference(self, q: object, frame: int | str = -1) -> np.ndarray:
        """FK of one configuration as the textbook writes it: the base transform times the DH
        matrices (:func:`dh_matrix`) of the links from the base to ``frame``. The reference the
        compiled :meth:`fk` is tested against."""
        qa = self._check_q(q)
        t = self.base.copy()
        for i in self.path(frame):
            lk = self.links[i]
            theta, d = lk.theta, lk.d
            if lk.kind == "R":
                theta += lk.scale * float(qa[lk.joint])
            elif lk.kind == "P":
                d += lk.scale * float(qa[lk.joint])
            t = t @ dh_matrix(d, theta, lk.a, lk.alpha)
        return t

    # ------------------------------------------------------------------ kinematics
    def _check_q(self, q: object) -> np.ndarray:
        return as_array("q", q, (self.n_joints,))

    @staticmethod
    def _to_pose(comps: tuple, out: np.ndarray) -> None:
        """Write one frame's 12 components (scalars or arrays) into ``out (..., 4, 4)``."""
        for k in range(9):
            out[..., k // 3, k % 3] = comps[k]
        for k in range(3):
            out[..., k, 3] = comps[9 + k]
        out[..., 3, :3] = 0.0
        out[..., 3, 3] = 1.0

    def frames(self, q: object) -> np.ndarray:
        """Poses of every frame, shape ``(..., n_frames, 4, 4)`` (world coordinates)."""
        qa = self._check_q(q)
        if qa.ndim == 1:
            comps = self._fk_scalar(*qa.tolist())
        else:
            comps = self._fk_array(*np.moveaxis(qa, -1, 0))
        out = np.empty(qa.shape[:-1] + (self.n_frames, 4, 4))
        for i, c in enumerate(comps):
            self._to_pose(c, out[..., i, :, :])
        return out

    def fk(self, q: object, frame: int | str = -1) -> np.ndarray:
        """Pose of one frame (default: the last link), shape ``(..., 4, 4)``."""
        qa = self._check_q(q)
        idx = self.frame_index(frame)
        if qa.ndim == 1:
            c = self._fk_scalar(*qa.tolist())[idx]
            return np.array([[c[0], c[1], c[2], c[9]], [c[3], c[4], c[5], c[10]],
                             [c[6], c[7], c[8], c[11]], [0.0, 0.0, 0.0, 1.0]])
        out = np.empty(qa.shape[:-1] + (4, 4))
        self._to_pose(self._fk_array(*np.moveaxis(qa, -1, 0))[idx], out)
        return out

    def fk_fast(self, *q: float, frame: int = -1) -> tuple[float, ...]:
        """One configuration, plain floats in and out: ``(r00, r01, ..., r22, px, py, pz)``.

        The microsecond path for control loops; no input checks beyond Python's own.
        """
        return self._fk_scalar(*q)[frame]

    def jacobian(self, q: object, frame: int | str = -1) -> np.ndarray:
        """Geometric Jacobian of ``frame``: shape ``(..., 6, n_joints)``, rows ``[v; w]``."""
        qa = self._check_q(q)
        idx = self.frame_index(frame)
        fr = self.frames(qa)
        p_end = fr[..., idx, :3, 3]
        jac = np.zeros(qa.shape[:-1] + (6, self.n_joints))
        base = np.broadcast_to(self.base, qa.shape[:-1] + (4, 4))
        for i in self.path(idx):
            lk = self.links[i]
            if lk.kind == "F":
                continue
            parent = base if lk.parent == -1 else fr[..., lk.parent, :, :]
            z, o = parent[..., :3, 2], parent[..., :3, 3]
            if lk.kind == "R":
                jac[..., :3, lk.joint] += lk.scale * np.cross(z, p_end - o)
                jac[..., 3:, lk.joint] += lk.scale * z
            else:
                jac[..., :3, lk.joint] += lk.scale * z
        return jac

    def to_poe(self, frame: int | str = -1) -> PoEChain:
        """The equivalent product-of-exponentials chain for one frame (from the zero pose)."""
        idx = self.frame_index(frame)
        zero = self.frames(np.zeros(self.n_joints))
        screws = np.zeros((self.n_joints, 6))
        for i in self.path(idx):
            lk = self.links[i]
            if lk.kind == "F":
                continue
            parent = self.base if lk.parent == -1 else zero[lk.parent]
            z, o = parent[:3, 2], parent[:3, 3]
            if lk.kind == "R":
                screws[lk.joint] += lk.scale * np.concatenate([z, -np.cross(z, o)])
            else:
                screws[lk.joint] += lk.scale * np.concatenate([np.zeros(3), z])
        return PoEChain(screws=screws, home=zero[idx])


def _skew(w: np.ndarray) -> np.ndarray:
    o = np.zeros(w.shape[:-1] + (3, 3))
    o[..., 0, 1], o[..., 0, 2] = -w[..., 2], w[..., 1]
    o[..., 1, 0], o[..., 1, 2] = w[..., 2], -w[..., 0]
    o[..., 2, 0], o[..., 2, 1] = -w[..., 1], w[..., 0]
    return o


def screw_exp(screw: object, theta: object) -> np.ndarray:
    """Matrix exponential ``exp([S] theta)`` of a screw ``S = (w, v)``, batched: ``(..., 4, 4)``.

    ``w`` is a unit axis (revolute) or zero (prismatic: pure translation ``v theta``).
    Uses Rodrigues' formula and ``G(theta) = I theta + (1-cos) [w] + (theta-sin) [w]^2``.
    """
    s = np.asarray(screw, dtype=np.float64)
    th = np.asarray(theta, dtype=np.float64)[..., None, None]
    w, v = s[..., :3], s[..., 3:]
    wx = _skew(w)
    wx2 = wx @ wx
    eye = np.eye(3)
    rot = eye + np.sin(th) * wx + (1 - np.cos(th)) * wx2
    g = eye * th + (1 - np.cos(th)) * wx + (th - np.sin(th)) * wx2
    out = np.zeros(np.broadcast_shapes(rot.shape[:-2], v.shape[:-1]) + (4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = (g @ v[..., None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


@dataclass
class PoEChain:
    """Product-of-exponentials chain: space screw axes ``screws`` (n, 6) and home pose ``home``.

    Each screw is ``(w, v)`` with ``v = -w x q`` for a revolute joint through point ``q``,
    ``(0, axis)`` for a prismatic joint.
    """

    screws: np.ndarray
    home: np.ndarray

    def __post_init__(self) -> None:
        self.screws = as_array("screws", self.screws, (6,))
        if self.screws.ndim != 2:
            raise InvalidInputError(f"screws has shape {self.screws.shape}; expected (n, 6)")
        self.home = as_array("home", self.home, (4, 4))
        self.n_joints = self.screws.shape[0]

    def _exps(self, q: np.ndarray) -> np.ndarray:
        return screw_exp(self.screws, q)  # (..., n, 4, 4)

    def fk(self, q: object) -> np.ndarray:
        """Pose of the end frame, ``(..., 4, 4)``."""
        qa = as_array("q", q, (self.n_joints,))
        e = self._exps(qa)
        t = np.broadcast_to(np.eye(4), qa.shape[:-1] + (4, 4))
        for i in range(self.n_joints):
            t = t @ e[..., i, :, :]
        return t @ self.home

    def jacobian(self, q: object) -> np.ndarray:
        """Geometric Jacobian ``[v_point; w]`` of the end-frame origin, ``(..., 6, n)``."""
        qa = as_array("q", q, (self.n_joints,))
        e = self._exps(qa)
        t = np.broadcast_to(np.eye(4), qa.shape[:-1] + (4, 4))
        cols = []
        for i in range(self.n_joints):
            r, p = t[..., :3, :3], t[..., :3, 3]
            w = (r @ self.screws[i, :3, None])[..., 0]
            v = (r @ self.screws[i, 3:, None])[..., 0] + np.cross(p, w)
            cols.append(np.concatenate([v, w], axis=-1))  # spatial twist column
            t = t @ e[..., i, :, :]
        js = np.stack(cols, axis=-1)
        p_end = (t @ self.home)[..., :3, 3]
        # spatial twist (v_s, w) -> velocity of the end point: v_s + w x p_end
        jv = js[..., :3, :] + np.cross(js[..., 3:, :], p_end[..., :, None], axis=-2)
        return np.concatenate([jv, js[..., 3:, :]], axis=-2)
