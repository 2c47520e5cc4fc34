"""The swarm world: hand-built states with exact expectations, and batched vs reference."""

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
    Reason,
    RobotParams,
    SensorParams,
    World,
    WorldParams,
    spawn_positions,
)
from tin_swarm_env.world import locomotion as L
from tin_swarm_env.world.reference import reference_sense


def cliff_tin(width=0.5, top=100.0):
    """Plateau at `top` m for x <= 100, a cliff face one triangle pair wide (x 100..100+width),
    floor at 0 m up to x = 200; y in [0, 100]."""
    xs = [0.0, 100.0, 100.0 + width, 200.0]
    zs = [top, top, 0.0, 0.0]
    return Tin.from_points(np.array([(x, y, z) for x, z in zip(xs, zs) for y in (0.0, 100.0)]))


def ridge_tin(ridge_z):
    xy = np.array([[0, 0], [0, 100], [50, 0], [50, 100], [100, 0], [100, 100]], float)
    return Tin.from_points(np.column_stack([xy, [0, 0, ridge_z, ridge_z, 0, 0]]))


def params(**kw):
    robot = RobotParams(**kw.pop("robot", {}))
    sensor = SensorParams(**kw.pop("sensor", {}))
    battery = BatteryParams(**kw.pop("battery", {}))
    return WorldParams(robot=robot, sensor=sensor, battery=battery, **kw)


# -- sensing: hand-built --------------------------------------------------------------------


def test_robot_facing_away_does_not_see_a_robot_in_range():
    w = World(None, params(sensor={"range_m": 50, "fov_deg": 180}))
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


def test_ridge_blocks_sight_and_removing_it_restores_it():
    p = params(sensor={"range_m": 100, "fov_deg": 360, "height_m": 0.5})
    pos = [[20, 50], [80, 50]]
    w = World(ridge_tin(10.0), p)
    assert w.sense(w.reset(0, pos)).robots.as_set() == set()
    w = World(ridge_tin(0.0), p)
    assert w.sense(w.reset(0, pos)).robots.as_set() == {(0, 1), (1, 0)}
    # with line of sight switched off the ridge does not matter
    w = World(ridge_tin(10.0), params(sensor={"range_m": 100, "fov_deg": 360, "check_los": False}))
    assert w.sense(w.reset(0, pos)).robots.as_set() == {(0, 1), (1, 0)}
    # targets behind the ridge likewise
    w = World(ridge_tin(10.0), p)
    s = w.reset(0, pos[:1], targets=[[80, 50], [30, 50]])
    assert w.sense(s).targets.as_set() == {(0, 1)}


def test_out_of_range_and_fallen_robots_are_not_seen():
    w = World(None, params(sensor={"range_m": 30, "fov_deg": 360}))
    s = w.reset(0, [[100, 100], [125, 100], [140, 100]])
    assert w.sense(s).robots.as_set() == {(0, 1), (1, 0), (1, 2), (2, 1)}
    s.status[1] = Reason.FELL
    assert w.sense(s).robots.as_set() == set()
    s.status[1] = Reason.BATTERY  # present but blind
    assert w.sense(s).robots.as_set() == {(0, 1), (2, 1)}


# -- locomotion: hand-built -----------------------------------------------------------------


def test_driving_down_into_a_cliff_falls_and_up_into_it_is_blocked():
    w = World(cliff_tin(width=5.0), params(robot={"max_speed_mps": 2.0}, dt_s=1.0))
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
def test_no_tunnelling_through_a_one_triangle_wide_cliff(speed):
    w = World(cliff_tin(width=0.05), params(robot={"max_speed_mps": speed}, dt_s=1.0))
    x0 = 99.9
    s = w.reset(0, [[x0, 50.0], [100.2, 50.0]], headings=[0.0, math.pi])
    s, ev = w.step(s, [[1.0, 0.0], [1.0, 0.0]])
    assert ev.motion_event.tolist() == [FELL_INTO, BLOCKED_STEEP]
    assert s.positions[0, 0] < 100.05 and s.positions[1, 0] > 100.05


def test_border_blocks():
    w = World(None, params(robot={"max_speed_mps": 5.0}, dt_s=1.0, flat_size_m=(10.0, 10.0)))
    s = w.reset(0, [[8.0, 5.0]], headings=[0.0])
    s, ev = w.step(s, [[1.0, 0.0]])
    assert ev.motion_event[0] == BLOCKED_BORDER
    assert s.positions[0, 0] == pytest.approx(10.0 - 1e-3) and s.status[0] == Reason.NONE


def test_uphill_slows_by_pitch_and_downhill_does_not():
    g = math.tan(math.radians(15))
    xy = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], float)
    tin = Tin.from_points(np.column_stack([xy, g * xy[:, 0]]))  # rises to the east at 15 deg
    w = World(tin, params(robot={"max_speed_mps": 2.0, "max_climb_deg": 45.0}, dt_s=1.0))
    s = w.reset(0, [[50, 30], [50, 60], [50, 90]], headings=[0.0, math.pi, math.pi / 2])
    s, ev = w.step(s, np.array([[1.0, 0.0]] * 3))
    np.testing.assert_allclose(ev.moved_m, [2.0 * (1 - 15 / 45), 2.0, 2.0])
    np.testing.assert_allclose(ev.climb_m, [g * 2.0 * (1 - 15 / 45), -g * 2.0, 0.0], atol=1e-12)


def test_heading_turns_toward_motion_at_most_the_turn_rate():
    w = World(None, params(robot={"turn_rate_dps": 90.0}, dt_s=0.5))
    s = w.reset(0, [[100, 100], [200, 200]], headings=[0.0, 0.0])
    s, _ = w.step(s, [[0.0, 1.0], [1.0, 0.0]])  # robot 0 moves left (north): turns 45 deg
    np.testing.assert_allclose(s.headings, [math.radians(45), 0.0])
    np.testing.assert_allclose(s.positions[0], [100, 101])  # moved north, body-left of east
    s, _ = w.step(s, [[0.0, 0.0], [-1.0, 0.0]])
    assert s.headings[0] == pytest.approx(math.radians(45))  # no motion, no turn
    assert abs(s.headings[1]) == pytest.approx(math.radians(45))


def test_commands_clipped_to_the_unit_disc():
    w = World(None, params(robot={"max_speed_mps": 2.0}, dt_s=1.0))
    s = w.reset(0, [[100, 100]], headings=[0.0])
    s, ev = w.step(s, [[5.0, 5.0]])
    assert ev.moved_m[0] == pytest.approx(2.0)


def test_battery_never_increases_and_an_empty_robot_never_moves_again():
    bp = {"capacity_j": 100.0, "idle_w": 1.0, "sensing_w": 1.0, "drive_j_per_m": 10.0, "climb_j_per_m": 0.0}
    w = World(None, params(battery=bp, robot={"max_speed_mps": 1.0}, dt_s=1.0))
    s = w.reset(0, [[100, 100], [200, 100]], headings=[0.0, 0.0])
    rng = np.random.default_rng(0)
    prev = s.battery_j.copy()
    history = []
    for _ in range(20):
        s, ev = w.step(s, rng.uniform(-1, 1, (2, 2)))
        assert np.all(s.battery_j <= prev) and np.all(s.battery_j >= 0)
        prev = s.battery_j.copy()
        history.append((s.status.copy(), s.positions.copy()))
    assert np.all(s.status == Reason.BATTERY) and np.all(s.battery_j == 0)
    first_empty = next(k for k, (st_, _) in enumerate(history) if st_[0] == Reason.BATTERY)
    for st_, p in history[first_empty:]:
        np.testing.assert_array_equal(p[0], history[first_empty][1][0])


def test_collisions_are_counted_not_resolved():
    w = World(None, params(robot={"radius_m": 1.0}))
    s = w.reset(0, [[100, 100], [101.5, 100], [110, 100]], headings=0.0)
    s, ev = w.step(s, np.zeros((3, 2)))
    assert ev.collisions.tolist() == [1, 1, 0] and s.collisions.tolist() == [1, 1, 0]
    assert ev.collision_pairs.tolist() == [[0, 1]]
    np.testing.assert_array_equal(s.positions[:2], [[100, 100], [101.5, 100]])


def test_flat_world_matches_the_tin_world_on_a_flat_tin():
    rng = np.random.default_rng(5)
    xy = np.vstack([[[0, 0], [500, 0], [500, 500], [0, 500]], rng.uniform(0, 500, (300, 2))])
    flat_many = Tin.from_points(np.column_stack([xy, np.zeros(len(xy))]))
    p = params(sensor={"range_m": 80})
    wa, wb = World(None, p), World(flat_many, p)
    assert wa.flat and not wb.flat
    pos = spawn_positions(wa.tin, wa.steep, 40, np.random.default_rng(1), region=(50, 50, 450, 450))
    sa = wa.reset(7, pos, targets=[[250, 250]], targets_mobile=True)
    sb = wb.reset(7, pos, targets=[[250, 250]], targets_mobile=True)
    cr = np.random.default_rng(2)
    for _ in range(50):
        c = cr.uniform(-1, 1, (40, 2))
        sa, ea = wa.step(sa, c)
        sb, eb = wb.step(sb, c)
        np.testing.assert_array_equal(sa.positions, sb.positions)
        np.testing.assert_array_equal(sa.headings, sb.headings)
        np.testing.assert_array_equal(sa.battery_j, sb.battery_j)
        np.testing.assert_array_equal(sa.targets.positions, sb.targets.positions)
    ra, rb = wa.sense(sa), wb.sense(sb)
    assert ra.robots.as_set() == rb.robots.as_set() and ra.targets.as_set() == rb.targets.as_set()


def test_same_seed_same_commands_same_trajectories_bit_for_bit(random_tin):
    tin = random_tin(3, 60, zscale=40)

    def run(seed):
        w = World(tin, params(robot={"max_slope_deg": 20.0, "max_climb_deg": 40.0}))
        rng = np.random.default_rng(seed)
        pos = spawn_positions(w.tin, w.steep, 50, rng)
        s = w.reset(rng, pos, targets=pos[:3], targets_mobile=True, assets=pos[3:5], assets_mobile=True)
        out = []
        cr = np.random.default_rng(99)
        for _ in range(40):
            s, _ = w.step(s, cr.uniform(-1, 1, (50, 2)))
            out.append(np.concatenate([s.positions.ravel(), s.headings, s.battery_j, s.status,
                                       s.targets.positions.ravel(), s.assets.positions.ravel()]))
        return np.array(out)

    a, b, c = run(11), run(11), run(12)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_mobile_entities_stay_on_traversable_ground():
    w = World(cliff_tin(width=5.0), params(entity_speed_mps=3.0, entity_turn_sd_deg=60))
    s = w.reset(0, [[50, 50]], targets=[[150, 50], [20, 20]], targets_mobile=[True, False])
    for _ in range(300):
        s, _ = w.step(s, [[0.0, 0.0]])
        assert not w.steep[s.targets.tri_idx].any()
        np.testing.assert_array_equal(s.targets.positions[1], [20, 20])
    assert s.targets.positions[0, 0] > 105  # stayed below the cliff


# -- bad input ------------------------------------------------------------------------------


def test_bad_input_is_named():
    w = World(cliff_tin(width=5.0))
    with pytest.raises(ValueError, match="at least one robot"):
        w.reset(0, np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"robot 1 at \[300.0, 50.0\] lies outside"):
        w.reset(0, [[10, 10], [300, 50]])
    with pytest.raises(ValueError, match=r"robot 0 at \[102.0, 50.0\] lies on a too-steep"):
        w.reset(0, [[102, 50]])
    with pytest.raises(ValueError, match="target 0 .* too-steep"):
        w.reset(0, [[10, 10]], targets=[[102, 50]])
    s = w.reset(0, [[10, 10], [20, 20]])
    with pytest.raises(ValueError, match=r"robot 1: command \[nan, 0.0\] is not finite"):
        w.step(s, [[0, 0], [np.nan, 0]])
    with pytest.raises(ValueError, match=r"shape \(2, 2\)"):
        w.step(s, [[0, 0]])
    with pytest.raises(ValueError, match="range_m"):
        SensorParams(range_m=0)
    with pytest.raises(ValueError, match="max_climb_deg"):
        RobotParams(max_slope_deg=40, max_climb_deg=30)


# -- batched vs per-robot reference -------------------------------------------------------------


def _sense_against_reference(random_tin, seed, n, sensor, n_entities):
    """A random world (some robots fallen or empty), its batched sensing and the per-robot
    reference's sets, the robot/target/asset contacts already checked equal; None when the
    random TIN has no traversable triangle."""
    rng = np.random.default_rng(seed)
    w = World(random_tin(seed, 40, zscale=60), params(sensor=sensor, robot={"max_slope_deg": 25.0,
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
def test_batched_sensing_equals_a_per_robot_loop(random_tin, seed, n, range_m, fov, los):
    out = _sense_against_reference(random_tin, seed, n, {"range_m": range_m, "fov_deg": fov, "check_los": los}, 3)
    assume(out is not None)
    w, s, got, ref = out
    assert got.breaks.as_set() == ref[3]
    # K-nearest slots are the nearest of those sets, nearest first
    idx, dist, _ = got.robots.nearest(n, 3)
    for i in range(n):
        mine = sorted(np.hypot(*(s.positions[j] - s.positions[i])) for (o, j) in ref[0] if o == i)
        np.testing.assert_allclose(dist[i][: len(mine[:3])], mine[:3])
        assert np.all(idx[i][len(mine[:3]):] == -1)


# -- locomotion kernel vs a sub-stepping reference -------------------------------------------------


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
def test_locomotion_walk_matches_substepping(random_tin, seed):
    tin = random_tin(seed, 30, zscale=150)
    w = World(tin, params(robot={"max_slope_deg": 15.0, "max_climb_deg": 80.0}))
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


# -- bounded neighbours per robot (sensing memory linear in robots at any density) ----------------


def _line_of_robots(w, xs, headings):
    pos = np.column_stack([np.asarray(xs, float), np.full(len(xs), 250.0)])
    return w.reset(np.random.default_rng(0), pos, headings=np.asarray(headings, float))


def test_only_the_max_candidates_nearest_are_checked():
    w = World(None, params(sensor={"range_m": 100, "fov_deg": 360, "max_candidates": 3}))
    s = _line_of_robots(w, [100.0] + [100.0 + d for d in range(1, 11)], np.zeros(11))
    got = w.sense(s).robots
    assert {j for o, j in got.as_set() if o == 0} == {1, 2, 3}
    assert np.all(np.bincount(got.observer, minlength=11) <= 3)


def test_candidates_behind_the_observer_crowd_out_farther_ones_in_front():
    """The documented bound: the nearest max_candidates by distance are checked for FOV."""
    xs = [250.0, 251.0, 252.0, 253.0, 246.0, 245.0, 244.0]  # 3 behind (east), 3 in front (west)
    heads = [math.pi] + [0.0] * 6  # robot 0 faces west
    w3 = World(None, params(sensor={"range_m": 100, "fov_deg": 180, "max_candidates": 3}))
    assert {j for o, j in w3.sense(_line_of_robots(w3, xs, heads)).robots.as_set() if o == 0} == set()
    w6 = World(None, params(sensor={"range_m": 100, "fov_deg": 180, "max_candidates": 6}))
    assert {j for o, j in w6.sense(_line_of_robots(w6, xs, heads)).robots.as_set() if o == 0} == {4, 5, 6}


def test_contacts_per_robot_are_bounded_however_dense():
    k = 8
    w = World(None, params(sensor={"range_m": 60, "fov_deg": 360, "max_candidates": k}))
    rng = np.random.default_rng(1)
    n = 3000
    s = w.reset(rng, rng.uniform(240, 260, (n, 2)))  # all 3000 within range of each other
    r = w.sense(s)
    assert len(r.robots) == n * k
    d_all = np.hypot(*(s.positions[None, :, :] - s.positions[:50, None, :]).transpose(2, 0, 1))
    for i in range(50):  # the k nearest, exactly
        mine = np.sort(r.robots.distance_m[r.robots.observer == i])
        np.testing.assert_allclose(mine, np.sort(d_all[i])[1:k + 1])


def test_max_candidates_must_be_a_positive_integer():
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="max_candidates"):
            SensorParams(max_candidates=bad)


@settings(max_examples=20)
@given(st.integers(0, 10_000), st.integers(2, 40), st.floats(50, 400), st.floats(30, 360), st.booleans(),
       st.integers(1, 6))
def test_batched_sensing_with_few_candidates_equals_the_per_robot_loop(random_tin, seed, n, range_m, fov, los, k):
    out = _sense_against_reference(random_tin, seed, n, {"range_m": range_m, "fov_deg": fov, "check_los": los,
                                             "max_candidates": k}, 6)
    assume(out is not None)
    w, s, got, ref = out


def test_the_state_counts_collisions_over_the_episode_and_the_events_per_step():
    w = World(None, params())
    s = w.reset(0, [[100.0, 100.0], [100.5, 100.0], [200.0, 200.0]], headings=[0.0, 0.0, 0.0])
    for step in (1, 2):
        s, ev = w.step(s, np.zeros((3, 2)))  # robots 0 and 1 stand 0.5 m apart (radius 0.5 m: touching)
        assert ev.collisions.tolist() == [1, 1, 0]
        assert s.collisions.tolist() == [step, step, 0]
