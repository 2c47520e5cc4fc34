"""Is a triangle mesh a single surface? (one z per map position, triangles meeting edge to edge)

:func:`check_single_surface` is run by :class:`~tin_swarm_env.terrain.tin.Tin` on every
construction, hence on every load and build path. It refuses, naming the culprits:

* two vertices at the same (x, y);
* two triangles whose interiors overlap in plan (a fold, a second sheet, a vertex inside
  another triangle);
* a T-junction: a vertex lying inside an edge of a triangle it is not a corner of.

Candidate pairs come from the point-location bucket grid (each triangle is listed in every
cell its bounding box touches); a pair is tested once, in the first cell of the overlap of the
two triangles' cell ranges. On a mesh of ordinary triangles a cell holds a few triangles, so
the work is O(T) after the grid's O(T log T) sort. Each pair gets a separating-axis test on
the six edge lines and a T-junction test of each corner against the other's edges, in a
compiled kernel (:func:`scan_pairs`); :func:`pair_status` is the same test in plain numpy;
:func:`tin_swarm_env.terrain.reference.single_surface_brute` tests all T^2 pairs independently
(clipping one triangle by the other, corners against edges).
Tolerance: a point within ``1e-9`` of the plan extent of a line counts as on it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import TinStructureError

__all__ = ["check_single_surface", "pair_status", "scan_pairs", "OK", "OVERLAP", "T_JUNCTION"]

OK, OVERLAP, T_JUNCTION = 0, 1, 2


def on_line_tolerance(v: np.ndarray) -> float:
    """m: how far from a line a point may be and still count as on it."""
    return 1e-9 * float(max(np.ptp(v[:, 0]), np.ptp(v[:, 1]), 1e-300))


def check_single_surface(v: np.ndarray, tri: np.ndarray, nbrs: np.ndarray, bucket: dict, source: str) -> None:
    """Raise :class:`TinStructureError` unless ``tri`` (T, 3) CCW over ``v`` (V, 3), with adjacency
    ``nbrs`` (T, 3), is a single surface in plan. ``bucket``: the CSR grid of
    ``tin._build_bucket`` (with its cell size)."""
    _check_duplicate_xy(v, source)
    vx, vy = np.ascontiguousarray(v[:, 0]), np.ascontiguousarray(v[:, 1])
    b = bucket
    code, a, bb, k, j = scan_pairs(vx, vy, tri, nbrs, b["start"], b["tris"], b["x0"], b["y0"], b["cs"], b["nx"],
                                   b["ny"], on_line_tolerance(v))
    if code != OK:
        raise TinStructureError(describe(v, tri, code, a, bb, k, j, source))


def describe(v, tri, code, a, b, k, j, source) -> str:
    """The message for a bad pair found by :func:`scan_pairs` or :func:`pair_status`."""
    xy = v[:, :2]
    if code == OVERLAP:
        return (f"{source}: triangles {a} (vertices {tri[a].tolist()}, xy {xy[tri[a]].tolist()}) and {b} "
                f"(vertices {tri[b].tolist()}, xy {xy[tri[b]].tolist()}) overlap in plan; "
                "a TIN is a single-valued surface")
    p, q, r = int(tri[a, k]), int(tri[a, (k + 1) % 3]), int(tri[b, j])
    return (f"{source}: T-junction: vertex {r} at {xy[r].tolist()} (a corner of triangle {b}) lies inside "
            f"the edge {p}-{q} of triangle {a} without being one of its corners; triangles must meet "
            "edge to edge")


def _check_duplicate_xy(v: np.ndarray, source: str) -> None:
    order = np.lexsort((v[:, 1], v[:, 0]))
    s = v[order, :2]
    same = np.all(s[1:] == s[:-1], axis=1)
    if same.any():
        k = int(np.flatnonzero(same)[0])
        i, j = sorted((int(order[k]), int(order[k + 1])))
        raise TinStructureError(
            f"{source}: vertices {i} {v[i].tolist()} and {j} {v[j].tolist()} have the same x, y; "
            "a TIN is a single-valued surface")


@njit(cache=True, inline="always")
def _one_way(vx, vy, tri, p, q, delta):
    """Edges of triangle p against the corners of triangle q: (some edge line of p separates
    q, first T-junction as 3*k + j (corner j of q inside edge k of p) or -1)."""
    sep = False
    tj = -1
    for k in range(3):
        a = tri[p, k]
        c = tri[p, (k + 1) % 3]
        ex = vx[c] - vx[a]
        ey = vy[c] - vy[a]
        length = np.sqrt(ex * ex + ey * ey)
        tol = length * delta
        smax = -np.inf
        for j in range(3):
            r = tri[q, j]
            dx = vx[r] - vx[a]
            dy = vy[r] - vy[a]
            s = ex * dy - ey * dx  # > 0: left of the edge, inside p's half-plane
            smax = max(smax, s)
            if tj < 0 and abs(s) <= tol and r != tri[p, 0] and r != tri[p, 1] and r != tri[p, 2]:
                along = ex * dx + ey * dy
                if tol < along < length * length - tol:
                    tj = 3 * k + j
        if smax <= tol:
            sep = True
    return sep, tj


@njit(cache=True, inline="always")
def pair_code(vx, vy, tri, a, b, delta):
    """(code, edge triangle, corner triangle, k, j) for the pair a, b (OK, OVERLAP, T_JUNCTION)."""
    sep_a, tj_a = _one_way(vx, vy, tri, a, b, delta)
    sep_b, tj_b = _one_way(vx, vy, tri, b, a, delta)
    if not (sep_a or sep_b):
        return OVERLAP, a, b, 0, 0
    if tj_a >= 0:
        return T_JUNCTION, a, b, tj_a // 3, tj_a % 3
    if tj_b >= 0:
        return T_JUNCTION, b, a, tj_b // 3, tj_b % 3
    return OK, a, b, 0, 0


@njit(cache=True)
def _cell_index(c, c0, cs, n):
    return min(max(np.int64((c - c0) / cs), 0), n - 1)  # the bucket grid's own arithmetic


@njit(cache=True)
def scan_pairs(vx, vy, tri, nbrs, start, tris, x0, y0, cs, nx, ny, delta):
    """First bad pair of triangles sharing a bucket cell: (code, a, b, k, j), code OK if none."""
    T = tri.shape[0]
    ci0 = np.empty(T, dtype=np.int64)
    cj0 = np.empty(T, dtype=np.int64)
    box = np.empty((T, 4))  # xmin, ymin, xmax, ymax
    for t in range(T):
        xa, xb, xc = vx[tri[t, 0]], vx[tri[t, 1]], vx[tri[t, 2]]
        ya, yb, yc = vy[tri[t, 0]], vy[tri[t, 1]], vy[tri[t, 2]]
        box[t, 0] = min(min(xa, xb), xc)
        box[t, 1] = min(min(ya, yb), yc)
        box[t, 2] = max(max(xa, xb), xc)
        box[t, 3] = max(max(ya, yb), yc)
        ci0[t] = _cell_index(box[t, 0], x0, cs, nx)
        cj0[t] = _cell_index(box[t, 1], y0, cs, ny)
    for cell in range(start.shape[0] - 1):
        for p in range(start[cell], start[cell + 1]):
            a = tris[p]
            for q in range(p + 1, start[cell + 1]):
                b = tris[q]
                if (box[a, 0] > box[b, 2] + delta or box[b, 0] > box[a, 2] + delta
                        or box[a, 1] > box[b, 3] + delta or box[b, 1] > box[a, 3] + delta):
                    continue
                if max(cj0[a], cj0[b]) * nx + max(ci0[a], ci0[b]) != cell:
                    continue  # tested in the first cell the two share
                if nbrs[a, 0] == b or nbrs[a, 1] == b or nbrs[a, 2] == b:
                    continue  # across a shared edge: on opposite sides (checked by the adjacency build)
                code, e, c, k, j = pair_code(vx, vy, tri, a, b, delta)
                if code != OK:
                    return code, e, c, k, j
    return OK, -1, -1, -1, -1


def pair_status(v: np.ndarray, tri: np.ndarray, a: np.ndarray, b: np.ndarray, delta: float) -> np.ndarray:
    """Plain numpy :func:`pair_code` for arrays of pairs: ``(m,)`` OK/OVERLAP/T_JUNCTION."""
    xy = v[:, :2]
    out = np.zeros(len(a), dtype=np.int64)
    seps, tjs = [], []
    for p, q in ((a, b), (b, a)):
        P, Q = xy[tri[p]], xy[tri[q]]  # (m, 3, 2)
        sep = np.zeros(len(a), dtype=bool)
        tj = np.zeros(len(a), dtype=bool)
        for k in range(3):
            e = P[:, (k + 1) % 3] - P[:, k]
            length = np.hypot(e[:, 0], e[:, 1])
            tol = (length * delta)[:, None]
            d = Q - P[:, k][:, None, :]
            s = e[:, None, 0] * d[:, :, 1] - e[:, None, 1] * d[:, :, 0]
            along = e[:, None, 0] * d[:, :, 0] + e[:, None, 1] * d[:, :, 1]
            corner = np.any(tri[q][:, :, None] == tri[p][:, None, :], axis=2)
            tj |= np.any((np.abs(s) <= tol) & (along > tol) & (along < (length * length)[:, None] - tol) & ~corner,
                         axis=1)
            sep |= s.max(axis=1) <= tol[:, 0]
        seps.append(sep)
        tjs.append(tj)
    out[tjs[0] | tjs[1]] = T_JUNCTION
    out[~(seps[0] | seps[1])] = OVERLAP
    return out
