"""world/step_kernel.py: the one step pass (step_copies, the world's and the vector env's) equals the
kernels and numpy passes it fuses, bit for bit; collisions per copy equal all pairs."""

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tin_swarm_env.world import BatteryParams, RobotParams, World, WorldParams, spawn_positions
from tin_swarm_env.world import locomotion as L
from tin_swarm_env.world import reference as REF
from tin_swarm_env.world.battery import drain
from tin_swarm_env.world.grid import grid_build_copies
from tin_swarm_env.world.pack import one_copy, pack_one
from tin_swarm_env.world.sense_kernels import terrain_arrays
from tin_swarm_env.world.state import Reason, is_present
from tin_swarm_env.world.step_kernel import collisions, step_copies
from tin_swarm_env.world.world import step_scalars


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _all_pairs(x, y, present, cop, d):
    """``(collisions (n,), pairs (C, 2))`` by brute force: robots of one copy, both present, closer than ``d``."""
    dist = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    touch = (dist < d) & present[:, None] & present[None, :] & (cop[:, None] == cop[None, :])
    np.fill_diagonal(touch, False)
    return touch.sum(axis=1).astype(np.int64), np.argwhere(np.triu(touch)).astype(np.int64).reshape(-1, 2)


def _unfused(w, s, c):
    """The step as separate passes: move_kernel, battery.drain, the status codes, all pairs."""
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
    coll, pairs = _all_pairs(x, y, present, np.zeros(len(x), dtype=np.int64), d)
    return (pos, tri, head, heights, speeds, ev, moved, climb, batt, s.battery_j - batt, status, fell, emptied, coll,
            pairs)


@settings(max_examples=15)
@given(st.integers(0, 10_000), st.integers(1, 50), st.floats(0.0, 40.0))
def test_step_copies_on_one_copy_equals_the_unfused_passes(random_tin, seed, n, capacity):
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
    pk = pack_one(w)
    wor, cop, off = one_copy(n)
    for _ in range(4):
        c = rng.uniform(-1.5, 1.5, (n, 2)) * rng.uniform(0, 30)
        want = _unfused(w, s, c)
        got = step_copies(pk.T0, pk.steep, wor, cop, off, s.positions, s.tri_idx, s.headings, s.heights, s.status,
                          s.battery_j, c, step_scalars(P))
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


@settings(max_examples=30)
@given(st.lists(st.integers(0, 40), min_size=1, max_size=4), st.integers(0, 2 ** 31), st.floats(0.1, 50))
def test_collisions_per_copy_equal_all_pairs(sizes, seed, diameter):
    """Copies side by side on the same ground (their robots overlap in space): a robot touches only
    robots of its own copy; exact ties and duplicates; the pairs in (i, j) order."""
    rng = np.random.default_rng(seed)
    n = sum(sizes)
    off = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    cop = np.repeat(np.arange(len(sizes)), sizes).astype(np.int64)
    xy = rng.uniform(0, 100, (n, 2))
    xy[: n // 3] = np.round(xy[: n // 3])
    present = rng.random(n) < 0.8
    x, y = xy[:, 0].copy(), xy[:, 1].copy()
    coll, pairs = collisions(x, y, cop, grid_build_copies(x, y, present, off, diameter), diameter)
    want_coll, want_pairs = _all_pairs(x, y, present, cop, diameter)
    np.testing.assert_array_equal(coll, want_coll)
    np.testing.assert_array_equal(pairs.reshape(-1, 2), want_pairs)
