"""Assets: an observation part (K_a slots, 0 without assets), the APF's asset field, their role."""

import json

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import DEFAULT_K_ASSETS, ObsLayout
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import ObservationSpec, scenario_from_dict
from tin_swarm_env.world.fields import FIELDS, FieldParams, asset_field, fields_at


def guard(n_robots=6, assets=((100.0, 70.0),), **obs):
    """Flat 200 m square, robots spawned in a corner, one asset guarded at an 8 m ring, no threat."""
    return scenario_from_dict({
        "name": "guard", "task": "containment", "max_cycles": 200,
        "terrain": {"source": "flat", "size_m": [200.0, 200.0]},
        "robots": {"count": n_robots, "spawn_region": [20.0, 20.0, 60.0, 60.0]},
        "assets": {"positions": [list(a) for a in assets], "standoff_m": 8.0}, "observation": obs})


def test_asset_slots_only_when_the_scenario_has_assets():
    assert tse.parallel_env(scenario="cliff_goal").layout.size == 91  # no assets: the default size (with the scan)
    env = tse.parallel_env(scenario=guard(k_scan=0))
    assert env.layout.k_assets == DEFAULT_K_ASSETS and env.layout.size == 59 + 4 * DEFAULT_K_ASSETS
    assert env.layout.assets == slice(59, 59 + 4 * DEFAULT_K_ASSETS)  # after the breaks: the other offsets stay
    assert tse.parallel_env(scenario=guard()).layout.scan == slice(67, 67 + 32)  # the scan last, after the assets
    assert tse.parallel_env(scenario=guard(k_assets=0, k_scan=0)).layout.size == 59
    assert tse.parallel_env(scenario=guard(k_assets=3)).layout.k_assets == 3
    assert ObsLayout.from_spec(ObservationSpec(), n_assets=0) == ObsLayout()


def test_layout_without_assets_saves_the_dict_of_before():
    d = ObsLayout(k_scan=0).to_dict()
    assert "k_assets" not in d and set(d["slots"]) == {"robots", "targets", "breaks"}
    lay = ObsLayout(2, 1, 3, 2, 0)
    d = json.loads(json.dumps(lay.to_dict()))
    assert d["k_assets"] == 2 and ObsLayout.from_dict(d) == lay
    assert lay.names()[-4:] == ["assets[1].valid", "assets[1].x", "assets[1].y", "assets[1].d"]


def test_asset_slots_encode_what_the_robot_sees_and_equal_the_reference(observations_match):
    env = tse.parallel_env(scenario=guard(n_robots=12, assets=((100.0, 70.0), (60.0, 90.0))))
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    seen_any = False
    for _ in range(20):
        env.step_arrays(rng.uniform(-1, 1, (12, 2)))
        a = observations_match(env)
        valid = env.layout.field(a, "assets", "valid")
        seen = env.sensed().assets
        for i in range(12):  # robot i's first asset slot is valid exactly when it senses an asset
            assert bool(valid[i, 0]) == bool(np.any(seen.observer == i))
        seen_any |= valid.any()
    assert seen_any


def test_asset_field_pulls_to_the_guard_ring_of_the_nearest_seen_asset():
    rel = np.array([[[30.0, 0.0], [0.0, 4.0]], [[30.0, 0.0], [0.0, 4.0]], [[3.0, 4.0], [9.0, 9.0]]])
    valid = np.array([[1, 1], [1, 0], [0, 0]])
    f, u = asset_field(rel, valid, guard_m=2.0, gain=0.5, range_m=10.0)
    # robot 0: nearest is 4 m up, 2 m outside the ring: 0.5 * 2/10 toward it
    np.testing.assert_allclose(f[0], [0.0, 0.1])
    np.testing.assert_allclose(u[0], 0.5 * 4 / 20)
    # robot 1: only the far one is valid: 28 m out, beyond the range: full gain
    np.testing.assert_allclose(f[1], [0.5, 0.0])
    np.testing.assert_array_equal(f[2], [0.0, 0.0])  # none seen
    assert u[2] == 0.0
    pts = np.array([[0.0, 0.0], [100.0, 0.0]])
    out = fields_at(pts, FieldParams(fields=("asset",)), assets=[[0.0, 6.0], [100.0, 3.0]], guard_m=1.0)
    np.testing.assert_allclose(out["asset"][0], [[0.0, 0.25], [0.0, 0.1]])
    assert "asset" in FIELDS


def _final_distance(fields):
    env = tse.parallel_env(scenario=guard())
    pol = APFPolicy(env, fields=fields)
    obs, _ = env.reset(seed=0)
    while env.agents:
        obs, *_ = env.step(pol.act(obs))
    return np.hypot(*(env.world_state.positions - [100.0, 70.0]).T)


def test_robots_end_nearer_the_asset_with_the_asset_field_on():
    on = _final_distance(FIELDS)
    off = _final_distance(tuple(f for f in FIELDS if f != "asset"))
    assert on.mean() < off.mean() - 10.0
    held = on < 30.0
    assert held.sum() >= 3 and np.all(np.abs(on[held] - 8.0) < 2.0)  # they hold the 8 m guard ring


@pytest.mark.parametrize("k", [0, 2])
def test_apf_forces_report_the_asset_field(k):
    env = tse.parallel_env(scenario=guard(k_assets=k))
    obs, _ = env.reset(seed=0)
    f = APFPolicy(env).forces(np.stack(list(obs.values())))
    assert f["asset"].shape == (6, 2)
    assert np.any(f["asset"]) == (k > 0)
