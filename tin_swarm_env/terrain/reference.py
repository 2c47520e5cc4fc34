"""Slow, obvious reference implementations of the compiled queries (for tests and benches).

Each is plain numpy over all triangles or all edges: O(n * T) work, no walks, no indexes.
"""

from __future__ import annotations

import numpy as np

__all__ = ["locate_brute", "line_of_sight_brute", "line_of_sight_dense", "height_brute", "single_surface_brute",
           "on_passable_brute", "crosses_impassable_brute", "cost_to_go_graph_brute", "cost_to_go_grid",
           "cost_to_go_visibility_brute", "fan_labels_brute", "pinch_vertices_brute"]


def _bary(tin, pts):
    v = tin.vertices[:, :2]
    a, b, c = v[tin.triangles[:, 0]], v[tin.triangles[:, 1]], v[tin.triangles[:, 2]]
    # (n, T) orientations of the point against each edge
    def orient(p, q):
        return (q[None, :, 0] - p[None, :, 0]) * (pts[:, None, 1] - p[None, :, 1]) - (
            q[None, :, 1] - p[None, :, 1]) * (pts[:, None, 0] - p[None, :, 0])
    return orient(a, b), orient(b, c), orient(c, a)


def locate_brute(tin, xy, tol: float | None = None) -> np.ndarray:
    """Every triangle tested: the lowest-index triangle containing each point (-1 if none)."""
    pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    if tol is None:
        tol = tin.tolerances[0]
    out = np.full(len(pts), -1, dtype=np.int64)
    for s in range(0, len(pts), 256):
        o1, o2, o3 = _bary(tin, pts[s:s + 256])
        inside = (o1 >= -tol) & (o2 >= -tol) & (o3 >= -tol)
        has = inside.any(axis=1)
        out[s:s + 256][has] = inside[has].argmax(axis=1)
    return out


def height_brute(tin, xy) -> np.ndarray:
    """Barycentric interpolation in the triangle :func:`locate_brute` finds (NaN outside)."""
    pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    t = locate_brute(tin, pts)
    z = np.full(len(pts), np.nan)
    ok = t >= 0
    v = tin.vertices[tin.triangles[t[ok]]]  # (m, 3, 3)
    p = pts[ok]
    a, b, c = v[:, 0], v[:, 1], v[:, 2]
    den = (b[:, 1] - c[:, 1]) * (a[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (a[:, 1] - c[:, 1])
    l1 = ((b[:, 1] - c[:, 1]) * (p[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (p[:, 1] - c[:, 1])) / den
    l2 = ((c[:, 1] - a[:, 1]) * (p[:, 0] - c[:, 0]) + (a[:, 0] - c[:, 0]) * (p[:, 1] - c[:, 1])) / den
    z[ok] = l1 * a[:, 2] + l2 * b[:, 2] + (1 - l1 - l2) * c[:, 2]
    return z


def line_of_sight_brute(tin, a_xyz, b_xyz, ztol: float | None = None) -> np.ndarray:
    """Every edge tested: visible iff both end points are on or above the surface inside the
    TIN and the sight line is not below the terrain at any edge it crosses, and it crosses no
    border edge strictly between its ends."""
    a = np.atleast_2d(np.asarray(a_xyz, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b_xyz, dtype=np.float64))
    if ztol is None:
        ztol = tin.tolerances[1]
    za = height_brute(tin, a[:, :2])
    zb = height_brute(tin, b[:, :2])
    ok = (a[:, 2] >= za - ztol) & (b[:, 2] >= zb - ztol)  # NaN -> False
    E = tin.edges
    border = tin.edge_triangles[:, 1] < 0
    P = tin.vertices[E[:, 0]]
    Q = tin.vertices[E[:, 1]]
    for i in np.flatnonzero(ok):
        d = b[i, :2] - a[i, :2]
        e = Q[:, :2] - P[:, :2]
        den = d[0] * e[:, 1] - d[1] * e[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((P[:, 0] - a[i, 0]) * e[:, 1] - (P[:, 1] - a[i, 1]) * e[:, 0]) / den
            u = ((P[:, 0] - a[i, 0]) * d[1] - (P[:, 1] - a[i, 1]) * d[0]) / den
        hit = (den != 0) & (s >= 0) & (s <= 1) & (u >= 0) & (u <= 1)
        if np.any(hit & border & (s > 1e-9) & (s < 1 - 1e-9)):
            ok[i] = False
            continue
        z_edge = P[hit, 2] + u[hit] * (Q[hit, 2] - P[hit, 2])
        z_sight = a[i, 2] + s[hit] * (b[i, 2] - a[i, 2])
        ok[i] = not np.any(z_edge > z_sight + ztol)
    return ok


def line_of_sight_dense(tin, a_xyz, b_xyz, n_samples: int = 2000):
    """Dense sampling: min over ``n_samples`` points of (sight line - terrain) per ray, the terrain
    height of each sample from the plane of the triangle holding it (:func:`height_brute`: every
    triangle tested; no walk, no line-of-sight code). Returns ``(n,)`` clearances in m (NaN where a
    sample falls outside the TIN)."""
    a = np.atleast_2d(np.asarray(a_xyz, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b_xyz, dtype=np.float64))
    s = np.linspace(0.0, 1.0, n_samples)
    out = np.empty(len(a))
    for i in range(len(a)):
        p = a[i] + s[:, None] * (b[i] - a[i])
        out[i] = np.min(p[:, 2] - height_brute(tin, p[:, :2]))
    return out


def _clip_area(P, Q) -> float:
    """Plan area of the intersection of two counter-clockwise triangles ``P``, ``Q`` ``(3, 2)``:
    Sutherland-Hodgman, ``P`` clipped by each edge of ``Q``, then the shoelace formula."""
    poly = [tuple(p) for p in P]
    for k in range(3):
        a, b = Q[k], Q[(k + 1) % 3]
        ex, ey = b[0] - a[0], b[1] - a[1]

        def side(p, a=a, ex=ex, ey=ey):  # > 0: left of a->b, inside Q
            return ex * (p[1] - a[1]) - ey * (p[0] - a[0])

        out = []
        for i in range(len(poly)):
            p, q = poly[i], poly[(i + 1) % len(poly)]
            sp, sq = side(p), side(q)
            if sp >= 0:
                out.append(p)
            if (sp >= 0) != (sq >= 0):
                t = sp / (sp - sq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        poly = out
        if len(poly) < 3:
            return 0.0
    x = np.array([p[0] for p in poly])
    y = np.array([p[1] for p in poly])
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _inside_edge(p, a, b, delta) -> bool:
    """Whether point ``p`` lies on segment ``a -> b`` (within ``delta`` m of its line) strictly
    between its ends (more than ``delta`` from each)."""
    e = b - a
    length = float(np.hypot(*e))
    t = float(np.dot(p - a, e)) / length  # m along the edge
    off = abs(float(e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0]))) / length  # m off its line
    return off <= delta and delta < t < length - delta


def single_surface_brute(vertices, triangles) -> np.ndarray:
    """Every pair of triangles tested (T^2/2 pairs, no grid), from the coordinates alone
    (independent of :func:`~tin_swarm_env.terrain.validity.pair_status`): ``(T, T)`` int64
    upper-triangular matrix of codes 0 OK, 1 OVERLAP (the interiors overlap in plan: the
    intersection found by clipping one triangle by the other has an area above ``delta`` times the
    longer triangle's longest edge), 2 T_JUNCTION (a corner of one lies inside an edge of the
    other, within ``delta`` of it, and is not a corner of it); 0 for pairs sharing an edge and on
    and below the diagonal. ``delta``: 1e-9 of the plan extent (the validity check's tolerance)."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    xy = v[:, :2]
    delta = 1e-9 * float(max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1]), 1e-300))
    out = np.zeros((len(tri), len(tri)), dtype=np.int64)
    for i in range(len(tri)):
        for j in range(i + 1, len(tri)):
            A, B = tri[i], tri[j]
            if len(set(A.tolist()) & set(B.tolist())) == 2:
                continue
            P, Q = xy[A], xy[B]
            longest = max(float(np.hypot(*(T[(k + 1) % 3] - T[k]))) for T in (P, Q) for k in range(3))
            if _clip_area(P, Q) > delta * longest:
                out[i, j] = 1
                continue
            for X, Y, Yi in ((P, Q, B), (Q, P, A)):
                for c in range(3):
                    corner_idx = (A if X is P else B)[c]
                    if corner_idx in Yi:
                        continue
                    if any(_inside_edge(X[c], Y[k], Y[(k + 1) % 3], delta) for k in range(3)):
                        out[i, j] = 2
    return out


# -- cost-to-go -------------------------------------------------------------------------------


def on_passable_brute(tin, xy, passable, tol: float | None = None) -> np.ndarray:
    """``(n,)`` bool: whether each point lies on the closed union of the passable triangles
    (every triangle tested, a point on an edge counts for both sides)."""
    pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    if tol is None:
        tol = tin.tolerances[0]
    out = np.zeros(len(pts), dtype=bool)
    for s in range(0, len(pts), 256):
        o1, o2, o3 = _bary(tin, pts[s:s + 256])
        inside = (o1 >= -tol) & (o2 >= -tol) & (o3 >= -tol) & passable[None, :]
        out[s:s + 256] = inside.any(axis=1)
    return out


def cost_to_go_graph_brute(ctg) -> np.ndarray:
    """The plain Steiner-graph distances of a :class:`~.cost_to_go.CostToGo` (its nodes,
    ``any_angle=False``), from an explicit edge list (every node pair on every passable
    triangle, the goal as an extra node) and ``scipy.sparse.csgraph.dijkstra``. ``(N,)`` m."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    xy = ctg.node_xy
    N = len(xy)
    tn = ctg._tri_nodes[ctg.passable]  # (Tp, S)
    S = tn.shape[1]
    i, j = np.triu_indices(S, 1)
    a, b = tn[:, i].ravel(), tn[:, j].ravel()
    g = np.flatnonzero(ctg.goal_triangles)
    ga = np.unique(ctg._tri_nodes[g].ravel()) if len(g) else np.zeros(0, dtype=np.int64)
    a = np.r_[a, ga]
    b = np.r_[b, np.full(len(ga), N)]
    pairs = np.unique(np.column_stack([np.minimum(a, b), np.maximum(a, b)]), axis=0)  # coo sums duplicates
    a, b = pairs[:, 0], pairs[:, 1]
    pts = np.vstack([xy, ctg.goal_xy[None]])
    w = np.hypot(*(pts[a] - pts[b]).T) + 1e-300  # csgraph drops explicit zeros
    m = coo_matrix((w, (a, b)), shape=(N + 1, N + 1)).tocsr()
    return dijkstra(m, directed=False, indices=N)[:N]


def fan_labels_brute(tin, passable) -> np.ndarray:
    """``(T, 3)`` int: the fan of each corner of a passable triangle (-1 on impassable ones):
    two corners at one vertex share a fan when their triangles share an edge through that vertex
    (both passable), or are linked through a chain of such triangles. scipy connected components:
    the reference of :func:`~._ctg_kernels.split_fans`."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    passable = np.asarray(passable, dtype=bool)
    tri, nb = tin.triangles, tin.neighbors
    T = len(tri)
    ids = np.arange(3 * T).reshape(T, 3)
    rows, cols = [ids[:, 0]], [ids[:, 0]]
    for j in range(3):  # edge opposite corner j joins corners (j+1)%3 and (j+2)%3 of t to u
        u = nb[:, j]
        ok = (u >= 0) & passable & passable[np.maximum(u, 0)]
        t_ok, u_ok = np.flatnonzero(ok), u[ok]
        for c in ((j + 1) % 3, (j + 2) % 3):
            v = tri[t_ok, c]
            rows.append(ids[t_ok, c])
            cols.append(ids[u_ok, np.argmax(tri[u_ok] == v[:, None], axis=1)])
    r, c = np.concatenate(rows), np.concatenate(cols)
    _, lab = connected_components(coo_matrix((np.ones(len(r)), (r, c)), shape=(3 * T, 3 * T)), directed=False)
    return np.where(passable[:, None], lab.reshape(T, 3), -1)


def pinch_vertices_brute(tin, passable) -> np.ndarray:
    """``(P,)`` int, sorted: vertices with two or more fans (:func:`fan_labels_brute`)."""
    lab = fan_labels_brute(tin, passable)
    vf = np.unique(np.stack([tin.triangles[lab >= 0], lab[lab >= 0]], axis=1), axis=0)
    v, cnt = np.unique(vf[:, 0], return_counts=True)
    return v[cnt > 1]


def _in_fan(tin, lab, v, f, d) -> np.ndarray:
    """``(k,)`` bool: whether directions ``d`` ``(k, 2)`` from vertex ``v`` point into (or along
    the sides of) a corner of fan ``f``."""
    xy = tin.vertices[:, :2]
    ts, ks = np.nonzero((tin.triangles == v) & (lab == f))
    d = d / np.maximum(np.hypot(*d.T), 1e-300)[:, None]
    out = np.zeros(len(d), dtype=bool)
    for t, k in zip(ts, ks):
        a = xy[tin.triangles[t, (k + 1) % 3]] - xy[v]
        b = xy[tin.triangles[t, (k + 2) % 3]] - xy[v]
        a, b = a / np.hypot(*a), b / np.hypot(*b)
        out |= (a[0] * d[:, 1] - a[1] * d[:, 0] >= -1e-9) & (d[:, 0] * b[1] - d[:, 1] * b[0] >= -1e-9)
    return out


def _passable_of(lab) -> np.ndarray:
    return (lab >= 0).any(axis=1)


def _pinch_ok(tin, lab, pinches, a, b, fa, fb, va, vb) -> np.ndarray:
    """``(k,)`` bool: segments ``a -> b`` ``(k, 2)`` obey the pinch rule: an end at pinch vertex
    ``va``/``vb`` (-1: not a vertex) leaves it into its fan ``fa``/``fb``, and a pinch vertex
    strictly inside a segment is passed within one fan (both sides in the same fan)."""
    ok = np.ones(len(a), dtype=bool)
    for p in pinches:
        for v, f, s, e in ((va, fa, a, b), (vb, fb, b, a)):
            at = v == p
            for ff in np.unique(f[at]):
                sel = at & (f == ff)
                ok[sel] &= _in_fan(tin, lab, p, ff, e[sel] - s[sel])
        xy = tin.vertices[p, :2]
        d = b - a
        L2 = np.maximum(np.sum(d * d, axis=1), 1e-300)
        u = np.sum((xy - a) * d, axis=1) / L2
        off = np.abs(d[:, 0] * (xy[1] - a[:, 1]) - d[:, 1] * (xy[0] - a[:, 0])) / np.sqrt(L2)
        inside = (va != p) & (vb != p) & (u > 1e-9) & (u < 1 - 1e-9)
        inner = inside & (off <= 1e-9 * max(1.0, np.sqrt(L2.max())))
        near = np.flatnonzero(inside & ~inner & (off < 0.05 * np.sqrt(L2)))  # sampling alone may step past
        if len(near):  # the steep wedges by p: dense samples round the closest point
            t = np.linspace(-20.0, 20.0, 81)[None, :] * off[near, None] / np.sqrt(L2[near, None])
            uu = np.clip(u[near, None] + t, 0.0, 1.0)
            pts = a[near, None] + uu[..., None] * d[near, None]
            ok[near] &= on_passable_brute(tin, pts.reshape(-1, 2), _passable_of(lab), tol=1e-9).reshape(
                len(near), -1).all(axis=1)
        for i in np.flatnonzero(inner):
            fans = np.unique(lab[(tin.triangles == p) & (lab >= 0)])
            ok[i] &= any(_in_fan(tin, lab, p, f, np.stack([d[i], -d[i]])).all() for f in fans)
    return ok


def crosses_impassable_brute(tin, passable, a, b, tol_m: float = 1e-9) -> np.ndarray:
    """``(k,)`` bool: whether each segment ``a -> b`` (``(k, 2)`` each) runs through the open
    interior of an impassable triangle over a stretch longer than ``1e-12`` of its length
    (every impassable triangle tested exactly: the part of the segment more than ``tol_m``
    inside all three edge lines) or along an edge with no passable side. Running along an edge
    with passable ground on one side, or through a vertex, is not crossing.
    Exact where sampling is not: a sliver of impassable ground narrower than the sample step
    is still seen."""
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b, dtype=np.float64))
    v = tin.vertices[tin.triangles[~np.asarray(passable, dtype=bool)], :2]  # (Ti, 3, 2) CCW
    out = np.zeros(len(a), dtype=bool)
    if len(v) == 0:
        return out
    for s0 in range(0, len(a), 256):
        pa, pb = a[s0:s0 + 256, None], b[s0:s0 + 256, None]  # (c, 1, 2)
        lo = np.zeros((len(pa), len(v)))
        hi = np.ones((len(pa), len(v)))
        for k in range(3):
            p, q = v[None, :, k], v[None, :, (k + 1) % 3]  # (1, Ti, 2)
            e = q - p
            L = np.maximum(np.hypot(e[..., 0], e[..., 1]), 1e-300)
            o0 = (e[..., 0] * (pa[..., 1] - p[..., 1]) - e[..., 1] * (pa[..., 0] - p[..., 0])) / L - tol_m
            o1 = (e[..., 0] * (pb[..., 1] - p[..., 1]) - e[..., 1] * (pb[..., 0] - p[..., 0])) / L - tol_m
            do = o1 - o0  # signed distance inside this edge line (less tol_m) is o0 + s * do, s in [0, 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                cut = -o0 / do
            lo = np.where(do > 0, np.maximum(lo, cut), lo)
            hi = np.where(do < 0, np.minimum(hi, cut), hi)
            hi = np.where((do == 0) & (o0 <= 0), -1.0, hi)  # parallel, outside
        out[s0:s0 + 256] = (hi - lo > 1e-12).any(axis=1)
    et = tin.edge_triangles
    side_ok = (et >= 0) & np.asarray(passable, dtype=bool)[np.maximum(et, 0)]
    closed = tin.edges[~side_ok.any(axis=1)]  # edges with no passable side
    if len(closed):
        p, q = tin.vertices[closed[:, 0], :2][None], tin.vertices[closed[:, 1], :2][None]  # (1, Ec, 2)
        e = q - p
        L = np.maximum(np.hypot(e[..., 0], e[..., 1]), 1e-300)
        pa, pb = a[:, None], b[:, None]
        da = (e[..., 0] * (pa[..., 1] - p[..., 1]) - e[..., 1] * (pa[..., 0] - p[..., 0])) / L
        db = (e[..., 0] * (pb[..., 1] - p[..., 1]) - e[..., 1] * (pb[..., 0] - p[..., 0])) / L
        ta = np.sum((pa - p) * e, axis=-1) / (L * L)  # the segment's ends along the edge, 0..1 on it
        tb = np.sum((pb - p) * e, axis=-1) / (L * L)
        overlap = np.minimum(np.maximum(ta, tb), 1.0) - np.maximum(np.minimum(ta, tb), 0.0)
        on_line = (np.abs(da) <= tol_m) & (np.abs(db) <= tol_m)
        out |= (on_line & (overlap * L > 1e-12 * np.maximum(np.hypot(*(b - a).T), 1e-300)[:, None])).any(axis=1)
    return out


def cost_to_go_visibility_brute(tin, goal_xy, passable, xy, n_samples: int = 200) -> np.ndarray:
    """The exact shortest drivable path lengths ``(n,)`` m from points ``xy`` ``(n, 2)`` to the goal:
    Dijkstra on the visibility graph of the goal and *every* TIN vertex, one node per passable fan
    (a shortest path in a polygonal domain is straight between bends at vertices), a segment
    counting as visible when ``n_samples`` points along it lie on passable ground
    (:func:`on_passable_brute`: inside the TIN), it crosses no impassable triangle
    (:func:`crosses_impassable_brute`, exact: samples alone step over slivers) and it obeys the pinch rule (it never passes from one fan of a
    vertex to another: :func:`_pinch_ok`). Slow (O(V^2) segments): for small TINs. ``inf``
    where the goal cannot be reached."""
    from scipy.sparse.csgraph import dijkstra

    passable = np.asarray(passable, dtype=bool)
    lab = fan_labels_brute(tin, passable)
    vf = np.unique(np.stack([tin.triangles[lab >= 0], lab[lab >= 0]], axis=1), axis=0)  # (vertex, fan) nodes
    vs, cnt = np.unique(vf[:, 0], return_counts=True)
    pinches = vs[cnt > 1]
    pts = np.vstack([np.asarray(goal_xy, dtype=np.float64)[None], tin.vertices[vf[:, 0], :2]])
    nv = np.r_[-1, vf[:, 0]]
    nf = np.r_[-1, vf[:, 1]]
    s = np.linspace(0.0, 1.0, n_samples)[None, :, None]

    def seen(a, b, ia, ib):  # (k, 2), (k, 2), node ids (k,) (-1: a query point) -> (k,) bool
        seg = a[:, None] + s * (b - a)[:, None]
        on = on_passable_brute(tin, seg.reshape(-1, 2), passable, tol=1e-9).reshape(len(a), -1).all(axis=1)
        on &= ~crosses_impassable_brute(tin, passable, a, b)
        va = np.where(ia >= 0, nv[np.maximum(ia, 0)], -1)
        vb = np.where(ib >= 0, nv[np.maximum(ib, 0)], -1)
        return on & _pinch_ok(tin, lab, pinches, a, b, nf[np.maximum(ia, 0)], nf[np.maximum(ib, 0)], va, vb)

    i, j = np.triu_indices(len(pts), 1)
    keep = np.hypot(*(pts[i] - pts[j]).T) > 0
    i, j = i[keep], j[keep]
    vis = seen(pts[i], pts[j], i, j)
    w = np.full((len(pts), len(pts)), np.inf)
    w[i[vis], j[vis]] = w[j[vis], i[vis]] = np.hypot(*(pts[i[vis]] - pts[j[vis]]).T) + 1e-300
    if len(pts) > 1 and not on_passable_brute(tin, pts[:1], passable, tol=1e-9)[0]:
        w[0] = w[:, 0] = np.inf
    D = dijkstra(np.where(np.isfinite(w), w, 0.0), directed=False, indices=0)
    q = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    out = np.full(len(q), np.inf)
    qon = on_passable_brute(tin, q, passable, tol=1e-9)
    fin = np.flatnonzero(np.isfinite(D))
    for k in np.flatnonzero(qon):
        none = np.full(len(fin), -1)
        v = seen(np.repeat(q[k][None], len(fin), axis=0), pts[fin], none, fin)
        if v.any():
            out[k] = np.min(np.hypot(*(pts[fin[v]] - q[k]).T) + D[fin[v]])
    return out


_GRID_MOVES = np.array([(a, b) for a in range(-3, 4) for b in range(-3, 4)
                        if (a, b) != (0, 0) and np.gcd(a, b) == 1])  # 32 moves, 16 directions per half-turn


def cost_to_go_grid(tin, goal_xy, passable, cell_m: float):
    """Dijkstra on a dense grid sampling of the TIN: cells whose centre lies on passable
    ground, 32 moves ``(a, b)`` with ``|a|, |b| <= 3`` coprime (worst direction error
    ``1/cos(9.2 deg) - 1 = 1.3 %``), a move allowed when its end cells and 4 samples per cell
    along it lie on passable ground. ``goal_xy`` should be a cell centre.

    Returns ``(xs (nx,), ys (ny,), dist (ny, nx))`` m, ``inf`` off passable ground/unreached.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    xmin, ymin, xmax, ymax = tin.bounds
    xs = np.arange(xmin + cell_m / 2, xmax, cell_m)
    ys = np.arange(ymin + cell_m / 2, ymax, cell_m)
    X, Y = np.meshgrid(xs, ys)
    ok = on_passable_brute(tin, np.column_stack([X.ravel(), Y.ravel()]), passable).reshape(X.shape)
    ny, nx = ok.shape
    idx = np.arange(nx * ny).reshape(ny, nx)
    rows, cols, ws = [], [], []
    for a, b in _GRID_MOVES:
        r0, r1 = max(0, -b), min(ny, ny - b)
        c0, c1 = max(0, -a), min(nx, nx - a)
        good = ok[r0:r1, c0:c1] & ok[r0 + b:r1 + b, c0 + a:c1 + a]
        n_s = 4 * max(abs(a), abs(b))
        for k in range(1, n_s):
            f = k / n_s
            pts = np.column_stack([(X[r0:r1, c0:c1] + f * a * cell_m)[good], (Y[r0:r1, c0:c1] + f * b * cell_m)[good]])
            sub = np.zeros_like(good)
            sub[good] = on_passable_brute(tin, pts, passable)
            good &= sub
        rows.append(idx[r0:r1, c0:c1][good])
        cols.append(idx[r0 + b:r1 + b, c0 + a:c1 + a][good])
        ws.append(np.full(int(good.sum()), cell_m * np.hypot(a, b)))
    m = coo_matrix((np.concatenate(ws), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny, nx * ny))
    gi = int(np.argmin(np.abs(ys - goal_xy[1]))) * nx + int(np.argmin(np.abs(xs - goal_xy[0])))
    dist = dijkstra(m.tocsr(), directed=True, indices=gi).reshape(ny, nx)
    return xs, ys, np.where(ok, dist, np.inf)
