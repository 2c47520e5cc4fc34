"""Scenario files: built-ins by name, files by path, and bad files named by file and key."""

import shutil

import pytest

import tin_swarm_env as tse
from tin_swarm_env.scenario import SCENARIO_DIR, ScenarioError, list_scenarios, load_scenario

BUILTIN = {"flat", "ramp", "hill", "cliff_goal", "jacksboro", "containment"}


def test_builtins_are_listed_and_load():
    assert BUILTIN <= set(list_scenarios())
    for name in BUILTIN:
        cfg = load_scenario(name)
        assert cfg.name == name and list_scenarios()[name]
    assert load_scenario("jacksboro").robots.count == 200


def test_a_scenario_by_path(tmp_path):
    p = tmp_path / "mine.toml"
    shutil.copy(SCENARIO_DIR / "ramp.toml", p)
    env = tse.parallel_env(scenario=str(p), n_robots=2, max_cycles=5)
    env.reset(seed=0)
    assert env.config.name == "mine"


def write(tmp_path, text, name="bad.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


BASE = '''task = "goal"
[terrain]
source = "flat"
[targets]
positions = [[100.0, 100.0]]
'''


def test_unknown_key_names_the_file_and_the_key(tmp_path):
    p = write(tmp_path, BASE + "[robots]\ncuont = 3\n")
    with pytest.raises(ScenarioError, match=r"bad\.toml \[robots\]: unknown key 'cuont'"):
        load_scenario(p)
    p = write(tmp_path, "colour = 1\n" + BASE)
    with pytest.raises(ScenarioError, match=r"bad\.toml: unknown key 'colour'"):
        load_scenario(p)
    p = write(tmp_path, BASE + "[sensor]\nrange = 5.0\n")
    with pytest.raises(ScenarioError, match=r"\[sensor\]: unknown key 'range'"):
        load_scenario(p)


def test_wrong_types_and_values_name_the_key(tmp_path):
    p = write(tmp_path, BASE + "[robots]\ncount = \"many\"\n")
    with pytest.raises(ScenarioError, match=r"\[robots\]: 'count' must be an integer"):
        load_scenario(p)
    p = write(tmp_path, BASE.replace("[[100.0, 100.0]]", "[[100.0]]"))
    with pytest.raises(ScenarioError, match=r"\[targets\]: 'positions\[0\]' must be a list of 2 numbers"):
        load_scenario(p)
    p = write(tmp_path, BASE + "[sensor]\nrange_m = 0.0\n")
    with pytest.raises(ScenarioError, match=r"\[sensor\]: SensorParams.range_m must be"):
        load_scenario(p)
    p = write(tmp_path, BASE.replace('"goal"', '"dance"'))
    with pytest.raises(ScenarioError, match="task must be"):
        load_scenario(p)
    p = write(tmp_path, "task = \"goal\"\n[terrain\n")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(p)


def test_missing_dem_file_and_target_in_a_cliff(tmp_path):
    p = write(tmp_path, BASE.replace('source = "flat"', 'source = "dem"\npath = "nowhere.asc"'))
    with pytest.raises(ScenarioError, match=r"bad\.toml \[terrain\] path: DEM file .*nowhere\.asc.* does not exist"):
        tse.parallel_env(scenario=str(p))
    text = (SCENARIO_DIR / "ramp.toml").read_text().replace("[[270.0, 120.0]]", "[[221.0, 120.0]]")
    p = write(tmp_path, text, "cliff.toml")
    with pytest.raises(ScenarioError, match=r"cliff\.toml \[targets\] positions\[0\] at \[221\.0, 120\.0\] lies "
                                            r"on a too-steep"):
        tse.parallel_env(scenario=str(p))
    p = write(tmp_path, BASE.replace('source = "flat"', 'source = "procedural"\nrecipe = "volcano"'))
    with pytest.raises(ScenarioError, match="unknown terrain recipe 'volcano'"):
        tse.parallel_env(scenario=str(p))
    with pytest.raises(ScenarioError, match="unknown scenario 'nope'"):
        load_scenario("nope")


def test_the_example_dem_scenario_in_scenarios_dir_runs_by_path():
    from pathlib import Path

    p = Path(__file__).resolve().parents[2] / "scenarios" / "valley.toml"
    env = tse.parallel_env(scenario=str(p), n_robots=4, max_cycles=20)
    env.reset(seed=0)
    assert env.world.tin.n_triangles > 100 and env.world.steep.any()
    pol = tse.policies.APFPolicy(env)
    obs, _ = env.reset(seed=0)
    while env.agents:
        obs, *_ = env.step(pol.act(obs))
    assert env.steps == 20
