"""Pickle-free policy files: SB3 export -> numpy load gives SB3's deterministic actions; every
corruption of the files is refused naming the file (and key); loading never unpickles."""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.errors import PolicyFileError, TinSwarmError
from tin_swarm_env.policies import MLPPolicy, load_policy, save_policy
from tin_swarm_env.policies.learned import _layout_dict

# the layout these policy files were written for: no terrain scan (59 elements), the default before it
# had the scan; a policy file carries its layout and runs on an env built with it (policy_scenario)
SCEN = {"scenario": load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0)), "n_robots": 4, "max_cycles": 30}


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A tiny PPO (a few hundred steps), its vec env and its exported policy directory."""
    torch = pytest.importorskip("torch")
    from stable_baselines3 import PPO

    from tin_swarm_env.adapters.sb3 import export_sb3_policy

    vec = tse.adapters.make_sb3_vec_env(SCEN["scenario"], n_robots=4, n_envs=1, seed=0, max_cycles=30)
    model = PPO("MlpPolicy", vec, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu",
                policy_kwargs={"net_arch": [32, 16]})
    model.learn(256)
    with torch.no_grad():  # make the outputs large enough that clipping to [-1, 1] is exercised
        model.policy.action_net.weight.mul_(400.0)
    d = tmp_path_factory.mktemp("pol") / "shared"
    export_sb3_policy(model, d, vec, extra={"note": "test"})
    return model, vec, d


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A policy directory written by save_policy alone (no torch): random 59-32-16-2 tanh layers, the
    layout of the cliff_goal env; what the refusal tests edit."""
    rng = np.random.default_rng(0)
    sizes = [59, 32, 16, 2]
    layers = [(rng.normal(0, 1, (m, n)), rng.normal(0, 1, m)) for n, m in zip(sizes[:-1], sizes[1:])]
    return save_policy(tmp_path_factory.mktemp("pol") / "shared", layers, "tanh", layout=env().layout,
                       scenario="cliff_goal", extra={"note": "test"})


def env(**kw):
    args = dict(SCEN)
    args.update(kw)
    return tse.parallel_env(**args)


def observations(n=200, seed=0):
    e = env()
    rng = np.random.default_rng(seed)
    out = []
    obs, _ = e.reset(seed=seed)
    while len(out) < n:
        out += list(obs.values())
        obs, *_ = e.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in e.agents})
        if not e.agents:
            obs, _ = e.reset(seed=seed + len(out))
    return np.stack(out[:n])


def test_exported_policy_acts_as_sb3_predict(trained):
    model, _, d = trained
    pol = load_policy(d, env())
    assert isinstance(pol, MLPPolicy)
    obs = observations(200)
    ref, _ = model.predict(obs, deterministic=True)
    got = pol.act_batch(obs)
    assert got.shape == (200, 2) and got.dtype == np.float32
    np.testing.assert_allclose(got, ref, atol=1e-5)
    assert np.any(np.abs(got) == 1.0) and np.any(np.abs(got) < 1.0)  # clipping exercised, not everywhere
    meta = json.loads((d / "policy.json").read_text())
    assert meta["scenario"] == "cliff_goal" and meta["network"]["layer_sizes"] == [59, 32, 16, 2]
    assert meta["training"]["algorithm"] == "PPO" and meta["training"]["note"] == "test"
    e = env()
    o, _ = e.reset(seed=3)
    acts = pol.act(o)
    assert set(acts) == set(o) and all(a.shape == (2,) for a in acts.values())


def test_layout_mismatch_is_refused_naming_both(saved, tmp_path):
    with pytest.raises(PolicyFileError, match=r"policy\.json.*'k_robots': 4.*environment's layout.*'k_robots': 6"):
        load_policy(saved, _env_with_k(6, tmp_path))


def test_a_layout_that_differs_only_in_a_scale_names_the_scale(saved, tmp_path):
    """Counts and names equal, one scale changed: the message shows that key on both sides (it printed two
    identical summaries)."""
    p = _copy(saved, tmp_path)
    _edit_json(p, lambda j: j["observation"]["layout"]["scales"].update(dz_scale_m=20.0))
    with pytest.raises(PolicyFileError, match=r"'scales\.dz_scale_m': 20\.0.*environment's layout.*"
                                              r"'scales\.dz_scale_m': 10\.0"):
        load_policy(p, env())


def _env_with_k(k, dd):
    """The cliff_goal env with ``k`` robot slots, from a scenario file written in ``dd``."""
    from tin_swarm_env.scenario import SCENARIO_DIR

    text = (SCENARIO_DIR / "cliff_goal.toml").read_text()
    if "[observation]" in text:
        text = text.replace("[observation]", f"[observation]\nk_robots = {k}", 1)
    else:
        text += f"\n[observation]\nk_robots = {k}\n"
    p = os.path.join(dd, "k.toml")
    with open(p, "w") as fh:
        fh.write(text)
    return tse.parallel_env(scenario=p, n_robots=4)


def _copy(d, tmp_path, name="p"):
    out = tmp_path / name
    shutil.copytree(d, out)
    return out


def _edit_json(p, fn):
    j = json.loads((p / "policy.json").read_text())
    fn(j)
    (p / "policy.json").write_text(json.dumps(j))


def _edit_npz(p, fn):
    with np.load(p / "weights.npz") as f:
        a = {k: f[k] for k in f.files}
    fn(a)
    np.savez(p / "weights.npz", **a)


JSON_EDITS = {
    "format": (lambda j: j.update(format="something.else"), r"policy\.json: key 'format'"),
    "version": (lambda j: j.update(version=2), r"policy\.json: key 'version' is 2"),
    "missing_network": (lambda j: j.pop("network"), r"policy\.json: missing key 'network'"),
    "activation": (lambda j: j["network"].update(activation="swish"), r"'network\.activation' is 'swish'"),
    "sizes_do_not_chain": (lambda j: j["network"].update(layer_sizes=[59, 33, 16, 2]),
                           r"weights\.npz: array 'W0' has shape \(32, 59\).*need \(33, 59\)"),
    "obs_size": (lambda j: j["observation"].update(size=60), r"'observation\.size' \(60\) differs"),
    "layout_names": (lambda j: j["observation"]["layout"]["names"].__setitem__(0, "own.charge"),
                     r"'observation\.layout'.*element 0 = 'own\.charge'.*environment's layout"),
    "transform": (lambda j: j["network"].update(action_transform="tanh"), r"'network\.action_transform'"),
    "sizes_type": (lambda j: j["network"].update(layer_sizes="59,32,2"), r"'layer_sizes' must be list"),
    "misspelt_shield": (lambda j: j.update(shiled="safety_cut"), r"policy\.json: unknown key 'shiled'; known at the top"),
    "network_extra": (lambda j: j["network"].update(colour="red"), r"unknown key 'network\.colour'"),
    "observation_extra": (lambda j: j["observation"].update(scale=2), r"unknown key 'observation\.scale'"),
    "action_extra": (lambda j: j["action"].update(dtype="f4"), r"unknown key 'action\.dtype'"),
}


@pytest.mark.parametrize("case", sorted(JSON_EDITS))
def test_edited_json_is_refused_naming_file_and_key(saved, tmp_path, case):
    fn, pattern = JSON_EDITS[case]
    p = _copy(saved, tmp_path)
    _edit_json(p, fn)
    with pytest.raises(PolicyFileError, match=pattern):
        load_policy(p, env())


NPZ_EDITS = {
    "nan": (lambda a: a["W1"].__setitem__((0, 0), np.nan), r"weights\.npz: array 'W1' holds NaN"),
    "wrong_shape": (lambda a: a.update(b0=np.zeros(31)), r"weights\.npz: array 'b0' has shape \(31,\)"),
    "missing_array": (lambda a: a.pop("b2"), r"weights\.npz: arrays .*missing \['b2'\]"),
    "extra_array": (lambda a: a.update(W9=np.zeros(2)), r"unexpected \['W9'\]"),
    "strings": (lambda a: a.update(b0=np.array(["x"] * 32)), r"array 'b0' holds <U1"),
}


@pytest.mark.parametrize("case", sorted(NPZ_EDITS))
def test_edited_weights_are_refused_naming_the_file(saved, tmp_path, case):
    fn, pattern = NPZ_EDITS[case]
    p = _copy(saved, tmp_path)
    _edit_npz(p, fn)
    with pytest.raises(PolicyFileError, match=pattern):
        load_policy(p, env())


class Boom:
    def __reduce__(self):
        return (os.system, ("touch PWNED_BY_POLICY",))


def test_a_pickled_object_array_is_never_unpickled(saved, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = _copy(saved, tmp_path)
    _edit_npz(p, lambda a: a.update(W0=np.array([Boom()], dtype=object)))
    with pytest.raises(PolicyFileError, match=r"weights\.npz: array 'W0' cannot be read without unpickling"):
        load_policy(p, env())
    assert not (tmp_path / "PWNED_BY_POLICY").exists()


def test_loading_never_calls_pickle(saved, monkeypatch):
    from tin_swarm_env.policies.learned import dense

    e = env()
    dense(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(1))  # numba reads its compile cache with pickle

    def no(*a, **k):
        raise AssertionError("pickle used")

    monkeypatch.setattr(pickle, "load", no)
    monkeypatch.setattr(pickle, "loads", no)
    monkeypatch.setattr(pickle, "Unpickler", no)
    pol = load_policy(saved, e)
    assert pol.act_batch(np.zeros((1, 59))).shape == (1, 2)


@pytest.mark.parametrize("what", ["no_dir", "no_json", "no_npz", "bad_json", "junk_npz", "json_list"])
def test_missing_or_unreadable_files_are_named(saved, tmp_path, what):
    p = _copy(saved, tmp_path)
    if what == "no_dir":
        p, pattern = tmp_path / "nowhere", r"nowhere: no such policy directory"
    elif what == "no_json":
        (p / "policy.json").unlink()
        pattern = r"policy\.json: missing"
    elif what == "no_npz":
        (p / "weights.npz").unlink()
        pattern = r"weights\.npz: missing"
    elif what == "bad_json":
        (p / "policy.json").write_text('{"format": "tin_swarm_env.policy",\n "version": 1,,}')
        pattern = r"policy\.json:2: not valid JSON"
    elif what == "junk_npz":
        (p / "weights.npz").write_bytes(b"PK\x03\x04 junk")
        pattern = r"weights\.npz: not a readable \.npz"
    else:
        (p / "policy.json").write_text("[1, 2]")
        pattern = r"policy\.json: the top level must be a JSON object"
    with pytest.raises(PolicyFileError, match=pattern):
        load_policy(p, env())


def test_a_file_of_the_directory_loads_it_and_a_directory_in_a_file_s_place_is_named(saved, tmp_path):
    """``.../weights.npz`` (or ``policy.json``) stands for its directory; a directory where ``weights.npz``
    should be is 'not a file' (it said 'missing'); a plain file given as the directory is named so."""
    p = _copy(saved, tmp_path)
    assert load_policy(p / "weights.npz", env()).act_batch(np.zeros((1, 59))).shape == (1, 2)
    other = tmp_path / "file.txt"
    other.write_text("x")
    with pytest.raises(PolicyFileError, match=r"file\.txt: is a file, not a policy directory"):
        load_policy(other, env())
    (p / "weights.npz").unlink()
    (p / "weights.npz").mkdir()
    with pytest.raises(PolicyFileError, match=r"weights\.npz: is not a file"):
        load_policy(p, env())


def test_policy_file_error_is_a_tin_swarm_error_and_value_error():
    assert issubclass(PolicyFileError, TinSwarmError) and issubclass(PolicyFileError, ValueError)


def test_save_is_atomic_and_replaces_only_a_policy_directory(tmp_path, monkeypatch):
    e = env()
    rng = np.random.default_rng(0)
    layers = [(rng.normal(size=(8, 59)), rng.normal(size=8)), (rng.normal(size=(2, 8)), rng.normal(size=2))]
    d = save_policy(tmp_path / "pol", layers, "relu", layout=e.layout, scenario="cliff_goal")
    pol = load_policy(d, e)
    x = rng.normal(size=(5, 59))
    ref = np.clip(np.maximum(x @ layers[0][0].T + layers[0][1], 0) @ layers[1][0].T + layers[1][1], -1, 1)
    np.testing.assert_allclose(pol.act_batch(x), ref, rtol=1e-6, atol=1e-6)
    # a failure half-way leaves the old policy and no temporary directory
    import tin_swarm_env.policies.learned as L

    def fail(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(L.json, "dump", fail)
    with pytest.raises(OSError, match="disk full"):
        save_policy(d, [(W * 2, b) for W, b in layers], "relu", layout=e.layout, scenario="cliff_goal")
    monkeypatch.undo()
    assert sorted(os.listdir(tmp_path)) == ["pol"]
    np.testing.assert_allclose(load_policy(d, e).act_batch(x), ref, rtol=1e-6, atol=1e-6)
    # replacing works; a non-policy path is refused
    save_policy(d, [(W * 2, b) for W, b in layers], "relu", layout=e.layout, scenario="cliff_goal")
    assert sorted(os.listdir(tmp_path)) == ["pol"]
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "keep.txt").write_text("mine")
    with pytest.raises(PolicyFileError, match="not a policy directory"):
        save_policy(tmp_path / "notes", layers, "relu", layout=e.layout, scenario="x")
    assert (tmp_path / "notes" / "keep.txt").read_text() == "mine"
    with pytest.raises(PolicyFileError, match="W1"):
        save_policy(tmp_path / "nan", [layers[0], (np.full((2, 8), np.nan), layers[1][1])], layout=e.layout,
                    scenario="x")
    assert not (tmp_path / "nan").exists()


def test_layout_dict_names_every_element():
    lay = env().layout
    d = _layout_dict(lay)
    assert len(d["names"]) == lay.size and d["k_robots"] == lay.k_robots


def test_export_of_a_model_without_an_mlp_actor_names_the_model():
    pytest.importorskip("torch")
    from types import SimpleNamespace

    from tin_swarm_env.adapters.sb3 import export_sb3_policy
    from tin_swarm_env.errors import ArgumentError

    class SAC:  # stands for any model whose policy has no mlp_extractor
        policy = SimpleNamespace(action_net=None)

    with pytest.raises(ArgumentError, match=r"model SAC\.policy has no mlp_extractor: only SB3 MlpPolicy"):
        export_sb3_policy(SAC(), None, "unused.npz")


def test_shield_filters_through_the_safety_cut(tmp_path):
    """``"shield": "safety_cut"``: the action is the network's, cut by the same
    :func:`safety_cut` APF applies last (constants from the env); ``net_batch`` is the raw net;
    the key round-trips through the file and an unknown shield is refused naming the key."""
    from tin_swarm_env.policies.base import SafetyShield

    e = env(n_robots=12)
    rng = np.random.default_rng(1)
    d = e.layout.size
    layers = [(rng.normal(0, 1, (16, d)), rng.normal(0, 1, 16)), (rng.normal(0, 3, (2, 16)), np.zeros(2))]
    p = save_policy(tmp_path / "sh", layers, layout=e.layout, scenario="cliff_goal", shield="safety_cut")
    assert json.loads((p / "policy.json").read_text())["shield"] == "safety_cut"
    pol = load_policy(p, e)
    plain = load_policy(save_policy(tmp_path / "plain", layers, layout=e.layout, scenario="cliff_goal"), e)
    assert "shield" not in json.loads((tmp_path / "plain" / "policy.json").read_text())
    obs = observations(300)
    ctl = SafetyShield(e)
    want = ctl.cut(plain.act_batch(obs), ctl.decode(obs.astype(np.float64)))
    got = pol.act_batch(obs)
    np.testing.assert_array_equal(pol.net_batch(obs), plain.act_batch(obs))
    np.testing.assert_allclose(got, want, atol=1e-7)
    assert not np.allclose(got, plain.act_batch(obs))  # the cut did change some actions
    # the cut never adds speed
    assert np.all(np.linalg.norm(got, axis=1) <= np.linalg.norm(plain.act_batch(obs), axis=1) + 1e-6)
    meta = json.loads((p / "policy.json").read_text())
    meta["shield"] = "magic"
    (p / "policy.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyFileError, match=r"policy\.json.*'shield'.*magic"):
        load_policy(p, e)
    with pytest.raises(TinSwarmError, match="needs the env"):
        MLPPolicy(layers, layout=_layout_dict(e.layout), shield="safety_cut")


# -- limits, checked before the weights are read ------------------------------------------------------------
def _small(tmp_path, name="small"):
    e = env()
    rng = np.random.default_rng(0)
    layers = [(rng.normal(size=(8, e.layout.size)), np.zeros(8)), (rng.normal(size=(2, 8)), np.zeros(2))]
    return save_policy(tmp_path / name, layers, layout=e.layout, scenario="flat"), e


def test_json_nested_too_deep_is_refused_before_parsing(tmp_path):
    from tin_swarm_env.policies.learned import MAX_JSON_DEPTH

    p, e = _small(tmp_path)
    (p / "policy.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(PolicyFileError, match=rf"policy\.json: JSON nested 100000 deep; at most {MAX_JSON_DEPTH}"):
        load_policy(p, e)
    (p / "policy.json").write_text('{"a": "' + "[" * 1000 + '"}')  # brackets inside a string do not count
    with pytest.raises(PolicyFileError, match="key 'format'"):
        load_policy(p, e)


def test_oversized_files_layers_and_weights_are_refused_naming_the_file(tmp_path):
    from tin_swarm_env.policies.learned import MAX_ABS_WEIGHT, MAX_JSON_BYTES

    p, e = _small(tmp_path)
    meta = json.loads((p / "policy.json").read_text())
    (p / "policy.json").write_text(json.dumps({**meta, "training": {"x": "a" * MAX_JSON_BYTES}}))
    with pytest.raises(PolicyFileError, match=r"policy\.json: [\d,]+ bytes; a policy file has at most"):
        load_policy(p, e)
    wide = {**meta, "network": {**meta["network"], "layer_sizes": [e.layout.size, 2_000_000, 2]}}
    (p / "policy.json").write_text(json.dumps(wide))
    with pytest.raises(PolicyFileError, match=r"layer_sizes.*beyond the limits: at most \d+ layers of 4096 units"):
        load_policy(p, e)
    (p / "policy.json").write_text(json.dumps(meta))
    # a small compressed file whose header claims a 20000 x 20000 array: refused from the header, never inflated
    np.savez_compressed(p / "weights.npz", W0=np.zeros((8, e.layout.size)), b0=np.zeros(8),
                        W1=np.zeros((20_000, 20_000), dtype=np.uint8), b1=np.zeros(2))
    assert (p / "weights.npz").stat().st_size < 1_000_000
    with pytest.raises(PolicyFileError, match=r"weights\.npz: array 'W1' has shape \(20000, 20000\)"):
        load_policy(p, e)
    np.savez(p / "weights.npz", W0=np.full((8, e.layout.size), 1e308), b0=np.zeros(8), W1=np.zeros((2, 8)),
             b1=np.zeros(2))
    with pytest.raises(PolicyFileError, match=r"array 'W0' holds a value of magnitude 1e\+308; at most "
                       + re.escape(f"{MAX_ABS_WEIGHT:g}")):
        load_policy(p, e)


def test_a_network_whose_output_overflows_blames_the_policy_not_a_robot():
    e = env()
    pol = MLPPolicy([(np.full((4, e.layout.size), 1e200), np.zeros(4)), (np.full((2, 4), 1e200), np.zeros(2))],
                    "identity", layout=e.layout.to_dict(), source="big/policy")
    with pytest.raises(PolicyFileError, match=r"big/policy: the network's output is not finite .* row 0"):
        pol.act_batch(np.ones((3, e.layout.size)))


def test_load_policy_names_a_path_of_the_wrong_type():
    with pytest.raises(TinSwarmError, match=r"load_policy\(path=\.\.\.\): path must be"):
        load_policy(None, env())
