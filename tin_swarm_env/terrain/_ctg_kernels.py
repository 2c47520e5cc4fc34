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
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import exit_edge

GOAL = -2  # parent of a node reached straight from the goal / query answered straight to the goal
NONE = -1  # no node


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
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


@njit(cache=True)
def visible(vx, vy, tris, nbrs, passable, t, ax, ay, bx, by, max_steps):
    """Whether the segment a -> b stays on passable triangles, walking from triangle ``t``
    (which holds ``a`` and which the segment enters first). Exact up to the symbolic
    perturbation of :func:`._kernels.exit_edge`; a segment running exactly along an edge or
    through a vertex may be reported hidden (never the reverse), which only costs accuracy."""
    dx = bx - ax
    dy = by - ay
    for _ in range(max_steps):
        k, s, _u = exit_edge(vx, vy, tris, t, ax, ay, dx, dy)
        if k < 0:
            return False
        if s >= 1.0 - 1e-12:
            return True
        nb = nbrs[t, k]
        if nb < 0 or not passable[nb]:
            return False
        t = nb
    return False


@njit(cache=True)
def _enters(vx, vy, tris, t, ax, ay, dx, dy, tol):
    """Whether the direction ``d`` from ``a`` (a point on triangle ``t``) points into ``t``."""
    L = np.sqrt(dx * dx + dy * dy)
    if L == 0.0:
        return True
    for k in range(3):
        p = tris[t, k]
        q = tris[t, (k + 1) % 3]
        ex = vx[q] - vx[p]
        ey = vy[q] - vy[p]
        # a on the edge line (within tol) and d pointing out of t: no
        if abs(ex * (ay - vy[p]) - ey * (ax - vx[p])) <= tol and ex * dy - ey * dx < -1e-12 * L * np.sqrt(ex * ex + ey * ey):
            return False
    return True


@njit(cache=True)
def _node_sees(nx, ny, vx, vy, tris, nbrs, passable, start, node_tris, u, bx, by, tol, max_steps):
    """Whether the segment from node ``u`` to point b stays on passable ground."""
    ax = nx[u]
    ay = ny[u]
    for a in range(start[u], start[u + 1]):
        t = node_tris[a]
        if _enters(vx, vy, tris, t, ax, ay, bx - ax, by - ay, tol):
            return visible(vx, vy, tris, nbrs, passable, t, ax, ay, bx, by, max_steps)
    return False


@njit(cache=True)
def dijkstra(nx, ny, vx, vy, tris, nbrs, passable, tri_nodes, start, node_tris, seeds, seed_dist,
             gx, gy, any_angle, tol):
    """Shortest paths to the goal over the implicit Steiner graph (indexed binary heap).

    ``seeds (s,)``: the nodes of the goal's triangles, at ``seed_dist (s,)`` (their straight
    distance to the goal), parent :data:`GOAL`. Plain mode (``any_angle=False``): Dijkstra on the
    graph. Any-angle mode: Lazy Theta* (Nash, Koenig and Tovey 2010) on the same graph: a node
    is offered the straight segment from its neighbour's parent (``dist[parent] + |w - parent|``);
    when it is popped that segment is checked with :func:`visible`, and if it crosses
    impassable ground the node falls back to its best settled neighbour and is queued again at
    that value (unlike plain Lazy Theta*, which settles it at once: that let a wrong optimistic
    key settle nodes early with values 20 % too long). Every settled value is
    the length of a chain of visible segments (``parent`` links) ending at the goal.
    Returns ``(dist (N,), parent (N,))``; ``inf``/:data:`NONE` unreached.
    """
    N = nx.shape[0]
    S = tri_nodes.shape[1]
    max_steps = tris.shape[0] + 3
    dist = np.full(N, np.inf)
    to_goal = np.full(N, np.inf)  # straight distance to the goal for the seeds
    parent = np.full(N, NONE, dtype=np.int64)
    pos = np.full(N, -1, dtype=np.int64)  # -1 never queued, -2 settled, else heap index
    heap = np.empty(N, dtype=np.int64)
    sure = np.zeros(N, dtype=np.bool_)  # parent link known drivable (a fallback to a neighbour)
    size = 0
    for i in range(seeds.shape[0]):
        u = seeds[i]
        to_goal[u] = seed_dist[i]
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
        ux = nx[u]
        uy = ny[u]
        if any_angle and not sure[u] and not (parent[u] == GOAL and to_goal[u] < np.inf):
            p = parent[u]
            if p == GOAL:
                ok = _node_sees(nx, ny, vx, vy, tris, nbrs, passable, start, node_tris, u, gx, gy, tol, max_steps)
            else:
                ok = _node_sees(nx, ny, vx, vy, tris, nbrs, passable, start, node_tris, u, nx[p], ny[p], tol,
                                max_steps)
            if not ok:  # fall back to the best settled neighbour (or the goal for a seed)
                best = to_goal[u]
                bp = GOAL
                for a in range(start[u], start[u + 1]):
                    t = node_tris[a]
                    for s in range(S):
                        w = tri_nodes[t, s]
                        if pos[w] == -2 and w != u:
                            c = dist[w] + np.sqrt((nx[w] - ux) ** 2 + (ny[w] - uy) ** 2)
                            if c < best:
                                best = c
                                bp = w
                dist[u] = best
                parent[u] = bp
                sure[u] = True
                if best < np.inf:  # queue again at its true value (plain Lazy Theta* settles it here)
                    heap[size] = u
                    pos[u] = size
                    size += 1
                    _sift_up(heap, pos, dist, size - 1)
                    continue
        # offer the neighbours a straight segment from u's parent (any-angle) or from u
        src = u
        if any_angle:
            src = parent[u]
        if src == GOAL:
            sx = gx
            sy = gy
            sd = 0.0
        else:
            sx = nx[src]
            sy = ny[src]
            sd = dist[src]
        for a in range(start[u], start[u + 1]):
            t = node_tris[a]
            for s in range(S):
                w = tri_nodes[t, s]
                if pos[w] == -2:
                    continue
                nd = sd + np.sqrt((nx[w] - sx) ** 2 + (ny[w] - sy) ** 2)
                if nd < dist[w]:
                    dist[w] = nd
                    parent[w] = src
                    sure[w] = not any_angle
                    if pos[w] == -1:
                        heap[size] = w
                        pos[w] = size
                        size += 1
                    _sift_up(heap, pos, dist, pos[w])
    return dist, parent


@njit(cache=True, inline="always")
def _orient(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
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


@njit(cache=True)
def _shortcut(nx, ny, dist, parent, tri_nodes, passable, gx, gy, vx, vy, tris, nbrs, t, x, y, best, arg,
              max_steps):
    """Any-angle query: node ``j``'s parent ``s`` (where its straight last leg starts) offers
    ``|p - s| + dist[s]`` (never more than ``|p - j| + dist[j]``), taken when the segment
    ``p -> s`` is drivable (:func:`visible`). Shortcuts are tried cheapest first, only while
    they beat ``best``; the first drivable one wins. Returns ``(best, arg)``."""
    S = tri_nodes.shape[1]
    tried = 0
    for _ in range(S):
        rb = best
        rs = -1
        for s in range(S):
            if tried & (1 << s):
                continue
            u = tri_nodes[t, s]
            p = parent[u]
            if dist[u] == np.inf or p == NONE:
                continue
            if p == GOAL:
                c = np.sqrt((gx - x) ** 2 + (gy - y) ** 2)
            else:
                c = np.sqrt((nx[p] - x) ** 2 + (ny[p] - y) ** 2) + dist[p]
            if c < rb * (1.0 - 1e-12):
                rb = c
                rs = s
        if rs < 0:
            break
        tried |= 1 << rs
        p = parent[tri_nodes[t, rs]]
        if p == GOAL:
            ok = visible(vx, vy, tris, nbrs, passable, t, x, y, gx, gy, max_steps)
        else:
            ok = visible(vx, vy, tris, nbrs, passable, t, x, y, nx[p], ny[p], max_steps)
        if ok:
            return rb, p
    return best, arg


@njit(cache=True)
def query(nx, ny, dist, parent, tri_nodes, passable, goal_tri, gx, gy, vx, vy, tris, nbrs,
          px, py, tidx, tol, eps_m, any_angle):
    """Distance ``(n,)`` and first-leg unit direction ``(n, 2)`` at each point.

    ``tidx[i]`` is the triangle holding point i (-1 outside). Candidates are the boundary
    nodes ``j`` of that triangle, ``|p - node_j| + dist[j]``, and ``|p - goal|`` when the goal
    lies on it; any-angle mode adds the shortcuts of :func:`_shortcut`. Direction: toward the
    minimising candidate, or up its parent chain past points within ``eps_m`` of ``p``.
    """
    n = px.shape[0]
    out = np.full(n, np.inf)
    dirs = np.zeros((n, 2))
    S = tri_nodes.shape[1]
    max_steps = tris.shape[0] + 3
    for i in range(n):
        t = tidx[i]
        if t < 0:
            continue
        x = px[i]
        y = py[i]
        if not passable[t]:
            t = _snap(vx, vy, tris, nbrs, passable, t, x, y, tol)
        best = np.inf
        arg = NONE
        if passable[t]:
            if goal_tri[t]:
                best = np.sqrt((gx - x) ** 2 + (gy - y) ** 2)
                arg = GOAL
            for s in range(S):
                u = tri_nodes[t, s]
                c = np.sqrt((nx[u] - x) ** 2 + (ny[u] - y) ** 2) + dist[u]
                if c < best:
                    best = c
                    arg = u
            if any_angle and best < np.inf:
                best, arg = _shortcut(nx, ny, dist, parent, tri_nodes, passable, gx, gy, vx, vy, tris, nbrs,
                                      t, x, y, best, arg, max_steps)
        else:  # on a vertex of an impassable triangle that passable ground touches
            for k in range(3):
                u = tris[t, k]
                if (nx[u] - x) ** 2 + (ny[u] - y) ** 2 <= eps_m * eps_m and dist[u] < best:
                    best = dist[u]
                    arg = u
        out[i] = best
        if best == np.inf:
            continue
        while arg >= 0 and (nx[arg] - x) ** 2 + (ny[arg] - y) ** 2 <= eps_m * eps_m:
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
    return out, dirs
