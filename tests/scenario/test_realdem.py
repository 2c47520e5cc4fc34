"""The ``realdem`` generated family (scenario/realdem.py): crops of the bundled real DEMs with
their slopes kept, the robots' slope limit drawn per task, spawn and target a detour apart on the
drivable ground; reproducible, solvable by the cost-to-go, mirrored, and refused by name when the
ranges are bad. The scenario builder gives the robots the task's own limit."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env import terrain as T
from tin_swarm_env.scenario import generators as gen
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario import realdem as rd
from tin_swarm_env.scenario.build import build_stage
from tin_swarm_env.scenario.config import ScenarioError
from tin_swarm_env.scenario.generators import ALL_FAMILIES, REAL_FAMILIES, generate, replay

SEEDS = range(16)


def draw(seed, **ranges):
    return generate(np.random.default_rng(seed), ("realdem",), {"realdem": ranges} if ranges else None)


@pytest.fixture(scope="module")
def tasks():
    return [draw(s) for s in SEEDS]


def same(a, b):
    return (np.array_equal(a.dem.z, b.dem.z) and np.array_equal(a.dem.x, b.dem.x) and a.spawn_region == b.spawn_region
            and np.array_equal(a.targets, b.targets) and a.params == b.params and a.detour_side == b.detour_side
            and a.seed == b.seed and a.detour_min == b.detour_min)


def test_same_seed_same_task_bit_for_bit_and_replay_rebuilds_it(tasks):
    for s in (0, 5):
        assert same(draw(s), tasks[s])
        assert same(replay(tasks[s]), tasks[s])
    assert not same(tasks[0], tasks[1])
    t = tasks[0]
    assert t.family == "realdem" and t.dem.source == "generated:realdem" and t.passes.shape == (0, 2, 2)
    # the robots' limit among the parameters is the drawn one, and a given one is ignored
    again = gen.FAMILIES["realdem"](np.random.default_rng(t.seed), **{**t.params, "max_slope_deg": 30.0})
    assert same(gen.dataclasses.replace(again, seed=t.seed), t)


def _field(task):
    tin = T.build_tin(task.dem, **rd.MESH)
    passable = tin.slope_deg <= task.params["max_slope_deg"]
    return tin, passable, T.cost_to_go(tin, task.targets[0], passable)


def test_every_draw_is_solvable_by_the_cost_to_go_and_a_detour(tasks):
    for t in tasks:
        tin, passable, f = _field(t)
        s, g = t.spawn_centre, t.targets[0]
        way, line = f.distance_at(s[None])[0], np.hypot(*(g - s))
        assert np.isfinite(way) and way >= 1.3 * line and t.detour_min == pytest.approx(1.3), (t.seed, way, line)
        assert line >= rd.MIN_STRAIGHT_FRAC * t.params["size_m"] * 0.99 and way <= rd.MAX_PATH_FRAC * t.params["size_m"]
        # so the straight line crosses ground too steep to drive
        on_line = tin.locate(s + np.linspace(0, 1, 2000)[:, None] * (g - s))
        assert not passable[on_line].all()
        x0, y0, x1, y1 = t.spawn_region
        assert 0 <= x0 < x1 <= t.dem.x[-1] and 0 <= y0 < y1 <= t.dem.y[-1] and np.all((g > 0) & (g < t.dem.x[-1]))


def test_the_drawn_limit_makes_steep_frac_of_the_area_too_steep(tasks):
    for t in tasks:
        tin, passable, _ = _field(t)
        v = tin.vertices[tin.triangles, :2]
        e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        share = area[~passable].sum() / area.sum()
        assert abs(share - t.params["steep_frac"]) <= 0.02, (t.seed, share, t.params["steep_frac"])
        lo, hi = rd.SLOPE_LIMITS_DEG
        assert lo <= t.params["max_slope_deg"] <= hi


def test_a_crop_keeps_the_source_slopes():
    """Sampled on the source's knots along a column, the crop's height steps are the source's
    times size / crop side, so every slope along it is the source's."""
    dem = T.sample_dem("jacksboro")
    dy = dem.y[1] - dem.y[0]
    cells = 24.0
    side = cells * rd.source_cell_m("jacksboro")
    assert rd.source_cell_m("jacksboro") == pytest.approx(dy)
    r0 = 40
    x, z = rd.crop_heights("jacksboro", (0.0, r0 * dy), cells, 24.0, 1.0)  # one map metre per source row
    assert x[-1] == 24.0 and z.shape == (25, 25) and z.min() == 0.0
    scale = 24.0 / side
    want = np.diff(dem.z[r0:r0 + 25, 0]) * scale
    np.testing.assert_allclose(np.diff(z[:, 0]), want, atol=1e-9)
    np.testing.assert_allclose(np.degrees(np.arctan(np.diff(z[:, 0]) / 1.0)),
                               np.degrees(np.arctan(np.diff(dem.z[r0:r0 + 25, 0]) / dy)), atol=1e-9)


def test_orientations_are_the_eight_symmetries_of_the_square():
    z = np.zeros((5, 5))
    z[2, 4] = 1.0  # a bump on the east edge (row 0 south)
    z[0, 0] = 0.5  # and the south-west corner marked
    got = {o: rd.orient_grid(z, o) for o in rd.ORIENTS}
    assert len({g.tobytes() for g in got.values()}) == 8
    assert got["rot90"][4, 2] == 1.0  # counter-clockwise: east goes north
    assert got["rot270"][0, 2] == 1.0 and got["rot180"][2, 0] == 1.0
    assert got["flip_x"][2, 0] == 1.0 and got["flip_y"][4, 4] == 0.0 and got["flip_y"][2, 4] == 1.0
    assert got["transpose"][4, 2] == 1.0 and got["transpose"][0, 0] == 0.5
    assert got["anti_transpose"][0, 2] == 1.0 and got["anti_transpose"][4, 4] == 0.5
    x, a = rd.crop_heights("topobathy", (1e4, 2e4), 30, 100.0, 2.0)
    for o in rd.ORIENTS:
        np.testing.assert_array_equal(rd.crop_heights("topobathy", (1e4, 2e4), 30, 100.0, 2.0, o)[1],
                                      rd.orient_grid(a, o))


def test_mirrored_draws_exist_and_both_dems_and_detour_sides_are_drawn():
    ts = [draw(s) for s in range(100, 180)]
    assert {t.params["orient"] for t in ts} == set(rd.ORIENTS)
    assert {t.params["dem"] for t in ts} == set(rd.SOURCES)
    sides = [t.detour_side for t in ts]
    assert sides.count("left") >= 20 and sides.count("right") >= 20


@pytest.mark.parametrize("ranges,match", [
    ({"steep_frac": [0.5, 0.9]}, r"realdem\.steep_frac: range \[0\.5, 0\.9\] must have lo <= hi within"),
    ({"dem": ["etopo"]}, r"realdem\.dem must be a non-empty list of \['jacksboro', 'topobathy'\]"),
    ({"orient": ["sideways"]}, r"realdem\.orient must be a non-empty list"),
    ({"crop_cells": [4, 10]}, r"realdem\.crop_cells: range \[4, 10\]"),
    ({"detour_min": [0.5, 1.3]}, r"realdem\.detour_min: range"),
    ({"noise_m": [0, 1]}, r"family 'realdem' has no parameter 'noise_m'"),
    ({"size_m": [100, 2000], "cell_m": [0.25, 1]}, r"realdem\.size_m up to 2000 m with cell_m down to 0\.25 m"),
])
def test_bad_ranges_are_refused_by_name(ranges, match):
    with pytest.raises(ScenarioError, match=r"^scen\.toml: " + match):
        generate(np.random.default_rng(0), ("realdem",), {"realdem": ranges}, where="scen.toml")


def test_a_draw_that_cannot_fit_is_redrawn_a_bounded_number_of_times_then_named(monkeypatch):
    r = {"realdem": {"detour_min": [3.0, 3.0], "steep_frac": [0.02, 0.02]}}
    with pytest.raises(ScenarioError, match=r"no solvable task in 2 draws .*last misfit: realdem: no crop of .* fitted in "
                                            r"12 tries; the last: "):
        generate(np.random.default_rng(0), ("realdem",), r, max_tries=2)
    monkeypatch.setattr(rd, "SPLINE_MARGIN", 20.0)  # a crop must keep 20 cells off each edge: 80 cells do not fit
    with pytest.raises(gen.NoFitError, match="a crop 80 cells wide does not fit topobathy"):
        gen.realdem(np.random.default_rng(0), dem="topobathy", crop_cells=80.0)


def test_realdem_is_held_out_of_the_default_mix():
    assert "realdem" not in ALL_FAMILIES and REAL_FAMILIES == ("realdem",)
    assert all(generate(np.random.default_rng(s)).family != "realdem" for s in range(30))
    cfg = load_scenario("generated")
    assert cfg.terrain.families == ()  # the default mix: ALL_FAMILIES


def test_the_scenario_builder_gives_the_robots_the_tasks_limit():
    cfg = load_scenario("generated").with_families(("realdem",))
    for seed in (0, 1):
        st = build_stage(cfg, np.random.default_rng(seed))
        limit = st.task.params["max_slope_deg"]
        assert st.world.params.robot.max_slope_deg == limit != cfg.world.robot.max_slope_deg
        np.testing.assert_array_equal(st.world.steep, st.world.tin.slope_deg > limit)
        f = st.fields[0]
        s = st.task.spawn_centre
        assert f.distance_at(s[None])[0] >= 1.3 * np.hypot(*(st.targets[0] - s))
    mirrored = build_stage(cfg.replace(terrain=gen.dataclasses.replace(cfg.terrain, mirror="ns")),
                           np.random.default_rng(0))
    assert mirrored.world.params.robot.max_slope_deg == build_stage(cfg, np.random.default_rng(0)).task.params[
        "max_slope_deg"]
