"""The vector env: E copies stepped by one call equal E separate parallel envs, bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.world import Reason


def _replay(v, scenarios, n_robots, steps, actions, **kw):
    """Step ``v`` and one parallel env per copy with the same actions (``actions(t, obs)`` ->
    ``(E, N, 2)``), resetting each separate env with ``v.copy_seeds`` when its copy auto-resets;
    every array must be identical. Returns how many copy resets happened and the reasons seen."""
    E = v.n_envs
    envs = [tse.parallel_env(scenarios[c % len(scenarios)], n_robots=n_robots, **kw) for c in range(E)]
    obs = v.reset()
    for c, e in enumerate(envs):
        np.testing.assert_array_equal(obs[c], e.reset_arrays(seed=int(v.copy_seeds[c])))
    resets, seen = 0, set()
    for t in range(steps):
        a = actions(t, obs)
        obs, rew, term, trunc, info = v.step(a)
        for c, e in enumerate(envs):
            o, r, te, tr, why = e.step_arrays(a[c])
            last = info["final_obs"][c] if info["_final"][c] else obs[c]
            np.testing.assert_array_equal(last, o, err_msg=f"step {t} copy {c} obs")
            np.testing.assert_array_equal(rew[c], r, err_msg=f"step {t} copy {c} rewards")
            np.testing.assert_array_equal(term[c], te)
            np.testing.assert_array_equal(trunc[c], tr)
            np.testing.assert_array_equal(info["reasons"][c], why)
            seen |= set(why.tolist())
            assert info["_final"][c] == (not e.live_mask.any())
            if info["_final"][c]:
                resets += 1
                np.testing.assert_array_equal(obs[c], e.reset_arrays(seed=int(v.copy_seeds[c])))
            np.testing.assert_array_equal(info["distance_to_go_m"][c], e.distance_to_go())
            np.testing.assert_array_equal(info["live"][c], e.live_mask)
    return resets, seen


def _random(E, N, seed=0):
    rng = np.random.default_rng(seed)
    return lambda t, obs: rng.uniform(-1.2, 1.2, (E, N, 2))


def test_bit_identical_to_separate_envs_across_auto_resets():
    v = tse.vector_env("cliff_goal", n_envs=3, n_robots=5, seed=7, max_cycles=20)
    resets, seen = _replay(v, ["cliff_goal"], 5, 45, _random(3, 5), max_cycles=20)
    assert resets == 6  # every copy truncated at steps 20 and 40
    assert int(Reason.TIMEOUT) in seen


def test_bit_identical_with_arrivals_and_a_copy_ending_alone():
    """APF drives the robots in (reason ARRIVED); copy 1 ends at its own max_cycles while copy 0 goes on."""
    cfg = load_scenario("flat")
    cfg = cfg.replace(robots=dataclasses.replace(cfg.robots, spawn_region=(200.0, 80.0, 250.0, 220.0)))
    scen = [cfg.replace(max_cycles=400), cfg.replace(max_cycles=30)]
    v = tse.vector_env(scen, n_envs=2, n_robots=6, seed=3)
    pols = [APFPolicy(tse.parallel_env(s, n_robots=6)) for s in scen]

    def act(t, obs):
        return np.stack([p.act_batch(obs[c]) for c, p in enumerate(pols)])

    resets, seen = _replay(v, scen, 6, 120, act)
    assert int(Reason.ARRIVED) in seen
    assert resets >= 3  # copy 1 every 30 steps, copy 0 not before its robots are in or out


def test_generated_terrains_per_copy_and_scenario_list():
    v = tse.vector_env("generated", n_envs=3, n_robots=4, seed=11, max_cycles=15)
    _replay(v, ["generated"], 4, 32, _random(3, 4, 1), max_cycles=15)
    assert len({id(w) for w in v._worlds}) == 3  # a terrain of its own per copy
    mix = ["cliff_goal", "ramp"]
    v = tse.vector_env(mix, n_envs=4, n_robots=4, seed=2, max_cycles=12)
    _replay(v, mix, 4, 26, _random(4, 4, 2), max_cycles=12)
    assert list(v.copy_scenario) == [0, 1, 0, 1]


def test_reproducible_from_one_seed():
    runs = []
    for _ in range(2):
        v = tse.vector_env("generated", n_envs=2, n_robots=3, seed=5, max_cycles=8)
        out = [v.reset()]
        a = np.full((2, 3, 2), 0.5)
        for _ in range(20):
            out.append(v.step(a)[0])
        runs.append((np.stack(out), v.copy_seeds.copy()))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_truncation_and_final_observations():
    v = tse.vector_env("ramp", n_envs=2, n_robots=3, seed=0, max_cycles=3)
    first = v.reset()
    seeds = v.copy_seeds.copy()
    a = np.zeros((2, 3, 2))
    for _ in range(2):
        obs, rew, term, trunc, info = v.step(a)
        assert not trunc.any() and not info["_final"].any()
        assert not info["final_obs"].any()
    obs, rew, term, trunc, info = v.step(a)
    assert trunc.all() and not term.any()
    assert (info["reasons"] == int(Reason.TIMEOUT)).all()
    assert info["_final"].all() and info["live"].all()
    assert not np.array_equal(seeds, v.copy_seeds)
    assert not np.array_equal(obs, info["final_obs"])  # the new episodes' first observations
    assert (v.steps == 0).all()
    assert first.shape == obs.shape == (2, 3, v.layout.size)


@pytest.mark.parametrize("n_envs", [0, -1, 1.5, True, "2", 1 << 17])
def test_bad_n_envs(n_envs):
    with pytest.raises(ArgumentError, match="n_envs"):
        tse.vector_env("ramp", n_envs=n_envs)


def test_an_unknown_keyword_is_refused_by_name():
    with pytest.raises(ArgumentError, match=r"vector_env: unknown argument 'colour'.*'max_cycles'"):
        tse.vector_env("ramp", n_envs=2, colour=3)
    assert tse.vector_env("ramp", n_envs=2, n_robots=2, max_cycles=5).n_envs == 2  # parallel_env's own are kept


def test_refused_mixes_and_actions():
    with pytest.raises(ArgumentError, match="n_robots"):
        tse.vector_env(["ramp", "hill"], n_envs=2)  # 20 and 30 robots
    cfg = load_scenario("ramp")
    scan = cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=8))
    with pytest.raises(ArgumentError, match="observation layout"):
        tse.vector_env([cfg, scan], n_envs=2)
    with pytest.raises(ArgumentError, match="scenario is an empty list"):
        tse.vector_env([], n_envs=2)
    v = tse.vector_env("ramp", n_envs=2, n_robots=3, seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        v.step(np.zeros((2, 3, 2)))
    v.reset()
    with pytest.raises(ArgumentError, match=r"shape \(2, 3, 2\)"):
        v.step(np.zeros((3, 2)))
    a = np.zeros((2, 3, 2))
    a[1, 2, 0] = np.nan
    with pytest.raises(ArgumentError, match="copy 1, robot_2"):
        v.step(a)
    with pytest.raises(ArgumentError, match="real numbers, got dtype <U7"):
        v.step("forward")


def test_scan_layout_and_packs_shared():
    """A layout with a scan (the scan beams read the packed break arrays), and copies of one fixed scenario share
    one world in the pack."""
    cfg = load_scenario("cliff_goal")
    scan = cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=16))
    v = tse.vector_env(scan, n_envs=3, n_robots=4, seed=1, max_cycles=10)
    _replay(v, [scan], 4, 14, _random(3, 4, 3), max_cycles=10)
    assert len(v._pack.worlds) == 1


def test_world_parameters_shared_or_refused_by_name():
    """Copies may differ in what shapes their own world (the flat plane's size, the slope limit), not in what every
    robot's step reads (sensor range...)."""
    v = tse.vector_env(["flat", "cliff_goal"], n_envs=2, n_robots=3, seed=0, max_cycles=6)  # 300 m and 500 m planes
    _replay(v, ["flat", "cliff_goal"], 3, 8, _random(2, 3, 4), max_cycles=6)
    cfg = load_scenario("ramp")
    far = cfg.replace(world=dataclasses.replace(cfg.world, sensor=dataclasses.replace(cfg.world.sensor, range_m=90.0)))
    with pytest.raises(ArgumentError, match=r"\[world\] sensor.range_m 90.0"):
        tse.vector_env([cfg, far], n_envs=2)


def test_a_refused_reset_copy_leaves_the_copy_as_it_was_and_bad_inputs_are_named():
    v = tse.vector_env("cliff_goal", n_envs=2, n_robots=3, seed=1)
    v.reset()
    a = np.full((2, 3, 2), 0.3)
    v.step(a)
    before = (v._pos.copy(), v.copy_seeds.copy(), v.steps.copy(), v._dist.copy())
    with pytest.raises(ArgumentError, match="copy 0 would have 2 targets"):
        v.reset_copy(0, seed=5, options={"target_positions": [[200.0, 150.0], [250.0, 150.0]]})
    for x, y in zip(before, (v._pos, v.copy_seeds, v.steps, v._dist)):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ArgumentError, match="2\\*\\*63"):
        v.reset_copy(0, seed=2 ** 64)
    for bad in (np.zeros((2, 3, 2)) + 1j, np.zeros((2, 3, 2), bool)):
        with pytest.raises(ArgumentError, match="real numbers"):
            v.step(bad)
    v.step(a)  # still steps


def test_generated_resets_append_to_the_packs_in_place():
    """A copy's reset appends its world and fields into spare capacity (no copy of the others'), and the packs
    stay bounded over many resets."""
    v = tse.vector_env("generated", n_envs=4, n_robots=2, seed=3, max_cycles=2)
    v.reset()
    a = np.zeros((4, 2, 2))
    sizes = []
    for _ in range(40):
        buf = v._pack.__dict__.get("_buf", {}).get("tris")
        v.step(a)
        if buf is not None and v._pack.__dict__.get("_buf", {}).get("tris") is buf:
            assert np.shares_memory(v._pack.a["tris"], buf)  # grown in place
        sizes.append(len(v._pack.worlds))
    assert max(sizes) <= 2 * 4 + 8 + 4 and len(v._fpack) <= 2 * 4 + 8 + 4
    _replay(tse.vector_env("generated", n_envs=3, n_robots=2, seed=9, max_cycles=2), ["generated"], 2, 30,
            _random(3, 2, 7), max_cycles=2)


def test_one_copy_is_the_single_env():
    """The single env and copy 0 of a one-copy vector env: the same trajectory, bit for bit, through an
    auto-reset (both step through the same per-robot kernels: after_move, robot_sight, gather_breaks, ...)."""
    v = tse.vector_env("hill", n_envs=1, n_robots=6, seed=4, max_cycles=15)
    resets, _ = _replay(v, ["hill"], 6, 35, _random(1, 6, 5), max_cycles=15)
    assert resets == 2
