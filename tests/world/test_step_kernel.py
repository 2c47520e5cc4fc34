"""world/step_kernel.py: the fused step equals the kernels and numpy passes it replaced, bit for bit."""

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tin_swarm_env.world import BatteryParams, RobotParams, World, WorldParams, spawn_positions
from tin_swarm_env.world import locomotion as L
from tin_swarm_env.world import reference as REF
from tin_swarm_env.world.battery import drain
from tin_swarm_env.world.grid import grid_build
from tin_swarm_env.world.sense_kernels import collision_counts, terrain_arrays
from tin_swarm_env.world.state import Reason, is_present
from tin_swarm_env.world.step_kernel import step_kernel


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _unfused(w, s, c):
    """The step as separate passes: move_kernel, battery.drain, the status codes, collision_counts."""
    P = w.params
    pos, tri, head, speeds, ev, heights, moved, climb = REF.move_kernel(
        terrain_arrays(w.tin), w.steep, s.positions, s.tri_idx, s.headings, s.heights, s.status == Reason.NONE, c,
        P.robot.max_speed_mps, P.robot.max_climb_deg, math.radians(P.robot.turn_rate_dps) * P.dt_s, P.dt_s)
    batt = drain(s.battery_j, s.status, moved, climb, P.battery, P.dt_s)
    fell = ev == L.FELL_INTO
    status = s.status.copy()
    status[fell] = Reason.FELL
    emptied = (status == Reason.NONE) & (batt <= 0.0)
    status[emptied] = Reason.BATTERY
    present = is_present(status)
    x, y = pos[:, 0].copy(), pos[:, 1].copy()
    d = 2 * P.robot.radius_m
    coll, pairs = collision_counts(x, y, present, grid_build(x, y, present, d), d)
    return (pos, tri, head, heights, speeds, ev, moved, climb, batt, s.battery_j - batt, status, fell, emptied, coll,
            pairs)


@settings(max_examples=15)
@given(st.integers(0, 10_000), st.integers(1, 50), st.floats(0.0, 40.0))
def test_step_kernel_equals_the_unfused_passes(random_tin, seed, n, capacity):
    """Random TINs with cliffs, robots some fallen or empty, batteries that run out mid-episode
    (``capacity`` J small): every output bit for bit, over several steps."""
    rng = np.random.default_rng(seed)
    P = WorldParams(robot=RobotParams(max_slope_deg=25.0, max_climb_deg=40.0, radius_m=8.0),
                    battery=BatteryParams(capacity_j=max(capacity, 1e-3)))
    w = World(random_tin(seed, 40, zscale=60), P)
    assume((~w.steep).any())
    s = w.reset(rng, spawn_positions(w.tin, w.steep, n, rng))
    s.status[rng.random(n) < 0.15] = Reason.FELL
    s.battery_j[rng.random(n) < 0.2] = 0.0
    B = P.battery
    for _ in range(4):
        c = rng.uniform(-1.5, 1.5, (n, 2)) * rng.uniform(0, 30)
        want = _unfused(w, s, c)
        got = step_kernel(terrain_arrays(w.tin), w.steep, s.positions, s.tri_idx, s.headings, s.heights, s.status,
                          s.battery_j, c, P.robot.max_speed_mps, P.robot.max_climb_deg,
                          math.radians(P.robot.turn_rate_dps) * P.dt_s, P.dt_s, (B.idle_w + B.sensing_w) * P.dt_s,
                          B.drive_j_per_m, B.climb_j_per_m, 2 * P.robot.radius_m)
        assert len(got) == len(want)
        for a, b in zip(got, want, strict=True):
            _same(a, b)
        s, _ = w.step(s, c)
        _same(s.positions, got[0])
        _same(s.status, got[10])


def test_a_fall_and_an_empty_battery_by_hand(world_params):
    """Flat world: robot 0 drives with 1 J left (runs dry: BATTERY, charge 0, energy 1 J);
    robot 1 already empty draws nothing and stays; robots 2 and 3 touch (one pair)."""
    w = World(None, world_params(battery={"capacity_j": 100.0, "idle_w": 1.0, "sensing_w": 1.0,
                                          "drive_j_per_m": 10.0, "climb_j_per_m": 0.0},
                                 robot={"radius_m": 1.0}, dt_s=1.0))
    s = w.reset(0, [[100, 100], [200, 100], [300, 300], [301, 300]], headings=0.0)
    s.battery_j[0] = 1.0
    s.battery_j[1] = 0.0
    s.status[1] = Reason.BATTERY
    s2, ev = w.step(s, np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 0.0]]))
    assert s2.status.tolist() == [Reason.BATTERY, Reason.BATTERY, Reason.NONE, Reason.NONE]
    assert s2.battery_j[:2].tolist() == [0.0, 0.0] and ev.energy_j[:2].tolist() == [1.0, 0.0]
    assert ev.emptied.tolist() == [True, False, False, False] and not ev.fell.any()
    assert s2.positions[1].tolist() == [200.0, 100.0] and s2.positions[0, 0] > 100.0
    assert ev.collisions.tolist() == [0, 0, 1, 1] and ev.collision_pairs.tolist() == [[2, 3]]
    assert s.status[0] == Reason.NONE and s.battery_j[0] == 1.0  # the old state is not modified
