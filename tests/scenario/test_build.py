"""scenario/build.py: a scenario's [terrain] method = "robot" builds the robot TIN at the robots' max_slope_deg."""

import shutil
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.build import build_tin_for

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
