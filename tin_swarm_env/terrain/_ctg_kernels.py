"""Compiled kernels of :mod:`.cost_to_go` (numba, ``cache=True``): the Steiner graph, its
Dijkstra and the batched query.

The graph is implicit: node ``u`` is joined to every node on the boundary of every passable
triangle ``u`` lies on (``node_tri_start``/``node_tris`` list those triangles, ``tri_nodes``
their boundary nodes), so no edge list is ever built. Node numbering: vertex ``v`` is node
``v``; Steiner point ``j`` of edge ``e`` is node ``V + e * m + j`` (``m`` points per edge).

The plain references are :func:`tin_swarm_env.terrain.reference.cost_to_go_graph_brute`
(an explicit edge list and ``scipy.sparse.csgraph.dijkstra``) and
:func:`~tin_swarm_env.terrain.reference.cost_to_go_query_brute`; the tests check the
compiled kernels against them and against their own ``.py_func``.

Speed: the window loop (:func:`_propagate`) and its small helpers are compiled without
reference counting (``_nrt=False``; they allocate nothing, the caller does): numba's
take-and-release of every array argument of every inlined helper had cost as much as the loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._kernels import orient as _orient

GOAL = -2  # parent of a node reached straight from the goal / query answered straight to the goal
NONE = -1  # no node
CHUNKS = 16  # runs of points :func:`distance_stacked` shares among the threads


@njit(cache=True, error_model="numpy")
def triangle_edges(tris, nbrs):
    """Edge ids ``(T, 3)`` int64 (edge of triangle t opposite vertex k) and the edge count.
    Ids follow first appearance in triangle order, like :attr:`Tin.edges`."""
    T = tris.shape[0]
    te = np.full((T, 3), -1, dtype=np.int64)
    ne = 0
    for t in range(T):
        for k in range(3):
            if te[t, k] >= 0:
                continue
            te[t, k] = ne
            nb = nbrs[t, k]
            if nb >= 0:
                for kk in range(3):
                    if nbrs[nb, kk] == t:
                        te[nb, kk] = ne
            ne += 1
    return te, ne


@njit(cache=True, error_model="numpy")
def build_nodes(vx, vy, tris, te, n_edges, m, passable):
    """Node coordinates, each triangle's boundary nodes and the node -> passable-triangle CSR.

    Returns ``(nx (N,), ny (N,), tri_nodes (T, 3 + 3m), start (N+1,), node_tris)``.
    Steiner points split each edge into ``m + 1`` equal parts.
    """
    V = vx.shape[0]
    T = tris.shape[0]
    N = V + n_edges * m
    nx = np.empty(N)
    ny = np.empty(N)
    nx[:V] = vx
    ny[:V] = vy
    S = 3 + 3 * m
    tri_nodes = np.empty((T, S), dtype=np.int64)
    done = np.zeros(n_edges, dtype=np.bool_)
    for t in range(T):
        for k in range(3):
            tri_nodes[t, k] = tris[t, k]
            e = te[t, k]
            a = tris[t, (k + 1) % 3]
            b = tris[t, (k + 2) % 3]
            for j in range(m):
                node = V + e * m + j
                tri_nodes[t, 3 + k * m + j] = node
                if not done[e]:
                    f = (j + 1.0) / (m + 1.0)
                    nx[node] = vx[a] + f * (vx[b] - vx[a])
                    ny[node] = vy[a] + f * (vy[b] - vy[a])
            done[e] = True
    start = np.zeros(N + 1, dtype=np.int64)
    for t in range(T):
        if passable[t]:
            for s in range(S):
                start[tri_nodes[t, s] + 1] += 1
    for i in range(N):
        start[i + 1] += start[i]
    fill = start[:-1].copy()
    node_tris = np.empty(start[N], dtype=np.int64)
    for t in range(T):
        if passable[t]:
            for s in range(S):
                u = tri_nodes[t, s]
                node_tris[fill[u]] = t
                fill[u] += 1
    return nx, ny, tri_nodes, start, node_tris


@njit(cache=True, error_model="numpy")
def edge_starts(tris, te, n_edges):
    """``(E,)`` int64: each edge's first vertex in the frame of the first triangle holding it
    (the frame :func:`build_nodes` spaces its Steiner points in: canonical parameter 0 there).
    Pass the original triangles: windows compare it with ``vorig`` of their own vertex."""
    ea = np.full(n_edges, -1, dtype=np.int64)
    for t in range(tris.shape[0]):
        for k in range(3):
            e = te[t, k]
            if ea[e] < 0:
                ea[e] = tris[t, (k + 1) % 3]
    return ea


@njit(cache=True, error_model="numpy", _nrt=False)
def _find(up, i):
    """Union-find root of i (path halving). Like every helper of a hot loop here, compiled
    without reference counting (``_nrt=False``: it allocates nothing): taking and releasing
    its array argument would cost more than the work."""
    while up[i] != i:
        up[i] = up[up[i]]
        i = up[i]
    return i


@njit(cache=True, error_model="numpy")
def split_fans(tris, nbrs, passable, V):
    """Pinch vertices split into one vertex per passable *fan*: the single definition of a pinch.

    The corners ``(t, k)`` of passable triangles at one vertex form a fan when linked through
    passable triangles sharing an edge through that vertex; a vertex with two or more fans is a
    *pinch* (passable areas touching only at that point: no robot can drive through it). Returns
    ``(tris2 (T, 3), vorig (V2,))``: ``tris`` with the corners of every fan but a vertex's first
    (in triangle order) renumbered to a new vertex ``V, V+1, ...`` at the same place, and the
    original vertex of each of the ``V2`` vertices. Impassable triangles keep the old vertex.
    Shortest paths over ``tris2`` (same neighbours) cannot pass from one fan to another."""
    T = tris.shape[0]
    up = np.arange(3 * T)
    for t in range(T):
        if not passable[t]:
            continue
        for k in range(3):  # the edge opposite k joins corners (k+1)%3, (k+2)%3 of t to nb's
            nb = nbrs[t, k]
            if nb < t or not passable[nb]:  # each edge once (a set's root is its smallest corner)
                continue
            for j in range(1, 3):
                v = tris[t, (k + j) % 3]
                kk = 0
                while tris[nb, kk] != v:
                    kk += 1
                a = _find(up, 3 * t + (k + j) % 3)
                b = _find(up, 3 * nb + kk)
                if a != b:
                    up[max(a, b)] = min(a, b)
    tris2 = tris.copy()
    newid = np.full(3 * T, -1, dtype=np.int64)
    claimed = np.zeros(V, dtype=np.bool_)
    vorig = np.empty(V + 3 * T, dtype=np.int64)
    vorig[:V] = np.arange(V)
    n = V
    for t in range(T):
        if not passable[t]:
            continue
        for k in range(3):
            v = tris[t, k]
            r = _find(up, 3 * t + k)
            if newid[r] < 0:
                if not claimed[v]:
                    claimed[v] = True
                    newid[r] = v
                else:
                    newid[r] = n
                    vorig[n] = v
                    n += 1
            tris2[t, k] = newid[r]
    return tris2, vorig[:n].copy()


@njit(cache=True, error_model="numpy")
def corners(vx, vy, tris, nbrs, passable):
    """``(V,)`` bool: vertices where a shortest path may bend: on the boundary of passable
    ground (an edge with passable ground on one side only, the TIN border counting as
    impassable) where passable ground turns by more than 180 deg (reflex). Shortest paths in a
    polygonal domain bend only there. ``tris`` has its pinches split (:func:`split_fans`): a
    vertex with two passable arcs would be a pinch, which no path passes."""
    V = vx.shape[0]
    ang = np.zeros(V)
    bcount = np.zeros(V, dtype=np.int64)
    for t in range(tris.shape[0]):
        if not passable[t]:
            continue
        for k in range(3):
            nb = nbrs[t, k]  # across the edge opposite corner k
            if nb < 0 or not passable[nb]:
                bcount[tris[t, (k + 1) % 3]] += 1
                bcount[tris[t, (k + 2) % 3]] += 1
    for t in range(tris.shape[0]):  # the angles, at boundary vertices only
        if not passable[t]:
            continue
        for k in range(3):
            a = tris[t, k]
            if bcount[a] != 2:
                continue
            b = tris[t, (k + 1) % 3]
            c = tris[t, (k + 2) % 3]
            ux = vx[b] - vx[a]
            uy = vy[b] - vy[a]
            wx = vx[c] - vx[a]
            wy = vy[c] - vy[a]
            ang[a] += np.arctan2(abs(ux * wy - uy * wx), ux * wx + uy * wy)
    out = np.zeros(V, dtype=np.bool_)
    for v in range(V):
        out[v] = bcount[v] == 2 and ang[v] > np.pi + 1e-9
    return out


@njit(cache=True, inline="always", error_model="numpy")
def _norm2(x, y):
    """x * x + y * y: squares as products, never ``** 2`` (Python's float power is libm's
    ``pow``, which can differ from the product in the last bit: ``.py_func`` would not match)."""
    return x * x + y * y


@njit(cache=True, inline="always", error_model="numpy")
def _hyp(x, y):
    return np.sqrt(_norm2(x, y))


@njit(cache=True, inline="always", error_model="numpy")
def _sift_up(heap, pos, key, i):
    u = heap[i]
    ku = key[u]
    while i > 0:
        p = (i - 1) >> 1
        w = heap[p]
        if key[w] <= ku:
            break
        heap[i] = w
        pos[w] = i
        i = p
    heap[i] = u
    pos[u] = i


@njit(cache=True, inline="always", error_model="numpy")
def _sift_down(heap, pos, key, i, size):
    u = heap[i]
    ku = key[u]
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and key[heap[c + 1]] < key[heap[c]]:
            c += 1
        w = heap[c]
        if ku <= key[w]:
            break
        heap[i] = w
        pos[w] = i
        i = c
    heap[i] = u
    pos[u] = i


@njit(cache=True, error_model="numpy")
def dijkstra(nx, ny, tri_nodes, start, node_tris, seeds, seed_dist):
    """Plain Dijkstra over the implicit Steiner graph (indexed binary heap): ``seeds (s,)`` are
    the nodes of the goal's triangles at ``seed_dist (s,)`` (their straight distance to the
    goal, parent :data:`GOAL`). Returns ``(dist (N,), parent (N,))``; ``inf``/:data:`NONE` unreached."""
    N = nx.shape[0]
    S = tri_nodes.shape[1]
    dist = np.full(N, np.inf)
    parent = np.full(N, NONE, dtype=np.int64)
    pos = np.full(N, -1, dtype=np.int64)  # -1 never queued, -2 settled, else heap index
    heap = np.empty(N, dtype=np.int64)
    size = 0
    for i in range(seeds.shape[0]):
        u = seeds[i]
        if seed_dist[i] < dist[u]:
            dist[u] = seed_dist[i]
            parent[u] = GOAL
            if pos[u] < 0:
                heap[size] = u
                pos[u] = size
                size += 1
            _sift_up(heap, pos, dist, pos[u])
    while size > 0:
        u = heap[0]
        pos[u] = -2
        size -= 1
        if size > 0:
            heap[0] = heap[size]
            pos[heap[0]] = 0
            _sift_down(heap, pos, dist, 0, size)
        for a in range(start[u], start[u + 1]):
            t = node_tris[a]
            for s in range(S):
                w = tri_nodes[t, s]
                if pos[w] == -2:
                    continue
                nd = dist[u] + _hyp(nx[w] - nx[u], ny[w] - ny[u])
                if nd < dist[w]:
                    dist[w] = nd
                    parent[w] = u
                    if pos[w] == -1:
                        heap[size] = w
                        pos[w] = size
                        size += 1
                    _sift_up(heap, pos, dist, pos[w])
    return dist, parent


@njit(cache=True, error_model="numpy")
def _snap(vx, vy, tris, nbrs, passable, t, x, y, tol):
    """A point located on impassable triangle ``t`` but lying on its edge with a passable
    neighbour belongs to that neighbour (passable ground is a closed set)."""
    for k in range(3):
        nb = nbrs[t, k]
        if nb >= 0 and passable[nb]:
            a = tris[t, (k + 1) % 3]
            b = tris[t, (k + 2) % 3]
            if _orient(vx[a], vy[a], vx[b], vy[b], x, y) <= tol:
                return nb
    return t


# -- exact any-angle field: window propagation ------------------------------------------------
#
# A *window* is an interval [u0, u1] of the edge ``k`` of triangle ``t`` (parameter u from
# A = tris[t, (k+1)%3] to B = tris[t, (k+2)%3], t's counter-clockwise frame) every point of which
# sees its *root* r (the goal or a corner vertex, at distance rd) along a straight segment on
# passable ground, the segment arriving from outside t: the wedge of rays from r through the
# interval continues into t. Window records: wf (cap, 8) float64 [u0, u1, rx, ry, rd, key, c0, c1]
# (c0, c1: the interval in the edge's canonical parameter, set once accepted), wi (cap, 4) int64
# [t, k, root, accepted]; t == -1 marks a *spawn* event of vertex ``root`` instead.

_REL = 1e-14  # a window must improve some test value by this relative amount to be kept
_UEPS = 1e-12  # interval parameters this close to 0/1 reach the edge's end vertex


@njit(cache=True, inline="always", error_model="numpy")
def _seg_dist(rx, ry, ax, ay, bx, by):
    """Distance from r to the segment a-b."""
    dx = bx - ax
    dy = by - ay
    L2 = dx * dx + dy * dy
    s = 0.0
    if L2 > 0.0:
        s = min(1.0, max(0.0, ((rx - ax) * dx + (ry - ay) * dy) / L2))
    return _hyp(ax + s * dx - rx, ay + s * dy - ry)


@njit(cache=True, inline="always", error_model="numpy")
def _push(st, wf, wi, links, heap, t, k, u0, u1, rx, ry, rd, root, key):
    """Append a record and queue it. st = [n, heap size, stacked corners, full]; heap (cap, 2)
    float64 rows [key, record] (keys contiguous with their ids). When the arrays are full the
    record is dropped and ``st[3]`` set: :func:`windows` starts again with twice the room."""
    n = st[0]
    if n == wf.shape[0]:
        st[3] = 1
        return
    wf[n, 0] = u0
    wf[n, 1] = u1
    wf[n, 2] = rx
    wf[n, 3] = ry
    wf[n, 4] = rd
    wf[n, 5] = key
    wf[n, 6] = 0.0
    wf[n, 7] = 0.0
    wi[n, 0] = t
    wi[n, 1] = k
    wi[n, 2] = root
    wi[n, 3] = 0
    i = st[1]
    while i > 0:
        p = (i - 1) >> 1
        if heap[p, 0] <= key:
            break
        heap[i, 0] = heap[p, 0]
        heap[i, 1] = heap[p, 1]
        i = p
    heap[i, 0] = key
    heap[i, 1] = n
    st[0] = n + 1
    st[1] += 1


@njit(cache=True, inline="always", error_model="numpy")
def _pop(st, heap):
    top = int(heap[0, 1])
    size = st[1] - 1
    st[1] = size
    if size > 0:
        ku = heap[size, 0]
        iu = heap[size, 1]
        i = 0
        while True:
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and heap[c + 1, 0] < heap[c, 0]:
                c += 1
            if ku <= heap[c, 0]:
                break
            heap[i, 0] = heap[c, 0]
            heap[i, 1] = heap[c, 1]
            i = c
        heap[i, 0] = ku
        heap[i, 1] = iu
    return top


@njit(cache=True, inline="always", error_model="numpy")
def _set(u, val, root, dist, parent, corner, spawned, pend, stack, st, V):
    """Offer node u the value val (a drivable path via root); corners improved are stacked
    for a spawn event."""
    if val < dist[u]:
        dist[u] = val
        parent[u] = root
        if u < V and corner[u] and not spawned[u] and not pend[u]:
            pend[u] = True
            stack[st[2]] = u
            st[2] += 1


@njit(cache=True, inline="always", error_model="numpy")
def _cover(e, c0, c1, rx, ry, rd, root, ea_v, eb_v, m, V, nx, ny, dist, parent, corner, spawned, pend, stack, st):
    """Offer the nodes of edge e in the canonical interval [c0, c1] their straight path to root."""
    if c0 <= _UEPS:
        _set(ea_v, rd + _hyp(nx[ea_v] - rx, ny[ea_v] - ry), root, dist, parent, corner, spawned, pend, stack, st, V)
    if c1 >= 1.0 - _UEPS:
        _set(eb_v, rd + _hyp(nx[eb_v] - rx, ny[eb_v] - ry), root, dist, parent, corner, spawned, pend, stack, st, V)
    for i in range(m):
        f = (i + 1.0) / (m + 1.0)
        if c0 - _UEPS <= f <= c1 + _UEPS:
            u = V + e * m + i
            _set(u, rd + _hyp(nx[u] - rx, ny[u] - ry), root, dist, parent, corner, spawned, pend, stack, st, V)


@njit(cache=True, inline="always", error_model="numpy")
def _edge_best(e, c, x, y, root, ehead, links, wf, wi):
    """The best distance at point (x, y) (canonical parameter c) of edge e straight to the
    root of an accepted window on e covering it, ``root``'s own windows left out (they cannot
    rule out a window of that root); ``inf`` when none covers it."""
    best = np.inf
    w = ehead[e]
    while w >= 0:
        if wi[w, 2] != root and wf[w, 6] - _UEPS <= c <= wf[w, 7] + _UEPS:
            best = min(best, wf[w, 4] + _hyp(x - wf[w, 2], y - wf[w, 3]))
        w = links[w, 0]
    return best


@njit(cache=True, inline="always", error_model="numpy")
def _ray_hit(rx, ry, px, py, ux, uy, wx, wy):
    """Parameter along segment u->w where the line r->p crosses it (nan when parallel)."""
    ou = _orient(rx, ry, px, py, ux, uy)
    ow = _orient(rx, ry, px, py, wx, wy)
    den = ou - ow
    if den == 0.0:
        return np.nan
    return min(1.0, max(0.0, ou / den))


@njit(cache=True, inline="always", error_model="numpy")
def _spawn(rx, ry, rd, root, t, vx, vy, tris, nbrs, passable, tri_nodes, nx, ny, dist, parent, corner, spawned,
           pend, stack, st, wf, wi, links, heap, phead):
    """Root r lies on passable triangle t: offer t's nodes their straight segment to r and
    open a full-edge window on each edge of t that r does not lie on, into the neighbour."""
    V = vx.shape[0]
    for s in range(tri_nodes.shape[1]):
        u = tri_nodes[t, s]
        _set(u, rd + _hyp(nx[u] - rx, ny[u] - ry), root, dist, parent, corner, spawned, pend, stack, st, V)
    for k in range(3):
        a = tris[t, (k + 1) % 3]
        b = tris[t, (k + 2) % 3]
        L2 = _norm2(vx[b] - vx[a], vy[b] - vy[a])
        if _orient(vx[a], vy[a], vx[b], vy[b], rx, ry) <= 1e-14 * L2:
            continue  # r on this edge (a vertex root's own edges)
        nb = nbrs[t, k]
        if nb < 0 or not passable[nb]:
            continue  # its nodes are t's, offered above
        kk = 0
        while nbrs[nb, kk] != t:
            kk += 1
        key = rd + _seg_dist(rx, ry, vx[a], vy[a], vx[b], vy[b])
        _push(st, wf, wi, links, heap, nb, kk, 0.0, 1.0, rx, ry, rd, root, key)


@njit(cache=True, inline="always", error_model="numpy")
def _better_at(c, rx, ry, rd, root, e, ea_v, eb_v, ax, ay, dx, dy, dist, parent, ehead, links, wf, wi):
    """Whether root r's straight path (length ``rd + |x - r|``) beats, by :data:`_REL`, every
    accepted window of another root covering the point x at canonical parameter c of edge e,
    and the edge's end vertex there."""
    x = ax + c * dx
    y = ay + c * dy
    best = _edge_best(e, c, x, y, root, ehead, links, wf, wi)
    if c <= 0.0 and parent[ea_v] != root:
        best = min(best, dist[ea_v])
    if c >= 1.0 and parent[eb_v] != root:
        best = min(best, dist[eb_v])
    return rd + _hyp(x - rx, y - ry) < best * (1.0 - _REL)


@njit(cache=True, inline="always", error_model="numpy")
def _add_crossings(buf, n, c0, c1, ax, ay, dx, dy, rx, ry, rd, sx, sy, sd):
    """Append to ``buf[n:]`` the parameters c in (c0, c1) where the two distance functions
    ``rd + |P(c) - r|`` and ``sd + |P(c) - s|`` along the edge ``P(c) = a + c d`` may cross
    (the roots of the squared equation, a superset, and its extremum for near-tangent cases);
    returns the new count."""
    k = sd - rd  # |P - r| - |P - s| = k  =>  (al + be c)^2 = 4 k^2 |P - s|^2
    wx = ax - rx
    wy = ay - ry
    zx = ax - sx
    zy = ay - sy
    al = _norm2(wx, wy) - _norm2(zx, zy) - k * k
    be = 2.0 * (dx * (sx - rx) + dy * (sy - ry))
    k4 = 4.0 * k * k
    qa = be * be - k4 * _norm2(dx, dy)
    qb = 2.0 * al * be - 2.0 * k4 * (dx * zx + dy * zy)
    qc = al * al - k4 * _norm2(zx, zy)
    r0 = np.nan
    r1 = np.nan
    r2 = np.nan
    if qa != 0.0:
        r2 = -qb / (2.0 * qa)
        disc = qb * qb - 4.0 * qa * qc
        if disc >= 0.0:
            sq = np.sqrt(disc)
            r0 = (-qb - sq) / (2.0 * qa)
            r1 = (-qb + sq) / (2.0 * qa)
    elif qb != 0.0:
        r0 = -qc / qb
    if c0 < r0 < c1:
        buf[n] = r0
        n += 1
    if c0 < r1 < c1:
        buf[n] = r1
        n += 1
    if c0 < r2 < c1:
        buf[n] = r2
        n += 1
    return n


@njit(cache=True, inline="always", error_model="numpy")
def _keep(w, e, ea_v, eb_v, flip, vx, vy, m, V, nx, ny, dist, parent, ehead, links, wf, wi, buf):
    """Whether window w beats every other root somewhere on its interval: the accepted windows
    of other roots on its edge, the edge's end vertices and Steiner nodes. Exact: the interval
    is cut at every point where the set of other windows covering it changes and where w's
    distance may cross one of theirs (:func:`_add_crossings`), so the comparison has one sign
    on each piece; each cut point and each piece's midpoint is tested (``buf``: scratch room),
    after 5 evenly spaced points (where most windows that are kept win: a shortcut)."""
    u0 = wf[w, 0]
    u1 = wf[w, 1]
    rx = wf[w, 2]
    ry = wf[w, 3]
    rd = wf[w, 4]
    root = wi[w, 2]
    c0 = 1.0 - u1 if flip else u0
    c1 = 1.0 - u0 if flip else u1
    for i in range(m):
        f = (i + 1.0) / (m + 1.0)
        if c0 <= f <= c1:
            u = V + e * m + i
            if parent[u] != root and rd + _hyp(nx[u] - rx, ny[u] - ry) < dist[u] * (1.0 - _REL):
                return True
    ax = vx[ea_v]
    ay = vy[ea_v]
    dx = vx[eb_v] - ax
    dy = vy[eb_v] - ay
    for q in range(5):  # most windows that are kept win at one of 5 evenly spaced points: no cut points
        if _better_at(c0 + (c1 - c0) * q / 4, rx, ry, rd, root, e, ea_v, eb_v, ax, ay, dx, dy, dist, parent, ehead,
                      links, wf, wi):
            return True
    buf[0] = c0
    buf[1] = c1
    n = 2
    x = ehead[e]
    while x >= 0:
        if wi[x, 2] != root and wf[x, 7] >= c0 - _UEPS and wf[x, 6] <= c1 + _UEPS:
            if c0 < wf[x, 6] < c1:
                buf[n] = wf[x, 6]
                n += 1
            if c0 < wf[x, 7] < c1:
                buf[n] = wf[x, 7]
                n += 1
            n = _add_crossings(buf, n, c0, c1, ax, ay, dx, dy, rx, ry, rd, wf[x, 2], wf[x, 3], wf[x, 4])
        x = links[x, 0]
    for i in range(1, n):  # insertion sort: a handful of cut points
        v = buf[i]
        j = i - 1
        while j >= 0 and buf[j] > v:
            buf[j + 1] = buf[j]
            j -= 1
        buf[j + 1] = v
    for i in range(n):
        if _better_at(buf[i], rx, ry, rd, root, e, ea_v, eb_v, ax, ay, dx, dy, dist, parent, ehead, links, wf, wi):
            return True
        if i + 1 < n and buf[i + 1] > buf[i] and _better_at(0.5 * (buf[i] + buf[i + 1]), rx, ry, rd, root, e, ea_v,
                                                            eb_v, ax, ay, dx, dy, dist, parent, ehead, links, wf, wi):
            return True
    return False


@njit(cache=True, inline="always", error_model="numpy")
def _merge(w, e, wf, wi, links, phead):
    """Absorb into window w the queued windows on edge e of the same root into the same
    triangle that continue its interval (pieces split by a vertex's ray join again one triangle
    later: merging keeps the window count near one per edge and root)."""
    t = wi[w, 0]
    root = wi[w, 2]
    changed = True
    while changed:
        changed = False
        prev = -1
        x = phead[e]
        while x >= 0:
            nxt = links[x, 1]
            drop = wi[x, 3] != 0
            if not drop and wi[x, 0] == t and wi[x, 2] == root and (
                    abs(wf[x, 0] - wf[w, 1]) <= 1e-9 or abs(wf[x, 1] - wf[w, 0]) <= 1e-9):
                wf[w, 0] = min(wf[w, 0], wf[x, 0])
                wf[w, 1] = max(wf[w, 1], wf[x, 1])
                wi[x, 3] = 3
                drop = True
                changed = True
            if drop:
                if prev < 0:
                    phead[e] = nxt
                else:
                    links[prev, 1] = nxt
            else:
                prev = x
            x = nxt


@njit(cache=True, error_model="numpy")
def windows(nx, ny, vx, vy, tris, nbrs, te, ea, vorig, passable, tri_nodes, start, node_tris, corner, goal_tris,
            gx, gy, m, cap=0):
    """Exact-visibility shortest paths to the goal by window propagation (a continuous
    Dijkstra restricted to passable triangles, in the plane).

    The goal and every corner vertex (:func:`corners`) act as *roots*; a root sends a window
    over each edge of its triangles; a window is pushed through the next triangle, its wedge of
    rays clipped to the triangle's two other edges (one or two child windows, same root); on
    an edge of impassable ground it stops. Windows are processed in order of their smallest
    distance, so a corner's distance is final when it spawns. A window is kept only if it
    improves some test point (:func:`_keep`). ``tris``/``vx``/``vy`` have their pinches split
    (:func:`split_fans`; ``vorig`` maps back, ``ea`` is in original ids). Every node gets the best straight segment to a
    root whose window covers it. Returns ``(dist (N,), parent (N,), wf, wi)`` (root per node:
    a vertex, :data:`GOAL` or :data:`NONE`; the accepted windows are those with ``wi[:, 3]``).
    ``cap``: room for window records at first (0: twice the edge count, about what a field
    needs); :func:`_propagate` starts again with twice the room whenever it runs out.
    """
    N = nx.shape[0]
    V = vx.shape[0]
    E = ea.shape[0]
    if cap <= 0:
        cap = 2 * E + 16
    while True:
        dist = np.full(N, np.inf)
        parent = np.full(N, NONE, dtype=np.int64)
        wf = np.empty((cap, 8))
        wi = np.empty((cap, 4), dtype=np.int64)  # state wi[:, 3]: 0 queued, 1 accepted, 2 done, 3 merged away
        links = np.full((cap, 2), -1, dtype=np.int64)  # next accepted / next queued window on the same edge
        heap = np.empty((cap, 2))
        ehead = np.full(E, -1, dtype=np.int64)
        phead = np.full(E, -1, dtype=np.int64)
        spawned = np.zeros(V, dtype=np.bool_)
        pend = np.zeros(V, dtype=np.bool_)
        stack = np.empty(V, dtype=np.int64)
        st = np.zeros(4, dtype=np.int64)  # records, heap size, stacked corners, full
        buf = np.empty(5 * cap + 8)  # _keep's cut points: at most 5 per accepted window on an edge, + 2
        _propagate(nx, ny, vx, vy, tris, nbrs, te, ea, vorig, passable, tri_nodes, start, node_tris, corner, goal_tris,
                   gx, gy, m, dist, parent, wf, wi, links, heap, ehead, phead, spawned, pend, stack, st, buf)
        if not st[3]:
            n = st[0]
            return dist, parent, wf[:n], wi[:n]
        cap *= 2


@njit(cache=True, error_model="numpy", _nrt=False)
def _propagate(nx, ny, vx, vy, tris, nbrs, te, ea, vorig, passable, tri_nodes, start, node_tris, corner, goal_tris,
               gx, gy, m, dist, parent, wf, wi, links, heap, ehead, phead, spawned, pend, stack, st, buf):
    """The loop of :func:`windows` over the work arrays it allocates (``st[3]`` set when the
    window arrays run out of room: the results are then void). Compiled without reference
    counting (``_nrt=False``: it allocates nothing), which would otherwise cost about as much
    as the loop itself, each inlined helper taking and releasing its array arguments. Long
    (~60 lines) on purpose: one compiled loop whose heap, window arrays and node state would
    otherwise travel through many more kernel arguments."""
    V = vx.shape[0]
    for i in range(goal_tris.shape[0]):
        _spawn(gx, gy, 0.0, GOAL, goal_tris[i], vx, vy, tris, nbrs, passable, tri_nodes, nx, ny, dist, parent, corner,
               spawned, pend, stack, st, wf, wi, links, heap, phead)
    while True:
        for i in range(st[2]):  # improved corners: queue their spawn at their new distance
            v = stack[i]
            pend[v] = False
            _push(st, wf, wi, links, heap, -1, 0, 0.0, 0.0, 0.0, 0.0, 0.0, v, dist[v])
        st[2] = 0
        if st[1] == 0 or st[3]:
            break
        w = _pop(st, heap)
        t = wi[w, 0]
        if wi[w, 3] == 3:
            continue
        wi[w, 3] = 2
        if t < 0:
            v = wi[w, 2]
            if spawned[v] or wf[w, 5] > dist[v]:
                continue
            spawned[v] = True
            for a in range(start[v], start[v + 1]):
                _spawn(vx[v], vy[v], dist[v], v, node_tris[a], vx, vy, tris, nbrs, passable, tri_nodes, nx, ny, dist,
                       parent, corner, spawned, pend, stack, st, wf, wi, links, heap, phead)
            continue
        k = wi[w, 1]
        e = te[t, k]
        _merge(w, e, wf, wi, links, phead)
        A = tris[t, (k + 1) % 3]
        B = tris[t, (k + 2) % 3]
        flip = ea[e] != vorig[A]
        ea_v = B if flip else A
        eb_v = A if flip else B
        if not _keep(w, e, ea_v, eb_v, flip, vx, vy, m, V, nx, ny, dist, parent, ehead, links, wf, wi, buf):
            continue
        rx = wf[w, 2]
        ry = wf[w, 3]
        rd = wf[w, 4]
        wi[w, 3] = 1
        wf[w, 6] = 1.0 - wf[w, 1] if flip else wf[w, 0]
        wf[w, 7] = 1.0 - wf[w, 0] if flip else wf[w, 1]
        links[w, 0] = ehead[e]
        ehead[e] = w
        _cover(e, wf[w, 6], wf[w, 7], rx, ry, rd, wi[w, 2], ea_v, eb_v, m, V, nx, ny, dist, parent, corner, spawned,
               pend, stack, st)
        _children(w, t, k, vx, vy, tris, nbrs, te, ea, vorig, passable, m, V, nx, ny, dist, parent, corner, spawned,
                  pend, stack, st, wf, wi, links, heap, phead)


@njit(cache=True, inline="always", error_model="numpy")
def _children(w, t, k, vx, vy, tris, nbrs, te, ea, vorig, passable, m, V, nx, ny, dist, parent, corner, spawned, pend,
              stack, st, wf, wi, links, heap, phead):
    """Push window w (on edge k of t) through t: clip its wedge to t's other two edges. Long
    (~65 lines) on purpose: both child edges are clipped in one pass over the shared geometry."""
    C = tris[t, k]
    A = tris[t, (k + 1) % 3]
    B = tris[t, (k + 2) % 3]
    u0 = wf[w, 0]
    u1 = wf[w, 1]
    rx = wf[w, 2]
    ry = wf[w, 3]
    rd = wf[w, 4]
    root = wi[w, 2]
    ax, ay, bx, by, cx, cy = vx[A], vy[A], vx[B], vy[B], vx[C], vy[C]
    p0x = ax + u0 * (bx - ax)
    p0y = ay + u0 * (by - ay)
    p1x = ax + u1 * (bx - ax)
    p1y = ay + u1 * (by - ay)
    s0 = _orient(rx, ry, p0x, p0y, cx, cy)
    s1 = _orient(rx, ry, p1x, p1y, cx, cy)
    # child intervals: on edge C->A (t's edge (k+2)%3) and on edge B->C (edge (k+1)%3)
    ca_lo = ca_hi = bc_lo = bc_hi = np.nan
    if s0 <= 0.0 and s1 >= 0.0:  # C sees r: both children end at C
        lam = _ray_hit(rx, ry, p0x, p0y, cx, cy, ax, ay)
        if np.isnan(lam) and u0 <= _UEPS:
            lam = 1.0
        ca_lo, ca_hi = 0.0, lam
        mu = _ray_hit(rx, ry, p1x, p1y, bx, by, cx, cy)
        if np.isnan(mu) and u1 >= 1.0 - _UEPS:
            mu = 0.0
        bc_lo, bc_hi = mu, 1.0
    elif s0 > 0.0:  # the whole wedge leaves through B-C
        m0 = _ray_hit(rx, ry, p0x, p0y, bx, by, cx, cy)
        m1 = _ray_hit(rx, ry, p1x, p1y, bx, by, cx, cy)
        bc_lo, bc_hi = min(m0, m1), max(m0, m1)
    else:  # through C-A
        l0 = _ray_hit(rx, ry, p0x, p0y, cx, cy, ax, ay)
        l1 = _ray_hit(rx, ry, p1x, p1y, cx, cy, ax, ay)
        ca_lo, ca_hi = min(l0, l1), max(l0, l1)
    for side in range(2):
        kc = (k + 2) % 3 if side == 0 else (k + 1) % 3
        lo = ca_lo if side == 0 else bc_lo
        hi = ca_hi if side == 0 else bc_hi
        if not (hi - lo > 1e-13):  # empty, a point or nan
            continue
        e2 = te[t, kc]
        a2 = tris[t, (kc + 1) % 3]
        b2 = tris[t, (kc + 2) % 3]
        nb = nbrs[t, kc]
        if nb < 0 or not passable[nb]:  # impassable beyond: the edge's nodes are reached, nothing more
            flip = ea[e2] != vorig[a2]
            _cover(e2, 1.0 - hi if flip else lo, 1.0 - lo if flip else hi, rx, ry, rd, root, b2 if flip else a2,
                   a2 if flip else b2, m, V, nx, ny, dist, parent, corner, spawned, pend, stack, st)
            continue
        kk = 0
        while nbrs[nb, kk] != t:
            kk += 1
        qx0 = vx[a2] + lo * (vx[b2] - vx[a2])
        qy0 = vy[a2] + lo * (vy[b2] - vy[a2])
        qx1 = vx[a2] + hi * (vx[b2] - vx[a2])
        qy1 = vy[a2] + hi * (vy[b2] - vy[a2])
        key = rd + _seg_dist(rx, ry, qx0, qy0, qx1, qy1)
        _push(st, wf, wi, links, heap, nb, kk, 1.0 - hi, 1.0 - lo, rx, ry, rd, root, key)
        if st[3]:  # no room: the record was dropped
            return
        e2 = te[nb, kk]
        links[st[0] - 1, 1] = phead[e2]  # pending on e2, to be merged with its contiguous pieces
        phead[e2] = st[0] - 1


@njit(cache=True, error_model="numpy")
def tri_windows(wf, wi, vx, vy, tris, T):
    """The accepted windows grouped by the triangle they open into, for queries: ``(start
    (T+1,), geo (n, 7) [rx, ry, rd, p0x, p0y, p1x, p1y], root (n,))``; a point p of triangle t
    sees the root of such a window iff p lies in its wedge (between rays r->p0 and r->p1)."""
    start = np.zeros(T + 1, dtype=np.int64)
    for w in range(wi.shape[0]):
        if wi[w, 0] >= 0 and wi[w, 3] == 1:
            start[wi[w, 0] + 1] += 1
    for t in range(T):
        start[t + 1] += start[t]
    fill = start[:-1].copy()
    geo = np.empty((start[T], 7))
    root = np.empty(start[T], dtype=np.int64)
    for w in range(wi.shape[0]):
        t = wi[w, 0]
        if t < 0 or wi[w, 3] != 1:
            continue
        k = wi[w, 1]
        A = tris[t, (k + 1) % 3]
        B = tris[t, (k + 2) % 3]
        i = fill[t]
        fill[t] += 1
        geo[i, 0] = wf[w, 2]
        geo[i, 1] = wf[w, 3]
        geo[i, 2] = wf[w, 4]
        geo[i, 3] = vx[A] + wf[w, 0] * (vx[B] - vx[A])
        geo[i, 4] = vy[A] + wf[w, 0] * (vy[B] - vy[A])
        geo[i, 5] = vx[A] + wf[w, 1] * (vx[B] - vx[A])
        geo[i, 6] = vy[A] + wf[w, 1] * (vy[B] - vy[A])
        root[i] = wi[w, 2]
    return start, geo, root


@njit(cache=True, inline="always", error_model="numpy")
def _twins(u, twin, dist, best, arg):
    """The best of (best, arg) and the distances of u and of every copy of its vertex."""
    w = u
    while True:
        if dist[w] < best:
            best = dist[w]
            arg = w
        w = twin[w]
        if w == u:
            return best, arg


@njit(cache=True, error_model="numpy")
def twins(vorig):
    """``(V2,)`` int64: for each vertex of :func:`split_fans`' output, the next copy of the same
    original vertex (circular; itself for a vertex that is no pinch)."""
    n = vorig.shape[0]
    twin = np.arange(n)
    last = np.arange(n)  # per original vertex: the newest copy so far (copies follow their original)
    for i in range(n):
        v = vorig[i]
        if v != i:
            twin[i] = twin[last[v]]
            twin[last[v]] = i
            last[v] = i
    return twin


@njit(cache=True, inline="always", error_model="numpy")
def best_distance(nx, ny, dist, tri_nodes, passable, goal_tri, gx, gy, vx, vy, tris, nbrs, wstart, wgeo, wroot, x, y,
                  t, tol,
          eps_m, twin):
    """``(distance, source)`` of the point ``(x, y)`` on triangle ``t >= 0``: :func:`query`'s
    candidates, one point (shared by :func:`query` and :func:`distance_stacked`)."""
    if not passable[t]:
        t = _snap(vx, vy, tris, nbrs, passable, t, x, y, tol)
    best = np.inf
    arg = NONE
    if passable[t]:
        if goal_tri[t]:
            best = _hyp(gx - x, gy - y)
            arg = GOAL
        for s in range(tri_nodes.shape[1]):
            u = tri_nodes[t, s]
            c = _hyp(nx[u] - x, ny[u] - y) + dist[u]
            if c < best:
                best = c
                arg = u
        for a in range(wstart[t], wstart[t + 1]):
            rx = wgeo[a, 0]
            ry = wgeo[a, 1]
            L = _hyp(rx - x, ry - y)
            c = wgeo[a, 2] + L
            if c < best:
                lim0 = 1e-12 * L * _hyp(wgeo[a, 3] - rx, wgeo[a, 4] - ry)
                lim1 = 1e-12 * L * _hyp(wgeo[a, 5] - rx, wgeo[a, 6] - ry)
                if (_orient(rx, ry, wgeo[a, 3], wgeo[a, 4], x, y) <= lim0
                        and _orient(rx, ry, wgeo[a, 5], wgeo[a, 6], x, y) >= -lim1):
                    best = c
                    arg = wroot[a]
        for k in range(3):
            u = tris[t, k]
            if twin[u] != u and _norm2(nx[u] - x, ny[u] - y) <= eps_m * eps_m:
                best, arg = _twins(u, twin, dist, best, arg)
    else:  # on a vertex of an impassable triangle that passable ground touches
        for k in range(3):
            u = tris[t, k]
            if _norm2(nx[u] - x, ny[u] - y) <= eps_m * eps_m:
                best, arg = _twins(u, twin, dist, best, arg)
    return best, arg


@njit(cache=True, error_model="numpy")
def query(nx, ny, dist, parent, tri_nodes, passable, goal_tri, gx, gy, vx, vy, tris, nbrs, wstart, wgeo, wroot,
          px, py, tidx, tol, eps_m, twin):
    """Distance ``(n,)``, first-leg unit direction ``(n, 2)`` and source ``(n,)`` at each point.

    ``tidx[i]`` is the triangle holding point i (-1 outside). Candidates (:func:`best_distance`), all
    lengths of drivable paths: ``|p - node_j| + dist[j]`` over the triangle's boundary nodes (the
    triangle is convex), ``|p - goal|`` when the goal lies on it, and ``|p - r| + rd`` for each
    window into it (:func:`tri_windows`) whose wedge holds p; at a pinch vertex (within ``eps_m``),
    the value of every fan's copy of it (``twin``: the next copy of each vertex, circular; itself
    where it has none): the point belongs to all its fans. ``src[i]``: where the straight first leg
    ends (a node, :data:`GOAL`, or :data:`NONE` where ``inf``). Direction: toward that point,
    or up its parent chain past points within ``eps_m`` of ``p``.
    """
    n = px.shape[0]
    out = np.full(n, np.inf)
    dirs = np.zeros((n, 2))
    src = np.full(n, NONE, dtype=np.int64)
    for i in range(n):
        t = tidx[i]
        if t < 0:
            continue
        x = px[i]
        y = py[i]
        best, arg = best_distance(nx, ny, dist, tri_nodes, passable, goal_tri, gx, gy, vx, vy, tris, nbrs, wstart,
                                  wgeo, wroot,
                          x, y, t, tol, eps_m, twin)
        out[i] = best
        if best == np.inf:
            continue
        src[i] = arg
        while arg >= 0 and _norm2(nx[arg] - x, ny[arg] - y) <= eps_m * eps_m:
            arg = parent[arg]
        if arg == GOAL:
            dx = gx - x
            dy = gy - y
        else:
            dx = nx[arg] - x
            dy = ny[arg] - y
        L = np.sqrt(dx * dx + dy * dy)
        if L > eps_m:
            dirs[i, 0] = dx / L
            dirs[i, 1] = dy / L
    return out, dirs, src


@njit(cache=True, error_model="numpy", parallel=True)
def distance_stacked(off_node, off_tri, off_vert, off_win, nx, ny, dist, tri_nodes, passable, goal_tri, gxy, vx, vy,
                     tris, nbrs, wstart, wgeo, wroot, twin, pos, tidx, which, tol, eps_m, out):
    """:func:`query`'s distance for points on several fields of one TIN at once, into ``out (n,)``:
    point i (``pos[i]``, on triangle ``tidx[i]``) on field ``which[i]`` (-1: none, ``inf``).
    Each per-field array is the fields' own arrays concatenated, field k's rows
    ``off_*[k]:off_*[k + 1]`` (``off_node`` for nx, ny, dist; ``off_tri`` for tri_nodes,
    passable, goal_tri, tris; ``off_vert`` for vx, vy, twin; ``off_win`` for wgeo, wroot;
    ``wstart`` has ``T + 1`` rows per field), so each field's own (local) indices hold. The
    points are cut into ``CHUNKS`` runs shared among the threads; in each, one pass per field
    (the views are taken once per run and field, not per point). Every point's value is computed
    alone, so the result is the same bit for bit on any thread count."""
    n = pos.shape[0]
    T = nbrs.shape[0]
    F = off_node.shape[0] - 1
    C = CHUNKS if n >= CHUNKS else 1
    for c in prange(C):
        lo = c * n // C
        hi = (c + 1) * n // C
        for i in range(lo, hi):
            out[i] = np.inf
        for k in range(F):
            a0, a1 = off_node[k], off_node[k + 1]
            t0, t1 = off_tri[k], off_tri[k + 1]
            v0, v1 = off_vert[k], off_vert[k + 1]
            w0, w1 = off_win[k], off_win[k + 1]
            nx_k, ny_k, d_k = nx[a0:a1], ny[a0:a1], dist[a0:a1]
            tn_k, pa_k, gt_k, tr_k = tri_nodes[t0:t1], passable[t0:t1], goal_tri[t0:t1], tris[t0:t1]
            vx_k, vy_k, tw_k = vx[v0:v1], vy[v0:v1], twin[v0:v1]
            ws_k = wstart[k * (T + 1):(k + 1) * (T + 1)]
            wg_k, wr_k = wgeo[w0:w1], wroot[w0:w1]
            gx = gxy[k, 0]
            gy = gxy[k, 1]
            for i in range(lo, hi):
                t = tidx[i]
                if which[i] != k or t < 0:
                    continue
                out[i] = best_distance(nx_k, ny_k, d_k, tn_k, pa_k, gt_k, gx, gy, vx_k, vy_k, tr_k, nbrs, ws_k, wg_k,
                                       wr_k,
                               pos[i, 0], pos[i, 1], t, tol, eps_m, tw_k)[0]
    return out
