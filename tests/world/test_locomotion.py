"""world/locomotion.py by hand at headings other than 0 and pi (where a rotation and its transpose
agree): 90 and -37 degrees, body-frame commands forward and left, the uphill factor along and
across a slope, the turn toward the motion across the +-pi seam.

Tolerances: 1e-12 absolute on metre-scale values is a few ulps of the float64 cos/sin products."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import (
    BLOCKED_BORDER,
    BLOCKED_STEEP,
    FELL_INTO,
    BatteryParams,
    RobotParams,
    SensorParams,
    World,
    WorldParams,
    spawn_positions,
)
from tin_swarm_env.world import locomotion as L
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


def test_driving_down_into_a_cliff_falls_and_up_into_it_is_blocked(world_params, cliff_tin):
    w = World(cliff_tin(width=5.0), world_params(robot={"max_speed_mps": 2.0}, dt_s=1.0))
    s = w.reset(0, [[99.0, 50.0], [106.0, 50.0]], headings=[0.0, math.pi])
    s, ev = w.step(s, [[1.0, 0.0], [1.0, 0.0]])  # both drive forward, toward the cliff face
    assert ev.motion_event.tolist() == [FELL_INTO, BLOCKED_STEEP]
    assert s.status.tolist() == [Reason.FELL, Reason.NONE]
    assert ev.fell.tolist() == [True, False]
    assert 100.0 < s.positions[0, 0] < 100.01  # just inside the cliff triangle
    assert s.positions[1, 0] == pytest.approx(105.001)  # 1 mm before the foot of the cliff
    assert not w.steep[s.tri_idx[1]]
    s2, ev = w.step(s, [[1.0, 0.0], [1.0, 0.0]])
    np.testing.assert_array_equal(s2.positions, s.positions)  # fallen: gone; blocked: stays


@pytest.mark.parametrize("speed", [10.0, 1000.0])
def test_no_tunnelling_through_a_one_triangle_wide_cliff(world_params, cliff_tin, speed):
    w = World(cliff_tin(width=0.05), world_params(robot={"max_speed_mps": speed}, dt_s=1.0))
    x0 = 99.9
    s = w.reset(0, [[x0, 50.0], [100.2, 50.0]], headings=[0.0, math.pi])
    s, ev = w.step(s, [[1.0, 0.0], [1.0, 0.0]])
    assert ev.motion_event.tolist() == [FELL_INTO, BLOCKED_STEEP]
    assert s.positions[0, 0] < 100.05 and s.positions[1, 0] > 100.05


def test_border_blocks(world_params):
    w = World(None, world_params(robot={"max_speed_mps": 5.0}, dt_s=1.0, flat_size_m=(10.0, 10.0)))
    s = w.reset(0, [[8.0, 5.0]], headings=[0.0])
    s, ev = w.step(s, [[1.0, 0.0]])
    assert ev.motion_event[0] == BLOCKED_BORDER
    assert s.positions[0, 0] == pytest.approx(10.0 - 1e-3) and s.status[0] == Reason.NONE


def test_uphill_slows_by_pitch_and_downhill_does_not(world_params):
    g = math.tan(math.radians(15))
    xy = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], float)
    tin = Tin.from_points(np.column_stack([xy, g * xy[:, 0]]))  # rises to the east at 15 deg
    w = World(tin, world_params(robot={"max_speed_mps": 2.0, "max_climb_deg": 45.0}, dt_s=1.0))
    s = w.reset(0, [[50, 30], [50, 60], [50, 90]], headings=[0.0, math.pi, math.pi / 2])
    s, ev = w.step(s, np.array([[1.0, 0.0]] * 3))
    np.testing.assert_allclose(ev.moved_m, [2.0 * (1 - 15 / 45), 2.0, 2.0])
    np.testing.assert_allclose(ev.climb_m, [g * 2.0 * (1 - 15 / 45), -g * 2.0, 0.0], atol=1e-12)


def test_heading_turns_toward_motion_at_most_the_turn_rate(world_params):
    w = World(None, world_params(robot={"turn_rate_dps": 90.0}, dt_s=0.5))
    s = w.reset(0, [[100, 100], [200, 200]], headings=[0.0, 0.0])
    s, _ = w.step(s, [[0.0, 1.0], [1.0, 0.0]])  # robot 0 moves left (north): turns 45 deg
    np.testing.assert_allclose(s.headings, [math.radians(45), 0.0])
    np.testing.assert_allclose(s.positions[0], [100, 101])  # moved north, body-left of east
    s, _ = w.step(s, [[0.0, 0.0], [-1.0, 0.0]])
    assert s.headings[0] == pytest.approx(math.radians(45))  # no motion, no turn
    assert abs(s.headings[1]) == pytest.approx(math.radians(45))


def test_commands_clipped_to_the_unit_disc(world_params):
    w = World(None, world_params(robot={"max_speed_mps": 2.0}, dt_s=1.0))
    s = w.reset(0, [[100, 100]], headings=[0.0])
    s, ev = w.step(s, [[5.0, 5.0]])
    assert ev.moved_m[0] == pytest.approx(2.0)


def substep_reference(w, p0, d, n_sub=4000):
    """Walk the displacement in tiny steps with brute-force location; return the event."""
    from tin_swarm_env.terrain.reference import locate_brute

    pts = p0 + np.linspace(0, 1, n_sub)[1:, None] * d
    tri = locate_brute(w.tin, pts)
    for t in tri:
        if t < 0:
            return BLOCKED_BORDER
        if w.steep[t]:
            g = w.tin.planes[t, :2]
            return FELL_INTO if g @ d < 0 else BLOCKED_STEEP
    return L.MOVED


@settings(max_examples=30)
@given(st.integers(0, 10_000))
def test_locomotion_walk_matches_substepping(world_params, random_tin, seed):
    tin = random_tin(seed, 30, zscale=150)
    w = World(tin, world_params(robot={"max_slope_deg": 15.0, "max_climb_deg": 80.0}))
    assume((~w.steep).sum() > 0)
    rng = np.random.default_rng(seed)
    pos = spawn_positions(w.tin, w.steep, 20, rng)
    disp = rng.normal(0, 150, (20, 2))
    # spawn draws the same numbers as random_tin's points: some robots sit exactly on vertices
    tri = w.tin.locate(pos)
    p, t, ev = L.walk(tin, w.steep, pos, tri, disp)
    grad = np.ascontiguousarray(tin.planes[:, :2])
    args = (tin._vx, tin._vy, tin.triangles, tin.neighbors, grad, w.steep, pos, tri, disp, tin.n_triangles + 3)
    k = L.move_walk(*args)
    for a, b in zip(k, L.move_walk.py_func(*args)):
        np.testing.assert_array_equal(a, b)
    for i in range(20):
        ref = substep_reference(w, pos[i], disp[i])
        assert ev[i] == ref, (i, ev[i], ref)
        if ev[i] == L.MOVED:
            np.testing.assert_allclose(p[i], pos[i] + disp[i])
        assert (not w.steep[t[i]]) or ev[i] == FELL_INTO
