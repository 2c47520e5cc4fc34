"""policies/export.py: another library's mean network written as a policy file gives that library's
deterministic action exactly (clip or tanh squash), and the export check catches a wrong file."""

import json

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies.base import unwrap_env
from tin_swarm_env.policies.export import export_actor, max_action_gap, real_observations
from tin_swarm_env.policies.learned import load_policy


@pytest.fixture(scope="module")
def env():
    return tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=40)


def _layers(d, rng, scale=1.0):
    return [(rng.normal(size=(5, d)) * scale / np.sqrt(d), rng.normal(size=5)),
            (rng.normal(size=(2, 5)) * scale, rng.normal(size=2) * scale)]


def _reference(layers, obs, squash):
    """The library's deterministic action written out by hand: tanh hidden layer, then the squash."""
    (W0, b0), (W1, b1) = layers
    mean = np.tanh(obs @ W0.T + b0) @ W1.T + b1
    return np.tanh(mean) if squash == "tanh" else np.clip(mean, -1.0, 1.0)


@pytest.mark.parametrize("squash", ["clip", "tanh"])
def test_exported_file_acts_as_the_library_would(env, tmp_path, squash):
    rng = np.random.default_rng(3)
    d = env.observation_space("robot_0").shape[0]
    obs = real_observations(env, seeds=(0, 1), steps=20, every=4)
    assert obs.shape[1] == d and len(obs) >= 10
    (W0, b0), (W1, b1) = _layers(d, rng)
    k = 1.0 / np.median(np.abs(np.tanh(obs @ W0.T + b0) @ W1.T + b1))  # half the means past +-1: the squash matters
    layers = [(W0, b0), (W1 * k, b1 * k)]
    lay = unwrap_env(env).layout
    export_actor(tmp_path / "p", layers, "tanh", squash=squash, layout=lay, scenario="ramp", extra={"x": 1})
    want = _reference(layers, obs, squash)
    assert (np.abs(want) > 0.95).any() and (np.abs(want) < 0.9).any()  # both saturated and inner actions
    got = load_policy(tmp_path / "p", env).act_batch(obs)
    np.testing.assert_allclose(got, want, atol=1e-6)
    meta = json.loads((tmp_path / "p" / "policy.json").read_text())
    sizes = [d, 5, 2] + ([2] if squash == "tanh" else [])  # tanh: one identity layer after the network's tanh
    assert meta["network"]["layer_sizes"] == sizes and meta["network"]["action_transform"] == "clip"
    assert meta["training"]["x"] == 1 and meta["training"]["action_squash"].startswith(squash)
    # the check: zero against the hand-written reference, the real gap against a wrong squash
    assert max_action_gap(tmp_path / "p", env, lambda o: _reference(layers, o, squash), obs) < 1e-6
    other = "clip" if squash == "tanh" else "tanh"
    gap = max_action_gap(tmp_path / "p", env, lambda o: _reference(layers, o, other), obs)
    assert gap == pytest.approx(np.abs(want - _reference(layers, obs, other)).max(), abs=1e-6) and gap > 0.01


def test_export_refuses_what_it_cannot_write_exactly(env, tmp_path):
    rng = np.random.default_rng(0)
    layers = _layers(env.observation_space("robot_0").shape[0], rng)
    lay = unwrap_env(env).layout
    with pytest.raises(ArgumentError, match="hidden activation must be 'tanh'"):
        export_actor(tmp_path / "a", layers, "relu", squash="tanh", layout=lay, scenario="ramp")
    with pytest.raises(ArgumentError, match="squash must be one of"):
        export_actor(tmp_path / "b", layers, "tanh", squash="sigmoid", layout=lay, scenario="ramp")
    with pytest.raises(ArgumentError, match="2 outputs"):
        export_actor(tmp_path / "c", [layers[0]], "tanh", squash="clip", layout=lay, scenario="ramp")
    assert not any(tmp_path.iterdir())  # nothing written
    with pytest.raises(ArgumentError, match=r"shape \(4, 2\), the file's \(3, 2\)"):
        export_actor(tmp_path / "d", layers, "tanh", squash="clip", layout=lay, scenario="ramp")
        max_action_gap(tmp_path / "d", env, lambda o: np.zeros((len(o) + 1, 2)), np.zeros((3, layers[0][0].shape[1])))


def test_a_shielded_export_acts_behind_the_safety_cut(env, tmp_path):
    """``shield="safety_cut"``: the file records it and its actions are the network's, cut by the
    env's shield (an actor trained or deployed behind it)."""
    from tin_swarm_env.policies.base import SafetyShield

    rng = np.random.default_rng(5)
    d = env.observation_space("robot_0").shape[0]
    obs = real_observations(env, seeds=(0, 1), steps=20, every=4)
    layers = _layers(d, rng, scale=3.0)
    lay = unwrap_env(env).layout
    export_actor(tmp_path / "s", layers, "tanh", squash="clip", layout=lay, scenario="ramp", shield="safety_cut")
    assert json.loads((tmp_path / "s" / "policy.json").read_text())["shield"] == "safety_cut"
    want = SafetyShield(env)(_reference(layers, obs, "clip"), obs)
    np.testing.assert_allclose(load_policy(tmp_path / "s", env).act_batch(obs), want, atol=1e-6)
    export_actor(tmp_path / "n", layers, "tanh", squash="clip", layout=lay, scenario="ramp")
    assert json.loads((tmp_path / "n" / "policy.json").read_text()).get("shield", "none") == "none"
