"""``[terrain] source = "generated"`` in the env: resampling, determinism, PettingZoo API."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test, seed_test

import tin_swarm_env as tse
from tin_swarm_env import tin_swarm_v0
from tin_swarm_env.scenario import ScenarioError, load_scenario, scenario_from_dict
from tin_swarm_env.scenario.generators import ALL_FAMILIES

SMALL = {"scenario": "generated", "n_robots": 4}


def _terrain(env):
    return env.tin.vertices.copy(), env.tin.triangles.copy(), env.world_state.positions.copy()


def test_seeds_draw_terrains_and_the_same_seed_the_same_terrain_bit_for_bit():
    a = tse.parallel_env(**SMALL)
    b = tse.parallel_env(**SMALL)
    seen = []
    for seed in (0, 1, 2):
        a.reset(seed=seed)
        seen.append(_terrain(a))
    for seed in (2, 0, 1):  # another env, another order: the seed alone fixes the terrain
        b.reset(seed=seed)
        for x, y in zip(seen[seed], _terrain(b), strict=True):  # vertices, triangles, robots
            np.testing.assert_array_equal(x, y)
    assert not np.array_equal(seen[0][0], seen[1][0]) and not np.array_equal(seen[0][1], seen[1][1])
    assert not np.array_equal(seen[1][0], seen[2][0])
    a.reset()  # no seed: the stream goes on, a new terrain
    assert not any(np.array_equal(a.tin.vertices, v) for v, *_ in seen)


def _edge_pieces(tin, passable):
    """``(T,)`` int: connected piece of each passable triangle over shared edges (-1: steep)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    t = np.repeat(np.arange(tin.n_triangles), 3)
    nb = tin.neighbors.ravel()
    ok = (nb >= 0) & passable[t] & passable[np.maximum(nb, 0)]
    g = coo_matrix((np.ones(ok.sum()), (t[ok], nb[ok])), shape=(tin.n_triangles,) * 2)
    lab = connected_components(g, directed=False)[1]
    return np.where(passable, lab, -1)


def test_spaces_never_change_and_every_task_is_solvable():
    env = tse.parallel_env(**SMALL)
    obs_space, act_space, state_space = env.observation_space("robot_0"), env.action_space("robot_0"), env.state_space
    assert state_space.shape == (6 * 4 + 2,)
    families = set()
    for seed in range(8):
        obs, infos = env.reset(seed=seed)
        families.add(env.task.family)
        assert env.observation_space("robot_0") is obs_space and env.action_space("robot_3") is act_space
        assert env.state_space is state_space and state_space.contains(env.state())
        assert env.tin is env.world.tin and env.task.dem.source.startswith("generated:")
        np.testing.assert_array_equal(env.world_state.targets.positions, env.task.targets)
        x0, y0, x1, y1 = env.task.spawn_region
        p = env.world_state.positions
        assert np.all((p >= [x0, y0]) & (p <= [x1, y1]))
        d = np.array([infos[a]["distance_to_go_m"] for a in env.possible_agents])
        straight = np.hypot(*(env.task.targets[0] - p).T)
        assert np.all(np.isfinite(d)) and np.all(d >= straight - 1e-9)
        # solvable by an independent test: every robot's triangle and the target's are in one
        # piece of passable triangles joined by shared edges (never through a pinch vertex)
        piece = _edge_pieces(env.tin, ~env.world.steep)
        t_goal = env.tin.locate(env.task.targets)[0]
        assert np.all(piece[env.world_state.tri_idx] == piece[t_goal]) and piece[t_goal] >= 0
        assert all(obs_space.contains(o) for o in obs.values())
    assert len(families) >= 3 and families <= set(ALL_FAMILIES)


def test_parallel_api_test_with_resampling():
    parallel_api_test(tse.parallel_env(**SMALL, max_cycles=40), num_cycles=60)


def test_seed_tests_with_resampling():
    seed_test(lambda: tin_swarm_v0.env(**SMALL, max_cycles=30), num_cycles=30)
    parallel_seed_test(lambda: tse.parallel_env(**SMALL, max_cycles=30), num_cycles=30)


def test_resample_once_keeps_one_terrain(tmp_path):
    p = tmp_path / "once.toml"
    p.write_text('seed = 5\n[terrain]\nsource = "generated"\nfamilies = {mesa = 1}\nresample = "once"\n'
                 '[robots]\ncount = 3\n')
    env = tse.parallel_env(scenario=str(p))
    v0 = env.tin.vertices.copy(), env.tin.triangles.copy()
    for seed in (0, 1):
        env.reset(seed=seed)
        assert np.array_equal(env.tin.vertices, v0[0]) and env.task.family == "mesa"
    assert np.array_equal(tse.parallel_env(scenario=str(p)).tin.triangles, v0[1])


@pytest.mark.parametrize("terrain,extra,match", [
    ({"families": ["canyon", "volcano"]}, {}, r"g\.toml \[terrain\].*unknown terrain family 'volcano'"),
    ({"ranges": {"canyon": {"cliff_mm": [1, 2]}}}, {}, r"g\.toml \[terrain\] ranges.*cliff_mm"),
    ({"ranges": {"mesa": {"mesa_m": [9, 1000]}}}, {}, r"g\.toml \[terrain\] ranges.*mesa"),
    ({"resample": "always"}, {}, r"g\.toml \[terrain\].*'resample' must be 'reset' or 'once'"),
    ({"families": "canyon"}, {}, r"g\.toml \[terrain\].*'families' must be a list"),
    ({}, {"targets": {"positions": [[1.0, 1.0]]}}, r"g\.toml \[targets\].*must be empty"),
    ({}, {"targets": {"count": 2}}, r"g\.toml \[targets\].*'count' must be empty"),
    ({}, {"robots": {"spawn_region": [0.0, 0.0, 9.0, 9.0]}}, r"g\.toml \[robots\].*spawn_region"),
    ({}, {"task": "containment"}, r"g\.toml \[terrain\].*goal task"),
])
def test_generated_settings_are_checked_at_load_with_the_file_named(terrain, extra, match):
    d = {"terrain": {"source": "generated", **terrain}, **extra}
    with pytest.raises(ScenarioError, match=match):
        scenario_from_dict(d, source="g.toml")


def test_counted_assets_are_placed_reachable_from_the_generated_spawn_region(tmp_path, monkeypatch):
    from tin_swarm_env.scenario import build

    p = tmp_path / "assets.toml"
    p.write_text('[terrain]\nsource = "generated"\n[robots]\ncount = 3\n[assets]\ncount = 2\n')
    env = tse.parallel_env(scenario=str(p))
    seen = []
    real = build.place_entities
    monkeypatch.setattr(build, "place_entities", lambda *a, **k: seen.append(k["spawn_region"]) or real(*a, **k))
    env.reset(seed=3)
    assert seen and seen[-1] == env.task.spawn_region  # not the scenario's (None) region
    reach = build.spawn_reachable(env.world, env.task.spawn_region)
    assert len(env.world_state.assets) == 2 and reach[env.world_state.assets.tri_idx].all()


def test_builtin_generated_scenario():
    cfg = load_scenario("generated")
    assert cfg.terrain.source == "generated" and cfg.terrain.resample == "reset"
    assert cfg.terrain.families == () and cfg.robots.count == 20  # () = every family (ALL_FAMILIES)


def test_cli_runs_three_episodes_on_generated(capsys):
    from tin_swarm_env.apps.cli import main

    assert main(["run", "generated", "--robots", "3", "--episodes", "3", "--max-cycles", "40", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "generated" in out
