"""The compiled query kernels (terrain/_kernels.py): each equals its plain Python version, and the
walk finds points on shared and border edges without a fallback."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from tin_swarm_env.terrain import Tin
from tin_swarm_env.terrain import _kernels as K


def test_compiled_kernels_equal_their_plain_python_versions(random_rays, random_tin):
    tin = random_tin(7, 40, zscale=80)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-50, 1050, (200, 2))
    px, py = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    hints = rng.integers(0, tin.n_triangles, 200)
    args = (tin._vx, tin._vy, tin.triangles, tin.neighbors, px, py, hints, tin.n_triangles + 3, tin._tol[0])
    np.testing.assert_array_equal(K.walk_locate(*args), K.walk_locate.py_func(*args))
    bk = tin._bucket
    args = (tin._vx, tin._vy, tin.triangles, bk["start"], bk["tris"], bk["x0"], bk["y0"], bk["inv_cs"],
            bk["nx"], bk["ny"], px, py, tin._tol[0])
    np.testing.assert_array_equal(K.bucket_locate(*args), K.bucket_locate.py_func(*args))
    a, b = random_rays(tin, rng, 200)
    start = tin.locate(a[:, :2])
    args = (tin._vx, tin._vy, tin._vz, tin.triangles, tin.neighbors, tin._grad, a, b, start,
            tin.n_triangles + 3, tin._tol[1])
    np.testing.assert_array_equal(K.los_walk(*args), K.los_walk.py_func(*args))
    za, zb = tin.height_at(a[:, :2]), tin.height_at(b[:, :2])
    border = tin.edge_triangles[:, 1] < 0
    args = (tin._vx, tin._vy, tin._vz, tin.edges, border, a, b, za, zb, tin._tol[1], 1e-9)
    brute = K.los_brute(*args)
    np.testing.assert_array_equal(brute, K.los_brute.py_func(*args))
    np.testing.assert_array_equal(brute.astype(bool), tin.line_of_sight(a, b))


def test_the_walk_itself_finds_points_on_shared_and_border_edges():
    """The walk's tolerance: a point on an edge is inside both triangles, so the walk stops in the
    first one it tries (it never steps across an edge the point lies on, which would leave the TIN
    at a border edge or give up going back and forth); only then is no fallback needed."""
    tin = Tin(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]], float), [[0, 1, 2], [0, 2, 3]])
    pts = np.array([[5.0, 5.0], [5.0, 0.0], [10.0, 5.0], [0.0, 5.0], [5.0, 10.0], [2.0, 1.0]])
    want = [[0, 1], [0], [0], [1], [1], [0]]
    vx, vy = tin.xy_columns
    for hint in (0, 1):
        got = K.walk_locate(vx, vy, tin.triangles, tin.neighbors, pts[:, 0], pts[:, 1],
                            np.full(len(pts), hint, np.int64), tin.n_triangles + 3, tin.tolerances[0])
        assert all(int(g) in w for g, w in zip(got, want)), (hint, got)
        assert got[0] == hint  # on the shared diagonal: stays where it started


@njit(cache=True)
def _los_walk_full_search(vx, vy, vz, tris, nbrs, grad, a, b, start, max_steps, ztol):
    """The walk as it was: exit_edge's full search in every triangle (the reference of the
    incremental one in los_walk1)."""
    out = np.empty(a.shape[0], dtype=np.int8)
    for i in range(a.shape[0]):
        ax, ay, az, bx, by, bz, t = a[i, 0], a[i, 1], a[i, 2], b[i, 0], b[i, 1], b[i, 2], start[i]
        r = -2
        if t < 0:
            r = 0
        elif az < vz[tris[t, 0]] + grad[t, 0] * (ax - vx[tris[t, 0]]) + grad[t, 1] * (ay - vy[tris[t, 0]]) - ztol:
            r = 0
        elif bx - ax == 0.0 and by - ay == 0.0:
            zb = vz[tris[t, 0]] + grad[t, 0] * (bx - vx[tris[t, 0]]) + grad[t, 1] * (by - vy[tris[t, 0]])
            r = 1 if bz >= zb - ztol else 0
        else:
            for _ in range(max_steps):
                ex, s, u = K.exit_edge(vx, vy, tris, t, ax, ay, bx - ax, by - ay)
                if ex < 0:
                    r = -2
                    break
                if s >= 1.0:
                    zb = vz[tris[t, 0]] + grad[t, 0] * (bx - vx[tris[t, 0]]) + grad[t, 1] * (by - vy[tris[t, 0]])
                    r = 1 if bz >= zb - ztol else 0
                    break
                vi = tris[t, (ex + 1) % 3]
                vj = tris[t, (ex + 2) % 3]
                if vz[vi] + u * (vz[vj] - vz[vi]) > az + s * (bz - az) + ztol:
                    r = 0
                    break
                if nbrs[t, ex] < 0:
                    r = 0
                    break
                t = nbrs[t, ex]
        out[i] = r
    return out


@pytest.mark.parametrize("seed", range(4))
def test_the_incremental_walk_equals_the_full_exit_edge_search(random_tin, random_rays, seed):
    """Random rays, rays from vertex to vertex (along edges and through vertices) and rays on a
    regular grid TIN, where sight lines run exactly through vertices and along edges: the same
    answers, bit for bit (including the -2 of a degenerate walk)."""
    rng = np.random.default_rng(seed)
    tins = [random_tin(seed, 60, zscale=80)]
    g = np.arange(6) * 100.0
    gx, gy = np.meshgrid(g, g)
    tins.append(Tin.from_points(np.column_stack([gx.ravel(), gy.ravel(), rng.uniform(0, 40, gx.size)])))
    for tin in tins:
        a, b = random_rays(tin, rng, 300)
        v = tin.vertices
        pick = rng.integers(0, len(v), (300, 2))
        va, vb = v[pick[:, 0]].copy(), v[pick[:, 1]].copy()
        va[:, 2] += rng.uniform(0, 20, 300)
        vb[:, 2] += rng.uniform(0, 20, 300)
        a, b = np.vstack([a, va]), np.vstack([b, vb])
        start = tin.locate(a[:, :2])
        args = (tin._vx, tin._vy, tin._vz, tin.triangles, tin.neighbors, tin._grad, a, b, start,
                tin.n_triangles + 3, tin._tol[1])
        got = K.los_walk(*args)
        np.testing.assert_array_equal(got, _los_walk_full_search(*args))
        assert (got == 1).any() and (got == 0).any()
