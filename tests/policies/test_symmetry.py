"""The mirror-equivariant policy option (policies/symmetry.py, ``"symmetry": "mirror"`` in a policy
file, ``clip((g(o) + M g(M o)) / 2)``): pi(M o) == M pi(o) on random observations, exactly for the network and to float rounding
through the shield; the option round-trips through the file and a bad value is refused by name."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import SLOT_FIELDS, mirror_action
from tin_swarm_env.errors import PolicyFileError, TinSwarmError
from tin_swarm_env.policies import MLPPolicy, load_policy, save_policy
from tin_swarm_env.policies.symmetry import symmetrize


def _env(n=12):
    return tse.parallel_env(scenario="cliff_goal", n_robots=n, max_cycles=30)


def _random_obs(layout, n, seed):
    """Random observations in [-1, 1] with 0/1 valid flags (so shields see real slots)."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-1, 1, (n, layout.size))
    for part in SLOT_FIELDS:
        if layout.count(part) and "valid" in SLOT_FIELDS[part]:  # (scan beams hold ranges only)
            sl = layout.slots(o, part)  # a view: valid and danger flags set in place
            sl[..., layout.slot_index(part, "valid")] = rng.integers(0, 2, sl.shape[:-1])
            if part == "breaks":
                sl[..., layout.slot_index(part, "danger")] = rng.integers(0, 2, sl.shape[:-1])
    o[:, layout.own["target_valid"]] = 1.0
    return o.astype(np.float32)


def _layers(d, seed, scale=3.0):
    rng = np.random.default_rng(seed)
    return [(rng.normal(0, 1, (24, d)), rng.normal(0, 1, 24)), (rng.normal(0, 1, (24, 24)), rng.normal(0, 1, 24)),
            (rng.normal(0, scale, (2, 24)), rng.normal(0, 1, 2))]


def _net(layers, x):
    """The network before its clip, plain numpy (tanh after every layer but the last)."""
    x = np.asarray(x, dtype=np.float64)
    for i, (W, b) in enumerate(layers):
        x = x @ W.T + b
        if i < len(layers) - 1:
            x = np.tanh(x)
    return x


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_mirror_policy_is_equivariant_exactly(tmp_path, seed):
    e = _env()
    lay = e.layout
    layers = _layers(lay.size, seed)
    sym = load_policy(save_policy(tmp_path / "s", layers, layout=lay, scenario="x", symmetry="mirror"), e)
    plain = load_policy(save_policy(tmp_path / "p", layers, layout=lay, scenario="x"), e)
    assert sym.symmetry == "mirror" and "symmetry='mirror'" in repr(sym)
    o = _random_obs(lay, 500, seed)
    mo = lay.mirror(o)
    a, am = sym.act_batch(o), sym.act_batch(mo)
    np.testing.assert_array_equal(am, mirror_action(a))  # bit for bit: sign flips and commuting sums
    # it is the clipped average of the network and its mirror image, the network computed here by hand
    g, gm = _net(layers, o), _net(layers, mo)
    np.testing.assert_allclose(a, np.clip((g + mirror_action(gm)) / 2, -1, 1), atol=1e-6)
    assert np.any(np.abs(g) > 1.0) and np.any(np.abs(a) == 1.0)  # the output clipping was exercised
    f = plain.act_batch(o)
    np.testing.assert_allclose(f, np.clip(g, -1, 1), atol=1e-6)
    # the plain network is not equivariant (so the assertion above has power)
    assert np.abs(plain.act_batch(mo) - mirror_action(f)).max() > 0.1
    # a self-mirrored observation drives straight
    o0 = o.copy()
    for name, sl in lay.own.items():
        o0[:, sl] *= lay.mirror(np.ones(lay.size))[sl] > 0
    o0[:, lay.own_size:] = 0
    np.testing.assert_array_equal(sym.act_batch(o0)[:, 1], 0.0)


def _scan_env(n=12, k_scan=8):
    import dataclasses

    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(max_cycles=30, observation=dataclasses.replace(cfg.observation, k_scan=k_scan))
    return tse.parallel_env(scenario=cfg, n_robots=n)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_mirror_policy_with_scan_beams_is_equivariant_exactly(tmp_path, seed):
    """With the terrain scan the mirror permutes the beams (k -> K - k) as well as flipping signs:
    the file's mirror policy is still equivariant bit for bit, and a sign flip alone would not do."""
    from tin_swarm_env.policies.symmetry import Mirror, mirror_map

    e = _scan_env()
    lay = e.layout
    assert lay.k_scan == 8
    layers = _layers(lay.size, seed)
    sym = load_policy(save_policy(tmp_path / "s", layers, layout=lay, scenario="x", symmetry="mirror"), e)
    o = _random_obs(lay, 400, seed)
    beams = slice(lay.size - lay.k_scan, lay.size)
    o[:, beams] = np.random.default_rng(seed).uniform(0, 1, (len(o), lay.k_scan))  # ranges in [0, 1]
    mo = lay.mirror(o)
    a = sym.act_batch(o)
    np.testing.assert_array_equal(sym.act_batch(mo), mirror_action(a))
    g, gm = _net(layers, o), _net(layers, mo)
    np.testing.assert_allclose(a, np.clip((g + mirror_action(gm)) / 2, -1, 1), atol=1e-6)
    perm, signs = mirror_map(lay)
    assert not np.array_equal(perm, np.arange(lay.size))
    np.testing.assert_array_equal(Mirror(lay)(o), o[:, perm].astype(np.float64) * signs)
    # averaging with the sign flip alone (beams not permuted) is not equivariant: the permutation matters
    wrong = np.clip(symmetrize(lambda x: _net(layers, x), o, signs), -1, 1)
    wrong_m = np.clip(symmetrize(lambda x: _net(layers, x), mo, signs), -1, 1)
    assert np.abs(wrong_m - mirror_action(wrong)).max() > 0.05


def test_the_shielded_mirror_policy_is_equivariant_to_rounding(tmp_path):
    e = _env()
    lay = e.layout
    p = save_policy(tmp_path / "s", _layers(lay.size, 5, scale=0.2), layout=lay, scenario="x", symmetry="mirror",
                    shield="safety_cut")
    pol = load_policy(p, e)
    o = _random_obs(lay, 800, 7)
    a, am = pol.act_batch(o), pol.act_batch(lay.mirror(o))
    assert not np.allclose(a, pol.net_batch(o))  # the shield cut some actions
    # the one exception (policies/symmetry.py): a command exactly backwards (vy == 0) into the blind
    # sector is turned to the left in both images
    net = pol.net_batch(o)
    tie = (net[:, 1] == 0) & (np.abs(np.arctan2(net[:, 1], net[:, 0])) > np.radians(e.config.world.sensor.fov_deg) / 2)
    assert tie.sum() < len(o) / 4
    np.testing.assert_allclose(am[~tie], mirror_action(a[~tie]), atol=1e-6)
    assert np.all(a[tie, 1] >= 0) and np.all(am[tie, 1] >= 0)
    got = pol.act({f"robot_{i}": o[i] for i in range(5)})
    np.testing.assert_array_equal(np.stack(list(got.values())), a[:5])


def test_symmetry_key_round_trips_and_is_checked(tmp_path):
    e = _env()
    p = save_policy(tmp_path / "s", _layers(e.layout.size, 0), layout=e.layout, scenario="x", symmetry="mirror")
    meta = json.loads((p / "policy.json").read_text())
    assert meta["symmetry"] == "mirror"
    meta["symmetry"] = "rotate"
    (p / "policy.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyFileError, match=r"policy\.json.*'symmetry'.*rotate"):
        load_policy(p, e)
    with pytest.raises(TinSwarmError, match="symmetry 'both'"):
        MLPPolicy(_layers(e.layout.size, 0), layout=e.layout.to_dict(), symmetry="both")
    with pytest.raises(PolicyFileError, match="'symmetry'"):
        save_policy(tmp_path / "t", _layers(e.layout.size, 0), layout=e.layout, scenario="x", symmetry="left")


def test_symmetrize_calls_the_network_once_on_both_images():
    calls = []

    def f(x):
        calls.append(len(x))
        return np.column_stack([x[:, 0], x[:, 1]])  # vx = o0 (kept by M), vy = o1 (negated by M)

    signs = np.array([1.0, -1.0, 1.0])
    x = np.array([[0.5, 0.25, 3.0], [-1.0, 0.75, 0.0]])
    out = symmetrize(f, x, signs)
    assert calls == [4]
    np.testing.assert_array_equal(out, x[:, :2])  # f is already equivariant: unchanged
    out = symmetrize(lambda x: np.column_stack([x[:, 2], x[:, 2]]), x, signs)  # vy from an even field: cancels
    np.testing.assert_array_equal(out, np.column_stack([x[:, 2], np.zeros(2)]))


def test_apf_with_its_memory_is_mirror_equivariant_over_an_episode():
    """Why mirrored demonstrations (train --mirror-samples) of the bug search are its own labels: an
    APF fed the mirror images of another's observations acts as its mirror image, memory included.
    (The chart search, APF's default, plans A* on a grid whose ties break one way, and each robot
    prefers one side of its way (chart.robot_side): a robot's mirror image keeps the same side, not its
    mirror, so the chart search is mirror equivariant as a swarm, not robot by robot; its mirror gap is
    measured in docs/figures/apf_mirror.md.)"""
    from tin_swarm_env.policies import APFPolicy

    e = _env()
    lay = e.layout
    a, b = APFPolicy(e, search="bug"), APFPolicy(e, search="bug")
    obs = e.reset_arrays(seed=1)
    for _ in range(150):
        x = a.act_batch(obs)
        np.testing.assert_allclose(b.act_batch(lay.mirror(obs)), mirror_action(x), atol=1e-6)
        obs, *_ = e.step_arrays(x)
    o = _random_obs(lay, 1000, 3)
    a, b = APFPolicy(e, search="bug"), APFPolicy(e, search="bug")
    for _ in range(3):
        np.testing.assert_allclose(b.act_batch(lay.mirror(o)), mirror_action(a.act_batch(o)), atol=1e-6)


def test_check_mirror_map_accepts_the_layouts_own_map_and_names_any_other():
    import dataclasses

    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.policies.symmetry import check_mirror_map, mirror_map

    plain = ObsLayout(k_scan=0)
    scan = dataclasses.replace(plain, k_scan=6)
    for lay in (plain, scan):
        perm, signs = mirror_map(lay)
        check_mirror_map(lay, perm, signs, "m")  # its own map passes
    check_mirror_map(plain, None, mirror_map(plain)[1], "m")  # no scan: the identity may be left out
    perm, signs = mirror_map(scan)
    bad = signs.copy()
    bad[0] = -bad[0]
    for args in ((perm, bad), (None, signs), (perm[:-1], signs[:-1]), (perm, mirror_map(plain)[1])):
        with pytest.raises(ArgumentError, match="^model X: .*not the mirror map"):
            check_mirror_map(scan, *args, "model X")
