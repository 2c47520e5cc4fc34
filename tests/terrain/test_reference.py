"""The slow, obvious references themselves (terrain/reference.py), on tiny hand-built TINs with exact
answers. The comparisons of the compiled code against them live in the compiled code's test files
(tests/terrain/test_tin.py, test_validity.py, test_cost_to_go.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tin_swarm_env.terrain import Tin
from tin_swarm_env.terrain import reference as R

# a 10 m square split along its diagonal (0,0)-(10,10) into triangle 0 (below, y < x) and
# triangle 1 (above), heights on the plane z = x + 2 y
SQUARE = Tin(np.array([[0, 0, 0], [10, 0, 10], [10, 10, 30], [0, 10, 20]], float), [[0, 1, 2], [0, 2, 3]])


def fan():
    """The square with a centre vertex 4 at (5, 5): triangles 0 bottom, 1 right, 2 top, 3 left."""
    v = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [5, 5, 0]], float)
    return Tin(v, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])


def test_locate_brute_takes_the_lowest_index_triangle_and_minus_one_outside():
    xy = [[7, 2], [2, 7], [5, 5], [5, 0], [11, 5], [-1e-3, 5]]
    assert R.locate_brute(SQUARE, xy).tolist() == [0, 1, 0, 0, -1, -1]  # (5, 5) lies on both: 0


def test_height_brute_is_the_plane_inside_and_nan_outside():
    xy = np.array([[7.0, 2.0], [2.0, 7.0], [5.0, 5.0], [10.0, 10.0], [0.5, 9.5]])
    np.testing.assert_allclose(R.height_brute(SQUARE, xy), xy[:, 0] + 2 * xy[:, 1], rtol=1e-14)
    assert np.isnan(R.height_brute(SQUARE, [[20.0, 5.0]])).all()


def ridge(h):
    """A 20 x 10 m strip, flat at 0 m with a north-south ridge of height ``h`` along x = 10."""
    xy = np.array([[0, 0], [0, 10], [10, 0], [10, 10], [20, 0], [20, 10]], float)
    return Tin.from_points(np.column_stack([xy, [0, 0, h, h, 0, 0]]))


def test_line_of_sight_brute_on_a_ridge():
    a, b = [[2.0, 5.0, 1.0]], [[18.0, 5.0, 1.0]]
    assert not R.line_of_sight_brute(ridge(5.0), a, b)[0]  # the ridge (5 m) above the line (1 m)
    assert R.line_of_sight_brute(ridge(0.0), a, b)[0]
    assert R.line_of_sight_brute(ridge(5.0), [[2.0, 5.0, 5.0]], [[18.0, 5.0, 5.0]])[0]  # grazing: seen
    assert not R.line_of_sight_brute(ridge(0.0), [[2.0, 5.0, -0.5]], b)[0]  # an end below ground
    assert not R.line_of_sight_brute(ridge(0.0), [[-2.0, 5.0, 1.0]], b)[0]  # an end outside


def test_line_of_sight_dense_is_the_least_clearance_along_the_line():
    # on the plane: the clearance is linear along the line, 1 m at a and 0.5 m at b
    a = np.array([[1.0, 1.0, 3.0 + 1.0]])
    b = np.array([[9.0, 1.0, 11.0 + 0.5]])
    assert R.line_of_sight_dense(SQUARE, a, b)[0] == pytest.approx(0.5, abs=1e-12)
    # 2001 samples put one on the ridge line (x = 10) itself: the least clearance is 1 - 5 m
    assert R.line_of_sight_dense(ridge(5.0), [[2.0, 5.0, 1.0]], [[18.0, 5.0, 1.0]], 2001)[0] == pytest.approx(-4.0)
    assert np.isnan(R.line_of_sight_dense(SQUARE, a, [[12.0, 1.0, 0.0]])[0])


def test_single_surface_brute_finds_an_overlap_and_a_t_junction():
    v = np.array([[0, 0, 0], [10, 0, 0], [5, 5, 0], [5, 0, 0], [2.5, -5, 0], [2, 1, 0], [8, 1, 0], [5, 4, 0]],
                 float)
    # 0: the upper triangle; 1: below it, its corner (5, 0) inside 0's bottom edge; 2: inside 0
    got = R.single_surface_brute(v, [[0, 1, 2], [0, 4, 3], [5, 6, 7]])
    assert got.tolist() == [[0, 2, 1], [0, 0, 0], [0, 0, 0]]
    assert not R.single_surface_brute(SQUARE.vertices, SQUARE.triangles).any()  # sharing an edge


def test_on_passable_brute_counts_a_shared_edge_for_both_sides():
    passable = np.array([True, False])
    got = R.on_passable_brute(SQUARE, [[7, 2], [2, 7], [5, 5], [11, 5]], passable)
    assert got.tolist() == [True, False, True, False]


def test_crosses_impassable_brute_interior_edges_and_vertices():
    passable = np.array([True, False])  # triangle 1 (above the diagonal) impassable
    a = np.array([[1.0, 8.0], [6.0, 1.0], [1.0, 1.0], [9.0, 1.0], [10.0, 0.0]])
    b = np.array([[3.0, 9.0], [9.0, 2.0], [9.0, 9.0], [1.0, 9.0], [10.0, 10.0]])
    # inside the impassable one; inside the passable one; along the diagonal (passable on one
    # side); across the impassable one; along the border edge of the passable one
    assert R.crosses_impassable_brute(SQUARE, passable, a, b).tolist() == [True, False, False, True, False]
    # along the border edge (0,10)-(10,10) of the impassable triangle: no passable side
    assert R.crosses_impassable_brute(SQUARE, passable, [[2.0, 10.0]], [[8.0, 10.0]]).tolist() == [True]


def test_fans_and_pinch_vertices_of_two_triangles_meeting_at_a_vertex():
    tin = fan()
    lab = R.fan_labels_brute(tin, np.array([True, False, True, False]))
    assert (lab[[1, 3]] == -1).all() and (lab[[0, 2]] >= 0).all()
    assert lab[0, 2] != lab[2, 2]  # the centre vertex's corners in the bottom and top triangles
    assert R.pinch_vertices_brute(tin, np.array([True, False, True, False])).tolist() == [4]
    assert R.pinch_vertices_brute(tin, np.array([True, False, True, True])).tolist() == []
    assert len(R.pinch_vertices_brute(tin, np.ones(4, bool))) == 0


def test_visibility_brute_bends_at_the_apex_of_an_impassable_wedge():
    tin = fan()
    goal, q = [9.0, 0.2], [[9.0, 9.8], [9.0, 1.0]]
    open_ = R.cost_to_go_visibility_brute(tin, goal, np.ones(4, bool), q)
    np.testing.assert_allclose(open_, [9.6, 0.8], rtol=1e-12)  # straight lines
    wedge = R.cost_to_go_visibility_brute(tin, goal, np.array([True, False, True, True]), q)
    np.testing.assert_allclose(wedge, [2 * math.hypot(4.0, 4.8), 0.8], rtol=1e-12)  # round (5, 5)
    # bottom and top meet only at the centre vertex: no way from one to the other
    pinched = R.cost_to_go_visibility_brute(tin, goal, np.array([True, False, True, False]), q)
    assert pinched[0] == np.inf and pinched[1] == pytest.approx(0.8, rel=1e-12)


def test_cost_to_go_grid_sums_its_moves():
    xs, ys, dist = R.cost_to_go_grid(SQUARE, [0.5, 0.5], np.ones(2, bool), 1.0)
    np.testing.assert_array_equal(xs, np.arange(0.5, 10, 1.0))
    assert dist[0, 3] == pytest.approx(3.0) and dist[3, 3] == pytest.approx(3 * math.sqrt(2))
    # (2, 1) is one move; (5, 2) is not (|a| <= 3): the best two are (3, 1) + (2, 1)
    assert dist[1, 2] == pytest.approx(math.sqrt(5)) and dist[2, 5] == pytest.approx(math.sqrt(10) + math.sqrt(5))
    # only the lower triangle passable: cells above the diagonal are off passable ground
    _, _, low = R.cost_to_go_grid(SQUARE, [9.5, 0.5], np.array([True, False]), 1.0)
    assert np.isinf(low[5, 2]) and low[0, 6] == pytest.approx(3.0)
