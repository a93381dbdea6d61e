"""Starting points for the writing arm's numeric IK: a table of workspace samples by cell.

:class:`ArmSeeds` samples the arm's joint space inside its limits once, bins the samples by
the cell of their pen pose (position, or position and pitch) and keeps per cell the best
sample and a few far from it (other branches of the arm). :func:`kinegym.kinematics.ik.solve_arm`
starts from the sample nearest the target's cell centre, which is what makes it converge in
about three LM iterations, and tries the cell's other samples when that start stalls.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence

import numpy as np

from .writing_arm import TWO_PI, WritingArm

__all__ = ["ArmSeeds"]


def _cell_table(
    key: np.ndarray, score: np.ndarray, q: np.ndarray, ncells: int, k: int, gap: float
) -> np.ndarray:
    """Per cell, up to ``k`` sample indices (-1: none): the best-scored sample, then the
    best ones farther than ``gap`` (max joint difference) from every one kept before."""
    order = np.argsort(key + score * (0.999 / max(float(score.max()), 1e-300)))
    ks = key[order]
    first = np.empty(len(ks), dtype=bool)
    first[0] = True
    np.not_equal(ks[1:], ks[:-1], out=first[1:])
    group = np.cumsum(first) - 1
    cells = ks[first]
    table = np.full((ncells, k), -1, dtype=np.int32)
    kept = order[first]
    table[cells, 0] = kept
    if k > 1:
        cols = [q[order, j] for j in range(q.shape[1])]
        far = ~first
    for c in range(1, k):
        ref = kept[group]
        dist = np.abs(cols[0] - q[ref, 0])
        for j in range(1, len(cols)):
            np.maximum(dist, np.abs(cols[j] - q[ref, j]), out=dist)
        far &= dist > gap
        rows = np.flatnonzero(far)
        if not len(rows):
            break
        rk = ks[rows]
        take = np.empty(len(rows), dtype=bool)
        take[0] = True
        np.not_equal(rk[1:], rk[:-1], out=take[1:])
        hit = rows[take]
        kept = kept.copy()  # cells without a new alternate keep comparing with the last one
        kept[group[hit]] = order[hit]
        table[ks[hit], c] = order[hit]
        far[hit] = False
    return table


def _dilate(table: np.ndarray, strides: Sequence[int], passes: int) -> None:
    """Give empty cells (no first sample) the samples of a filled face neighbour.

    ``table`` is (cells, k) of a C-ordered grid whose outer x, y, z layer is empty
    padding, so the flat shifts never carry a sample across those edges (a pitch-bin
    shift at the +-pi seam borrows from the next z cell: still a nearby start)."""
    for _ in range(passes):
        src = table.copy()
        for s in strides:
            for a, b in ((slice(s, None), slice(None, -s)), (slice(None, -s), slice(s, None))):
                d, n = table[a], src[b]
                hole = (d[:, :1] < 0) & (n[:, :1] >= 0)
                np.copyto(d, n, where=hole)


class _Grid:
    """A dense grid over (x, y, z) or (x, y, z, phi) holding sample rows (offsets into
    the sample array, -1: none) per cell."""

    def __init__(self, f: np.ndarray, q: np.ndarray, cell: float, phi_cell: float | None,
                 score_extra: np.ndarray, k: int, gap: float, passes: int) -> None:
        score = score_extra.copy()
        org, dims, key = [], [], None
        for ax in range(3):
            p = f[:, ax]
            o = math.floor(float(p.min()) / cell) * cell - cell  # one empty layer of padding
            org.append(o)
            dims.append(int((float(p.max()) - o) / cell) + 2)
            u = (p - o) * (1.0 / cell)
            i = u.astype(np.int64)
            r = u - i - 0.5
            score += r * r
            key = i if key is None else key * dims[-1] + i
        nphi = 0
        if phi_cell is not None:
            nphi = int(math.ceil(TWO_PI / phi_cell))
            w = (f[:, 3] + math.pi) * (nphi / TWO_PI)
            ip = np.minimum(w.astype(np.int64), nphi - 1)
            key = key * nphi + ip
            r = w - ip - 0.5
            score += r * r
        ncells = dims[0] * dims[1] * dims[2] * max(nphi, 1)
        self.table = _cell_table(key, score, q, ncells, k, gap)
        inner = max(nphi, 1)
        strides = (inner, dims[2] * inner, dims[1] * dims[2] * inner) + ((1,) if nphi else ())
        _dilate(self.table, strides, passes)
        self.params = (float(org[0]), float(org[1]), float(org[2]), 1.0 / cell,
                       dims[0], dims[1], dims[2], nphi, nphi / TWO_PI)

    def key(self, x: float, y: float, z: float, phi: float | None) -> int:
        ox, oy, oz, inv, nx, ny, nz, nphi, iphi = self.params
        i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
        if not (0 <= i < nx and 0 <= j < ny and 0 <= k < nz):
            return -1
        flat = (i * ny + j) * nz + k
        if nphi:
            if not -math.pi < phi <= math.pi:  # type: ignore[operator]
                phi = math.remainder(phi, TWO_PI)  # type: ignore[arg-type]
            ip = int((phi + math.pi) * iphi)  # type: ignore[operator]
            flat = flat * nphi + (ip if ip < nphi else nphi - 1)
        return flat


class ArmSeeds:
    """A table of workspace samples of one arm, for starting numeric IK near the answer.

    ``n`` configurations are drawn inside the joint limits (seeded) and binned on dense
    grids: by pen position (cells of ``cell`` cm) for position targets, and by pen position
    and pitch (``pitch_cell`` cm x ``phi_cell`` rad) for position + pitch targets, each also
    on a grid twice as coarse. A cell keeps the sample nearest its centre (samples close to
    a joint limit ranked down: they tend to stall on it) and alternates farther than
    ``branch_gap`` rad in joint space from it (the arm's other branches: elbow up/down,
    facing the target or reaching over the base), which :func:`solve_arm` tries when the
    first start stalls. Empty cells borrow a neighbour's samples. :meth:`nearest` is O(1):
    a few multiplications and one array look-up. With the defaults (Pincher) the build
    takes ~0.35 s and the tables ~17 MB.
    """

    def __init__(
        self,
        arm: WritingArm,
        n: int = 250_000,
        cell: float = 1.0,
        seed: int = 0,
        pitch_cell: float = 2.5,
        phi_cell: float = 0.25,
        candidates: int = 4,
        branch_gap: float = 1.0,
        limit_weight: float = 2.0,
        limit_margin: float = 0.6,
        cell_weight: float = 2.0,
    ) -> None:
        rng = np.random.default_rng(seed)
        lo, hi = arm.limits[:, 0], arm.limits[:, 1]
        q = rng.uniform(lo, hi, (n, 4))
        f = arm.fk(q)
        self.cell = float(cell)
        self.pitch_cell = float(pitch_cell)
        self.phi_cell = float(phi_cell)
        self.fallback = tuple(map(float, 0.5 * (lo + hi)))
        # rank down starts that would run into a joint limit: for position targets, those
        # within limit_margin rad of one; for position + pitch targets (no redundancy),
        # those whose branch leaves the limits within the cell (:meth:`_reach_penalty`)
        penalty = np.zeros(n)
        for j in range(4):
            gap = np.minimum(q[:, j] - lo[j], hi[j] - q[:, j])
            near = np.maximum(0.0, 1.0 - gap / limit_margin)
            penalty += near * near
        penalty *= limit_weight
        k = max(int(candidates), 1)
        fine, coarse = self._reach_penalty(
            arm, q, ((pitch_cell, phi_cell), (2 * pitch_cell, 2 * phi_cell)), cell_weight)
        grids = [
            _Grid(f, q, cell, None, penalty, min(k, 2), branch_gap, 2),
            _Grid(f, q, 2 * cell, None, penalty, k, branch_gap, 1),
            _Grid(f, q, pitch_cell, phi_cell, fine, min(k, 2), branch_gap, 1),
            _Grid(f, q, 2 * pitch_cell, 2 * phi_cell, coarse, k, branch_gap, 1),
        ]
        # keep only the samples some cell refers to; tables then hold offsets into _q
        mark = np.zeros(n + 1, dtype=bool)
        for g in grids:
            mark[g.table.ravel()] = True  # -1 marks the extra last slot
        used = np.flatnonzero(mark[:n])
        remap = np.full(n + 1, -1, dtype=np.int32)
        remap[used] = 4 * np.arange(len(used), dtype=np.int32)
        self._q = array("d", q[used].ravel().tobytes())
        for g in grids:
            g.table = remap[g.table]  # -1 stays -1 (remap[-1] == -1)
        self._grids = grids
        self._g3 = array("i", np.ascontiguousarray(grids[0].table[:, 0]).tobytes())
        self._g4 = array("i", np.ascontiguousarray(grids[2].table[:, 0]).tobytes())
        self._p3, self._p4 = grids[0].params, grids[2].params
        self._arm = arm

    @staticmethod
    def _reach_penalty(
        arm: WritingArm, q: np.ndarray, cells: Sequence[tuple[float, float]], weight: float
    ) -> list[np.ndarray]:
        """Rank of position + pitch samples, per ``(cell, phi_cell)``: how far the cell's
        extent, mapped to the joints through the inverse Jacobian (to first order), would
        push the sample past a joint limit.

        A start whose own branch leaves the limits inside its cell sends LM into a limit
        on the wrong branch; ranking those down keeps the branch that stays inside. Uses
        the Jacobian in the heading frame (see :mod:`kinegym.kinematics._kernels.arm_lm`): joint 1 moves
        only the t row, joints 2..4 solve the 3x3 (u, z, phi) block by cross products."""
        pa = q[:, 1] + arm.pitch_offset
        pb = pa + q[:, 2]
        pt = pb + q[:, 3]
        ct = arm.tool * np.cos(pt)
        s4 = arm.tool * np.sin(pt)
        s3 = arm.forearm * np.sin(pb) + s4
        s2 = arm.upper_arm * np.sin(pa) + s3
        z3 = arm.forearm * np.cos(pb) + ct
        r = arm.upper_arm * np.cos(pa) + z3
        a = (-s2, -s3, -s4)  # rows of the 3x3 block: u, z, phi
        b = (r, z3, ct)
        # columns of the block's inverse: (b x c, c x a, a x b) / det with c = (1, 1, 1)
        bxc = (b[1] - b[2], b[2] - b[0], b[0] - b[1])
        cxa = (a[2] - a[1], a[0] - a[2], a[1] - a[0])
        axb = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        lo, hi = arm.limits[:, 0], arm.limits[:, 1]
        out = []
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            idet = np.abs(1.0 / (a[0] * bxc[0] + a[1] * bxc[1] + a[2] * bxc[2]))
            ir = 1.0 / np.abs(r)
            margin = [np.minimum(q[:, j] - lo[j], hi[j] - q[:, j]) for j in range(4)]
            du = [idet * np.abs(v) for v in bxc]
            dz = [idet * np.abs(v) for v in cxa]
            dp = [idet * np.abs(v) for v in axb]
            for cell, phi_cell in cells:
                near = np.maximum(0.0, 1.0 - margin[0] / (cell * ir))
                pen = near * near
                uext = cell * (1.0 + abs(arm.lateral_offset) * ir)
                for j in range(3):
                    reach = du[j] * uext + dz[j] * cell + dp[j] * phi_cell
                    near = np.maximum(0.0, 1.0 - margin[j + 1] / reach)
                    pen += near * near
                out.append(weight * np.nan_to_num(pen, nan=4.0, posinf=4.0))
        return out

    def _start(self, x: float, y: float, z: float, phi: float | None) -> Sequence[float]:
        """:meth:`nearest` without the tuple (the hot path of :func:`solve_arm`)."""
        if phi is None:
            ox, oy, oz, inv, nx, ny, nz, _, _ = self._p3
            i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                at = self._g3[(i * ny + j) * nz + k]
                if at >= 0:
                    return self._q[at:at + 4]
        else:
            ox, oy, oz, inv, nx, ny, nz, nphi, iphi = self._p4
            i, j, k = int((x - ox) * inv), int((y - oy) * inv), int((z - oz) * inv)
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                if not -math.pi < phi <= math.pi:
                    phi = math.remainder(phi, TWO_PI)
                ip = int((phi + math.pi) * iphi)
                at = self._g4[((i * ny + j) * nz + k) * nphi + (ip if ip < nphi else nphi - 1)]
                if at >= 0:
                    return self._q[at:at + 4]
        coarse = self._grids[1] if phi is None else self._grids[3]
        key = coarse.key(x, y, z, phi)
        at = int(coarse.table[key, 0]) if key >= 0 else -1
        return self._q[at:at + 4] if at >= 0 else self.fallback

    def nearest(self, x: float, y: float, z: float, phi: float | None = None) -> tuple[float, ...]:
        """The first start for a target: the sample nearest the centre of its cell (phi:
        its pitch cell too)."""
        return tuple(self._start(x, y, z, phi))

    def candidates(
        self, x: float, y: float, z: float, phi: float | None = None, gap: float = 1.0,
        wide: bool = False,
    ) -> list[tuple[float, ...]]:
        """Every start kept for the target: its cell's samples, then the coarse cell's,
        without repeats (closer than ``gap`` rad in every joint to an earlier one).

        ``wide``: then also the samples of the 3^d coarse cells around the target, nearest
        (in task space) first - other branches for targets near a joint-limit boundary."""
        fine, coarse = self._grids[2:] if phi is not None else self._grids[:2]
        offsets: list[int] = []
        for g in (fine, coarse):
            key = g.key(x, y, z, phi)
            if key >= 0:
                offsets += [at for at in g.table[key].tolist() if at >= 0]
        if wide:
            offsets += self._around(coarse, x, y, z, phi)
        out: list[tuple[float, ...]] = []
        for at in offsets:
            c = tuple(self._q[at:at + 4])
            if all(max(abs(a - b) for a, b in zip(c, o, strict=True)) > gap for o in out):
                out.append(c)
        return out or [self.fallback]

    def _around(self, g: _Grid, x: float, y: float, z: float, phi: float | None) -> list[int]:
        """Sample offsets of the coarse cells around a target, nearest sample first."""
        ox, oy, oz, inv, nx, ny, nz, nphi, iphi = g.params
        ijk = [int((v - o) * inv) for v, o in ((x, ox), (y, oy), (z, oz))]
        axes = [np.clip(np.arange(c - 1, c + 2), 0, d - 1)
                for c, d in zip(ijk, (nx, ny, nz), strict=True)]
        key = (axes[0][:, None, None] * ny + axes[1][None, :, None]) * nz + axes[2][None, None, :]
        key = key.ravel()
        if nphi:
            ph = math.remainder(phi, TWO_PI)  # type: ignore[arg-type]
            ip = min(int((ph + math.pi) * iphi), nphi - 1)
            key = (key[:, None] * nphi + (np.arange(ip - 1, ip + 2) % nphi)[None, :]).ravel()
        at = np.unique(g.table[key].ravel())
        at = at[at >= 0]
        if not len(at):
            return []
        qs = np.frombuffer(self._q, dtype=np.float64).reshape(-1, 4)[at // 4]
        f = self._arm.fk(qs)
        d = np.sqrt((f[:, 0] - x) ** 2 + (f[:, 1] - y) ** 2 + (f[:, 2] - z) ** 2)
        if nphi:
            d += 10.0 * np.abs(np.remainder(f[:, 3] - phi + math.pi, TWO_PI) - math.pi)
        return at[np.argsort(d, kind="stable")].tolist()
