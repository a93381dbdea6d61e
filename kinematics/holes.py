"""Maps of holes on a wall, for the climber to grip and to localise itself against.

A :class:`HoleMap` is a set of holes, each with an id ``(col, row)`` and a position in cm
(wall frame, x to the right, y up). Maps come from YAML (``configs/walls/*.yaml``; the
seed's measured 4 x 4 map is ``seed_4x4``) or are generated as a jittered grid with
missing holes, reproducibly from a seed. A spatial hash answers "which holes lie within r
of this point" in microseconds; the simulation, the planner, the localiser and the
drawings all use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import kinegym.configs as _configs

from .errors import InvalidInputError, as_array

__all__ = ["HoleMap", "WALL_SCHEMA"]


WALL_SCHEMA: dict[str, _configs.Spec] = {
    "name": _configs.Text(default="wall"),
    "description": _configs.Text(default=""),
    "holes": _configs.ListOf(
        item=_configs.Section(fields={
            "id": _configs.Vector(length=2, item=_configs.Number(integer=True)),
            "xy_cm": _configs.Vector(length=2),
        }),
        min_len=1,
        max_len=250_000,
        doc="holes with id [col, row] and position xy_cm",
    ),
}


@dataclass(frozen=True)
class HoleMap:
    """Holes of a wall: ``ids`` (N, 2) integer ``(col, row)`` and ``xy`` (N, 2) in cm."""

    ids: np.ndarray
    xy: np.ndarray
    name: str = "wall"

    def __post_init__(self) -> None:
        xy = as_array("xy", self.xy, (2,))
        ids = np.asarray(self.ids)
        if xy.ndim != 2 or xy.shape[0] == 0:
            raise InvalidInputError(f"xy has shape {xy.shape}; expected (N, 2) with N >= 1 holes")
        if ids.shape != xy.shape or not np.issubdtype(ids.dtype, np.integer):
            raise InvalidInputError(
                f"ids has shape {ids.shape} and dtype {ids.dtype}; expected integers of shape {xy.shape}"
            )
        keys = [tuple(map(int, i)) for i in ids]
        if len(set(keys)) != len(keys):
            dup = next(k for k in keys if keys.count(k) > 1)
            raise InvalidInputError(f"hole id {dup} appears more than once; ids must be unique")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "ids", ids.astype(np.int64))
        object.__setattr__(self, "_index", {k: n for n, k in enumerate(keys)})

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @property
    def xy_list(self) -> list[tuple[float, float]]:
        """Hole positions as Python floats (cached): for scalar hot loops."""
        got = self.__dict__.get("_xy_list")
        if got is None:
            got = [(float(a), float(b)) for a, b in self.xy.tolist()]
            object.__setattr__(self, "_xy_list", got)
        return got

    @property
    def id_list(self) -> list[tuple[int, int]]:
        """Hole ids as Python tuples (cached)."""
        got = self.__dict__.get("_id_list")
        if got is None:
            got = [(int(a), int(b)) for a, b in self.ids.tolist()]
            object.__setattr__(self, "_id_list", got)
        return got

    def index(self, hole_id: tuple[int, int]) -> int:
        """Row of hole ``(col, row)``; raises ``KeyError`` naming the id."""
        key = tuple(int(v) for v in hole_id)
        try:
            return self._index[key]  # type: ignore[attr-defined]
        except KeyError:
            raise KeyError(f"no hole {key} in map '{self.name}' ({len(self)} holes)") from None

    def position(self, hole_id: tuple[int, int]) -> np.ndarray:
        """Position (cm) of hole ``(col, row)``."""
        return self.xy[self.index(hole_id)].copy()

    @property
    def spacing(self) -> float:
        """Median nearest-neighbour distance (cm); the cell size of the spatial hash."""
        cached = self.__dict__.get("_spacing")
        if cached is None and len(self) < 2:
            cached = 1.0  # one hole has no neighbour (nearest_other would search for ever)
            object.__setattr__(self, "_spacing", cached)
        if cached is None:
            grid = _SpatialHash(self.xy, cell=max(1e-6, float(np.ptp(self.xy, axis=0).max()) / 64 or 1.0))
            d = [grid.nearest_other(i) for i in range(min(len(self), 400))]
            cached = float(np.median(d)) if len(self) > 1 else 1.0
            object.__setattr__(self, "_spacing", cached)
        return cached

    def within(self, point: object, radius: float) -> np.ndarray:
        """Indices of the holes within ``radius`` cm of ``point`` (constant time on average)."""
        grid = self.__dict__.get("_grid")
        if grid is None:
            grid = _SpatialHash(self.xy, cell=max(self.spacing, 1e-6))
            object.__setattr__(self, "_grid", grid)
        return grid.within(point, radius)

    @classmethod
    def from_config(cls, name_or_path: str | Path = "seed_4x4") -> HoleMap:
        """Load ``configs/walls/<name>.yaml`` or a YAML path; raises ``configs.ConfigError``."""
        cfg = _configs.load("walls", name_or_path, WALL_SCHEMA)
        ids = np.array([h["id"] for h in cfg["holes"]], dtype=np.int64)
        xy = np.array([h["xy_cm"] for h in cfg["holes"]], dtype=np.float64)
        src = str(_configs.resolve("walls", name_or_path))
        cells = np.floor(xy / 0.1)
        if len(np.unique(cells, axis=0)) < len(cells):
            raise _configs.ConfigError(src, "holes", "two holes at one place",
                                       "holes at least 0.1 cm apart (xy_cm)")
        try:
            return cls(ids=ids, xy=xy, name=cfg["name"])
        except InvalidInputError as exc:
            raise _configs.ConfigError(src, "holes", "duplicate id", str(exc)) from exc

    @classmethod
    def grid(
        cls,
        cols: int,
        rows: int,
        spacing: float = 20.0,
        jitter: float = 0.0,
        missing: float = 0.0,
        seed: int | None = 0,
        name: str | None = None,
    ) -> HoleMap:
        """A ``cols`` x ``rows`` grid, ``spacing`` cm apart, ids from (1, 1) at the origin.

        ``jitter``: each coordinate moved uniformly within +-jitter cm; ``missing``: the
        share of holes removed (at random, at least one kept). Reproducible from ``seed``.
        """
        if not (isinstance(cols, int) and isinstance(rows, int) and cols >= 1 and rows >= 1):
            raise InvalidInputError(f"cols={cols!r}, rows={rows!r}; expected integers >= 1")
        if not (np.isfinite(spacing) and spacing > 0):
            raise InvalidInputError(f"spacing={spacing!r}; expected a length > 0 cm")
        if not (np.isfinite(jitter) and 0 <= jitter < spacing / 2):
            raise InvalidInputError(f"jitter={jitter!r}; expected 0 <= jitter < spacing/2 cm")
        if not (0.0 <= missing < 1.0):
            raise InvalidInputError(f"missing={missing!r}; expected a share in [0, 1)")
        rng = np.random.default_rng(seed)
        c, r = np.meshgrid(np.arange(1, cols + 1), np.arange(1, rows + 1), indexing="ij")
        ids = np.stack([c.ravel(), r.ravel()], axis=-1)
        xy = (ids - 1) * float(spacing) + rng.uniform(-jitter, jitter, ids.shape)
        keep = rng.random(len(ids)) >= missing
        if not keep.any():
            keep[rng.integers(len(ids))] = True
        return cls(ids=ids[keep], xy=xy[keep], name=name or f"grid_{cols}x{rows}")


class _SpatialHash:
    """Points binned into square cells of a dict: neighbourhood queries in microseconds."""

    def __init__(self, xy: np.ndarray, cell: float) -> None:
        self.xy, self.cell = xy, float(cell)
        self.pts = [tuple(p) for p in xy.tolist()]
        cells: dict[tuple[int, int], list[tuple[int, float, float]]] = {}
        for i, (cx, cy) in enumerate(np.floor(xy / self.cell).astype(np.int64).tolist()):
            cells.setdefault((cx, cy), []).append((i, *self.pts[i]))
        self.cells = cells

    def within_list(self, px: float, py: float, radius: float) -> list[int]:
        c = self.cell
        x0, x1 = math.floor((px - radius) / c), math.floor((px + radius) / c)
        y0, y1 = math.floor((py - radius) / c), math.floor((py + radius) / c)
        r2 = radius * radius
        out = []
        get = self.cells.get
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                for i, hx, hy in get((cx, cy), ()):
                    dx, dy = hx - px, hy - py
                    if dx * dx + dy * dy <= r2:
                        out.append(i)
        return out

    def within(self, point: object, radius: float) -> np.ndarray:
        return np.array(self.within_list(float(point[0]), float(point[1]), radius),  # type: ignore[index]
                        dtype=np.int64)

    def nearest_other(self, i: int) -> float:
        if len(self.xy) < 2:
            return math.inf
        r = self.cell
        while True:
            idx = [j for j in self.within_list(*self.pts[i], r) if j != i]
            if idx:
                return float(np.min(np.hypot(*(self.xy[idx] - self.xy[i]).T)))
            r *= 2
