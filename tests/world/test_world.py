"""The swarm world (world/world.py): collisions, the flat world, determinism, bad input named."""

import numpy as np
import pytest

from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import (
    RobotParams,
    SensorParams,
    World,
    spawn_positions,
)


def test_collisions_are_counted_not_resolved(world_params):
    w = World(None, world_params(robot={"radius_m": 1.0}))
    s = w.reset(0, [[100, 100], [101.5, 100], [110, 100]], headings=0.0)
    s, ev = w.step(s, np.zeros((3, 2)))
    assert ev.collisions.tolist() == [1, 1, 0] and s.collisions.tolist() == [1, 1, 0]
    assert ev.collision_pairs.tolist() == [[0, 1]]
    np.testing.assert_array_equal(s.positions[:2], [[100, 100], [101.5, 100]])


def test_flat_world_matches_the_tin_world_on_a_flat_tin(world_params):
    rng = np.random.default_rng(5)
    xy = np.vstack([[[0, 0], [500, 0], [500, 500], [0, 500]], rng.uniform(0, 500, (300, 2))])
    flat_many = Tin.from_points(np.column_stack([xy, np.zeros(len(xy))]))
    p = world_params(sensor={"range_m": 80})
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


def test_same_seed_same_commands_same_trajectories_bit_for_bit(world_params, random_tin):
    tin = random_tin(3, 60, zscale=40)

    def run(seed):
        w = World(tin, world_params(robot={"max_slope_deg": 20.0, "max_climb_deg": 40.0}))
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


# -- bad input ------------------------------------------------------------------------------


def test_bad_input_is_named(cliff_tin):
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


def test_the_state_counts_collisions_over_the_episode_and_the_events_per_step(world_params):
    w = World(None, world_params())
    s = w.reset(0, [[100.0, 100.0], [100.5, 100.0], [200.0, 200.0]], headings=[0.0, 0.0, 0.0])
    for step in (1, 2):
        s, ev = w.step(s, np.zeros((3, 2)))  # robots 0 and 1 stand 0.5 m apart (radius 0.5 m: touching)
        assert ev.collisions.tolist() == [1, 1, 0]
        assert s.collisions.tolist() == [step, step, 0]
