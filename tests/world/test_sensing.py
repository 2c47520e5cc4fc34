"""Sensing (world/sensing.py): hand-built scenes with exact answers (field of view, range, line of
sight, fallen robots, the max_candidates bound) and the batched sensing against the per-robot
reference loop (world/reference.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import (
    Reason,
    RobotParams,
    SensorParams,
    World,
    WorldParams,
    spawn_positions,
)
from tin_swarm_env.world.reference import reference_sense


def ridge_tin(ridge_z):
    xy = np.array([[0, 0], [0, 100], [50, 0], [50, 100], [100, 0], [100, 100]], float)
    return Tin.from_points(np.column_stack([xy, [0, 0, ridge_z, ridge_z, 0, 0]]))


def test_robot_facing_away_does_not_see_a_robot_in_range(world_params):
    w = World(None, world_params(sensor={"range_m": 50, "fov_deg": 180}))
    s = w.reset(0, [[100, 100], [120, 100]], headings=[math.pi, 0.0])  # robot 0 faces west, away
    seen = w.sense(s).robots.as_set()
    assert (0, 1) not in seen
    assert (1, 0) not in seen  # robot 1 faces east, away from robot 0 too
    s = w.reset(0, [[100, 100], [120, 100]], headings=[0.0, 0.0])
    seen = w.sense(s).robots.as_set()
    assert (0, 1) in seen and (1, 0) not in seen
    r = w.sense(s).robots
    k = list(zip(r.observer, r.target)).index((0, 1))
    assert r.distance_m[k] == pytest.approx(20.0) and r.bearing_rad[k] == pytest.approx(0.0)


@pytest.mark.parametrize("heading_deg", [90.0, -90.0, 30.0, 180.0])
def test_bearings_are_measured_from_the_heading_counterclockwise(world_params, heading_deg):
    """Robot 0 at the origin facing ``heading``; robots 20 m east, north and west of it, and a
    target north-east: each bearing is the world angle of the direction minus the heading, wrapped
    to (-pi, pi] (positive: to the robot's left), by hand."""
    w = World(None, world_params(sensor={"range_m": 50, "fov_deg": 360}))
    h = math.radians(heading_deg)
    s = w.reset(0, [[100, 100], [120, 100], [100, 120], [80, 100]], headings=[h, 0.0, 0.0, 0.0],
                targets=[[110, 110]])
    seen = w.sense(s)
    r = seen.robots
    got = {int(t): float(b) for o, t, b in zip(r.observer, r.target, r.bearing_rad) if o == 0}
    want = {1: 0.0, 2: math.pi / 2, 3: math.pi}  # world angles of east, north, west
    for j, a in want.items():
        expect = math.remainder(a - h, 2 * math.pi)
        assert abs(math.remainder(got[j] - expect, 2 * math.pi)) < 1e-12, (j, got[j], expect)
    t = seen.targets
    tb = [float(b) for o, b in zip(t.observer, t.bearing_rad) if o == 0]
    assert len(tb) == 1 and abs(math.remainder(tb[0] - (math.pi / 4 - h), 2 * math.pi)) < 1e-12


def test_ridge_blocks_sight_and_removing_it_restores_it(world_params):
    p = world_params(sensor={"range_m": 100, "fov_deg": 360, "height_m": 0.5})
    pos = [[20, 50], [80, 50]]
    w = World(ridge_tin(10.0), p)
    assert w.sense(w.reset(0, pos)).robots.as_set() == set()
    w = World(ridge_tin(0.0), p)
    assert w.sense(w.reset(0, pos)).robots.as_set() == {(0, 1), (1, 0)}
    # with line of sight switched off the ridge does not matter
    w = World(ridge_tin(10.0), world_params(sensor={"range_m": 100, "fov_deg": 360, "check_los": False}))
    assert w.sense(w.reset(0, pos)).robots.as_set() == {(0, 1), (1, 0)}
    # targets behind the ridge likewise
    w = World(ridge_tin(10.0), p)
    s = w.reset(0, pos[:1], targets=[[80, 50], [30, 50]])
    assert w.sense(s).targets.as_set() == {(0, 1)}


def test_out_of_range_and_fallen_robots_are_not_seen(world_params):
    w = World(None, world_params(sensor={"range_m": 30, "fov_deg": 360}))
    s = w.reset(0, [[100, 100], [125, 100], [140, 100]])
    assert w.sense(s).robots.as_set() == {(0, 1), (1, 0), (1, 2), (2, 1)}
    s.status[1] = Reason.FELL
    assert w.sense(s).robots.as_set() == set()
    s.status[1] = Reason.BATTERY  # present but blind
    assert w.sense(s).robots.as_set() == {(0, 1), (2, 1)}


def _sense_against_reference(world_params, random_tin, seed, n, sensor, n_entities):
    """A random world (some robots fallen or empty), its batched sensing and the per-robot
    reference's sets, the robot/target/asset contacts already checked equal; None when the
    random TIN has no traversable triangle."""
    rng = np.random.default_rng(seed)
    w = World(random_tin(seed, 40, zscale=60), world_params(sensor=sensor, robot={"max_slope_deg": 25.0,
                                                                              "max_climb_deg": 40.0},
                                                      break_angle_deg=10.0))
    if (~w.steep).sum() == 0:
        return None
    pos = spawn_positions(w.tin, w.steep, n, rng)
    ents = spawn_positions(w.tin, w.steep, 2 * n_entities, rng)
    s = w.reset(rng, pos, targets=ents[:n_entities], assets=ents[n_entities:])
    s.status[rng.random(n) < 0.2] = Reason.FELL
    s.status[rng.random(n) < 0.2] = Reason.BATTERY
    got = w.sense(s)
    ref = reference_sense(w, s)
    assert got.robots.as_set() == ref[0]
    assert got.targets.as_set() == ref[1]
    assert got.assets.as_set() == ref[2]
    return w, s, got, ref


@settings(max_examples=25)
@given(st.integers(0, 10_000), st.integers(1, 40), st.floats(20, 400), st.floats(30, 360),
       st.booleans())
def test_batched_sensing_equals_a_per_robot_loop(world_params, random_tin, seed, n, range_m, fov, los):
    sensor = {"range_m": range_m, "fov_deg": fov, "check_los": los}
    out = _sense_against_reference(world_params, random_tin, seed, n, sensor, 3)
    assume(out is not None)
    w, s, got, ref = out
    assert got.breaks.as_set() == ref[3]
    # K-nearest slots are the nearest of those sets, nearest first
    idx, dist, _ = got.robots.nearest(n, 3)
    for i in range(n):
        mine = sorted(np.hypot(*(s.positions[j] - s.positions[i])) for (o, j) in ref[0] if o == i)
        np.testing.assert_allclose(dist[i][: len(mine[:3])], mine[:3])
        assert np.all(idx[i][len(mine[:3]):] == -1)


@given(st.integers(0, 10_000), st.integers(1, 30), st.integers(1, 6))
def test_nearest_k_kernel_equals_the_stable_sort_reference(seed, n, k):
    from tin_swarm_env.world.sensing import _nearest_k, nearest_k, nearest_k_reference

    rng = np.random.default_rng(seed)
    p = int(rng.integers(0, 200))
    obs = rng.integers(0, n, p)
    key = rng.integers(0, 8, p).astype(float)  # many ties
    got = nearest_k(obs, key, n, k)
    np.testing.assert_array_equal(got, nearest_k_reference(obs, key, n, k))
    if p:
        np.testing.assert_array_equal(_nearest_k.py_func(obs, key, n, k), got)


def _line_of_robots(w, xs, headings):
    pos = np.column_stack([np.asarray(xs, float), np.full(len(xs), 250.0)])
    return w.reset(np.random.default_rng(0), pos, headings=np.asarray(headings, float))


def test_only_the_max_candidates_nearest_are_checked(world_params):
    w = World(None, world_params(sensor={"range_m": 100, "fov_deg": 360, "max_candidates": 3}))
    s = _line_of_robots(w, [100.0] + [100.0 + d for d in range(1, 11)], np.zeros(11))
    got = w.sense(s).robots
    assert {j for o, j in got.as_set() if o == 0} == {1, 2, 3}
    assert np.all(np.bincount(got.observer, minlength=11) <= 3)


def test_candidates_behind_the_observer_crowd_out_farther_ones_in_front(world_params):
    """The documented bound: the nearest max_candidates by distance are checked for FOV."""
    xs = [250.0, 251.0, 252.0, 253.0, 246.0, 245.0, 244.0]  # 3 behind (east), 3 in front (west)
    heads = [math.pi] + [0.0] * 6  # robot 0 faces west
    w3 = World(None, world_params(sensor={"range_m": 100, "fov_deg": 180, "max_candidates": 3}))
    assert {j for o, j in w3.sense(_line_of_robots(w3, xs, heads)).robots.as_set() if o == 0} == set()
    w6 = World(None, world_params(sensor={"range_m": 100, "fov_deg": 180, "max_candidates": 6}))
    assert {j for o, j in w6.sense(_line_of_robots(w6, xs, heads)).robots.as_set() if o == 0} == {4, 5, 6}


def test_contacts_per_robot_are_bounded_however_dense(world_params):
    k = 8
    w = World(None, world_params(sensor={"range_m": 60, "fov_deg": 360, "max_candidates": k}))
    rng = np.random.default_rng(1)
    n = 3000
    s = w.reset(rng, rng.uniform(240, 260, (n, 2)))  # all 3000 within range of each other
    r = w.sense(s)
    assert len(r.robots) == n * k
    d_all = np.hypot(*(s.positions[None, :, :] - s.positions[:50, None, :]).transpose(2, 0, 1))
    for i in range(50):  # the k nearest, exactly
        mine = np.sort(r.robots.distance_m[r.robots.observer == i])
        np.testing.assert_allclose(mine, np.sort(d_all[i])[1:k + 1])


@settings(max_examples=20)
@given(st.integers(0, 10_000), st.integers(2, 40), st.floats(50, 400), st.floats(30, 360), st.booleans(),
       st.integers(1, 6))
def test_batched_sensing_with_few_candidates_equals_the_per_robot_loop(world_params, random_tin, seed, n, range_m, fov,
                                                                       los, k):
    sensor = {"range_m": range_m, "fov_deg": fov, "check_los": los, "max_candidates": k}
    out = _sense_against_reference(world_params, random_tin, seed, n, sensor, 6)
    assume(out is not None)
    w, s, got, ref = out


def test_robot_bearings_are_computed_when_read_and_survive_a_pickle():
    """The robot contacts' bearings are left to their first read (the env never reads them):
    they then equal the formula of the module docstring, and a pickled copy (made before any read)
    carries the same values."""
    import pickle

    v = np.array([[0, 0, 0], [200, 0, 0], [200, 200, 0], [0, 200, 0]], float)
    w = World(Tin(v, [[0, 1, 2], [0, 2, 3]]))
    pos = np.array([[50.0, 50.0], [70.0, 50.0], [50.0, 80.0], [30.0, 40.0]])
    s = w.reset(0, pos, headings=np.array([0.0, math.pi, -math.pi / 2, 1.0]))
    r = w.sense(s).robots
    copy = pickle.loads(pickle.dumps(r))
    want = [(math.atan2(pos[j, 1] - pos[i, 1], pos[j, 0] - pos[i, 0]) - s.headings[i] + math.pi) % (2 * math.pi)
            - math.pi for i, j in zip(r.observer, r.target)]
    assert len(want) > 0
    assert r.bearing_rad.tolist() == want
    assert copy.bearing_rad.tolist() == want and copy.target.tolist() == r.target.tolist()


def test_lazy_robot_bearings_are_those_of_the_sensed_state_after_it_changes_in_place():
    """Bearings read after the state's positions and headings were overwritten in place are still
    those of the state that was sensed (sensing keeps its own copies)."""
    v = np.array([[0, 0, 0], [200, 0, 0], [200, 200, 0], [0, 200, 0]], float)
    w = World(Tin(v, [[0, 1, 2], [0, 2, 3]]))
    pos = np.array([[50.0, 50.0], [70.0, 50.0], [50.0, 80.0], [30.0, 40.0]])
    head = np.array([0.0, math.pi, -math.pi / 2, 1.0])
    s = w.reset(0, pos, headings=head)
    r = w.sense(s).robots
    want = [(math.atan2(pos[j, 1] - pos[i, 1], pos[j, 0] - pos[i, 0]) - head[i] + math.pi) % (2 * math.pi)
            - math.pi for i, j in zip(r.observer, r.target)]
    s.positions[:] = s.positions[::-1] + 3.0  # the state changes in place before anyone reads a bearing
    s.headings[:] = 2.0
    assert len(want) > 0 and r.bearing_rad.tolist() == want


def test_entities_are_sighted_at_their_height_above_the_ground():
    """A 2 m ridge between a robot (sensor 1 m up) and a target and an asset on the ground beyond it:
    their sight points ``entity_height_m`` = 5 m up clear the ridge (the line is 3 m up there); at 0 m
    the ridge hides them."""
    v = np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0], [50, 0, 2], [50, 100, 2]], float)
    tin = Tin(v, [[0, 4, 5], [0, 5, 3], [4, 1, 2], [4, 2, 5]])
    seen = {}
    for eh in (5.0, 0.0):
        p = WorldParams(robot=RobotParams(max_slope_deg=60.0, max_climb_deg=60.0),
                        sensor=SensorParams(range_m=150.0, fov_deg=360.0, height_m=1.0), entity_height_m=eh)
        w = World(tin, p)
        s = w.reset(0, [[10.0, 50.0]], headings=0.0, targets=[[90.0, 50.0]], assets=[[90.0, 40.0]])
        r = w.sense(s)
        seen[eh] = (r.targets.as_set(), r.assets.as_set())
    assert seen[5.0] == ({(0, 0)}, {(0, 0)})
    assert seen[0.0] == (set(), set())
