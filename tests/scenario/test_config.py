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


def test_a_built_in_name_is_the_built_in_whatever_lies_in_the_working_directory(tmp_path, monkeypatch):
    """``./flat/`` (a directory) and ``./ramp`` (a file) do not shadow the built-ins ``flat`` and ``ramp``;
    a bare name that is no built-in but a file here is that file; ``./ramp.toml`` is a file."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "flat").mkdir()
    (tmp_path / "ramp").write_text("not toml [")
    assert load_scenario("flat").name == "flat" and load_scenario("ramp").name == "ramp"
    shutil.copy(SCENARIO_DIR / "hill.toml", tmp_path / "mine")
    assert load_scenario("mine").name == "mine"
    shutil.copy(SCENARIO_DIR / "hill.toml", tmp_path / "ramp.toml")
    assert load_scenario("ramp.toml").name == "ramp" and load_scenario("ramp.toml").terrain.source == \
        load_scenario("hill").terrain.source
    with pytest.raises(ScenarioError, match="unknown scenario 'atlantis'"):
        load_scenario("atlantis")


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
    p = write(tmp_path, BASE.replace('source = "flat"', 'source = "sample"\nmax_vertices = 3'))
    with pytest.raises(ScenarioError, match=r"bad\.toml.*max_vertices must be 0 \(not set\) or at least 4.*got 3"):
        load_scenario(p)  # when the file loads, not when the TIN is built


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


# -- every part checks itself (__post_init__), so a config built in code gets the file's checks -------------
@pytest.mark.parametrize("make, match", [
    (lambda c: c.TerrainSpec(source="magic"), r"TerrainSpec\.source must be one of flat, procedural"),
    (lambda c: c.TerrainSpec(source="dem", path="x.asc", method="magic"), r"TerrainSpec\.method must be one of vip"),
    (lambda c: c.TerrainSpec(source="generated", families=[]), r"TerrainSpec\.families is empty"),
    (lambda c: c.TerrainSpec(source="generated", families={"canyon": -1}), r"families\['canyon'\] must be"),
    (lambda c: c.TerrainSpec(source="generated", resample="x"), "'resample' must be 'reset' or 'once'"),
    (lambda c: c.TerrainSpec(source="generated", recipe="ridge"), r"TerrainSpec\.recipe does not apply to source "
                                                                 r"= 'generated'"),
    (lambda c: c.TerrainSpec(source="flat", path="x.asc"), r"TerrainSpec\.path does not apply to source = 'flat'"),
    (lambda c: c.TerrainSpec(size_m=5), r"TerrainSpec\.size_m must be a list of 2 numbers, got 5"),
    (lambda c: c.TerrainSpec(size_m=(1e7, 1e7)), "a flat plane of at most"),
    (lambda c: c.RobotsSpec(count="3"), r"RobotsSpec\.count must be an integer, got '3'"),
    (lambda c: c.RobotsSpec(spawn_region=5), r"RobotsSpec\.spawn_region must be a list of 4 numbers"),
    (lambda c: c.EntitiesSpec(positions=5), r"EntitiesSpec\.positions must be a list of \[x, y\] pairs"),
    (lambda c: c.EntitiesSpec(positions=((1, 2, 3),)), r"EntitiesSpec\.positions\[0\] must be a list of 2 numbers"),
    (lambda c: c.EntitiesSpec(mobile="yes"), r"EntitiesSpec\.mobile must be true or false"),
    (lambda c: c.RewardWeights(fall="x"), r"RewardWeights\.fall must be a number"),
    (lambda c: c.ObservationSpec(k_assets=-1), r"ObservationSpec\.k_assets must be an integer >= 0"),
    (lambda c: c.ScenarioConfig(terrain="flat"), r"ScenarioConfig\.terrain must be a TerrainSpec, got str"),
    (lambda c: c.ScenarioConfig(robots=5), r"ScenarioConfig\.robots must be a RobotsSpec"),
    (lambda c: c.ScenarioConfig(name=5), r"ScenarioConfig\.name must be a string"),
    (lambda c: c.ScenarioConfig(max_cycles=True), r"ScenarioConfig\.max_cycles must be an integer"),
    (lambda c: c.ScenarioConfig(max_cycles=10 ** 12), r"max_cycles must be an integer >= 1 and <= 1e\+07"),
    (lambda c: c.ScenarioConfig(terrain=c.TerrainSpec(source="generated"),
                                targets=c.EntitiesSpec(positions=((1.0, 1.0),))), r"\[targets\] 'positions'"),
])
def test_config_parts_built_in_code_are_checked(make, match):
    from tin_swarm_env.errors import TinSwarmError
    from tin_swarm_env.scenario import config

    with pytest.raises(TinSwarmError, match=match):
        make(config)


def test_code_built_parts_normalise_numpy_numbers_and_lists():
    import numpy as np

    from tin_swarm_env.scenario import config

    r = config.RobotsSpec(count=np.int64(3), spawn_region=[0, 0, np.float32(5), 5])
    assert r.count == 3 and type(r.count) is int and r.spawn_region == (0.0, 0.0, 5.0, 5.0)
    assert config.EntitiesSpec(positions=[[1, 2]]).positions == ((1.0, 2.0),)
    assert config.TerrainSpec(source="generated", families=["canyon"]).families == ("canyon",)


@pytest.mark.parametrize("text, match", [
    ("robots = 5\n" + BASE, r"bad\.toml: 'robots' must be a table \(\[robots\] followed by its keys\), got 5"),
    (BASE.replace('source = "flat"', 'source = "dem"\npath = "v.asc"\nmethod = "magic"'),
     r"bad\.toml \[terrain\]: TerrainSpec\.method must be one of"),
    (BASE.replace('source = "flat"', 'source = "flat"\nmethod = "vip"'),
     r"bad\.toml \[terrain\]: 'method' does not apply to source = 'flat' \(it reads size_m\)"),
    ('[terrain]\nsource = "generated"\nfamilies = []\n', r"bad\.toml \[terrain\]: 'families' is empty"),
    ('[terrain]\nsource = "generated"\nfamilies = {canyon = "a"}\n', r"bad\.toml \[terrain\]: families\.canyon must be"),
    ('[terrain]\nsource = "generated"\nsize_m = [100.0, 100.0]\n', r"'size_m' does not apply to source = 'generated'"),
    ('[terrain]\nsource = "generated"\nranges = {canyon = {size_m = [2000, 2000], cell_m = [0.25, 0.25]}}\n',
     r"bad\.toml \[terrain\] ranges: canyon\.size_m up to 2000 m with cell_m down to 0\.25 m makes .* grid cells"),
    ('[terrain]\nsource = "mars"\n', r"bad\.toml \[terrain\]: 'source' must be one of"),
    ("description = 5\n" + BASE, r"bad\.toml: 'description' must be a string"),
])
def test_scenario_file_errors_name_the_file_and_the_key(tmp_path, text, match):
    with pytest.raises(ScenarioError, match=match):
        load_scenario(write(tmp_path, text))


def test_non_utf8_directory_and_huge_scenario_files_are_named(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_bytes(b'name = "ok"\nrobots = "\xff\xfe"\n')
    with pytest.raises(ScenarioError, match=r"bad\.toml: line 2: not UTF-8 text \(byte 0xff\)"):
        load_scenario(p)
    d = tmp_path / "dir.toml"
    d.mkdir()
    with pytest.raises(ScenarioError, match=r"dir\.toml: is a directory"):
        load_scenario(d)
    p.write_text("# " + "x" * 2_000_000 + "\n")
    with pytest.raises(ScenarioError, match=r"bad\.toml: [\d,]+ bytes; a scenario file has at most"):
        load_scenario(p)


def test_with_families_restricts_the_generated_terrain_and_is_checked():
    from tin_swarm_env.errors import TinSwarmError
    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario("generated")
    assert cfg.with_families(("fork",)).terrain.families == ("fork",)
    assert cfg.with_families(["trap", "mesa"]).terrain.families == ("trap", "mesa")
    assert cfg.with_families({"fork": 2.0}).terrain.families == {"fork": 2.0}
    assert cfg.terrain.families == ()  # the original is left as it was
    with pytest.raises(TinSwarmError, match="families"):
        cfg.with_families(("volcano",))
    with pytest.raises(TinSwarmError, match="families"):
        cfg.with_families(())
