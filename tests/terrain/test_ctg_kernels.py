"""The compiled cost-to-go kernels (terrain/_ctg_kernels.py) equal their plain Python versions."""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.terrain import _ctg_kernels as K
from tin_swarm_env.terrain import cost_to_go, reference


@settings(max_examples=10)
@given(st.integers(0, 10_000), st.booleans())
def test_compiled_kernels_match_py_func(obstacle_case, random_tin, seed, any_angle):
    tin, passable, goal, rng = obstacle_case(random_tin, seed, n=20)
    ctg = cost_to_go(tin, goal, passable, steiner_per_edge=1, any_angle=any_angle)
    gt = np.flatnonzero(ctg.goal_triangles)
    if any_angle:
        te, n_edges = K.triangle_edges(tin.triangles, tin.neighbors)
        for a, b in zip(K.split_fans(tin.triangles, tin.neighbors, passable, tin.n_vertices),
                        K.split_fans.py_func(tin.triangles, tin.neighbors, passable, tin.n_vertices)):
            np.testing.assert_array_equal(a, b)
        corner = K.corners(ctg._vx, ctg._vy, ctg._tris, tin.neighbors, passable)
        np.testing.assert_array_equal(corner, K.corners.py_func(ctg._vx, ctg._vy, ctg._tris, tin.neighbors,
                                                                passable))
        args = (ctg._nx, ctg._ny, ctg._vx, ctg._vy, ctg._tris, tin.neighbors, te,
                K.edge_starts(tin.triangles, te, n_edges), ctg._vorig, ctg.passable, ctg._tri_nodes, ctg._start,
                ctg._node_tris, corner, gt, goal[0], goal[1], 1)
        fn = K.windows
    else:
        seeds = np.unique(ctg._tri_nodes[gt].ravel())
        sd = np.hypot(*(ctg.node_xy[seeds] - goal).T)
        args = (ctg._nx, ctg._ny, ctg._tri_nodes, ctg._start, ctg._node_tris, seeds, sd)
        fn = K.dijkstra
    with mock.patch.object(K, "_propagate", K._propagate.py_func):  # windows' loop in Python too
        plain = fn.py_func(*args)
    for a, b in zip(fn(*args), plain):
        np.testing.assert_array_equal(a, b)
    if any_angle:  # a window kernel that runs out of room starts again with twice the room: same answer
        for a, b in zip(fn(*args, 3), plain):
            np.testing.assert_array_equal(a, b)
    q = rng.uniform(-10, 1010, (200, 2))
    t = tin.locate(q)
    qargs = (ctg._nx, ctg._ny, ctg.node_distance, ctg._parent, ctg._tri_nodes, ctg.passable, ctg.goal_triangles,
             goal[0], goal[1], ctg._vx, ctg._vy, ctg._tris, tin.neighbors, ctg._wstart, ctg._wgeo, ctg._wroot,
             q[:, 0].copy(), q[:, 1].copy(), t, tin._tol[0], 1e-6, ctg._twin)
    for a, b in zip(K.query(*qargs), K.query.py_func(*qargs)):
        np.testing.assert_array_equal(a, b)
    # the query against a brute-force search of the triangle's candidates: the answer is the
    # plain minimum over the triangle's nodes, or a cheaper straight segment to the source the
    # query names (a node or the goal) that is drivable (dense samples) and adds up
    d, _, src = K.query(*qargs)
    tb = reference.locate_brute(tin, q)
    s = np.linspace(0, 1, 41)[:, None]
    for i in np.flatnonzero(tb >= 0):
        if not passable[tb[i]]:
            continue
        nodes = ctg._tri_nodes[tb[i]]
        direct = np.hypot(*(goal - q[i])) if ctg.goal_triangles[tb[i]] else np.inf
        plain = min(np.min(np.hypot(*(ctg.node_xy[nodes] - q[i]).T) + ctg.node_distance[nodes]), direct)
        if not any_angle or plain == np.inf:
            assert d[i] == pytest.approx(plain, rel=1e-12, abs=1e-9)
            continue
        assert d[i] <= plain * (1 + 1e-12)
        end = goal if src[i] == K.GOAL else ctg.node_xy[src[i]]
        dend = 0.0 if src[i] == K.GOAL else ctg.node_distance[src[i]]
        assert d[i] == pytest.approx(np.hypot(*(end - q[i])) + dend, rel=1e-12)
        seg = q[i] + s * (end - q[i])
        assert reference.on_passable_brute(tin, seg, passable, tol=1e-6).all()
