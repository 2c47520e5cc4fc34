"""Mirror images of scenarios (tin_swarm_env/scenario/mirror.py): every position of the task is reflected,
two flips on one axis cancel, and APF does as well on the mirror image of a hand-built case as on the
original. The reflections themselves: tests/scenario/test_reflect.py."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.errors import ArgumentError, ScenarioError
from tin_swarm_env.scenario import build_stage, load_scenario, scenario_from_dict
from tin_swarm_env.scenario.mirror import (
    mirror_scenario,
    mirror_task,
    reflect_region,
    reflect_xy,
)


def _hand_built(assets: bool = True):
    """A 200 m square: a 20 m plateau west of a cliff at x = 100 m whose one way down is a pass at
    y 160-176 m (north); robots spawn south-west, the target stands south-east."""
    return scenario_from_dict({
        "name": "wall", "task": "goal", "max_cycles": 600,
        "terrain": {"source": "procedural", "recipe": "canyon", "method": "greedy", "max_error_m": 0.25,
                    "params": {"width": 200.0, "height": 200.0, "cell": 2.0, "plateau_m": 20.0, "cliff_x": 100.0,
                               "pass_y": [160.0, 176.0], "ramp_in_m": 60.0}},
        "robots": {"count": 8, "spawn_region": [20.0, 40.0, 60.0, 80.0], "max_slope_deg": 30.0},
        "targets": {"positions": [[160.0, 70.0]], "arrival_radius_m": 8.0},
        **({"assets": {"count": 2, "region": [10.0, 10.0, 50.0, 30.0]}} if assets else {})})


def test_mirror_scenario_reflects_the_terrain_and_every_position():
    cfg = _hand_built()
    m = mirror_scenario(cfg, "ns")  # the terrain's bounds: (0, 0, 200, 200)
    assert m.terrain.mirror == "ns" and m.name == "wall (mirror ns)"
    assert m.robots.spawn_region == (20.0, 120.0, 60.0, 160.0)
    assert m.targets.positions == ((160.0, 130.0),)
    assert m.assets.region == (10.0, 170.0, 50.0, 190.0) and m.assets.count == 2
    back = mirror_scenario(m, "ns")
    assert back.terrain.mirror == "" and back.robots.spawn_region == cfg.robots.spawn_region
    assert back.targets.positions == cfg.targets.positions and back.assets.region == cfg.assets.region
    s, sm = build_stage(cfg), build_stage(m)
    assert sm.targets.tolist() == [[160.0, 130.0]]
    v, vm = s.world.tin.vertices, sm.world.tin.vertices
    np.testing.assert_array_equal(vm[:, 0], v[:, 0])
    np.testing.assert_array_equal(vm[:, 1], 200.0 - v[:, 1])
    np.testing.assert_array_equal(vm[:, 2], v[:, 2])
    # the pass went south with the reflection: the plateau's one way down is now at y 24-40 m
    assert sm.world.tin.height_at([[90.0, 32.0]])[0] < 20.0 - 1 and sm.world.tin.height_at([[90.0, 168.0]])[0] == 20.0
    assert s.fields[0].distance_at([[40.0, 60.0]])[0] == pytest.approx(sm.fields[0].distance_at([[40.0, 140.0]])[0],
                                                                      rel=1e-9)


def test_a_flat_scenario_mirrors_over_its_plane_and_a_bad_axis_is_refused(tmp_path):
    cfg = load_scenario("flat")  # 300 x 300 m
    m = mirror_scenario(cfg, "ew")
    assert m.targets.positions == ((30.0, 100.0), (30.0, 200.0)) and m.robots.spawn_region == (220.0, 10.0, 290.0,
                                                                                                290.0)
    with pytest.raises(ArgumentError, match="mirror axis"):
        mirror_scenario(cfg, "up")
    p = tmp_path / "m.toml"
    p.write_text('task = "goal"\n[terrain]\nsource = "flat"\nmirror = "sideways"\n[targets]\npositions = [[1.0, 1.0]]\n')
    with pytest.raises(ScenarioError, match="mirror"):
        load_scenario(p)


def test_a_generated_terrain_mirrors_each_drawn_task():
    g = load_scenario("generated")
    s, sm = build_stage(g, np.random.default_rng(7)), build_stage(mirror_scenario(g), np.random.default_rng(7))
    t, tm = s.task, sm.task
    assert tm.family == t.family and tm.seed == t.seed
    np.testing.assert_array_equal(tm.dem.z, t.dem.z[::-1])
    y0, y1 = t.dem.y[0], t.dem.y[-1]
    np.testing.assert_array_equal(tm.targets[:, 1], (y0 + y1) - t.targets[:, 1])
    np.testing.assert_array_equal(sm.targets, tm.targets)
    assert tm.spawn_region == pytest.approx(reflect_region(t.spawn_region, "ns", (t.dem.x[0], y0, t.dem.x[-1], y1)))
    assert {t.detour_side, tm.detour_side} in ({"left", "right"}, {"both"}, {"none"})
    np.testing.assert_array_equal(mirror_task(t, "ns").passes[..., 1], (y0 + y1) - t.passes[..., 1])
    q = np.random.default_rng(0).uniform((t.dem.x[0], y0), (t.dem.x[-1], y1), (200, 2))
    np.testing.assert_allclose(sm.world.tin.height_at(reflect_xy(q, "ns", (0, y0, 0, y1))), s.world.tin.height_at(q),
                               rtol=0, atol=1e-9)


def test_apf_arrives_on_the_mirror_image_of_a_hand_built_case_as_on_the_original():
    from tin_swarm_env.env import parallel_env
    from tin_swarm_env.policies import APFPolicy
    from tin_swarm_env.training.rollout import rollout

    arrived = {}
    for axis in ("", "ns"):
        cfg = _hand_built(assets=False)
        env = parallel_env(scenario=mirror_scenario(cfg, axis) if axis else cfg)
        arrived[axis] = np.mean([rollout(env, APFPolicy(env), seed).shares()["arrived"] for seed in (0, 1)])
    # the pass is on the robots' left in one and on their right in the other; 16 robot-episodes each
    assert arrived[""] >= 0.75 and arrived["ns"] >= 0.75
    assert abs(arrived[""] - arrived["ns"]) <= 0.2
