"""The compiled query kernels (terrain/_kernels.py): each equals its plain Python version, and the
walk finds points on shared and border edges without a fallback."""

from __future__ import annotations

import numpy as np

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
