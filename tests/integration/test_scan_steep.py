"""Ground too steep to drive, with no cliff: a drivable plain, a gentle ramp, then a hillside
steeper than the robots' limit. The foot of the too-steep hillside is a STEEP break (no angle
break anywhere: the planes meet at 20 and 15 deg, under the 25 deg break angle), so it is a
dangerous break in the break slots and each scan beam that crosses it reads the range to it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.scenario import scenario_from_dict
from tin_swarm_env.terrain import STEEP, Tin, save_tin

R = 100.0  # sensor range, m
FOOT_X = 130.0  # where the 35 deg hillside starts (the 20 deg ramp below it is drivable)
XS = np.array([0.0, 100.0, FOOT_X, 180.0])  # plain 0..100, ramp 20 deg to 130, hillside 35 deg to 180
ZS = np.array([0.0, 0.0, 30 * math.tan(math.radians(20)), 30 * math.tan(math.radians(20)) + 50 * math.tan(math.radians(35))])
Y0, Y1 = -50.0, 50.0


@pytest.fixture(scope="module")
def hillside(tmp_path_factory):
    pts = [(x, y, z) for x, z in zip(XS, ZS, strict=True) for y in (Y0, 0.0, Y1)]
    tin = Tin.from_points(np.array(pts))
    path = tmp_path_factory.mktemp("hillside") / "hillside.npz"
    save_tin(tin, path)
    env = tse.parallel_env(scenario=scenario_from_dict({
        "name": "hillside", "task": "goal", "max_cycles": 5, "terrain": {"source": "tin", "path": str(path)},
        "robots": {"count": 1, "max_slope_deg": 30.0}, "sensor": {"range_m": R, "fov_deg": 360.0},
        "targets": {"positions": [[20.0, 0.0]], "arrival_radius_m": 1.0},
        "observation": {"k_scan": 8, "k_breaks": 8}}, source="hillside"))
    return env


def test_the_hillside_foot_is_the_only_inner_break_and_it_is_steep(hillside):
    br = hillside.world.breaks
    inner = br.unsafe_idx >= 0
    assert inner.sum() == 2  # the two edges along x = FOOT_X (one per strip of triangles)
    assert np.all(br.kinds[inner] == STEEP)
    np.testing.assert_allclose(br.segments[inner][:, :, 0], FOOT_X)
    assert np.all(br.normals[inner, 0] < -0.999)  # safe side: toward the plain


@pytest.mark.parametrize("x,heading_deg", [(60.0, 0.0), (115.0, 0.0), (60.0, 30.0), (60.0, 90.0)])
def test_the_beam_toward_the_hillside_reads_the_range_to_its_foot(hillside, x, heading_deg):
    lay = hillside.layout
    h = math.radians(heading_deg)
    obs = hillside.reset_arrays(seed=0, options={"robot_positions": np.array([[x, 0.0]]), "headings": np.array([h])})
    scan = obs[0, lay.scan]
    east = (-round(heading_deg / 45.0)) % 8  # the beam whose world bearing is east (beams every 45 deg)
    want = min(FOOT_X - x, R) / R
    if heading_deg % 45 == 0:
        assert scan[east] == pytest.approx(want, abs=1e-6)
    # every beam: the nearest of the hillside's foot and the border along its world bearing
    for k in range(8):
        a = h + 2 * math.pi * k / 8
        dx, dy = math.cos(a), math.sin(a)
        ts = [t for t in ((FOOT_X - x) / dx if dx > 1e-12 else math.inf, (0.0 - x) / dx if dx < -1e-12 else math.inf,
                          (Y1 / dy) if dy > 1e-12 else math.inf, (Y0 / dy) if dy < -1e-12 else math.inf)]
        assert scan[k] == pytest.approx(min(min(ts), R) / R, abs=1e-6), k


def test_the_foot_fills_a_dangerous_break_slot(hillside):
    lay = hillside.layout
    x = 60.0
    obs = hillside.reset_arrays(seed=0, options={"robot_positions": np.array([[x, 0.0]]),
                                                 "headings": np.array([0.0])})
    valid = lay.field(obs, "breaks", "valid")[0] > 0.5
    d = lay.field(obs, "breaks", "d")[0] * R
    danger = lay.field(obs, "breaks", "danger")[0]
    nx = lay.field(obs, "breaks", "nx")[0]
    foot = valid & np.isclose(d, FOOT_X - x, atol=1e-4)
    assert foot.any()
    assert np.all(danger[foot] == 1.0) and np.all(nx[foot] < -0.999)  # dangerous, safe side behind the robot
