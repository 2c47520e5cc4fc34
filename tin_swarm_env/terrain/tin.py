"""The :class:`Tin`: a triangulated irregular network with adjacency, planes and batched queries.

Structure (scipy's vocabulary)::

    vertices   (V, 3) float64 m      x east, y north, z up
    triangles  (T, 3) int64          vertex indices, counter-clockwise seen from above
    neighbors  (T, 3) int64          neighbors[t, k]: triangle across the edge opposite vertex k;
                                     -1 on the border
    planes     (T, 3) float64        z = a*x + b*y + c for each triangle
    normals    (T, 3) float64        unit upward normals
    slope_deg  (T,)   float64        angle between the plane and the horizontal, 0..90
    aspect_deg (T,)   float64        direction the slope faces (downhill), degrees clockwise
                                     from north in [0, 360) (thesis Algorithm 6); -1 when flat

Queries are batched over ``n`` points or pairs and run compiled triangle walks
(:mod:`._kernels`); none loops over points in Python.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from ..errors import ArgumentError, TinStructureError
from . import _kernels as K
from .breaks import BREAK_ANGLE_DEG, MAX_SLOPE_DEG
from .validity import check_single_surface

__all__ = ["Tin"]

_FLAT_ASPECT = -1.0
MAX_ABS_COORD_M = 1e15  # products of coordinate differences stay far inside float64


class Tin:
    """A TIN built from vertices and triangles (validated, oriented, adjacency rebuilt).

    Parameters
    ----------
    vertices : (V, 3) array_like, m
    triangles : (T, 3) array_like of int
        Any orientation; clockwise triangles are flipped to counter-clockwise.
    source : str
        Where it came from, for messages.

    Zero-area triangles (area below ``1e-12`` of the squared extent) are dropped and counted
    in :attr:`n_degenerate_removed`; vertices no triangle uses are dropped too. An edge shared
    by more than two triangles, or two triangles overlapping on a shared edge, raise
    :class:`~tin_swarm_env.errors.TinStructureError` naming the edge; two vertices at one
    (x, y), triangles overlapping in plan and T-junctions raise it naming the vertices and
    triangles (:func:`~tin_swarm_env.terrain.validity.check_single_surface`).
    """

    def __init__(self, vertices, triangles, *, source: str = "<array>"):
        v, tri = _checked_arrays(vertices, triangles, source)
        v, tri, self.n_degenerate_removed = _orient_ccw(v, tri, source)
        v, tri = _drop_unused_vertices(v, tri)
        self.source = source
        self.vertices = v
        self.triangles = tri
        self.neighbors = triangle_neighbors(tri, v, source)
        bucket = _build_bucket(v, tri)
        check_single_surface(v, tri, self.neighbors, bucket, source)
        self.__dict__["_bucket"] = bucket  # the cached point-location grid, built once
        self._derive_planes()
        for a in (self.vertices, self.triangles, self.neighbors, self.planes, self.normals,
                  self.slope_deg, self.aspect_deg, self.areas, self._grad):
            a.setflags(write=False)

    # -- construction helpers -------------------------------------------------------------
    @classmethod
    def from_points(cls, points, *, source: str = "<points>") -> Tin:
        """Delaunay triangulation (in x, y) of scattered ``(n, 3)`` points."""
        from .triangulate import delaunay_triangles

        pts = np.asarray(points, dtype=np.float64)
        return cls(pts, delaunay_triangles(pts, source=source), source=source)

    def _derive_planes(self):
        v, tri = self.vertices, self.triangles
        a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
        n = np.cross(b - a, c - a)  # CCW in xy -> n_z > 0
        self.areas = 0.5 * n[:, 2]  # horizontal (planimetric) area, m^2
        # gradient of z over the plane: dz/dx = -nx/nz, dz/dy = -ny/nz
        gx = -n[:, 0] / n[:, 2]
        gy = -n[:, 1] / n[:, 2]
        self._grad = np.ascontiguousarray(np.column_stack([gx, gy]))
        self.planes = np.column_stack([gx, gy, a[:, 2] - gx * a[:, 0] - gy * a[:, 1]])
        self.normals = n / np.linalg.norm(n, axis=1, keepdims=True)
        g = np.hypot(gx, gy)
        self.slope_deg = np.degrees(np.arctan(g))
        # downhill direction (-gx, -gy); clockwise from north: atan2(east, north)
        asp = np.degrees(np.arctan2(-gx, -gy)) % 360.0
        asp[g == 0] = _FLAT_ASPECT
        asp[asp >= 360.0] = 0.0
        self.aspect_deg = asp

    # -- basic properties -----------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)

    @cached_property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the vertices."""
        lo = self.vertices[:, :2].min(axis=0)
        hi = self.vertices[:, :2].max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @cached_property
    def _tol(self) -> tuple[float, float]:
        xmin, ymin, xmax, ymax = self.bounds
        scale = max(xmax - xmin, ymax - ymin, 1.0)
        zscale = max(float(np.ptp(self.vertices[:, 2])), 1.0)
        return 1e-12 * scale * scale, 1e-9 * (zscale + float(np.abs(self.vertices[:, 2]).max()))

    @property
    def tolerances(self) -> tuple[float, float]:
        """``(area tolerance m^2, height tolerance m)`` of the geometric predicates: a point is
        inside a triangle when every edge orientation is >= -area tolerance (``1e-12`` of the
        squared extent); heights within the second (``1e-9`` of the z range plus largest |z|) tie."""
        return self._tol

    @cached_property
    def edges(self) -> np.ndarray:
        """Unique edges ``(E, 2)`` int64 vertex pairs (lower index first)."""
        return self._edge_table[0]

    @cached_property
    def edge_triangles(self) -> np.ndarray:
        """``(E, 2)`` int64: the triangles on either side of each edge (-1 for none)."""
        return self._edge_table[1]

    @cached_property
    def _edge_table(self):
        tri, nb = self.triangles, self.neighbors
        T = len(tri)
        t_idx = np.repeat(np.arange(T), 3)
        k_idx = np.tile(np.arange(3), T)
        p = tri[t_idx, (k_idx + 1) % 3]
        q = tri[t_idx, (k_idx + 2) % 3]
        other = nb[t_idx, k_idx]
        keep = (other < 0) | (t_idx < other)  # each interior edge once
        e = np.column_stack([np.minimum(p, q), np.maximum(p, q)])[keep]
        et = np.column_stack([t_idx[keep], other[keep]])
        return e, et

    @property
    def nbytes(self) -> int:
        """Bytes held by the TIN's arrays (vertices, triangles, adjacency, planes, normals,
        slope, aspect, area), not counting lazily built indexes."""
        arrs = (self.vertices, self.triangles, self.neighbors, self.planes, self.normals,
                self.slope_deg, self.aspect_deg, self.areas, self._grad)
        return int(sum(a.nbytes for a in arrs))

    @property
    def index_nbytes(self) -> int:
        """Bytes held by the point-location grid (built with the TIN), not counted in :attr:`nbytes`."""
        return int(sum(a.nbytes for a in self._bucket.values() if hasattr(a, "nbytes")))

    def __repr__(self) -> str:
        return f"Tin({self.source!r}, {self.n_vertices} vertices, {self.n_triangles} triangles)"

    def __eq__(self, other) -> bool:
        """Same vertex coordinates and the same set of triangles (vertex order free)."""
        if not isinstance(other, Tin):
            return NotImplemented
        return _canonical(self) == _canonical(other)

    __hash__ = None  # mutable-free but array-valued: not hashable

    # -- point location -------------------------------------------------------------------
    @cached_property
    def _bucket(self):
        return _build_bucket(self.vertices, self.triangles)

    @cached_property
    def _vx(self):
        return np.ascontiguousarray(self.vertices[:, 0])

    @cached_property
    def _vy(self):
        return np.ascontiguousarray(self.vertices[:, 1])

    @cached_property
    def _vz(self):
        return np.ascontiguousarray(self.vertices[:, 2])

    @property
    def xy_columns(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x (V,), y (V,))`` contiguous vertex coordinates, for compiled triangle walks
        (:func:`tin_swarm_env.terrain.exit_edge`)."""
        return self._vx, self._vy

    def locate_ahead(self, xy, direction, hint=None) -> tuple[np.ndarray, np.ndarray]:
        """The triangle a segment from each point ``xy (n, 2)`` along ``direction (n, 2)``
        (non-zero) enters: a point on a vertex or an edge belongs to several triangles, so this
        is the one holding the point 1 um along the segment (or a thousandth of its length when
        shorter). Returns ``(ahead points (n, 2), tri_idx (n,))``, -1 outside."""
        xy = np.asarray(xy, dtype=np.float64)
        d = np.asarray(direction, dtype=np.float64)
        length = np.hypot(d[:, 0], d[:, 1])
        ahead = xy + d * np.minimum(1e-6 / length, 1e-3)[:, None]
        return ahead, self.locate(ahead, hint=hint)

    def locate(self, xy, hint=None) -> np.ndarray:
        """Triangle holding each point: ``(n,)`` int64, ``-1`` outside the TIN.

        ``xy``: ``(n, 2)`` (or ``(2,)``) m. ``hint``: ``(n,)`` triangle indices to walk from
        (e.g. last step's triangles of moving robots; ``-1`` entries use the bucket grid).
        Without hints, a uniform bucket grid over triangle bounding boxes answers in O(1)
        expected time. Points on a shared edge get either triangle.
        """
        pts = as_xy(xy, "xy")
        px = np.ascontiguousarray(pts[:, 0])
        py = np.ascontiguousarray(pts[:, 1])
        tol = self._tol[0]
        if hint is None:
            return self._bucket_locate(px, py)
        h = np.asarray(hint, dtype=np.int64).reshape(-1)
        if h.shape[0] != px.shape[0]:
            raise ArgumentError(f"hint has {h.shape[0]} entries for {px.shape[0]} points")
        bad_h = (h < 0) | (h >= self.n_triangles)
        h = np.where(bad_h, 0, h)
        out = K.walk_locate(self._vx, self._vy, self.triangles, self.neighbors, px, py, h,
                            self.n_triangles + 3, tol)
        redo = (out < 0) | bad_h
        if redo.any():
            out[redo] = self._bucket_locate(px[redo], py[redo])
        return out

    def _bucket_locate(self, px, py):
        b = self._bucket
        px, py = (np.require(v, np.float64, "CW") for v in (px, py))  # writable: one compiled signature for all
        return K.bucket_locate(self._vx, self._vy, self.triangles, b["start"], b["tris"],
                               b["x0"], b["y0"], b["inv_cs"], b["nx"], b["ny"], px, py, self._tol[0])

    def _located(self, xy, hint, what):
        pts = as_xy(xy, "xy")
        t = self.locate(pts, hint)
        if np.any(t < 0):
            i = int(np.flatnonzero(t < 0)[0])
            raise ArgumentError(f"{what}: point {i} at {pts[i].tolist()} lies outside the TIN "
                             f"(bounds {self.bounds}); {int((t < 0).sum())} of {len(t)} outside")
        return pts, t

    def height_at(self, xy, hint=None) -> np.ndarray:
        """Terrain height ``(n,)`` m under each point (linear over its triangle).

        Raises ValueError naming the first point outside the TIN; use :meth:`locate` first
        to filter. Exact at vertices up to rounding.
        """
        pts, t = self._located(xy, hint, "height_at")
        return self._height_in(pts, t)

    def height_in(self, xy, tri) -> np.ndarray:
        """Heights ``(n,)`` at points whose triangles ``tri (n,)`` are already known (no
        location step; the points are assumed to lie in those triangles' planes)."""
        return self._height_in(np.asarray(xy, dtype=np.float64).reshape(-1, 2), np.asarray(tri))

    def _height_in(self, pts, t):
        a = self.triangles[t, 0]
        g = self._grad[t]
        v = self.vertices[a]
        return v[:, 2] + g[:, 0] * (pts[:, 0] - v[:, 0]) + g[:, 1] * (pts[:, 1] - v[:, 1])

    def slope_at(self, xy, hint=None) -> np.ndarray:
        """Slope ``(n,)`` degrees of the triangle under each point."""
        _, t = self._located(xy, hint, "slope_at")
        return self.slope_deg[t]

    def aspect_at(self, xy, hint=None) -> np.ndarray:
        """Aspect ``(n,)`` degrees clockwise from north (downhill), -1 where flat."""
        _, t = self._located(xy, hint, "aspect_at")
        return self.aspect_deg[t]

    def sensor_tilt(self, xy, heading_rad, hint=None) -> np.ndarray:
        """Sensor tilt (thesis 3.1) in radians: ``asin(sin(slope) * sin(heading - aspect))``.

        ``heading_rad`` ``(n,)`` is the robot's heading in the world frame's math convention
        (counter-clockwise from east, as everywhere else in the package); it is turned into
        a compass bearing (clockwise from north, like the aspect) before the difference is
        taken. The result is the tilt of a sensor fixed to the robot's front about the
        forward axis: 0 facing straight up or down the slope, ``±slope`` facing across it;
        positive when the downhill side is on the robot's left. 0 on flat triangles.
        """
        pts, t = self._located(xy, hint, "sensor_tilt")
        return self.sensor_tilt_in(t, heading_rad)

    def sensor_tilt_in(self, tri, heading_rad) -> np.ndarray:
        """:meth:`sensor_tilt` for robots whose triangles ``tri (n,)`` are already known."""
        t = np.asarray(tri)
        h = np.broadcast_to(np.asarray(heading_rad, dtype=np.float64), t.shape)
        sin_slope, aspect = self._tilt_tables  # per triangle: sin(radians(slope)), radians(max(aspect, 0))
        heading_compass = np.pi / 2 - h
        return np.arcsin(sin_slope[t] * np.sin(heading_compass - aspect[t]))

    @cached_property
    def _tilt_tables(self):
        """``(sin(slope), aspect)`` per triangle (radians, flat triangles' aspect -1 read as 0),
        computed once: numpy's ufuncs give each element the same bits in any array, so gathering
        them equals computing them on the gathered slopes."""
        return np.sin(np.radians(self.slope_deg)), np.radians(np.maximum(self.aspect_deg, 0.0))

    # -- line of sight --------------------------------------------------------------------
    def line_of_sight(self, a_xyz, b_xyz, hint=None) -> np.ndarray:
        """Whether each segment ``a -> b`` clears the terrain: ``(n,)`` bool.

        ``a_xyz``, ``b_xyz``: ``(n, 3)`` m (e.g. sensor positions, ground + sensor height).
        Exact for the piecewise-planar surface (thesis Algorithm 7, walking triangles along
        the segment and comparing heights at every crossed edge). Grazing contact (terrain
        equal to the sight line within 1e-9 of the height range) counts as visible.
        An end point below the surface or outside the TIN, or a segment that leaves the TIN,
        is not visible. Symmetric: ``los(a, b) == los(b, a)``. ``hint``: triangles holding
        the ``a`` points, if known.
        """
        a = _as_xyz(a_xyz, "a_xyz")
        b = _as_xyz(b_xyz, "b_xyz")
        if a.shape != b.shape:
            raise ArgumentError(f"a_xyz {a.shape} and b_xyz {b.shape} must have the same shape")
        ta = self.locate(a[:, :2], hint)
        # an end point on a vertex or edge belongs to several triangles: start the walk in
        # the one the segment enters
        d = b[:, :2] - a[:, :2]
        mv = (np.hypot(d[:, 0], d[:, 1]) > 0) & (ta >= 0)
        if mv.any():
            _, t2 = self.locate_ahead(a[mv, :2], d[mv], hint=ta[mv])
            ta[np.flatnonzero(mv)[t2 >= 0]] = t2[t2 >= 0]
        ztol = self._tol[1]
        res = K.los_walk(self._vx, self._vy, self._vz, self.triangles, self.neighbors, self._grad,
                         a, b, ta, self.n_triangles + 3, ztol)
        bad = res < 0
        if bad.any():
            res[bad] = self._los_brute(a[bad], b[bad])
        return res.astype(bool)

    def _los_brute(self, a, b):
        ta = self.locate(a[:, :2])
        tb = self.locate(b[:, :2])
        za = np.full(len(a), np.nan)
        zb = np.full(len(b), np.nan)
        za[ta >= 0] = self._height_in(a[ta >= 0, :2], ta[ta >= 0])
        zb[tb >= 0] = self._height_in(b[tb >= 0, :2], tb[tb >= 0])
        border = self.edge_triangles[:, 1] < 0
        return K.los_brute(self._vx, self._vy, self._vz, self.edges, border, a, b, za, zb,
                           self._tol[1], 1e-9)

    # -- terrain breaks -------------------------------------------------------------------
    def breaks(self, max_slope_deg: float = MAX_SLOPE_DEG, break_angle_deg: float | None = BREAK_ANGLE_DEG):
        """Terrain breaks: see :func:`tin_swarm_env.terrain.breaks.find_breaks`."""
        from .breaks import find_breaks

        return find_breaks(self, max_slope_deg=max_slope_deg, break_angle_deg=break_angle_deg)


# -- helpers ---------------------------------------------------------------------------------


def as_xy(xy, name) -> np.ndarray:
    a = np.asarray(xy, dtype=np.float64)
    if a.ndim == 1 and a.shape[0] == 2:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 2:
        raise ArgumentError(f"{name} must have shape (n, 2), got {np.shape(xy)}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.all(np.isfinite(a), axis=1))[0])
        raise ArgumentError(f"{name}: point {i} is not finite: {a[i].tolist()}")
    return a


def _as_xyz(p, name) -> np.ndarray:
    a = np.asarray(p, dtype=np.float64)
    if a.ndim == 1 and a.shape[0] == 3:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise ArgumentError(f"{name} must have shape (n, 3), got {np.shape(p)}")
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.all(np.isfinite(a), axis=1))[0])
        raise ArgumentError(f"{name}: point {i} is not finite: {a[i].tolist()}")
    return np.ascontiguousarray(a)


def triangle_neighbors(tri: np.ndarray, v: np.ndarray, source: str) -> np.ndarray:
    """Adjacency by sorting directed edges; checks the TIN is a manifold with consistent
    orientation (each edge used once in each direction at most)."""
    T = len(tri)
    nv = np.int64(len(v))
    t_idx = np.repeat(np.arange(T), 3)
    k_idx = np.tile(np.arange(3), T)
    p = tri[t_idx, (k_idx + 1) % 3]
    q = tri[t_idx, (k_idx + 2) % 3]
    key = np.minimum(p, q) * nv + np.maximum(p, q)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    # run lengths of equal keys
    starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    counts = np.diff(np.r_[starts, len(ks)])
    if np.any(counts > 2):
        j = order[starts[np.flatnonzero(counts > 2)[0]]]
        a, b = int(p[j]), int(q[j])
        raise TinStructureError(
            f"{source}: non-manifold TIN: the edge between vertices {a} {v[a].tolist()} and "
            f"{b} {v[b].tolist()} is shared by {int(counts.max())} triangles (at most 2 allowed)"
        )
    nb = np.full(T * 3, -1, dtype=np.int64)
    pair = starts[counts == 2]
    i, j = order[pair], order[pair + 1]
    same_dir = p[i] == p[j]
    if np.any(same_dir):
        m = int(np.flatnonzero(same_dir)[0])
        a, b = int(p[i[m]]), int(q[i[m]])
        raise TinStructureError(
            f"{source}: triangles {int(t_idx[i[m]])} and {int(t_idx[j[m]])} overlap: both lie on the "
            f"same side of their shared edge {a} {v[a].tolist()} - {b} {v[b].tolist()}"
        )
    nb[i] = t_idx[j]
    nb[j] = t_idx[i]
    return nb.reshape(T, 3)


def _checked_arrays(vertices, triangles, source: str) -> tuple[np.ndarray, np.ndarray]:
    """``(V, 3)`` float64 vertices and ``(T, 3)`` int64 triangles from the user's arrays, or
    :class:`TinStructureError` naming ``source`` and the first bad vertex/triangle."""
    v = np.array(vertices)
    if not (np.issubdtype(v.dtype, np.integer) or np.issubdtype(v.dtype, np.floating)):
        raise TinStructureError(f"{source}: vertices must be real numbers, got {v.dtype}")
    v = v.astype(np.float64)
    tri = np.array(triangles)
    if v.ndim != 2 or v.shape[1] != 3:
        raise TinStructureError(f"{source}: vertices must have shape (V, 3), got {v.shape}")
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise TinStructureError(f"{source}: triangles must have shape (T, 3), got {tri.shape}")
    if not np.all(np.isfinite(v)):
        raise TinStructureError(f"{source}: vertices contain NaN or infinite coordinates")
    if np.any(np.abs(v) > MAX_ABS_COORD_M):
        i = int(np.flatnonzero(np.any(np.abs(v) > MAX_ABS_COORD_M, axis=1))[0])
        raise TinStructureError(f"{source}: vertex {i} {v[i].tolist()} has a coordinate beyond "
                                f"{MAX_ABS_COORD_M:g} m (planes and slopes would overflow); check the units")
    if tri.size and not np.issubdtype(tri.dtype, np.integer):
        raise TinStructureError(f"{source}: triangles must be integer vertex indices")
    tri = tri.astype(np.int64)
    if tri.size and (tri.min() < 0 or tri.max() >= len(v)):
        raise TinStructureError(f"{source}: triangle vertex index out of range 0..{len(v) - 1}")
    if len(tri) == 0:
        raise TinStructureError(f"{source}: no triangles")
    repeats = (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2])
    if np.any(repeats):
        bad = int(np.flatnonzero(repeats)[0])
        raise TinStructureError(f"{source}: triangle {bad} repeats a vertex: {tri[bad].tolist()}")
    return v, tri


def _orient_ccw(v: np.ndarray, tri: np.ndarray, source: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Drop zero-area triangles (area below ``1e-12`` of the squared extent) and flip clockwise
    ones to counter-clockwise: ``(v, tri (T', 3), number dropped)``."""
    p0, p1, p2 = v[tri[:, 0], :2], v[tri[:, 1], :2], v[tri[:, 2], :2]
    cross = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0])
    ext = np.ptp(v[:, :2], axis=0)
    scale2 = float(max(ext[0], ext[1], 1e-300)) ** 2
    degenerate = np.abs(cross) <= 1e-12 * scale2
    tri = tri[~degenerate]
    cross = cross[~degenerate]
    if len(tri) == 0:
        raise TinStructureError(f"{source}: every triangle has zero area (all points collinear?)")
    cw = cross < 0
    tri[cw] = tri[cw][:, [0, 2, 1]]
    return v, tri, int(degenerate.sum())


def _drop_unused_vertices(v: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Remove the vertices no triangle uses, renumbering ``tri``."""
    used = np.zeros(len(v), dtype=bool)
    used[tri.ravel()] = True
    if used.all():
        return v, tri
    remap = np.cumsum(used) - 1
    return v[used], remap[tri]


def _build_bucket(v: np.ndarray, tri: np.ndarray, per_cell: float = 2.0) -> dict:
    """A uniform grid over the TIN's bounding box; each cell lists the triangles whose bounding
    box overlaps it (CSR arrays ``start``/``tris``)."""
    T = len(tri)
    xmin, ymin = v[:, 0].min(), v[:, 1].min()
    xmax, ymax = v[:, 0].max(), v[:, 1].max()
    w = max(xmax - xmin, 1e-9)
    h = max(ymax - ymin, 1e-9)
    cs = math.sqrt(w * h * per_cell / max(T, 1))
    cs = max(cs, max(w, h) / 4096.0)
    tx = v[tri, 0]
    ty = v[tri, 1]
    for _ in range(8):
        nx = max(1, int(math.ceil(w / cs)))
        ny = max(1, int(math.ceil(h / cs)))
        i0 = np.clip(((tx.min(1) - xmin) / cs).astype(np.int64), 0, nx - 1)
        i1 = np.clip(((tx.max(1) - xmin) / cs).astype(np.int64), 0, nx - 1)
        j0 = np.clip(((ty.min(1) - ymin) / cs).astype(np.int64), 0, ny - 1)
        j1 = np.clip(((ty.max(1) - ymin) / cs).astype(np.int64), 0, ny - 1)
        wi = i1 - i0 + 1
        wj = j1 - j0 + 1
        counts = wi * wj
        total = int(counts.sum())
        if total <= 40 * max(T, 1):
            break
        cs *= 2.0  # very skinny triangles: coarser cells keep the index small
    tid = np.repeat(np.arange(T, dtype=np.int64), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    local = np.arange(total, dtype=np.int64) - first
    wi_r = np.repeat(wi, counts)
    ci = np.repeat(i0, counts) + local % wi_r
    cj = np.repeat(j0, counts) + local // wi_r
    cell = cj * nx + ci
    order = np.argsort(cell, kind="stable")
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    np.cumsum(np.bincount(cell, minlength=nx * ny), out=start[1:])
    return {"start": start, "tris": tid[order], "x0": float(xmin), "y0": float(ymin),
            "inv_cs": 1.0 / cs, "cs": cs, "nx": nx, "ny": ny}


def _canonical(t: Tin):
    """Order-free description of a TIN: sorted triangles as vertex-coordinate triples."""
    tri = t.vertices[t.triangles]  # (T, 3, 3)
    # rotate each triangle so its lexicographically smallest vertex is first (keeps CCW order)
    keys = [tuple(map(tuple, x)) for x in tri]
    canon = []
    for k in keys:
        m = min(range(3), key=lambda i: k[i])
        canon.append(k[m:] + k[:m])
    return sorted(canon)

