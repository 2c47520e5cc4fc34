"""world/locomotion.py by hand at headings other than 0 and pi (where a rotation and its transpose
agree): 90 and -37 degrees, body-frame commands forward and left, the uphill factor along and
across a slope, the turn toward the motion across the +-pi seam.

Tolerances: 1e-12 absolute on metre-scale values is a few ulps of the float64 cos/sin products."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import BatteryParams, RobotParams, SensorParams, World, WorldParams
from tin_swarm_env.world.locomotion import body_to_world, move, turn_toward, uphill_factor
from tin_swarm_env.world.state import Reason

D37 = math.radians(-37.0)
C37, S37 = math.cos(D37), math.sin(D37)  # 0.7986, -0.6018


@pytest.mark.parametrize("heading,command,want", [
    (0.0, (1.0, 0.0), (1.0, 0.0)),
    (math.pi / 2, (1.0, 0.0), (0.0, 1.0)),  # facing north, forward is north
    (math.pi / 2, (0.0, 1.0), (-1.0, 0.0)),  # facing north, left is west
    (math.pi / 2, (0.6, 0.8), (-0.8, 0.6)),
    (-math.pi / 2, (0.0, 1.0), (1.0, 0.0)),  # facing south, left is east
    (D37, (1.0, 0.0), (C37, S37)),
    (D37, (0.0, 1.0), (-S37, C37)),  # left of a heading of -37 deg: 53 deg
    (D37, (-1.0, 0.0), (-C37, -S37)),
    (math.pi, (0.0, 1.0), (0.0, -1.0)),
])
def test_body_to_world_rotates_by_the_heading(heading, command, want):
    v = body_to_world(np.array([command]), np.array([heading]), 2.0)
    np.testing.assert_allclose(v[0], 2.0 * np.array(want), atol=1e-12)


def test_body_to_world_clips_to_the_square_then_the_disc():
    v = body_to_world(np.array([[3.0, 0.0], [1.0, 1.0], [0.3, -0.4], [-5.0, 5.0]]), np.zeros(4), 2.0)
    np.testing.assert_allclose(v, [[2.0, 0.0], [math.sqrt(2), math.sqrt(2)], [0.6, -0.8],
                                   [-math.sqrt(2), math.sqrt(2)]], atol=1e-12)


def test_uphill_factor_along_against_and_across_the_slope():
    g = math.tan(math.radians(15.0))
    grad = np.array([[g, 0.0]] * 4)  # rises to the east at 15 deg
    vel = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [C37, S37]])
    f = uphill_factor(grad, vel, 45.0)
    pitch_37 = math.degrees(math.atan(g * C37))  # the slope along a heading of -37 deg
    np.testing.assert_allclose(f, [1 - 15 / 45, 1.0, 1.0, 1 - pitch_37 / 45], atol=1e-12)
    assert uphill_factor(np.array([[10.0, 0.0]]), np.array([[1.0, 0.0]]), 45.0)[0] == 0.0  # 84 deg: stops


def test_turn_toward_is_bounded_and_takes_the_short_way_across_the_seam():
    h = turn_toward(np.array([0.0, 3.0, -3.0, 1.0, 0.5]),
                    np.array([[0.0, 1.0], [math.cos(-3.0), math.sin(-3.0)], [math.cos(3.0), math.sin(3.0)],
                              [0.0, 0.0], [math.cos(0.6), math.sin(0.6)]]), 0.5)
    # +0.5 (bounded), 3 -> -3 the short way (+0.283, across pi), -3 -> 3 likewise, no motion: no turn,
    # 0.1 to go: reached exactly
    np.testing.assert_allclose(h, [0.5, -3.0, 3.0, 1.0, 0.6], atol=1e-12)


def flat_world(**robot):
    p = WorldParams(robot=RobotParams(**{"max_speed_mps": 2.0, **robot}), sensor=SensorParams(),
                    battery=BatteryParams(), dt_s=1.0)
    return World(None, p)


@pytest.mark.parametrize("heading_deg", [90.0, -37.0, 143.0])
def test_world_step_moves_forward_and_left_along_the_heading(heading_deg):
    w = flat_world()
    h = math.radians(heading_deg)
    s = w.reset(0, [[200.0, 200.0], [300.0, 300.0]], headings=[h, h])
    s, ev = w.step(s, [[1.0, 0.0], [0.0, 0.5]])
    fwd = np.array([math.cos(h), math.sin(h)])
    left = np.array([-math.sin(h), math.cos(h)])
    np.testing.assert_allclose(s.positions[0], [200.0, 200.0] + 2.0 * fwd, atol=1e-9)
    np.testing.assert_allclose(s.positions[1], [300.0, 300.0] + 1.0 * left, atol=1e-9)
    np.testing.assert_allclose(ev.moved_m, [2.0, 1.0], atol=1e-9)


def test_move_on_a_slope_at_minus_37_degrees_slows_by_the_pitch_along_the_motion():
    g = math.tan(math.radians(20.0))
    xy = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], float)
    tin = Tin.from_points(np.column_stack([xy, -g * xy[:, 1]]))  # falls to the north: uphill is south
    robot = RobotParams(max_speed_mps=2.0, max_climb_deg=45.0, max_slope_deg=30.0)
    pos = np.array([[50.0, 50.0], [50.0, 50.0]])
    tri = tin.locate(pos)
    heads = np.array([D37, math.pi / 2])
    cmd = np.array([[1.0, 0.0], [1.0, 0.0]])
    new_pos, new_tri, new_head, speeds, ev = move(tin, np.zeros(tin.n_triangles, bool), pos, tri, heads,
                                                  np.full(2, Reason.NONE, np.int8), cmd, robot, 1.0)
    pitch = math.degrees(math.atan(g * -S37))  # the rise along (cos -37, sin -37): southward part
    f = 1 - pitch / 45.0
    np.testing.assert_allclose(new_pos[0], [50 + 2 * f * C37, 50 + 2 * f * S37], atol=1e-9)
    np.testing.assert_allclose(new_pos[1], [50.0, 52.0], atol=1e-9)  # north: downhill, full speed
    np.testing.assert_allclose(speeds, [2 * f, 2.0], atol=1e-9)
    np.testing.assert_allclose(new_head, heads, atol=1e-12)  # moving straight ahead: no turn


def test_robots_that_are_not_active_do_not_move():
    tin = Tin.from_points(np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]], float))
    pos = np.array([[50.0, 50.0], [60.0, 60.0]])
    out = move(tin, np.zeros(tin.n_triangles, bool), pos, tin.locate(pos), np.array([0.3, 0.3]),
               np.array([Reason.NONE, Reason.FELL], np.int8), np.ones((2, 2)), RobotParams(), 1.0)
    assert not np.array_equal(out[0][0], pos[0]) and np.array_equal(out[0][1], pos[1]) and out[3][1] == 0.0


def test_a_robot_standing_on_a_cliff_edge_falls_driving_over_it_and_stays_driving_away():
    """The motion starts exactly on the edge of a too-steep triangle (the branch before the walk):
    a 10 m plateau (x <= 10), a cliff to the floor at x = 11, the floor beyond. Standing on the
    plateau's edge, driving east (down the cliff) is a fall; driving west (away from it) is not."""
    xy = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [11, 0], [11, 10], [20, 0], [20, 10]], float)
    z = np.where(xy[:, 0] <= 10, 10.0, 0.0)
    w = World(Tin.from_points(np.column_stack([xy, z])),
              WorldParams(robot=RobotParams(max_speed_mps=1.0, max_slope_deg=30.0), dt_s=1.0))
    s = w.reset(0, [[10.0, 3.0], [10.0, 7.0]], headings=[0.0, math.pi])
    s, ev = w.step(s, [[1.0, 0.0], [1.0, 0.0]])
    assert s.status.tolist() == [Reason.FELL, Reason.NONE]
    np.testing.assert_allclose(s.positions[1], [9.0, 7.0], atol=1e-9)
