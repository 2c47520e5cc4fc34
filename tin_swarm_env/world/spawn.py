"""Initial placement (the generator): random positions on traversable ground."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import ArgumentError, PlacementError

__all__ = ["spawn_positions"]


def spawn_positions(tin, steep, n: int, rng: np.random.Generator, region=None,
                    min_separation_m: float = 0.0, max_rounds: int = 50) -> np.ndarray:
    """``n`` positions ``(n, 2)`` drawn uniformly from ``region`` (xmin, ymin, xmax, ymax;
    default the TIN's bounds), each on a traversable triangle and at least
    ``min_separation_m`` from the others. Batched rejection sampling: each round draws a batch
    and drops candidates on steep or missing ground and the later member of each pair that
    is too close. Raises ValueError when ``max_rounds`` rounds do not find room."""
    if n < 0:
        raise ArgumentError(f"n must be >= 0, got {n}")
    x0, y0, x1, y1 = tin.bounds if region is None else region
    if not (x1 > x0 and y1 > y0):
        raise ArgumentError(f"spawn region {region} is empty")
    got = np.zeros((0, 2))
    for _ in range(max_rounds):
        if len(got) >= n:
            break
        need = n - len(got)
        cand = rng.uniform([x0, y0], [x1, y1], (2 * need + 8, 2))
        tri = tin.locate(cand)
        ok = tri >= 0
        ok[ok] = ~steep[tri[ok]]
        pts = np.vstack([got, cand[ok]])
        if min_separation_m > 0 and len(pts) > 1:
            pairs = cKDTree(pts).query_pairs(min_separation_m, output_type="ndarray")
            drop = np.zeros(len(pts), dtype=bool)
            # drop the later point of each close pair (earlier accepted points are never dropped)
            drop[np.maximum(pairs[:, 0], pairs[:, 1])] = True
            drop[: len(got)] = False
            pts = pts[~drop]
        got = pts[:n]
    if len(got) < n:
        raise PlacementError(f"could only place {len(got)} of {n} robots on traversable ground in region "
                         f"{(x0, y0, x1, y1)} with separation {min_separation_m} m")
    return got
