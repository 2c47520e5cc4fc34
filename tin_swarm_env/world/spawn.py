"""Initial placement (the generator): random positions on traversable ground."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import ArgumentError, PlacementError

__all__ = ["spawn_positions"]


def spawn_positions(tin, steep, n: int, rng: np.random.Generator, region=None,
                    min_separation_m: float = 0.0, max_rounds: int = 50, *, allowed=None,
                    groups=None) -> np.ndarray:
    """``n`` positions ``(n, 2)`` drawn uniformly from ``region`` (xmin, ymin, xmax, ymax;
    default the TIN's bounds), each on a traversable triangle and at least
    ``min_separation_m`` from the others. Batched rejection sampling: each round draws a batch
    and drops candidates on steep or missing ground and the later member of each pair that
    is too close.

    ``allowed`` ``(G, T)`` bool (or ``(T,)``, G = 1) narrows where robot ``i`` may stand to the
    triangles ``allowed[groups[i]]`` (and not steep); ``groups`` ``(n,)`` int in ``0..G-1``,
    default all 0. The env passes, per target, the triangles from which that target can be
    reached, so no robot starts where its assigned target is unreachable. Each round's
    candidates fill the open slots of each group in order. Raises a PlacementError when
    ``max_rounds`` rounds do not find room."""
    if n < 0:
        raise ArgumentError(f"n must be >= 0, got {n}")
    x0, y0, x1, y1 = tin.bounds if region is None else region
    if not (x1 > x0 and y1 > y0):
        raise ArgumentError(f"spawn region {region} is empty")
    ok_tri = ~np.asarray(steep, dtype=bool)[None, :]  # (G, T)
    if allowed is not None:
        ok_tri = ok_tri & np.atleast_2d(np.asarray(allowed, dtype=bool))
    g = np.zeros(n, dtype=np.int64) if groups is None else np.asarray(groups, dtype=np.int64).reshape(-1)
    if g.shape != (n,) or (n and (g.min() < 0 or g.max() >= len(ok_tri))):
        raise ArgumentError(f"groups must be {n} integers in 0..{len(ok_tri) - 1}")
    out = np.zeros((n, 2))
    filled = np.zeros(n, dtype=bool)
    for _ in range(max_rounds):
        if filled.all():
            break
        need = int(n - filled.sum())
        cand = rng.uniform([x0, y0], [x1, y1], (2 * need + 8, 2))
        tri = tin.locate(cand)
        fits = np.zeros((len(cand), len(ok_tri)), dtype=bool)  # (k, G)
        fits[tri >= 0] = ok_tri[:, tri[tri >= 0]].T
        keep = fits.any(axis=1)
        cand, cand_fits = cand[keep], fits[keep]
        if min_separation_m > 0 and len(cand):
            pts = np.vstack([out[filled], cand])
            pairs = cKDTree(pts).query_pairs(min_separation_m, output_type="ndarray")
            drop = np.zeros(len(pts), dtype=bool)
            # drop the later point of each close pair (earlier accepted points are never dropped)
            drop[np.maximum(pairs[:, 0], pairs[:, 1])] = True
            drop = drop[int(filled.sum()):]
            cand, cand_fits = cand[~drop], cand_fits[~drop]
        used = np.zeros(len(cand), dtype=bool)
        for k in range(len(ok_tri)):  # a loop over groups (targets), not robots
            slots = np.flatnonzero(~filled & (g == k))
            take = np.flatnonzero(cand_fits[:, k] & ~used)[: len(slots)]
            out[slots[: len(take)]] = cand[take]
            filled[slots[: len(take)]] = True
            used[take] = True
    if not filled.all():
        why = " from which their assigned target can be reached" if allowed is not None else ""
        raise PlacementError(f"could only place {int(filled.sum())} of {n} robots on traversable ground{why} "
                             f"in region {(x0, y0, x1, y1)} with separation {min_separation_m} m")
    return out
