"""The writing arm of seed 003 in pymunk: servo loops, encoders, homing, a spring-loaded pen
and a sponge that really touch the board, ink where the tip really went.

Modelling choice
----------------
The arm is a base yaw joint and three pitch joints (``kinematics.writing_arm``). Seen from
above - the plane the pen draws in - it is a boom turning about the base axis whose length
is the *horizontal reach* ``r`` of the pitch chain: ``tip_xy = base + r u(yaw) + l_f v(yaw)``.
A top view alone cannot carry what the pitch joints do (lift the pen, fight gravity, press
on the board), so one pymunk space holds the arm's two planar projections, which together
are the 4-DOF arm:

* the **yaw plane** (top view): one body turning about the base axis with the inertia
  the arm has about that axis *at its current reach* (``base_inertia + sum m (r^2 + l_f^2)
  + rod terms``, updated every step), driven by the base servo;
* the **reach plane** (the vertical plane through the arm): the upper arm, forearm and pen
  holder as rods with their masses and inertias, pivoted at the shoulder, elbow and wrist
  under gravity (``-z``), driven by the three pitch servos.

What this neglects: the velocity coupling of the two planes - the centrifugal pull
``w^2 r`` of a turning base on the pitch links and the Coriolis torque of a changing reach
on the yaw. At drawing speeds (``w < 0.5 rad/s``, ``r < 30 cm``) that is below 1 % of
gravity; everything else - masses, inertias, limits, torques, friction - is the arm's.

Every servo (thesis section 3.2) is a motor whose rotor has its own reflected inertia and
Coulomb friction, connected to its link through a gear with ``backlash_deg`` of play (a
pymunk rotary limit joint); the link has hard stops ``_STOP_MARGIN`` beyond the soft joint
limits. The encoder sits on the motor side - it does not see the backlash - and counts in
``encoder_step_deg`` steps. Relative encoders (``absolute: false``) read 0 wherever the arm
was at power-on; :meth:`ArmSim.home` finds each joint's index switch (reversing at a limit
stop, detected as a stall) and sets the offset, as in section 3.1.

Control is the thesis's cascade at ``control_hz``: an outer position loop
``w_ref = kp (q_ref - q_enc) + w_ff`` (clamped to ``max_speed``), an inner speed loop
PI on the low-passed differentiated encoder, its torque clamped to the servo's
``max_torque_ncm`` with conditional integration (no wind-up while saturated).

The pen sits in a spring-loaded holder (section 3.3.2): when the IK'd tip goes below the
board the spring (``spring_n_per_cm``, ``travel_cm`` before the holder bottoms out) pushes
back on the tool, and friction ``mu N`` opposes the tip's motion over the board - in the
reach plane as a force, in the yaw plane as a torque. While the pen touches, the tip's
true path (not the commanded one) is inked on a :class:`~envs.sim.board.BoardCanvas`; the
sponge (the pen turned to horizontal, its face ``offset_cm`` below the tool axis) wipes.

Units: cm, kg, s, radians in the API; torques in N cm (pymunk works in kg cm^2 / s^2,
``1 N cm = 100``); forces in N.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

import kinegym.configs as _configs
from kinegym.kinematics.errors import UnreachableError
from kinegym.kinematics.writing_arm import ARM_SCHEMA, WritingArm

from .arm_config import ARM_SIM_SCHEMA, JointParams, joint_params
from .arm_physics import _NCM, ArmPhysics
from .arm_record import HomingReport, Recording, StepMetrics, step_metrics
from .arm_render import render_arm, view_box
from .board import BoardCanvas, Pen
from .strokes import (
    TOOL_NONE,
    TOOL_PEN,
    TOOL_SPONGE,
    BoardLayout,
    DrawingSpec,
    Stroke,
    Trajectory,
    _profile,
    plan,
)

__all__ = ["ArmSim", "Recording", "HomingError", "HomingReport", "StepMetrics", "step_metrics", "JointParams",
           "view_box"]

_N = 100.0  # 1 N in kg cm / s^2
_INK_STEP = 0.02  # cm between recorded ink points
_SPONGE_CHUNK = 1.0  # cm of wipe per erase call
_V_EPS = 0.2  # cm/s: friction is regularised below this tip speed
_MODE_TOL = 0.35  # rad: tool within this of vertical (pen) or horizontal (sponge)
_HARD_K = 100.0  # the holder bottoming out is this much stiffer than its spring


class HomingError(RuntimeError):
    """Homing failed: no index found after reversing at both stops, or timed out."""


class ArmSim:
    """The writing arm drawing on a board.

    Args:
        arm: ``configs/arms`` name or YAML path (``thesis_rrrr``: the seed-003 arm).
        seed: seeds power-on offsets (with homing) - everything else is deterministic.
        homing: power on at a random pose near park with unknown relative-encoder offsets
            and run :meth:`home` in :meth:`reset`. ``False``: power on at park, offsets known.
        canvas: the board to draw on (default: a fresh whiteboard of the config's size).

    The board frame: :class:`~envs.sim.strokes.BoardLayout` places the canvas in the arm
    frame. ``draw(strokes)`` plans and runs, and returns a :class:`Recording`.
    """

    def __init__(self, arm: str | Path = "thesis_rrrr", seed: int | None = None, homing: bool = False,
                 canvas: BoardCanvas | None = None, px_per_cm: float = 16.0) -> None:
        whole = _configs.load("arms", arm, ARM_SCHEMA)  # the file is read once, for the arm and its sim
        self._source = str(_configs.resolve("arms", arm))
        self.arm = WritingArm.from_dict(whole, self._source)
        cfg = _configs.validate(whole["sim"], ARM_SIM_SCHEMA, self._source, prefix="sim")
        self.cfg = cfg
        self.joints = joint_params(cfg, self.arm)
        self.layout = BoardLayout.from_section(cfg["board"])
        pen_phi = -0.5 * math.pi - self.arm.pitch_offset  # the tool pointing straight down
        self.spec = DrawingSpec.from_sim(cfg, pen_phi=pen_phi, sponge_phi=pen_phi + 0.5 * math.pi)
        self.dt = 1.0 / cfg["control_hz"]
        pc = cfg["pen"]
        self.pen = Pen(tuple(int(c) for c in pc["colour"]), pc["width_cm"])  # type: ignore[arg-type]
        w, h = self.layout.canvas_size
        self.canvas = canvas if canvas is not None else BoardCanvas(w, h, px_per_cm)
        x, y, z = cfg["park_cm"]
        self.q_draw_ref = self._draw_reference()
        try:
            self.q_park = self.arm.ik([x, y, z, pen_phi], current=self.q_draw_ref)
        except Exception as exc:
            raise _configs.ConfigError(self._source, "sim.park_cm", cfg["park_cm"], f"a reachable pen position ({exc})"
                                       ) from exc
        self.park_pose = np.array([x, y, z, pen_phi])
        self.homing_default = homing
        self.np_random = np.random.default_rng(seed)
        self.reset(seed=seed, homing=homing)

    def _draw_reference(self) -> np.ndarray:
        """A joint pose over the field's centre, pen down: IK branches are chosen near it."""
        cx, cy = self.layout.to_arm(self.layout.field_centre)
        phi = self.spec.pen_phi
        sols, ok, inl = self.arm.ik_all([cx, cy, 0.0, phi])
        # prefer the arm facing the target with the elbow up (the wrist below the elbow)
        cands = [k for k in range(4) if ok[k] and inl[k]]
        if not cands:
            raise _configs.ConfigError(self._source, "sim.board", self.cfg["board"],
                                       "a field whose centre the arm reaches with the pen vertical")
        pos = self.arm.joint_positions(sols[cands])
        best = cands[int(np.argmax(pos[:, 2, 2] - pos[:, 3, 2]))]
        return sols[best].copy()

    # ------------------------------------------------------------------ power on
    def reset(self, seed: int | None = None, homing: bool | None = None) -> HomingReport | None:
        """Power on: a fresh board is *not* made (the canvas keeps its ink); the arm starts at
        park (``homing=False``) or near it with unknown offsets, then homes."""
        if seed is not None:
            self.np_random = np.random.default_rng(seed)
        homing = self.homing_default if homing is None else homing
        q0 = self.q_park.copy()
        rel = np.array([not jp.absolute for jp in self.joints])
        if homing:
            spread = math.radians(self.cfg["start_spread_deg"])
            q0 = q0 + np.where(rel, self.np_random.uniform(-spread, spread, 4), 0.0)
            q0 = np.clip(q0, self.arm.limits[:, 0] + 0.02, self.arm.limits[:, 1] - 0.02)
        self.phys = ArmPhysics(self.arm, self.joints, self.cfg["base_inertia_kgcm2"], q0, [0.0] * 4)
        motor0 = np.asarray(self.phys.q_motor())
        # encoder counts from 0 at power-on (relative) or reads the motor angle (absolute)
        self._enc_zero = np.where(rel, motor0, 0.0)
        self._enc_step = np.array([jp.encoder_step for jp in self.joints])
        self._ticks = 0  # physics steps since power-on (keys the encoder reading)
        self._enc_cache: tuple[int, np.ndarray] = (-1, np.zeros(4))
        # what the controller assumes at power-on: relative joints are where park is
        self.offset = np.where(rel, self.q_park, 0.0) if homing else np.where(rel, motor0, 0.0)
        self._filt_v = [0.0] * 4
        self._integ = [0.0] * 4
        self._enc_prev = self.encoders().tolist()
        self.time_s = 0.0
        self.contact_n = 0.0
        self._ink: list[tuple[float, float]] = []
        self._ink_tool = TOOL_NONE
        self._ink_len = 0.0
        self.q_cmd = self.q_enc()
        self.last_torque = np.zeros(4)
        self.homed = not homing or not rel.any()
        self.homing_report: HomingReport | None = None
        if homing and rel.any():
            self.homing_report = self.home()
        return self.homing_report

    # ------------------------------------------------------------------ sensing
    def encoders(self) -> np.ndarray:
        """Raw encoder readings (rad): motor angle since power-on, quantised. Read once per
        physics step (the servo tick and the recording share the reading)."""
        if self._enc_cache[0] == self._ticks:
            return self._enc_cache[1].copy()
        raw = np.asarray(self.phys.q_motor()) - self._enc_zero
        step = self._enc_step
        enc = np.where(step > 0, np.round(raw / np.where(step > 0, step, 1.0)) * step, raw)
        self._enc_cache = (self._ticks, enc)
        return enc.copy()

    def q_enc(self) -> np.ndarray:
        """Joint angles the controller believes (encoder + offset), rad."""
        return self.encoders() + self.offset

    def q_true(self) -> np.ndarray:
        return np.asarray(self.phys.q_true())

    def tip_true(self) -> np.ndarray:
        """The pen tip's true pose ``(x, y, z, phi)`` in the arm frame."""
        return self.arm.fk(self.q_true())

    # ------------------------------------------------------------------ one servo tick
    def _tick(self, q_ref: Sequence[float], w_ff: Sequence[float]) -> list[float]:
        dt = self.dt
        ph = self.phys
        enc = self.encoders()
        alpha = min(1.0, dt * 2 * math.pi * self.cfg["speed_filter_hz"])
        torques = [0.0] * 4
        for j, jp in enumerate(self.joints):
            e_pos = enc[j] + self.offset[j]
            v_meas = (enc[j] - self._enc_prev[j]) / dt
            fv = self._filt_v[j] + alpha * (v_meas - self._filt_v[j])
            self._filt_v[j] = fv
            w_ref = jp.kp * (q_ref[j] - e_pos) + w_ff[j]
            if w_ref > jp.max_speed:
                w_ref = jp.max_speed
            elif w_ref < -jp.max_speed:
                w_ref = -jp.max_speed
            ev = w_ref - fv
            integ = self._integ[j] + ev * dt
            tau = jp.kv * ev + jp.ki * integ
            if tau > jp.max_torque:
                tau = jp.max_torque
                if ev < 0:
                    self._integ[j] = integ
            elif tau < -jp.max_torque:
                tau = -jp.max_torque
                if ev > 0:
                    self._integ[j] = integ
            else:
                self._integ[j] = integ
            torques[j] = tau
            self._enc_prev[j] = enc[j]
            ph.rotors[j].torque = tau * _NCM
            if j:  # the reaction on the parent link (joint 1's parent is the ground)
                par = ph.parents[j]
                if par is not ph.space.static_body:
                    par.torque = par.torque - tau * _NCM
        self._contact()
        ph.update_yaw_inertia()
        ph.space.step(dt)
        self._ticks += 1
        self.time_s += dt
        return torques

    def _contact(self) -> None:
        """Pen / sponge on the board: spring force, friction, ink or wipe."""
        ph = self.phys
        r, z, vr, vz, ang = ph.tip_plane()
        sponge = abs(ang) < _MODE_TOL
        pen = abs(ang + 0.5 * math.pi) < _MODE_TOL
        zc = z - self.spec.sponge_offset_cm if sponge else z
        if zc >= 0.0 or not (pen or sponge):
            self.contact_n = 0.0
            if self._ink:
                self._flush_ink()
            return
        pc = self.cfg["pen"]
        k = pc["spring_n_per_cm"] * _N
        d = -zc
        travel = pc["travel_cm"]
        f = k * min(d, travel) + (_HARD_K * k * (d - travel) if d > travel else 0.0)
        f -= 2.0 * math.sqrt(k * ph.masses[2]) * vz  # critical-ish damping of the holder
        f = max(f, 0.0)
        self.contact_n = f / _N
        tool = ph.links[2]
        tip_world = tool.local_to_world((0.5 * ph.lengths[2], 0.0))
        # board-plane velocity of the tip: reach rate along u, yaw rate around the base axis
        yaw = ph.yaw.angle + self.arm.yaw_offset
        c, s = math.cos(yaw), math.sin(yaw)
        lf = self.arm.lateral_offset
        px, py = r * c + lf * s, r * s - lf * c  # tip relative to the base axis
        w = ph.yaw.angular_velocity
        vx, vy = vr * c - w * py, vr * s + w * px
        speed = math.hypot(vx, vy)
        mu_n = pc["friction"] * f
        scale = mu_n / max(speed, _V_EPS)
        fx, fy = -vx * scale, -vy * scale
        f_r = fx * c + fy * s  # along the reach
        tool.apply_force_at_world_point((f_r, f), tip_world)
        ph.yaw.torque = ph.yaw.torque + (px * fy - py * fx)
        # ink where the tip is (canvas cm)
        tool_kind = TOOL_SPONGE if sponge else TOOL_PEN
        if self._ink and tool_kind != self._ink_tool:
            self._flush_ink()
        self._ink_tool = tool_kind
        bx, by = self.arm.base_xy
        cx = bx + px - self.layout.canvas_origin[0]
        cy = by + py - self.layout.canvas_origin[1]
        if not self._ink:
            self._ink.append((cx, cy))
            return
        lx, ly = self._ink[-1]
        step = math.hypot(cx - lx, cy - ly)
        if step >= _INK_STEP:
            self._ink.append((cx, cy))
            self._ink_len += step
            if (sponge and self._ink_len >= _SPONGE_CHUNK) or len(self._ink) >= 4000:
                last = self._ink[-1]
                self._flush_ink()
                self._ink = [last]

    def _flush_ink(self) -> None:
        pts = np.asarray(self._ink)
        if self._ink_tool == TOOL_SPONGE:
            sp = self.cfg["sponge"]
            self.canvas.erase(pts, sp["width_cm"], sp["efficiency"])
        else:
            self.canvas.stroke(pts, self.pen)
        self._ink = []
        self._ink_len = 0.0

    # ------------------------------------------------------------------ running
    def joint_targets(self, traj: Trajectory) -> np.ndarray:
        """IK of every trajectory sample, each branch chosen nearest the previous sample.

        Raises:
            UnreachableError: a pose no branch reaches inside the limits, or one the arm could
                reach only by jumping to another IK branch mid-stroke (named in the message).
        """
        n = len(traj)
        out = np.empty((n, 4))
        cur = tuple(float(v) for v in self.q_cmd)
        ik = self.arm.ik_fast
        jump = [10.0 * jp.max_speed * self.dt + 1e-3 for jp in self.joints]
        poses = traj.pose.tolist()
        for i in range(n):
            x, y, z, phi = poses[i]
            q = ik(x, y, z, phi, cur)
            if q is None:
                raise UnreachableError(
                    f"arm '{self.arm.name}' cannot reach pen pose x={x:.3f}, y={y:.3f}, z={z:.3f} cm, "
                    f"phi={math.degrees(phi):.1f} deg (sample {i} of {n}, t={i * traj.dt:.3f} s) "
                    "inside its joint limits", target=[x, y, z, phi])
            for k in range(4):
                if abs(q[k] - cur[k]) > jump[k]:
                    dq = math.degrees(q[k] - cur[k])
                    why = (f"jumping q{k + 1} by {dq:.1f} deg to another IK branch" if abs(dq) > 20 else
                           f"turning q{k + 1} at {abs(dq) / traj.dt:.0f} deg/s (its limit: "
                           f"{math.degrees(self.joints[k].max_speed):.0f}) at the edge of the workspace")
                    raise UnreachableError(
                        f"arm '{self.arm.name}' reaches pen pose x={x:.3f}, y={y:.3f}, z={z:.3f} cm, "
                        f"phi={math.degrees(phi):.1f} deg (sample {i} of {n}) only by {why}: move the strokes "
                        "or the board (sim.board) inside the workspace", target=[x, y, z, phi])
            out[i] = q
            cur = q
        return out

    def run(self, traj: Trajectory, q_ref: np.ndarray | None = None,
            progress: Callable[[int, int], None] | None = None,
            on_frame: Callable[[ArmSim], None] | None = None, frame_every_s: float = 0.1) -> Recording:
        """Track a trajectory (pen poses, or joint targets ``q_ref`` for the same samples).

        ``progress(done, total)`` is called about 100 times; ``on_frame(sim)`` every
        ``frame_every_s`` simulated seconds (e.g. to collect :meth:`render` frames for a GIF).
        :meth:`start` does the same in slices (a window steps it between frames).
        """
        r = self.start(traj, q_ref)
        every = max(1, r.n // 100)
        frame_every = max(1, int(round(frame_every_s / self.dt)))
        while not r.done:
            i = r.i
            r.advance(1)
            if progress is not None and (i % every == 0 or i == r.n - 1):
                progress(i + 1, r.n)
            if on_frame is not None and i % frame_every == 0:
                r.show_ink()
                on_frame(self)
        return r.finish()

    def start(self, traj: Trajectory, q_ref: np.ndarray | None = None) -> ArmRun:
        """A run of ``traj`` to advance tick by tick (:class:`ArmRun`); :meth:`run` runs it whole."""
        if abs(traj.dt - self.dt) > 1e-12:
            raise ValueError(f"trajectory dt {traj.dt} s; this arm's servo tick is {self.dt} s")
        return ArmRun(self, traj, self.joint_targets(traj) if q_ref is None else np.asarray(q_ref, float))

    def pose_cmd(self) -> np.ndarray:
        """The pen pose the arm is commanded to (FK of the last joint targets)."""
        return self.arm.fk(self.q_cmd)

    def plan(self, strokes: Sequence[Stroke], speed_cm_s: float | None = None,
             end: Sequence[float] | None = None) -> Trajectory:
        """Time strokes from the current commanded pose back to park (or ``end``)."""
        return plan(strokes, self.layout, self.spec, self.dt, self.pose_cmd(), speed_cm_s,
                    self.park_pose if end is None else end)

    def draw(self, strokes: Sequence[Stroke], speed_cm_s: float | None = None,
             progress: Callable[[int, int], None] | None = None,
             on_frame: Callable[[ArmSim], None] | None = None, frame_every_s: float = 0.1) -> Recording:
        """Plan and draw strokes (pen or sponge), ending parked. Returns the recording."""
        return self.run(self.plan(strokes, speed_cm_s), progress=progress, on_frame=on_frame,
                        frame_every_s=frame_every_s)

    def hold(self, seconds: float) -> Recording:
        """Hold the current command for ``seconds``."""
        n = max(1, int(round(seconds / self.dt)))
        pose = np.repeat(self.pose_cmd()[None], n, 0)
        traj = Trajectory(self.dt, pose, np.zeros(n, np.int8), np.full(n, -1, np.int16), np.ones(n, bool))
        return self.run(traj, q_ref=np.repeat(self.q_cmd[None], n, 0))

    def move_joints(self, q_target: Sequence[float], speed_frac: float = 0.5, settle_s: float = 0.3) -> Recording:
        """A joint-space move (trapezoid at ``speed_frac`` of each servo's max speed) and a hold."""
        q0 = self.q_cmd.copy()
        q1 = np.asarray(q_target, float)
        d = q1 - q0
        vmax = speed_frac * np.array([jp.max_speed for jp in self.joints])
        dur = float(np.max(np.abs(d) / vmax)) if np.any(d) else 0.0
        s = _profile(1.0, 1.0 / max(dur, 1e-9), 4.0 / max(dur, 1e-9) ** 2 * 1.5, self.dt) if dur > 0 else np.zeros(0)
        n_settle = max(1, int(round(settle_s / self.dt)))
        qr = np.vstack([q0 + s[:, None] * d, np.repeat(q1[None], n_settle, 0)])
        pose = self.arm.fk(qr)
        hold = np.r_[np.zeros(len(s), bool), np.ones(n_settle, bool)]
        traj = Trajectory(self.dt, pose, np.zeros(len(qr), np.int8), np.full(len(qr), -1, np.int16), hold)
        return self.run(traj, q_ref=qr)

    # ------------------------------------------------------------------ homing
    def home(self, timeout_s: float = 60.0) -> HomingReport:
        """Find every relative joint's index switch in turn and set its offset (thesis 3.1).

        Each joint ramps at ``homing_speed`` in ``homing_dir`` (slowing down with
        ``homing_slowdown_s``, as the thesis's drive 3 approaches the switch that is both its
        index and its limit); the index switch fires when the link crosses ``index_deg``; a
        command running ``stall_deg`` ahead of the encoder means a limit stop (or
        ``homing_sweep_deg`` without an index, drive 2's fixed-angle sweep): the joint turns
        back. A joint with ``homing_wait_deg`` then turns there and waits while the later
        joints home (drive 1, out of the board's way). After two reversals without an
        index, or ``timeout_s``, :class:`HomingError`. Ends with a joint move to park.
        """
        t0 = self.time_s
        start_err = self.q_enc() - self.q_true()
        stall = math.radians(self.cfg["stall_deg"])
        reversals = []
        self.q_cmd = self.q_enc()
        zeros = [0.0] * 4
        for j, jp in enumerate(self.joints):
            if jp.absolute:
                reversals.append(0)
                continue
            direction = jp.homing_dir
            ref = list(self.q_enc())
            start = ref[j]
            side = math.copysign(1.0, self.phys.q_true()[j] - jp.index)
            n_rev, found, t_joint = 0, False, self.time_s
            while not found:
                if self.time_s - t0 > timeout_s:
                    raise HomingError(f"arm '{self.arm.name}': homing joint {j + 1} timed out after {timeout_s} s")
                speed = jp.homing_speed
                if jp.homing_slowdown > 0:
                    speed *= max(0.2, math.exp(-(self.time_s - t_joint) / jp.homing_slowdown))
                ref[j] += direction * speed * self.dt
                ff = list(zeros)
                ff[j] = direction * speed
                self._tick(ref, ff)
                enc_j = float(self.encoders()[j])
                q_t = self.phys.q_true()[j]
                new_side = math.copysign(1.0, q_t - jp.index)
                if new_side != side:  # the index switch fires: set the offset
                    self.offset[j] = jp.index - enc_j
                    found = True
                    break
                belief = enc_j + self.offset[j]
                swept = jp.homing_sweep > 0 and direction * (ref[j] - (start + direction * jp.homing_sweep)) > 0
                if abs(ref[j] - belief) > stall or swept:
                    n_rev += 1
                    if n_rev > 2:
                        raise HomingError(
                            f"arm '{self.arm.name}': joint {j + 1} found no index switch at "
                            f"{math.degrees(jp.index):.1f} deg between its stops (reversed {n_rev - 1} times); "
                            "check sim.joints[].index_deg and homing_dir")
                    direction = -direction
                    ref[j] = belief
                    self._integ[j] = 0.0
            reversals.append(n_rev)
            self.q_cmd = self.q_enc()
            self.q_cmd[:j] = np.asarray(ref[:j])
            self.hold(0.1)
            if jp.homing_wait is not None:  # homed: out of the way while the others home
                target = self.q_cmd.copy()
                target[j] = jp.homing_wait
                self.move_joints(target)
        self.homed = True
        self.move_joints(self.q_park)
        self.hold(0.2)
        residual = self.q_enc() - self.q_true()
        return HomingReport(self.offset.copy(), start_err, residual, tuple(reversals), self.time_s - t0)

    # ------------------------------------------------------------------ servo test
    def step_response(self, joint: int, amplitude: float = math.radians(10.0), duration_s: float = 1.5,
                      settle_first_s: float = 0.5) -> tuple[np.ndarray, np.ndarray, np.ndarray, StepMetrics]:
        """Step one joint's target by ``amplitude`` rad from the current command, holding the
        others, after holding still for ``settle_first_s``; returns ``t``, the joint's true
        angle, every joint's torque (N cm) and the :class:`StepMetrics` of the true angle."""
        if joint not in range(4):
            raise ValueError(f"joint={joint!r}; expected 0..3 (q1..q4)")
        if settle_first_s > 0:
            self.hold(settle_first_s)
        n = max(10, int(round(duration_s / self.dt)))
        q0 = self.q_cmd.copy()
        q1 = q0.copy()
        q1[joint] += amplitude
        if not self.arm.within_limits(q1):
            raise ValueError(f"step of {math.degrees(amplitude):.1f} deg on q{joint + 1} leaves the joint limits "
                             f"{np.degrees(self.arm.limits[joint]).round(1).tolist()} deg")
        start = float(self.q_true()[joint])
        qr = np.repeat(q1[None], n, 0)
        pose = self.arm.fk(qr)
        rec = self.run(Trajectory(self.dt, pose, np.zeros(n, np.int8), np.full(n, -1, np.int16)), q_ref=qr)
        m = step_metrics(rec.t, rec.q_true[:, joint], start, float(q1[joint]))
        return rec.t, rec.q_true[:, joint], rec.torque, m

    # ------------------------------------------------------------------ pictures
    def render(self, scale: float = 24.0, status: Sequence[str] = ()) -> np.ndarray:
        """Top view (RGB): the board with its ink, the arm's links projected on it, the
        commanded tip, and an inset side view of the reach plane."""
        return render_arm(self, scale, status)

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("ArmSim holds a pymunk space mid-motion and does not pickle; rebuild it and replay "
                        "(the TicTacToeDraw env pickles by replaying its actions)")


class ArmRun:
    """One trajectory being tracked: :meth:`advance` steps ``ticks`` servo ticks, ``i`` of ``n``
    are done; :meth:`recording` is what was recorded so far, :meth:`finish` ends the run (the
    ink flushed, the arm's command updated) and returns the whole recording."""

    def __init__(self, sim: ArmSim, traj: Trajectory, qr: np.ndarray) -> None:
        self.sim, self.traj, self.qr, self.n, self.i = sim, traj, qr, len(qr), 0
        w_ff = np.zeros_like(qr)
        if self.n > 1:
            w_ff[1:] = np.diff(qr, axis=0) / sim.dt
        lim = np.array([jp.max_speed for jp in sim.joints])
        w_ff = np.clip(w_ff, -lim, lim)
        self.q_enc, self.q_true = np.empty((self.n, 4)), np.empty((self.n, 4))
        self.torque, self.contact = np.empty((self.n, 4)), np.empty(self.n)
        self._qr, self._wf = qr.tolist(), w_ff.tolist()

    @property
    def done(self) -> bool:
        return self.i >= self.n

    def advance(self, ticks: int) -> int:
        """Step up to ``ticks`` servo ticks; returns how many were stepped."""
        sim, k = self.sim, 0
        while k < ticks and self.i < self.n:
            i = self.i
            self.torque[i] = sim._tick(self._qr[i], self._wf[i])
            self.q_enc[i] = sim.q_enc()
            self.q_true[i] = sim.phys.q_true()
            self.contact[i] = sim.contact_n
            self.i, k = i + 1, k + 1
        return k

    def show_ink(self) -> None:
        """Put the ink drawn so far on the canvas (the stroke in progress continues)."""
        if self.sim._ink:
            last = self.sim._ink[-1]
            self.sim._flush_ink()
            self.sim._ink = [last]

    def recording(self) -> Recording:
        m, t = self.i, self.traj
        return Recording(self.sim.arm, self.sim.dt, t.pose[:m].copy(), self.qr[:m], self.q_enc[:m], self.q_true[:m],
                         self.torque[:m], self.sim.arm.fk(self.q_true[:m]), self.contact[:m], t.tool[:m].copy(),
                         t.stroke[:m].copy(), t.hold[:m].copy())

    def finish(self) -> Recording:
        sim = self.sim
        if sim._ink:
            sim._flush_ink()
        if self.i:
            sim.q_cmd = self.qr[self.i - 1].copy()
            sim.last_torque = self.torque[self.i - 1].copy()
        return self.recording()
