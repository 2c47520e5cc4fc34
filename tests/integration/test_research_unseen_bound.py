"""research/unseen_bound.py (run by hand, research/unseen_bound.md): the idealised map-less robot on an
open map arrives within the octile bound of the straight way; on a wall across the straight way it
takes the way round; the table reads the bench's records as they are written."""

import math

import numpy as np
import pytest

import tin_swarm_env as tse


@pytest.fixture
def ub(repo_script):
    return repo_script("research/unseen_bound.py")


def _shape(ub, name, fn, monkeypatch):
    monkeypatch.setitem(ub.UNSEEN.SHAPES, name, fn)
    return name


def _steps(ub, tmp_path, name, robots=3, cap=600):
    env = tse.parallel_env(scenario=ub.UNSEEN.shape_config(name, tmp_path, "", robots, cap))
    return env, *ub.ideal_steps(env, 0, "scan", cap)


def test_on_open_ground_it_drives_the_straight_way(ub, tmp_path, monkeypatch):
    name = _shape(ub, "flat_test", lambda X, Y: (np.zeros(X.shape), (250.0, 150.0)), monkeypatch)
    env, steps, geo = _steps(ub, tmp_path, name)
    b = env.unwrapped
    p = b.world.params
    step_m = p.robot.max_speed_mps * p.dt_s
    pos = np.asarray(b.world_state.positions)[:, :2]
    d = np.hypot(*(pos - [250.0, 150.0]).T)
    arrive = b.config.targets.arrival_radius_m
    lo = np.floor((d - arrive) / step_m)  # the straight way, less the arrival radius
    hi = np.ceil((d * (1 + (math.sqrt(2) - 1) * 0.25) + 2 * ub.RASTER_M) / step_m)  # an 8-connected way
    assert np.all(steps >= lo) and np.all(steps <= hi), (steps, lo, hi)
    assert np.allclose(geo, d / step_m, rtol=0.02)  # no wall: the geodesic is the straight line


def test_a_wall_across_the_way_is_driven_round(ub, tmp_path, monkeypatch):
    def wall(X, Y):  # a 10 m cliff wall across the straight way, x 140..146, y 60..240
        return np.where((np.abs(X - 143.0) <= 3.0) & (np.abs(Y - 150.0) <= 90.0), 10.0, 0.0), (250.0, 150.0)

    name = _shape(ub, "wall_test", wall, monkeypatch)
    env, steps, geo = _steps(ub, tmp_path, name, cap=1500)
    pos = np.asarray(env.unwrapped.world_state.positions)[:, :2]
    straight = np.hypot(*(pos - [250.0, 150.0]).T) / (env.unwrapped.world.params.robot.max_speed_mps
                                                      * env.unwrapped.world.params.dt_s)
    assert np.all(steps <= 1500)  # it arrives
    assert np.all(steps > geo - 10) and np.all(geo > straight + 20)  # round the wall, no shorter than the map allows


def test_share_by_counts_arrivals_at_the_horizon(ub):
    assert ub.share_by([100, 200, 201, 2501], 200) == 0.5
    assert ub.share_by([1], 0) == 0.0


def test_the_table_reads_the_bench_records(ub, monkeypatch):
    rec = {"horizon": 100, "rows": {im: {"apf": {"n": 4, "arrived": 1, "median": 90.0}} for im in ub.IMAGES},
           "at_long": {im: {"apf": {"arrived": 3, "fell": 0}} for im in ub.IMAGES}}
    monkeypatch.setattr(ub, "_record", lambda shape: rec)
    res = {("s", im, se): (np.array([50, 150, 250, 2501]), np.array([40.0, 40, 40, 40]))
           for im in ub.IMAGES for se in ub.SENSING}
    rows = ub.table(res, ["s"], 1, 4)
    assert len(rows) == 2 + len(ub.IMAGES) * len(ub.SENSING)
    cells = [c.strip() for c in rows[2].strip("|").split("|")]
    assert cells[:3] == ["s", "as built", "scan"]
    assert cells[6:] == ["25.0%", "50.0%", "40", "100", "90", "25.0%", "75.0%"]
