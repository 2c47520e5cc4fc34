"""``build_tin``: DEM or point cloud -> :class:`~tin_swarm_env.terrain.tin.Tin`."""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, DemFormatError
from .dem import Dem, PointCloud
from .tin import Tin

__all__ = ["build_tin"]

MAX_CELL_ASPECT = 1e6  # dx/dy (or dy/dx) of a DEM's cells: up to here every builder's mesh passes the validity
# check (points are triangulated in grid units, see triangulate.MAX_SPACING_RATIO); beyond it rounding in the
# check's tolerances makes T-junctions, so such a DEM is refused before any work (resample it)
METHODS = ("vip", "greedy", "delaunay", "robot", "trust")
SLOPE_METHODS = ("robot", "trust")  # the methods that take the robots' max_slope_deg


def build_tin(dem: Dem | PointCloud, method: str | None = None, *, max_vertices: int | None = None,
              min_significance_m: float | None = None, max_error_m: float | None = None,
              border: str = "line", backbone: float = 0.5, delaunay: bool = False,
              max_slope_deg: float | None = None) -> Tin:
    """Reduce and triangulate elevation data into a :class:`Tin`.

    ========== ================================================================================
    method     what it does
    ========== ================================================================================
    "vip"      VIP point reduction (:func:`~.vip.vip_select`: ``max_vertices`` or
               ``min_significance_m``; ``border`` and ``backbone`` as documented there), then
               Delaunay in x, y. The default for a :class:`Dem`.
    "greedy"   Garland-Heckbert greedy insertion via pydelatin (:func:`~.greedy.greedy_mesh`),
               until ``max_error_m`` and/or ``max_vertices``; its own triangles are kept, or
               with ``delaunay=True`` its vertices are re-triangulated as Delaunay in x, y
               (thesis 2.2's empty-circle condition; the vertical error grows, see
               :func:`~.metrics.vertical_error` and the terrain table in docs/figures/terrain.md).
    "robot"    keeps what robots use: the slope class at ``max_slope_deg`` (required), terrain
               breaks, crests and drivable connectivity, vertical error as tie-breaker
               (:mod:`~.robot`); ``max_vertices`` and/or ``max_error_m``.
    "trust"    the robot method with half the budget by greedy insertion and the rest inserted
               where the slope class is wrong (:data:`~.robot.TRUST_SETTINGS`): the builder
               measured best on issue 45's measures (docs/figures/terrain_robot.md);
               ``max_slope_deg`` required.
    "delaunay" every point, Delaunay in x, y. The default (and only choice) for a
               :class:`PointCloud`; ``max_vertices`` smaller than the cloud is an error.
    ========== ================================================================================

    ``delaunay`` applies to method "greedy" only (VIP and "delaunay" are Delaunay already).
    """
    if delaunay and method != "greedy":
        raise ArgumentError(f"delaunay=True applies to method='greedy' only, not {method!r} (vip and delaunay "
                            "triangulations are Delaunay already)")
    if method is None:
        method = "delaunay" if isinstance(dem, PointCloud) else "vip"
    if method not in METHODS:
        raise ArgumentError(f"unknown method {method!r}; expected one of {METHODS}")
    if max_slope_deg is not None and method not in SLOPE_METHODS:
        raise ArgumentError(f"max_slope_deg applies to method='robot' or 'trust', not {method!r}")
    if isinstance(dem, PointCloud):
        return _cloud_tin(dem, method, max_vertices)
    if not isinstance(dem, Dem):
        raise ArgumentError(f"dem: build_tin needs a Dem or PointCloud, got {type(dem).__name__}")
    if len(dem.x) > 1 and len(dem.y) > 1 and max(dem.dx / dem.dy, dem.dy / dem.dx) > MAX_CELL_ASPECT:
        raise DemFormatError(f"{dem.source}: cells of {dem.dx:g} x {dem.dy:g} m (aspect ratio "
                             f"{max(dem.dx / dem.dy, dem.dy / dem.dx):.3g}); at most {MAX_CELL_ASPECT:g}: resample "
                             "the DEM to cells closer to square")
    if method == "vip":
        if max_error_m is not None:
            raise ArgumentError("max_error_m applies to method='greedy'; VIP takes max_vertices or min_significance_m")
        return _vip_tin(dem, max_vertices, min_significance_m, border, backbone)
    if method == "greedy":
        if min_significance_m is not None:
            raise ArgumentError("min_significance_m applies to method='vip'")
        return _greedy_tin(dem, max_vertices, max_error_m, delaunay)
    if method in SLOPE_METHODS:
        if min_significance_m is not None:
            raise ArgumentError("min_significance_m applies to method='vip'")
        from .robot import TRUST_SETTINGS, robot_mesh

        kw = TRUST_SETTINGS if method == "trust" else {}
        try:
            v, t = robot_mesh(dem, max_slope_deg, max_vertices, max_error_m, **kw)
        except ArgumentError as e:  # the robot builder's messages, naming the method asked for
            raise ArgumentError(str(e).replace("method='robot'", f"method={method!r}")) from None
        return Tin(v, t, source=f"{dem.source} ({method}, {max_slope_deg:g} deg)")
    if np.isnan(dem.z).any():
        raise DemFormatError(f"{dem.source}: {dem.n_nodata} NODATA cells; fill or crop them first")
    return Tin.from_points(dem.points(), source=f"{dem.source} (delaunay)")


def _cloud_tin(cloud: PointCloud, method: str, max_vertices: int | None) -> Tin:
    """Every point of a scattered cloud, Delaunay in x, y (the only method without a grid)."""
    if method != "delaunay":
        raise ArgumentError(f"{cloud.source}: method {method!r} needs a regular grid; scattered points "
                            "are triangulated whole with method='delaunay'")
    if max_vertices is not None and max_vertices < len(cloud.points):
        raise ArgumentError(f"{cloud.source}: {len(cloud.points)} scattered points exceed max_vertices="
                            f"{max_vertices}; reduction needs a regular grid")
    return Tin.from_points(cloud.points, source=cloud.source)


def _vip_tin(dem: Dem, max_vertices, min_significance_m, border: str, backbone: float) -> Tin:
    """VIP-selected grid points, Delaunay in x, y."""
    from .vip import vip_select

    if max_vertices is None and min_significance_m is None:
        raise ArgumentError("method='vip' needs max_vertices or min_significance_m")
    keep = vip_select(dem, max_vertices, min_significance_m, border=border, backbone=backbone)
    r, c = np.nonzero(keep)
    pts = np.column_stack([dem.x[c], dem.y[r], dem.z[r, c]])
    return Tin.from_points(pts, source=f"{dem.source} (vip)")


def _greedy_tin(dem: Dem, max_vertices, max_error_m, delaunay: bool) -> Tin:
    """pydelatin's greedy mesh, its own triangles or (``delaunay``) re-triangulated as Delaunay."""
    from .greedy import greedy_mesh

    v, t = greedy_mesh(dem, max_error_m=max_error_m, max_vertices=max_vertices)
    if delaunay:
        return Tin.from_points(v, source=f"{dem.source} (greedy, Delaunay)")
    return Tin(v, t, source=f"{dem.source} (greedy)")
