"""Threats/targets and assets by count: seeded placement, never on steep ground, always reachable."""

import shutil
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import PlacementError, ScenarioError
from tin_swarm_env.scenario import load_scenario, scenario_from_dict
from tin_swarm_env.scenario.build import build_tin_for
from tin_swarm_env.terrain import Dem, build_tin, save_tin

COUNTED = """
name = "counted"
task = "goal"
[terrain]
source = "procedural"
recipe = "cliff_goal"
[robots]
count = 6
spawn_region = [20.0, 20.0, 80.0, 80.0]
[targets]
count = 3
min_separation_m = 20.0
[assets]
count = 2
"""


@pytest.fixture(scope="module")
def counted(tmp_path_factory):
    p = tmp_path_factory.mktemp("scn") / "counted.toml"
    p.write_text(COUNTED)
    return p


def _placed(env, seed):
    env.reset(seed=seed)
    s = env.world_state
    return s.targets.positions.copy(), s.assets.positions.copy()


def test_same_seed_same_placement_different_seeds_differ(counted):
    env = tse.parallel_env(scenario=str(counted))
    a, b, c = _placed(env, 7), _placed(env, 7), _placed(env, 8)
    assert a[0].shape == (3, 2) and a[1].shape == (2, 2)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.allclose(a[0], c[0]) and not np.allclose(a[1], c[1])
    assert env.state_space.shape == (6 * 6 + 2 * 3,)
    assert set(env.target_assignment) == {0, 1, 2}


def test_counted_targets_never_on_steep_ground_and_apart(counted):
    env = tse.parallel_env(scenario=str(counted))
    w = env.world
    assert w.steep.any()  # cliff_goal has a cliff to avoid
    for seed in range(20):
        tg, at = _placed(env, seed)
        for pts in (tg, at):
            tri = w.tin.locate(pts)
            assert np.all(tri >= 0) and not w.steep[tri].any()
        d = np.hypot(*(tg[:, None] - tg[None]).T)[~np.eye(3, dtype=bool)]
        assert d.min() >= 20.0


def _mesa_scenario(tmp_path, **targets):
    """A 300 m square with a mesa (walls ~80 deg) in the middle: its top cannot be reached."""
    x = y = 5.0 * np.arange(61)
    X, Y = np.meshgrid(x, y)
    z = np.where((np.abs(X - 150) < 60) & (np.abs(Y - 150) < 60), 30.0, 0.0)
    save_tin(build_tin(Dem(z, x, y), method="delaunay"), tmp_path / "mesa.tin")
    d = {"name": "mesa", "task": "goal", "terrain": {"source": "tin", "path": "mesa.tin"},
         "robots": {"count": 4, "spawn_region": [0.0, 0.0, 60.0, 60.0]}, "targets": targets}
    return scenario_from_dict(d, source=str(tmp_path / "mesa.toml"), base_dir=str(tmp_path))


def test_counted_targets_are_reachable_from_the_spawn_region(tmp_path):
    cfg = _mesa_scenario(tmp_path, count=4, min_separation_m=5.0)
    env = tse.parallel_env(scenario=cfg)
    w = env.world
    on_top = []
    for seed in range(15):
        env.reset(seed=seed)
        tg = env.world_state.targets.positions
        on_top.append((np.abs(tg - 150) < 55).all(axis=1))  # the top (walls from 55 to 60 m out)
        for g in tg:  # solvable: a drivable path from the spawn region's corner to every target
            ctg = tse.terrain.cost_to_go(w.tin, g, ~w.steep)
            assert np.isfinite(ctg.distance_at(np.array([[5.0, 5.0]])))[0]
    assert not np.any(on_top)
    # the mesa top is traversable (flat), only unreachable: a region there has no room
    cfg = _mesa_scenario(tmp_path, count=1, region=[110.0, 110.0, 190.0, 190.0])
    with pytest.raises(ScenarioError, match=r"mesa\.toml \[targets\].*count = 1.*reachable"):
        tse.parallel_env(scenario=cfg)


def test_count_and_positions_together_is_an_error_naming_the_file(tmp_path):
    p = tmp_path / "both.toml"
    p.write_text(COUNTED.replace("count = 3", "count = 3\npositions = [[300.0, 150.0]]"))
    with pytest.raises(ScenarioError, match=r"both\.toml \[targets\].*'positions' or 'count', not both"):
        load_scenario(p)
    p.write_text(COUNTED.replace("count = 2", "count = -1"))
    with pytest.raises(ScenarioError, match=r"\[assets\].*EntitiesSpec\.count must be an integer >= 0"):
        load_scenario(p)


def test_position_lists_still_work_and_draw_nothing():
    a = tse.parallel_env(scenario="cliff_goal", n_robots=4)
    a.reset(seed=3)
    cfg = a.config
    assert cfg.targets.count == 0 and cfg.targets.n == len(cfg.targets.positions)
    np.testing.assert_array_equal(a.world_state.targets.positions, np.asarray(cfg.targets.positions))


def test_entity_and_reward_specs_name_the_field_through_the_shared_checks():
    from tin_swarm_env.errors import ParameterError
    from tin_swarm_env.scenario.config import EntitiesSpec, RewardWeights

    with pytest.raises(ParameterError, match=r"EntitiesSpec\.count must be an integer >= 0 and <= 10000, got 10001"):
        EntitiesSpec(count=10_001)
    with pytest.raises(ParameterError, match=r"EntitiesSpec\.count must be an integer.*got 2\.5"):
        EntitiesSpec(count=2.5)
    with pytest.raises(ParameterError, match=r"EntitiesSpec\.min_separation_m must be a finite number >= 0"):
        EntitiesSpec(min_separation_m=-1.0)
    with pytest.raises(ParameterError, match=r"EntitiesSpec\.region must be \[x0, y0, x1, y1\] with x0 < x1"):
        EntitiesSpec(count=1, region=(10.0, 0.0, 5.0, 8.0))
    with pytest.raises(ParameterError, match=r"EntitiesSpec\.region\[2\] must be a finite number"):
        EntitiesSpec(count=1, region=(0.0, 0.0, float("nan"), 8.0))
    with pytest.raises(ParameterError, match=r"EntitiesSpec: give 'positions' or 'count', not both"):
        EntitiesSpec(count=1, positions=((1.0, 2.0),))
    with pytest.raises(ParameterError, match=r"RewardWeights\.progress must be 'geodesic' or 'euclidean'"):
        RewardWeights(progress="manhattan")
    assert EntitiesSpec(count=2, region=(0.0, 0.0, 5.0, 8.0)).n == 2  # a good one passes


def test_spawn_reachable_and_reaches_region_sample_the_region_alike():
    """Steep everywhere but one 10 m island square [30, 40]^2 and a passable strip along y < 10:
    "from some point of the whole terrain" must mean the same for both checks (a 5 x 5 lattice
    would miss the island, which lies between its points)."""
    from tin_swarm_env.scenario.build import reaches_region, spawn_reachable
    from tin_swarm_env.world import World

    xs, ys = np.meshgrid(np.arange(11) * 10.0, np.arange(11) * 10.0)
    v = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    tris, cells = [], []
    for r in range(10):
        for c in range(10):
            a, b, d, e = 11 * r + c, 11 * r + c + 1, 11 * (r + 1) + c + 1, 11 * (r + 1) + c
            tris += [[a, b, d], [a, d, e]]
            cells += [(c, r)] * 2
    cells = np.array(cells)
    world = World(tse.terrain.Tin(v, tris))
    island = (cells[:, 0] == 3) & (cells[:, 1] == 3)
    world.steep = ~(island | (cells[:, 1] == 0))
    for region in (None, (0.0, 0.0, 100.0, 100.0), (31.0, 31.0, 32.0, 32.0), (50.0, 50.0, 90.0, 90.0)):
        reach = spawn_reachable(world, region)
        for t in np.flatnonzero(~world.steep):
            f = tse.terrain.cost_to_go(world.tin, world.tin.vertices[world.tin.triangles[t], :2].mean(axis=0),
                                       ~world.steep)
            assert reach[t] == reaches_region(f, region), (region, t)
    assert spawn_reachable(world, None)[island].all()
    assert not spawn_reachable(world, (31.0, 31.0, 32.0, 32.0))[cells[:, 1] == 0].any()
    assert not spawn_reachable(world, (50.0, 50.0, 90.0, 90.0)).any()


# -- [terrain] method = "robot" ------------------------------------------------------------

EXAMPLES = Path(__file__).resolve().parents[2] / "scenarios"  # the example DEM scenario


def robot_scenario(tmp_path, max_slope_deg):
    shutil.copy(EXAMPLES / "valley.asc", tmp_path / "valley.asc")
    text = (EXAMPLES / "valley.toml").read_text()
    text = text.replace('method = "greedy"', 'method = "robot"\nmax_vertices = 600')
    text = text.replace("max_slope_deg = 25.0", f"max_slope_deg = {max_slope_deg}")
    p = tmp_path / f"robot_{int(max_slope_deg)}.toml"
    p.write_text(text)
    return p


def test_robot_method_uses_the_robots_max_slope(tmp_path):
    tins = {}
    for s in (15.0, 25.0):
        cfg = load_scenario(robot_scenario(tmp_path, s))
        tins[s] = build_tin_for(cfg)
    dem = tse.terrain.load_dem(tmp_path / "valley.asc")
    for s, tin in tins.items():
        want = tse.terrain.build_tin(dem, method="robot", max_vertices=600, max_error_m=0.3, max_slope_deg=s)
        assert np.array_equal(tin.vertices, want.vertices) and np.array_equal(tin.triangles, want.triangles)
        assert "robot" in tin.source
    assert not np.array_equal(tins[15.0].vertices, tins[25.0].vertices)  # the slope reached the builder


def test_robot_scenario_runs(tmp_path):
    env = tse.parallel_env(scenario=str(robot_scenario(tmp_path, 25.0)), n_robots=2, max_cycles=3)
    env.reset(seed=0)
    assert "robot" in env.tin.source


def test_a_spawn_region_too_small_for_the_robots_names_the_knobs_that_make_room(tmp_path):
    """256 robots 2 m apart do not fit a canyon's ~25 m spawn square: the error says what to change, and
    the change it names (a wider generated spawn_m) places them all."""
    p = tmp_path / "g.toml"
    p.write_text('[terrain]\nsource = "generated"\nfamilies = ["canyon"]\n')
    with pytest.raises(PlacementError, match=r"could only place \d+ of 256 robots.*n_robots.*spawn_region.*"
                                             r"ranges spawn_m.*min_separation_m"):
        tse.parallel_env(scenario=str(p), n_robots=256).reset(seed=0)
    p.write_text('[terrain]\nsource = "generated"\nfamilies = ["canyon"]\nranges = {canyon = {spawn_m = [70, 70]}}\n')
    env = tse.parallel_env(scenario=str(p), n_robots=256)
    obs, _ = env.reset(seed=0)
    assert len(obs) == 256


def _dem_scenario(tmp_path, path, extra=""):
    p = tmp_path / "s.toml"
    p.write_text(f'task = "goal"\n[terrain]\nsource = "dem"\npath = "{path}"\n{extra}\n[robots]\ncount = 2\n'
                 '[targets]\npositions = [[100.0, 100.0]]\n')
    return p


@pytest.mark.parametrize("path, extra, exc, match", [
    ("scatter.xyz", "", "ArgumentError", r"\[terrain\] \(method = 'greedy', max_error_m = 0\.5\): .*scatter\.xyz: "
                                         r"method 'greedy' needs a regular grid"),
    (".", "", "DemFormatError", r"\[terrain\] path: .*: is a directory, not a DEM file"),
    ("nan.npz", "", "DemFormatError", r"\[terrain\] path: .*nan\.npz: every cell is NODATA"),
])
def test_a_terrain_error_names_the_scenario_file_and_its_terrain_keys(tmp_path, path, extra, exc, match):
    """Errors raised while the scenario's terrain is read or reduced keep their class and lead with the
    scenario file and ``[terrain]`` (the DEM's own error alone did not say which scenario asked for it)."""
    np.savez(tmp_path / "dem.npz", z=np.random.default_rng(0).random((20, 20)) * 5, dx=10.0)
    np.savez(tmp_path / "nan.npz", z=np.full((20, 20), np.nan), dx=10.0)
    xyz = np.random.default_rng(1).random((40, 3)) * [200.0, 200.0, 5.0]  # scattered points, no grid
    (tmp_path / "scatter.xyz").write_text("\n".join(f"{x:.3f} {y:.3f} {z:.3f}" for x, y, z in xyz) + "\n")
    p = _dem_scenario(tmp_path, path, extra)
    with pytest.raises(getattr(tse.errors, exc), match=match) as e:
        tse.parallel_env(scenario=str(p))
    assert str(e.value).startswith(f"{p} [terrain]")
