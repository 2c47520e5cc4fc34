"""Delaunay triangulation of points in x, y (scipy/Qhull), replacing the thesis's O(n^2)
insertion (Algorithms 1-4) and edge flips (Algorithm 5) with an O(n log n) method whose
output satisfies the same opposite-angle (Delaunay) condition."""

from __future__ import annotations

import numpy as np

from ..errors import TinStructureError

__all__ = ["delaunay_triangles", "MAX_SPACING_RATIO"]

MAX_SPACING_RATIO = 10.0  # beyond this ratio of typical x and y point spacings (a DEM's cell aspect ratio),
# Qhull's Delaunay of the raw coordinates makes needle triangles whose corners lie on other triangles' edges
# to within rounding (T-junctions): such points are triangulated with y rescaled to the x spacing


def _spacing(v: np.ndarray) -> float:
    """The typical gap between the distinct values of ``v`` (median; 0 when all equal)."""
    d = np.diff(np.unique(v))
    return float(np.median(d)) if len(d) else 0.0


def delaunay_triangles(points, *, source: str = "<points>") -> np.ndarray:
    """Delaunay triangles ``(T, 3)`` int64 (counter-clockwise) of ``(n, 3)`` points in x, y.

    Raises :class:`~tin_swarm_env.errors.TinStructureError` for fewer than 3 distinct points,
    all points collinear, or non-finite coordinates. Points with the same x, y as an earlier
    point are left out of the triangulation (Qhull's coplanar points).
    """
    from scipy.spatial import Delaunay, QhullError

    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < 2:
        raise TinStructureError(f"{source}: points must have shape (n, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise TinStructureError(f"{source}: points contain NaN or infinite coordinates")
    n_distinct = len(np.unique(p[:, :2], axis=0))
    if n_distinct < 3:
        raise TinStructureError(f"{source}: {n_distinct} distinct point(s) in x, y; a TIN needs at least 3")
    xy = p[:, :2]
    # Qhull is happiest near the origin: shift (not scale) to keep the Delaunay test exact
    xy = xy - xy.min(axis=0)
    sx, sy = _spacing(xy[:, 0]), _spacing(xy[:, 1])
    if sx > 0 and sy > 0 and max(sx / sy, sy / sx) > MAX_SPACING_RATIO:
        # a positive scaling keeps every triangle's orientation and incidences: the triangulation of the
        # rescaled points is a valid one of the originals, made of well-shaped triangles in grid units
        xy = xy * np.array([1.0 / sx, 1.0 / sy])
    try:
        d = Delaunay(xy, qhull_options="Qbb Qc Qz Q12")
    except QhullError as exc:
        first = str(exc).splitlines()[0]
        raise TinStructureError(
            f"{source}: cannot triangulate: all points collinear or degenerate ({first})") from None
    tri = d.simplices.astype(np.int64)
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    cw = cross < 0
    tri[cw] = tri[cw][:, [0, 2, 1]]
    return tri
