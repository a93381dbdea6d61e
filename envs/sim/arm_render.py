"""The arm simulation's picture (:meth:`~kinegym.envs.sim.arm.ArmSim.render`), kept apart from the physics:
the board as inked, the arm from above with the commanded tip, and a side view of the reach plane.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["view_box", "render_arm"]


def view_box(sim: Any) -> tuple[float, float, float, float]:
    """The arm-frame box ``(x0, x1, y0, y1)`` cm that :meth:`ArmSim.render` shows: the canvas
    and the base; image pixel ``(u, v)`` at ``scale`` is arm point ``(x0 + u / scale, y1 - v / scale)``."""
    ox, oy = sim.layout.canvas_origin
    w_cm, h_cm = sim.layout.canvas_size
    bx, by = sim.arm.base_xy
    return (min(ox, bx - 4) - 1, max(ox + w_cm, bx + 4) + 1, min(oy, by - 4) - 1, max(oy + h_cm, by + 4) + 1)


def render_arm(sim: Any, scale: float, status: Sequence[str]) -> np.ndarray:
    """Draw :meth:`ArmSim.render`'s picture (kept apart from the physics)."""
    import cv2

    lay = sim.layout
    ox, oy = lay.canvas_origin
    w_cm, h_cm = lay.canvas_size
    x0, x1, y0, y1 = view_box(sim)
    W, H = int(round((x1 - x0) * scale)), int(round((y1 - y0) * scale))
    img = np.empty((H, W, 3), np.uint8)
    img[...] = (205, 205, 200)

    def px(p: np.ndarray) -> tuple[int, int]:
        return int(round((p[0] - x0) * scale)), int(round((y1 - p[1]) * scale))

    board = cv2.resize(sim.canvas.image(), (int(round(w_cm * scale)), int(round(h_cm * scale))),
                       interpolation=cv2.INTER_AREA)
    c0, r0 = px(np.array([ox, oy + h_cm]))
    hh, ww = board.shape[:2]
    img[max(0, r0):r0 + hh, max(0, c0):c0 + ww] = board[max(0, -r0):H - r0, max(0, -c0):W - c0][
        : min(hh, H - max(0, r0)), : min(ww, W - max(0, c0))]
    q = sim.q_true()
    pts = sim.arm.joint_positions(q)
    xy = [px(p[:2]) for p in pts]
    cv2.circle(img, xy[0], int(0.25 * scale * 4), (90, 90, 95), -1, cv2.LINE_AA)
    for a, b, col, wcm in ((1, 2, (200, 120, 40), 1.4), (2, 3, (220, 150, 60), 1.1), (3, 4, (120, 120, 130), 0.6)):
        cv2.line(img, xy[a], xy[b], col, max(1, int(wcm * scale * 0.5)), cv2.LINE_AA)
    cv2.line(img, xy[0], xy[1], (90, 90, 95), max(1, int(0.6 * scale)), cv2.LINE_AA)
    tip_col = (200, 30, 30) if sim.contact_n > 0 else (40, 40, 40)
    cv2.circle(img, xy[4], max(2, int(0.15 * scale)), tip_col, -1, cv2.LINE_AA)
    cmd = sim.pose_cmd()
    cv2.drawMarker(img, px(cmd[:2]), (20, 140, 20), cv2.MARKER_CROSS, max(6, int(0.5 * scale)), 1, cv2.LINE_AA)
    # side view inset: the reach plane
    iw, ih = int(W * 0.34), int(H * 0.28)
    inset = np.empty((ih, iw, 3), np.uint8)
    inset[...] = (245, 245, 240)
    reach = sim.arm.upper_arm + sim.arm.forearm + sim.arm.tool
    zs = sim.arm.shoulder_height
    s2 = min(iw / (2.0 * reach + 4), ih / (zs + reach * 0.3 + 4))
    ground = ih - 6

    def ipx(r: float, z: float) -> tuple[int, int]:
        return int(round(iw * 0.5 + r * s2)), int(round(ground - z * s2))

    cv2.line(inset, (0, ground), (iw, ground), (120, 120, 120), 2)
    u = np.array([math.cos(q[0] + sim.arm.yaw_offset), math.sin(q[0] + sim.arm.yaw_offset)])
    rz = [(float(np.dot(p[:2] - np.asarray(sim.arm.base_xy), u)), float(p[2])) for p in pts]
    for a, b in ((0, 1), (1, 2), (2, 3), (3, 4)):
        cv2.line(inset, ipx(*rz[a]), ipx(*rz[b]), (60, 60, 70), 2, cv2.LINE_AA)
    cv2.putText(inset, "side", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (60, 60, 60), 1, cv2.LINE_AA)
    img[H - ih - 4:H - 4, W - iw - 4:W - 4] = inset
    lines = [f"t = {sim.time_s:6.2f} s   pen force {sim.contact_n:4.2f} N", *status]
    for i, s in enumerate(lines):
        cv2.putText(img, s, (8, 20 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (20, 20, 20), 1, cv2.LINE_AA)
    return img
