"""Error-bounded reduction: Garland-Heckbert greedy insertion through ``pydelatin``.

``pydelatin`` wraps Michael Fogleman's ``hmm`` (MIT): starting from two triangles over the
grid it repeatedly inserts the cell of largest vertical error and re-triangulates locally,
until the maximum error is at most ``max_error`` or ``max_points`` vertices are placed.
Its triangles are kept as they are by default (re-running Delaunay on its vertices raises
jacksboro's maximum error from 28.5 m to 130 m); ``build_tin(..., method="greedy",
delaunay=True)`` does that re-triangulation for callers that need thesis 2.2's Delaunay TIN.
It works in cell-index space with row 0 at the *top*; vertices are mapped back to our metres
(row 0 south) here.
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, DemFormatError
from .dem import Dem

__all__ = ["greedy_mesh"]

MAX_ABS_ELEVATION_M = 1e30  # pydelatin works in float32 (max 3.4e38); its errors need headroom


def greedy_mesh(dem: Dem, max_error_m: float | None = None, max_vertices: int | None = None):
    """Vertices ``(V, 3)`` m and triangles ``(T, 3)`` of a greedy-insertion TIN of ``dem``.

    Stops at whichever comes first: the maximum vertical error at most ``max_error_m``, or
    ``max_vertices`` vertices. At least one of the two must be given.
    """
    if max_error_m is None and max_vertices is None:
        raise ArgumentError("greedy reduction needs max_error_m, max_vertices or both")
    if max_error_m is not None and not (np.isfinite(max_error_m) and max_error_m >= 0):
        raise ArgumentError(f"max_error_m must be a finite number >= 0, got {max_error_m}")
    if max_vertices is not None and (int(max_vertices) != max_vertices or max_vertices < 4):
        raise ArgumentError(f"max_vertices must be an integer >= 4, got {max_vertices}")
    if np.isnan(dem.z).any():
        raise DemFormatError(f"{dem.source}: {dem.n_nodata} NODATA cells; greedy insertion needs a "
                             "complete grid (use dem.fill_nodata() or crop them away)")
    import pydelatin  # a core dependency

    rows, cols = dem.shape
    # hmm's row 0 is the top of the image: give it north first
    _check_float32(dem)
    z_img = np.ascontiguousarray(dem.z[::-1], dtype=np.float32)
    kw = {"max_error": float(max_error_m) if max_error_m is not None else 0.0}
    if max_vertices is not None:
        kw["max_points"] = int(max_vertices)
    d = pydelatin.Delatin(z_img, width=cols, height=rows, **kw)
    vi = np.asarray(d.vertices, dtype=np.float64)  # (col, y, z) in cell units
    tri = np.asarray(d.triangles, dtype=np.int64)
    # pydelatin's y counts up from the bottom image row: y = rows-1 - row_img = our row index
    col = np.rint(vi[:, 0]).astype(np.int64)
    row = np.rint(vi[:, 1]).astype(np.int64)
    if col.min() < 0 or col.max() >= cols or row.min() < 0 or row.max() >= rows:
        raise RuntimeError("pydelatin returned vertices outside the grid")  # pragma: no cover
    xyz = np.column_stack([dem.x[col], dem.y[row], dem.z[row, col]])
    return xyz, tri


def _check_float32(dem: Dem) -> None:
    """Refuse elevations that float32 (pydelatin's type) cannot hold, naming the DEM and cell."""
    big = np.abs(dem.z) > MAX_ABS_ELEVATION_M
    if big.any():
        r, c = np.argwhere(big)[0]
        raise DemFormatError(
            f"{dem.source}: elevation {dem.z[r, c]!r} m at row {r}, col {c} is beyond what greedy insertion "
            f"(float32) can hold (|z| <= {MAX_ABS_ELEVATION_M:g} m); check the file's units and NODATA value")
