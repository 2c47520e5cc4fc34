"""The one placement check: robots, targets and assets must stand on traversable terrain."""

from __future__ import annotations

import numpy as np

from ..errors import PlacementError

__all__ = ["check_placement"]


def check_placement(tin, steep, positions, label: str = "point {i}") -> tuple[np.ndarray, np.ndarray]:
    """``(positions (m, 2) float64 copy, tri_idx (m,))`` of points that must each be finite,
    inside the terrain and on a triangle that is not too steep (``steep (T,)`` bool); otherwise a
    :class:`~tin_swarm_env.errors.PlacementError` naming the first culprit with ``label``
    formatted with its index (``"robot {i}"``, ``"ramp.toml [targets] positions[{i}]"``)."""
    p = np.array(positions, dtype=np.float64).reshape(-1, 2) if np.size(positions) else np.zeros((0, 2))
    bad = ~np.all(np.isfinite(p), axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise PlacementError(f"{label.format(i=i)} at {p[i].tolist()} is not finite")
    tri = tin.locate(p) if len(p) else np.zeros(0, dtype=np.int64)
    if np.any(tri < 0):
        i = int(np.flatnonzero(tri < 0)[0])
        bounds = tuple(round(float(b), 1) for b in tin.bounds)
        raise PlacementError(f"{label.format(i=i)} at {p[i].tolist()} lies outside the terrain (bounds {bounds})")
    on_steep = steep[tri]
    if on_steep.any():
        i = int(np.flatnonzero(on_steep)[0])
        raise PlacementError(f"{label.format(i=i)} at {p[i].tolist()} lies on a too-steep triangle "
                             f"({tin.slope_deg[tri[i]]:.1f} deg)")
    return p, tri
