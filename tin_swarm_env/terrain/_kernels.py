"""Compiled triangle walks (numba): point location and line of sight.

Each kernel is a plain scalar loop over the query points, compiled with ``numba.njit``
(``cache=True``). The same functions run uncompiled through ``.py_func``; the test suite
checks the compiled kernels against independent brute-force references
(:mod:`tin_swarm_env.terrain.reference`).

Geometry conventions: triangles are counter-clockwise; ``nbrs[t, k]`` is the triangle across
the edge opposite vertex ``k`` (edge ``tri[(k+1)%3] -> tri[(k+2)%3]``), ``-1`` on the border.
``tol`` is an area tolerance: a point counts as inside a triangle when every edge orientation
is ``>= -tol``, so points on shared edges and on the hull are found.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# status codes of the walks
OUTSIDE = -1  # the point (or sight line) left the TIN through a border edge
GAVE_UP = -2  # the walk made no progress (degenerate geometry or a step limit): use the fallback


@njit(cache=True, inline="always")
def orient(ax, ay, bx, by, cx, cy):
    """Twice the signed area of triangle abc in plan (m^2): > 0 when c lies left of a->b.
    The one orientation predicate of the numba kernels (``_ctg_kernels`` should import it)."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, inline="always")
def walk_locate1(vx, vy, tris, nbrs, x, y, t, max_steps, tol):
    """:func:`walk_locate` for one point ``(x, y)`` from triangle ``t``."""
    res = GAVE_UP
    for step in range(max_steps):
        moved = False
        for kk in range(3):
            k = (kk + step) % 3
            a = tris[t, (k + 1) % 3]
            b = tris[t, (k + 2) % 3]
            if orient(vx[a], vy[a], vx[b], vy[b], x, y) < -tol:
                nb = nbrs[t, k]
                if nb < 0:
                    res = OUTSIDE
                else:
                    t = nb
                    moved = True
                break
        if not moved:
            if res != OUTSIDE:
                res = t
            break
    return res


@njit(cache=True)
def walk_locate(vx, vy, tris, nbrs, px, py, hints, max_steps, tol):
    """Visibility walk from ``hints[i]`` to the triangle holding point i.

    Returns ``(n,)`` int64: the triangle, ``OUTSIDE`` when the walk reached a border edge with
    the point beyond it, or ``GAVE_UP`` after ``max_steps`` steps. The starting edge of each
    test rotates with the step count, which keeps the walk from cycling on non-Delaunay
    triangulations.
    """
    n = px.shape[0]
    out = np.empty(n, dtype=np.int64)
    for i in range(n):
        out[i] = walk_locate1(vx, vy, tris, nbrs, px[i], py[i], hints[i], max_steps, tol)
    return out


@njit(cache=True, inline="always")
def bucket_locate1(vx, vy, tris, cell_start, cell_tris, gx0, gy0, inv_cs, gnx, gny, x, y, tol):
    """:func:`bucket_locate` for one point."""
    fi = (x - gx0) * inv_cs
    fj = (y - gy0) * inv_cs
    if not (fi >= 0.0 and fj >= 0.0 and fi < gnx and fj < gny):
        # outside the grid; allow the closing boundary (x == max) through clipping
        if fi >= -1e-9 and fj >= -1e-9 and fi <= gnx + 1e-9 and fj <= gny + 1e-9:
            fi = min(max(fi, 0.0), gnx - 1.0)
            fj = min(max(fj, 0.0), gny - 1.0)
        else:
            return -1
    c = int(fj) * gnx + int(fi)
    for m in range(cell_start[c], cell_start[c + 1]):
        t = cell_tris[m]
        a = tris[t, 0]
        b = tris[t, 1]
        d = tris[t, 2]
        if (orient(vx[a], vy[a], vx[b], vy[b], x, y) >= -tol
                and orient(vx[b], vy[b], vx[d], vy[d], x, y) >= -tol
                and orient(vx[d], vy[d], vx[a], vy[a], x, y) >= -tol):
            return t
    return -1


@njit(cache=True)
def bucket_locate(vx, vy, tris, cell_start, cell_tris, gx0, gy0, inv_cs, gnx, gny, px, py, tol):
    """Point location through a uniform bucket grid of triangle bounding boxes.

    Exact and independent of convexity: each point is tested against the triangles whose
    bounding box overlaps its cell. Returns ``(n,)`` int64 triangle indices, ``-1`` outside.
    """
    n = px.shape[0]
    out = np.empty(n, dtype=np.int64)
    for i in range(n):
        out[i] = bucket_locate1(vx, vy, tris, cell_start, cell_tris, gx0, gy0, inv_cs, gnx, gny, px[i], py[i], tol)
    return out


@njit(cache=True)
def exit_edge(vx, vy, tris, t, ax, ay, dx, dy):
    """Where the directed line ``a + s * (dx, dy)`` leaves triangle ``t``: ``(k, s, u)`` with
    ``k`` the exit edge (opposite vertex ``k``; -1 if the line does not cross ``t``), ``s`` the
    line parameter of the crossing and ``u`` the fraction along the edge from vertex
    ``tris[t, (k+1)%3]``. A vertex exactly on the line counts as lying to its left (a symbolic
    perturbation), which makes the exit edge unique: the counter-clockwise edge whose start
    lies strictly right of the line and whose end does not."""
    for k in range(3):
        vi = tris[t, (k + 1) % 3]
        vj = tris[t, (k + 2) % 3]
        si = dx * (vy[vi] - ay) - dy * (vx[vi] - ax)
        sj = dx * (vy[vj] - ay) - dy * (vx[vj] - ax)
        if si < 0.0 and sj >= 0.0:
            exx = vx[vj] - vx[vi]
            eyy = vy[vj] - vy[vi]
            den = dx * eyy - dy * exx  # = sj - si > 0 in exact arithmetic
            if den <= 0.0:  # rounding on a near-degenerate crossing: the exactly positive form
                den = sj - si
            s = ((vx[vi] - ax) * eyy - (vy[vi] - ay) * exx) / den
            return k, s, -si / den
    return -1, 0.0, 0.0


@njit(cache=True, inline="always")
def _plane_z(vx, vy, vz, tris, grad, t, x, y):
    a = tris[t, 0]
    return vz[a] + grad[t, 0] * (x - vx[a]) + grad[t, 1] * (y - vy[a])


@njit(cache=True, inline="always")
def _side(vx, vy, v, ax, ay, dx, dy):
    """Which side of the line ``a + s (dx, dy)`` vertex ``v`` lies on (> 0 left): :func:`exit_edge`'s
    expression, so the same bits."""
    return dx * (vy[v] - ay) - dy * (vx[v] - ax)


@njit(cache=True, inline="always")
def _crossing(vx, vy, vi, vj, si, sj, ax, ay, dx, dy):
    """:func:`exit_edge`'s ``(s, u)`` for its exit edge ``vi -> vj`` (sides ``si < 0 <= sj``)."""
    exx = vx[vj] - vx[vi]
    eyy = vy[vj] - vy[vi]
    den = dx * eyy - dy * exx
    if den <= 0.0:
        den = sj - si
    return ((vx[vi] - ax) * eyy - (vy[vi] - ay) * exx) / den, -si / den


@njit(cache=True, inline="always")
def los_walk1(vx, vy, vz, tris, nbrs, grad, ax, ay, az, bx, by, bz, t, max_steps, ztol):
    """:func:`los_walk` for one segment ``a -> b`` starting in triangle ``t``: 1, 0 or -2.

    The first triangle's exit edge comes from :func:`exit_edge`; every later triangle is entered
    through the edge ``vi -> vj`` it shares with the one before, run the other way round, so only
    its third vertex ``w`` is new: one side test picks the exit, ``vi -> w`` when ``w`` lies left
    of the line, else ``w -> vj`` (the one edge :func:`exit_edge` would find, from the same side
    values). A neighbour that does not run ``vj -> vi -> w`` counter-clockwise gets the full search."""
    if t < 0:
        return 0
    if az < _plane_z(vx, vy, vz, tris, grad, t, ax, ay) - ztol:
        return 0
    dx = bx - ax
    dy = by - ay
    if dx == 0.0 and dy == 0.0:
        return 1 if bz >= _plane_z(vx, vy, vz, tris, grad, t, bx, by) - ztol else 0
    ex, s, u = exit_edge(vx, vy, tris, t, ax, ay, dx, dy)
    vi = vj = 0
    si = sj = 0.0
    if ex >= 0:
        vi = tris[t, (ex + 1) % 3]
        vj = tris[t, (ex + 2) % 3]
        si = _side(vx, vy, vi, ax, ay, dx, dy)
        sj = _side(vx, vy, vj, ax, ay, dx, dy)
    for step in range(max_steps):
        if ex < 0:
            return -2  # degenerate: gave up
        if s >= 1.0:
            # b lies in this triangle, before the exit edge
            return 1 if bz >= _plane_z(vx, vy, vz, tris, grad, t, bx, by) - ztol else 0
        z_edge = vz[vi] + u * (vz[vj] - vz[vi])
        z_sight = az + s * (bz - az)
        if z_edge > z_sight + ztol:
            return 0
        nb = nbrs[t, ex]
        if nb < 0:
            return 0  # the sight line leaves the TIN
        t = nb
        pi = pj = -1
        for m in range(3):
            v = tris[t, m]
            if v == vi:
                pi = m
            elif v == vj:
                pj = m
        if pj >= 0 and pi == (pj + 1) % 3:
            w = tris[t, (pj + 2) % 3]
            sw = _side(vx, vy, w, ax, ay, dx, dy)
            if sw >= 0.0:
                ex = pj
                s, u = _crossing(vx, vy, vi, w, si, sw, ax, ay, dx, dy)
                vj = w
                sj = sw
            else:
                ex = pi
                s, u = _crossing(vx, vy, w, vj, sw, sj, ax, ay, dx, dy)
                vi = w
                si = sw
        else:
            ex, s, u = exit_edge(vx, vy, tris, t, ax, ay, dx, dy)
            if ex >= 0:
                vi = tris[t, (ex + 1) % 3]
                vj = tris[t, (ex + 2) % 3]
                si = _side(vx, vy, vi, ax, ay, dx, dy)
                sj = _side(vx, vy, vj, ax, ay, dx, dy)
    return -2


@njit(cache=True)
def los_walk(vx, vy, vz, tris, nbrs, grad, a_xyz, b_xyz, start, max_steps, ztol):
    """Line of sight along each segment a->b over the piecewise-planar TIN surface.

    ``start[i]`` is the triangle holding ``a_xyz[i]`` (or -1). The walk follows the segment
    triangle by triangle; at every crossed edge it compares the sight line's height with the
    edge's height (thesis Algorithm 7). Between crossings both are linear, so this is exact.
    A vertex lying exactly on the line counts as lying to its left (a symbolic perturbation),
    which keeps the exit edge unique.

    Returns ``(n,)`` int8: 1 visible, 0 blocked (terrain above the sight line, an end point
    below the surface or outside the TIN, or the segment leaving the TIN), -2 gave up.
    """
    n = a_xyz.shape[0]
    out = np.empty(n, dtype=np.int8)
    for i in range(n):
        out[i] = los_walk1(vx, vy, vz, tris, nbrs, grad, a_xyz[i, 0], a_xyz[i, 1], a_xyz[i, 2],
                           b_xyz[i, 0], b_xyz[i, 1], b_xyz[i, 2], start[i], max_steps, ztol)
    return out


@njit(cache=True)
def los_brute1(vx, vy, vz, edges, edge_border, ax, ay, az, bx, by, bz, za_ground, zb_ground, ztol, stol):
    """:func:`los_brute` for one segment: 1 or 0."""
    if not (az >= za_ground - ztol and bz >= zb_ground - ztol):
        return 0  # NaN (outside) compares False too
    dx = bx - ax
    dy = by - ay
    for e in range(edges.shape[0]):
        p = edges[e, 0]
        q = edges[e, 1]
        exx = vx[q] - vx[p]
        eyy = vy[q] - vy[p]
        den = dx * eyy - dy * exx
        if den == 0.0:
            continue  # parallel: the terrain under a parallel edge is met at its end vertices
        s = ((vx[p] - ax) * eyy - (vy[p] - ay) * exx) / den
        u = ((vx[p] - ax) * dy - (vy[p] - ay) * dx) / den
        if s < 0.0 or s > 1.0 or u < 0.0 or u > 1.0:
            continue
        if edge_border[e] and s > stol and s < 1.0 - stol:
            return 0
        z_edge = vz[p] + u * (vz[q] - vz[p])
        z_sight = az + s * (bz - az)
        if z_edge > z_sight + ztol:
            return 0
    return 1


@njit(cache=True)
def los_brute(vx, vy, vz, edges, edge_border, a_xyz, b_xyz, za_ground, zb_ground, ztol, stol):
    """Line of sight by testing every TIN edge (O(edges) per ray): the fallback of
    :func:`los_walk` for degenerate rays. ``za_ground``/``zb_ground`` are the terrain heights
    under the end points (NaN when outside the TIN). Returns int8 1/0 like :func:`los_walk`."""
    n = a_xyz.shape[0]
    out = np.empty(n, dtype=np.int8)
    for i in range(n):
        out[i] = los_brute1(vx, vy, vz, edges, edge_border, a_xyz[i, 0], a_xyz[i, 1], a_xyz[i, 2],
                            b_xyz[i, 0], b_xyz[i, 1], b_xyz[i, 2], za_ground[i], zb_ground[i], ztol, stol)
    return out
