"""world/battery.py by hand: what each term draws, descents and robots that are not active."""

import numpy as np

from tin_swarm_env.world import (
    BatteryParams,
    World,
)
from tin_swarm_env.world.battery import drain
from tin_swarm_env.world.state import Reason

P = BatteryParams(capacity_j=1000.0, idle_w=2.0, sensing_w=3.0, drive_j_per_m=20.0, climb_j_per_m=200.0)


def test_each_term_by_hand_descents_draw_no_climb_energy_and_inactive_robots_draw_nothing():
    status = np.array([Reason.NONE, Reason.NONE, Reason.NONE, Reason.FELL, Reason.BATTERY, Reason.ARRIVED], np.int8)
    charge = np.array([500.0, 500.0, 30.0, 500.0, 0.0, 500.0])
    dist = np.array([2.0, 2.0, 2.0, 2.0, 2.0, 2.0])
    climb = np.array([0.5, -3.0, 0.0, 1.0, 1.0, 1.0])
    # 0: (2 + 3) W * 0.5 s + 20 J/m * 2 m + 200 J/m * 0.5 m = 2.5 + 40 + 100 = 142.5 J
    # 1: downhill: 2.5 + 40, no climb term (and no refund) = 42.5 J
    # 2: 42.5 J asked, 30 J left: empty at 0, never negative
    # 3-5: fell, empty, arrived: nothing drawn
    got = drain(charge, status, dist, climb, P, 0.5)
    assert got.tolist() == [357.5, 457.5, 0.0, 500.0, 0.0, 500.0]


def test_battery_never_increases_and_an_empty_robot_never_moves_again(world_params):
    bp = {"capacity_j": 100.0, "idle_w": 1.0, "sensing_w": 1.0, "drive_j_per_m": 10.0, "climb_j_per_m": 0.0}
    w = World(None, world_params(battery=bp, robot={"max_speed_mps": 1.0}, dt_s=1.0))
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
