"""Seed 000's own localisation (its part 2), kept as the baseline the benchmarks compare with.
"""

from __future__ import annotations

import math

import numpy as np

from .climber import ClimberGeometry, hand_positions
from .errors import as_array
from .holes import HoleMap

__all__ = ["seed_adjacent_search"]


def seed_adjacent_search(holes: HoleMap, q: object, geom: ClimberGeometry | None = None,
                         precision: float = 0.1) -> list[tuple[tuple[int, int], ...]]:
    """Seed 000's part 2, kept as the baseline: compare distances of *adjacent* holes only.

    For every hole and its right / up-right / up / up-left neighbour (by grid id), if their
    distance matches ``|hand1 - hand2|`` within ``precision`` cm, every hole adjacent to both
    whose distances match the other two hand distances (either way round) completes a
    solution. Unlabelled and unoriented, like the seed: mirror images are accepted, and the
    first pair is not told apart (arm 1 or 2). Returns every match as three ids, in the
    seed's order (p1, p2, p3). The seed's own code mixes ``&&`` and ``||`` and prints only
    the last match; this is the search it describes, done right, O(N) over the whole map.
    """
    g = geom or ClimberGeometry()
    h = hand_positions(as_array("joint angles q", q, (3, 2)), g)
    h1 = float(np.linalg.norm(h[0] - h[1]))
    h2 = float(np.linalg.norm(h[2] - h[1]))
    h3 = float(np.linalg.norm(h[0] - h[2]))
    index = holes._index  # type: ignore[attr-defined]
    xy = holes.xy
    out: list[tuple[tuple[int, int], ...]] = []
    neighbours = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)]
    for (cx, cy), a in index.items():
        for dx, dy in ((1, 0), (1, 1), (0, 1), (-1, 1)):
            b = index.get((cx + dx, cy + dy))
            if b is None:
                continue
            d_ab = math.dist(xy[a], xy[b])
            if abs(d_ab - h1) >= precision:
                continue
            bx, by = cx + dx, cy + dy
            for ex, ey in neighbours:
                kx, ky = cx + ex, cy + ey
                if (kx, ky) == (bx, by) or max(abs(kx - bx), abs(ky - by)) > 1:
                    continue
                c = index.get((kx, ky))
                if c is None:
                    continue
                d_bc, d_ac = math.dist(xy[b], xy[c]), math.dist(xy[a], xy[c])
                if ((abs(d_bc - h2) < precision and abs(d_ac - h3) < precision)
                        or (abs(d_bc - h3) < precision and abs(d_ac - h2) < precision)):
                    out.append(((cx, cy), (bx, by), (kx, ky)))
    return out
