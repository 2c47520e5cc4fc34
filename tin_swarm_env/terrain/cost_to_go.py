"""Cost-to-go: the length of the shortest drivable path to a goal, over a TIN.

>>> ctg = cost_to_go(tin, goal_xy, passable=tin.slope_deg <= 30)      # doctest: +SKIP
>>> ctg.distance_at(xy)        # (n,) m, inf where the goal cannot be reached
>>> ctg.direction_at(xy)       # (n, 2) unit vector of the first leg (zeros where inf / at goal)

Definition. Passable ground is the *closed* union of the triangles with ``passable[t]``: a
path may run along an edge (or through a vertex) that a passable triangle shares with an
impassable one, but never through a *pinch*, a vertex where two passable fans touch only at
that point (no robot can hit the point exactly): each pinch vertex is split into one node per
fan (:func:`pinch_vertices`, :func:`._ctg_kernels.split_fans`), so paths and windows reaching
it continue only into triangles of the same fan. ``distance_at(p)`` is the length of the
shortest path from ``p`` to the goal that stays on passable ground, ``inf`` where there is
none, outside the TIN and on impassable triangles. Lengths are **planar** (x, y) metres: the
reward and the robots' speed limits work in the plane, and a planar metric keeps the field a true distance (triangle
inequality, at least the straight-line distance). A slope-aware 3D length is not offered.

Method (default, ``any_angle=True``): window propagation, a continuous Dijkstra restricted to
passable triangles (Mitchell, Mount and Papadimitriou 1987 in the plane; the search nodes of
Polyanya, Cui, Harabor and Grastien 2017). A shortest path in a polygonal domain is straight
between bends at *corners*: vertices of the passable boundary where passable ground turns by
more than 180 deg (:func:`._ctg_kernels.corners`). The goal and each corner are
*roots*; a *window* is an interval of a triangle edge every point of which sees a root straight
across passable triangles. A root opens a window on each edge of its triangles; a window is
pushed through the next triangle (its wedge of rays clipped to the two other edges, one or two
children; impassable ground stops it); windows are processed by their smallest distance, so a
corner's distance is final when it opens its own windows (its shadow); contiguous pieces of
one root split by a vertex are merged one triangle later; a window is dropped when other
roots' windows (or the edge's nodes) are at least as short at every point of its interval,
tested exactly: at each point where the set of windows covering it or the order of the
distances changes, and between (:func:`._ctg_kernels._keep`). Visibility is never tested by
walking: it is carried by the wedges. Nodes are the TIN vertices plus ``steiner_per_edge``
points per edge, each with the straight distance to the best root whose window covers it (``parent``: that root). A query point ``p`` in triangle ``t`` takes the
cheapest of ``|p - r| + D[r]`` over the windows into ``t`` whose wedge holds ``p`` (the straight
segment to the root, exact), ``|p - node_j| + D[node_j]`` over ``t``'s nodes (``t`` is convex) and
``|p - goal|`` on the goal's triangles (on a pinch vertex, the best of its fans' copies: the
point belongs to each fan): O(1) candidates, no walk. Every value is the length of a real
drivable path, so never below the true distance; against the exact visibility-graph field
(tests) it agrees to rounding. ``any_angle=False`` is the plain Steiner graph (Lanthier,
Maheshwari and Sack 1997: Dijkstra over the nodes, two nodes neighbours when on one passable
triangle), kept as a reference: 2-8 % too long on flat TINs.
Why not the alternatives:

* triangle-centroid hops measure a path around a cliff end 5-20 % long and cannot run along a
  cliff edge; here the path bends at the cliff end exactly (the wall-with-a-gap test: 1e-9);
* Theta* over the Steiner graph (the previous method) walks the triangles of every straight
  segment it tries: 0.66 s at 20k triangles and 1.4-3.6e5 queries/s;
* fast marching on a triangulation needs non-obtuse triangles (greedy and VIP TINs are full of
  obtuse ones); an exact visibility graph costs O(n^2) visibility tests per goal.

Measured (``nice -n 10 python bench/cost_to_go.py --repeat 9``, jacksboro greedy, median of 9,
CPU time of the process on a shared 2-core machine, two runs; wall time under load up to
twice): build 4-6 ms / 21-24 ms / 0.14-0.16 s at 5k / 20k / 80k triangles (target 50 ms at
20k: met), about 1 window per edge, 0.3-0.4 us per window record: the window loop runs
without reference counting (:func:`._ctg_kernels._propagate`), which had doubled its cost;
queries 9e6 points/s with known triangles at 20k (3.9e6 with point location), 3e6 at 80k
(target 1e6: met). Flat TIN: error 2e-14 %.
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError
from . import _ctg_kernels as K
from .tin import Tin, as_xy

__all__ = ["CostToGo", "CostToGoStack", "cost_to_go", "pinch_vertices", "DEFAULT_STEINER_PER_EDGE"]

DEFAULT_STEINER_PER_EDGE = 1


class CostToGo:
    """The shortest-drivable-path field of one goal over one TIN (build with :func:`cost_to_go`).

    Attributes
    ----------
    tin : Tin
    goal_xy : (2,) float64 m
    passable : (T,) bool, read-only
    steiner_per_edge : int
    node_xy : (N, 2) float64 m        nodes: the V vertices first, then one copy per extra fan of
                                      each pinch vertex (:func:`pinch_vertices`), then the Steiner points
    node_distance : (N,) float64 m    shortest drivable path from each node to the goal (inf: none)
    goal_triangles : (T,) bool        passable triangles the goal lies on (none: nothing reachable)
    """

    def __init__(self, tin: Tin, goal_xy, passable, steiner_per_edge: int = DEFAULT_STEINER_PER_EDGE,
                 any_angle: bool = True):
        if not isinstance(tin, Tin):
            raise ArgumentError(f"cost_to_go needs a Tin, got {type(tin).__name__}")
        self.tin = tin
        self.goal_xy = _goal(goal_xy)
        self.passable = _passable(passable, tin.n_triangles)
        m = int(steiner_per_edge)
        if m != steiner_per_edge or m < 0:
            raise ArgumentError(f"steiner_per_edge must be a non-negative integer, got {steiner_per_edge!r}")
        self.steiner_per_edge = m
        self.any_angle = bool(any_angle)
        te, n_edges = K.triangle_edges(tin.triangles, tin.neighbors)
        tris, vorig = K.split_fans(tin.triangles, tin.neighbors, self.passable, tin.n_vertices)
        xs, ys = tin.xy_columns
        vx, vy = xs[vorig], ys[vorig]
        self._tris, self._vx, self._vy, self._vorig = tris, vx, vy, vorig
        self._twin = K.twins(vorig)
        nx, ny, self._tri_nodes, start, node_tris = K.build_nodes(vx, vy, tris, te, n_edges, m, self.passable)
        self._nx, self._ny = nx, ny
        self._start, self._node_tris = start, node_tris
        self.goal_triangles = self._goal_triangles()
        gt = np.flatnonzero(self.goal_triangles)
        if self.any_angle:
            corner = K.corners(vx, vy, tris, tin.neighbors, self.passable)
            ea = K.edge_starts(tin.triangles, te, n_edges)
            self.node_distance, self._parent, wf, wi = K.windows(
                nx, ny, vx, vy, tris, tin.neighbors, te, ea, vorig, self.passable, self._tri_nodes,
                start, node_tris, corner, gt, self.goal_xy[0], self.goal_xy[1], m)
            self._wstart, self._wgeo, self._wroot = K.tri_windows(wf, wi, vx, vy, tris, tin.n_triangles)
        else:
            seeds = np.unique(self._tri_nodes[gt].ravel())
            seed_dist = np.hypot(nx[seeds] - self.goal_xy[0], ny[seeds] - self.goal_xy[1])
            self.node_distance, self._parent = K.dijkstra(nx, ny, self._tri_nodes, start, node_tris, seeds,
                                                          seed_dist)
            self._wstart = np.zeros(tin.n_triangles + 1, dtype=np.int64)
            self._wgeo = np.zeros((0, 7))
            self._wroot = np.zeros(0, dtype=np.int64)
        self.node_distance.setflags(write=False)
        self.goal_triangles.setflags(write=False)

    def _goal_triangles(self) -> np.ndarray:
        """Passable triangles holding the goal: the one located and, when the goal lies on an
        edge or a vertex, every triangle around that vertex/edge that holds it too."""
        tin, g = self.tin, self.goal_xy
        t0 = int(tin.locate(g[None])[0])
        if t0 < 0:
            raise ArgumentError(f"goal_xy {g.tolist()} lies outside the TIN (bounds {tin.bounds})")
        tri, (a, b, c) = tin.triangles, tin.triangles[t0]
        near = ((tri == a) | (tri == b) | (tri == c)).any(axis=1)  # triangles sharing a vertex with t0
        cand = np.flatnonzero(near & self.passable)
        v = tin.vertices[tin.triangles[cand], :2]  # (c, 3, 2) CCW
        tol = tin.tolerances[0]
        inside = np.ones(len(cand), dtype=bool)
        for k in range(3):
            a, b = v[:, k], v[:, (k + 1) % 3]
            inside &= (b[:, 0] - a[:, 0]) * (g[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (g[0] - a[:, 0]) >= -tol
        out = np.zeros(tin.n_triangles, dtype=bool)
        out[cand[inside]] = True
        return out

    # -- derived ---------------------------------------------------------------------------
    @property
    def node_xy(self) -> np.ndarray:
        return np.column_stack([self._nx, self._ny])

    @property
    def pinch_vertices(self) -> np.ndarray:
        """``(P,)`` int: the TIN vertices where passable fans touch only at the vertex (sorted)."""
        return np.unique(self._vorig[self.tin.n_vertices:])

    @property
    def vertex_distance(self) -> np.ndarray:
        """``(V,)`` m: the field at the TIN's vertices (a view of :attr:`node_distance`; at a
        pinch vertex, the value of its first fan)."""
        return self.node_distance[: self.tin.n_vertices]

    @property
    def reachable(self) -> bool:
        """Whether the goal lies on passable ground (else every distance is ``inf``)."""
        return bool(self.goal_triangles.any())

    def triangle_reachable(self) -> np.ndarray:
        """``(T,)`` bool: passable triangles from which the goal can be reached (all of a
        triangle's points, or none, can)."""
        d = self.node_distance[self._tri_nodes[:, :3]]
        return self.passable & np.isfinite(d).any(axis=1)

    # -- queries ---------------------------------------------------------------------------
    def distance_at(self, xy, tri_idx=None) -> np.ndarray:
        """``(n,)`` m: length of the shortest drivable path from each point to the goal.

        ``xy`` ``(n, 2)`` m. ``tri_idx`` ``(n,)``: the triangles holding the points when the caller
        knows them (-1 outside); skips point location. ``inf`` where no path exists, outside the
        TIN and on impassable triangles."""
        return self.query(xy, tri_idx)[0]

    def direction_at(self, xy, tri_idx=None) -> np.ndarray:
        """``(n, 2)``: unit vector along the first leg of that path (toward the graph node or
        the goal the path leaves by); zeros where the distance is ``inf`` and at the goal.
        Moving a small step ``h`` along it lowers :meth:`distance_at` by ``h``."""
        return self.query(xy, tri_idx)[1]

    def query(self, xy, tri_idx=None) -> tuple[np.ndarray, np.ndarray]:
        """Both at once: ``(distance (n,) m, direction (n, 2))``."""
        pts = as_xy(xy, "xy")
        px = np.ascontiguousarray(pts[:, 0])
        py = np.ascontiguousarray(pts[:, 1])
        tin = self.tin
        if tri_idx is None:
            t = tin._bucket_locate(px, py)
        else:
            t = np.asarray(tri_idx, dtype=np.int64).reshape(-1)
            if t.shape[0] != px.shape[0]:
                raise ArgumentError(f"tri_idx has {t.shape[0]} entries for {px.shape[0]} points")
            if t.size and (t.min() < -1 or t.max() >= tin.n_triangles):
                raise ArgumentError(f"tri_idx must lie in -1..{tin.n_triangles - 1}")
        return self._query(px, py, t)[:2]

    def _query(self, px, py, t):
        tin = self.tin
        return K.query(self._nx, self._ny, self.node_distance, self._parent, self._tri_nodes, self.passable,
                       self.goal_triangles, self.goal_xy[0], self.goal_xy[1], self._vx, self._vy, self._tris,
                       tin.neighbors, self._wstart, self._wgeo, self._wroot, px, py, t, tin.tolerances[0], self._eps_m,
                       self._twin)

    @property
    def _eps_m(self) -> float:
        xmin, ymin, xmax, ymax = self.tin.bounds
        return 1e-9 * max(xmax - xmin, ymax - ymin, 1.0)

    def __repr__(self) -> str:
        return (f"CostToGo(goal={self.goal_xy.tolist()}, {int(self.passable.sum())}/{len(self.passable)} "
                f"passable triangles, {len(self._nx)} nodes)")


class CostToGoStack:
    """Several :class:`CostToGo` fields of one TIN, queried for many points in one compiled pass:
    ``stack.distance_at(xy, tri_idx, which)[i]`` is ``fields[which[i]].distance_at(xy[i], tri_idx[i])``,
    the same bits (one kernel, :func:`._ctg_kernels.distance_stacked`, shares the per-point code
    with :func:`._ctg_kernels.query`), ``inf`` where ``which[i]`` is -1. The env builds one per
    episode (its targets' fields) and measures every robot's distance to go with one call a step.

    >>> stack = CostToGoStack([ctg_a, ctg_b])                          # doctest: +SKIP
    >>> stack.distance_at(xy, tri_idx, which=[0, 1, -1])               # doctest: +SKIP
    """

    def __init__(self, fields):
        fields = tuple(fields)
        for k, f in enumerate(fields):
            if not isinstance(f, CostToGo):
                raise ArgumentError(f"CostToGoStack: fields[{k}] is a {type(f).__name__}, not a CostToGo")
            if f.tin is not fields[0].tin:
                raise ArgumentError(f"CostToGoStack: fields[{k}] is on another TIN than fields[0]")
            if f._tri_nodes.shape[1] != fields[0]._tri_nodes.shape[1]:
                raise ArgumentError(f"CostToGoStack: fields[{k}] has steiner_per_edge={f.steiner_per_edge}, "
                                    f"fields[0] {fields[0].steiner_per_edge}")
        self.fields = fields
        self.tin = fields[0].tin if fields else None

        def cat(get, empty):
            parts = [get(f) for f in fields]
            return np.ascontiguousarray(np.concatenate(parts)) if parts else empty

        def offsets(get):
            return np.concatenate([[0], np.cumsum([len(get(f)) for f in fields], dtype=np.int64)]).astype(np.int64)

        i64, f64 = np.zeros(0, np.int64), np.zeros(0)
        self._off = (offsets(lambda f: f._nx), offsets(lambda f: f.passable), offsets(lambda f: f._vx),
                     offsets(lambda f: f._wroot))
        self._arrays = (cat(lambda f: f._nx, f64), cat(lambda f: f._ny, f64), cat(lambda f: f.node_distance, f64),
                        cat(lambda f: f._tri_nodes, np.zeros((0, 1), np.int64)),
                        cat(lambda f: f.passable, np.zeros(0, bool)), cat(lambda f: f.goal_triangles, np.zeros(0, bool)),
                        np.array([f.goal_xy for f in fields], dtype=np.float64).reshape(-1, 2),
                        cat(lambda f: f._vx, f64), cat(lambda f: f._vy, f64),
                        cat(lambda f: f._tris, np.zeros((0, 3), np.int64)),
                        self.tin.neighbors if fields else np.zeros((0, 3), np.int64),
                        cat(lambda f: f._wstart, i64), cat(lambda f: f._wgeo, np.zeros((0, 7))), cat(lambda f: f._wroot, i64),
                        cat(lambda f: f._twin, i64))
        self._tol = float(self.tin.tolerances[0]) if fields else 0.0
        self._eps = fields[0]._eps_m if fields else 0.0

    def __len__(self) -> int:
        return len(self.fields)

    def distance_at(self, xy, tri_idx, which) -> np.ndarray:
        """``(n,)`` m: each point's distance to go on its field. ``xy`` ``(n, 2)`` m; ``tri_idx``
        ``(n,)`` the triangles holding the points (-1 outside: ``inf``); ``which`` ``(n,)`` the
        field of each point (-1: none, ``inf``)."""
        pts = np.ascontiguousarray(as_xy(xy, "xy"), dtype=np.float64)
        n = pts.shape[0]
        t = np.ascontiguousarray(np.asarray(tri_idx, dtype=np.int64).reshape(-1))
        w = np.ascontiguousarray(np.asarray(which, dtype=np.int64).reshape(-1))
        for name, a, hi in (("tri_idx", t, self.tin.n_triangles if self.fields else 0), ("which", w, len(self))):
            if a.shape[0] != n:
                raise ArgumentError(f"CostToGoStack.distance_at: {name} has {a.shape[0]} entries for {n} points")
            if a.size and (a.min() < -1 or a.max() >= hi):
                raise ArgumentError(f"CostToGoStack.distance_at: {name} must lie in -1..{hi - 1}")
        return self._distance(pts, t, w, np.empty(n))

    def _distance(self, pos, tri_idx, which, out) -> np.ndarray:
        """:meth:`distance_at` without the checks, into ``out``: ``pos`` C-contiguous ``(n, 2)``
        float64, ``tri_idx`` and ``which`` int64 ``(n,)`` in range (the env's own arrays)."""
        return K.distance_stacked(*self._off, *self._arrays, pos, tri_idx, which, self._tol, self._eps, out)


def cost_to_go(tin: Tin, goal_xy, passable=None, *, steiner_per_edge: int = DEFAULT_STEINER_PER_EDGE,
               any_angle: bool = True) -> CostToGo:
    """Shortest drivable path field to ``goal_xy`` (2,) m over ``tin``.

    ``passable`` ``(T,)`` bool marks the triangles a robot may drive on (e.g.
    ``tin.slope_deg <= max_slope_deg``); ``None`` means all. ``steiner_per_edge`` points per edge
    are nodes (more: finer window pruning and query fallbacks, a slower build; with
    ``any_angle=False`` they set the accuracy: see the module docstring). Raises ValueError when the goal
    lies outside the TIN or ``passable`` has the wrong shape. A goal on impassable ground gives
    a field that is ``inf`` everywhere (check :attr:`CostToGo.reachable`).
    """
    if passable is None:
        passable = np.ones(tin.n_triangles, dtype=bool)
    return CostToGo(tin, goal_xy, passable, steiner_per_edge, any_angle)


def pinch_vertices(tin: Tin, passable) -> np.ndarray:
    """``(P,)`` int, sorted: vertices of ``tin`` whose passable triangles (``passable`` ``(T,)``
    bool) form two or more fans (passable areas touching only at that point; no drivable path
    passes there). The definition is :func:`._ctg_kernels.split_fans`."""
    p = _passable(passable, tin.n_triangles)
    _, vorig = K.split_fans(tin.triangles, tin.neighbors, p, tin.n_vertices)
    return np.unique(vorig[tin.n_vertices:])


def _goal(goal_xy) -> np.ndarray:
    g = np.asarray(goal_xy, dtype=np.float64).reshape(-1)
    if g.shape != (2,) or not np.all(np.isfinite(g)):
        raise ArgumentError(f"goal_xy must be 2 finite numbers (x, y) m, got {goal_xy!r}")
    g = g.copy()
    g.setflags(write=False)
    return g


def _passable(passable, n_triangles) -> np.ndarray:
    p = np.asarray(passable)
    if p.shape != (n_triangles,):
        raise ArgumentError(f"passable must have shape ({n_triangles},) (one flag per triangle), got {p.shape}")
    if p.dtype != np.bool_:
        raise ArgumentError(f"passable must be a bool array, got dtype {p.dtype}")
    p = np.ascontiguousarray(p).copy()
    p.setflags(write=False)
    return p
