"""PufferLib: the native PufferEnv steps the vector env into PufferLib's buffers, runs under
pufferlib.vector's backends, and PuffeRL trains on it with the advantage kernel written for the CPU."""

import numpy as np
import pytest

pytest.importorskip("pufferlib", reason="pufferlib-core not installed: pip install 'tin_swarm_env[puffer]'")
torch = pytest.importorskip("torch")

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.adapters.puffer import make_puffer_env, puff_advantage, use_cpu_advantage  # noqa: E402


def test_buffers_hold_the_vector_envs_numbers_and_frozen_robots_read_zeros():
    pe = make_puffer_env("cliff_goal", n_envs=2, n_robots=4, seed=3, max_cycles=120)
    ve = tse.vector_env("cliff_goal", n_envs=2, n_robots=4, seed=3, max_cycles=120)
    obs, infos = pe.reset()
    np.testing.assert_array_equal(obs, ve.reset().reshape(8, -1))
    assert pe.num_agents == pe.agents_per_batch == 8 and obs is pe.observations and infos == []
    ended_once = np.zeros(8, dtype=bool)
    saw_frozen = False
    for _ in range(120):
        act = pe.observations[:, 7:9].astype(np.float64)  # at the target: over the cliff, robots fall one by one
        live_before = ve.live_mask.reshape(-1)
        vo, vr, vt, vtr, vi = ve.step(act.reshape(2, 4, 2))
        o, r, t, tr, infos = pe.step(act)
        np.testing.assert_array_equal(r, vr.reshape(-1))
        np.testing.assert_array_equal(t, vt.reshape(-1))
        np.testing.assert_array_equal(tr, vtr.reshape(-1))
        np.testing.assert_array_equal(pe.masks, live_before)
        ended = t | tr
        assert not (ended & ended_once).any()  # one end per robot-episode
        ended_once |= ended
        final = np.repeat(vi["_final"], 4)
        ended_once[final] = False
        frozen = ~vi["live"].reshape(-1) & ~final
        saw_frozen |= bool(frozen.any())
        assert np.all(o[frozen] == 0) and np.all(r[~live_before] == 0)
        if ended.any():
            assert infos and abs(sum(infos[0].values()) - 1.0) < 1e-9
        np.testing.assert_array_equal(o[~frozen], vo.reshape(8, -1)[~frozen])
    assert saw_frozen


def test_runs_under_pufferlibs_vector_backends():
    import pufferlib.vector

    v = pufferlib.vector.make(make_puffer_env, env_kwargs={"scenario": "ramp", "n_envs": 2, "n_robots": 3},
                              backend=pufferlib.vector.Serial, num_envs=2)
    v.async_reset(0)
    o, r, d, t, ta, info, env_id, mask = v.recv()
    assert o.shape == (12, v.single_observation_space.shape[0])
    v.send(np.zeros((12, 2), dtype=np.float32))
    o, r, d, t, ta, info, env_id, mask = v.recv()
    assert np.isfinite(r).all() and o.any()
    v.close()


def _advantage_reference(values, rewards, dones, importance, gamma, lam, rho_clip, c_clip):
    """PufferLib's puff_advantage_row (extensions/pufferlib.cpp), element by element."""
    out = np.zeros_like(values)
    for row in range(values.shape[0]):
        last = np.float32(0.0)
        for t in range(values.shape[1] - 2, -1, -1):
            nonterminal = np.float32(1.0) - dones[row, t + 1]
            rho = min(importance[row, t], np.float32(rho_clip))
            c = min(importance[row, t], np.float32(c_clip))
            delta = rho * (rewards[row, t + 1] + np.float32(gamma) * values[row, t + 1] * nonterminal - values[row, t])
            last = delta + np.float32(gamma) * np.float32(lam) * c * last * nonterminal
            out[row, t] = last
    return out


def test_cpu_advantage_kernel_is_pufferlibs():
    rng = np.random.default_rng(0)
    v, r, imp = (rng.normal(size=(5, 9)).astype(np.float32) for _ in range(3))
    imp = np.abs(imp) + np.float32(0.5)
    d = (rng.random((5, 9)) < 0.2).astype(np.float32)
    adv = torch.zeros(5, 9)
    puff_advantage(*(torch.from_numpy(a) for a in (v, r, d, imp)), adv, 0.99, 0.95, 1.0, 1.0)
    np.testing.assert_allclose(adv.numpy(), _advantage_reference(v, r, d, imp, 0.99, 0.95, 1.0, 1.0), rtol=1e-5,
                               atol=1e-5)
    assert adv[:, -1].eq(0).all() and adv.abs().sum() > 0


def test_pufferl_trains_on_it(tmp_path):
    use_cpu_advantage()
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("train_puffer", "agents/train_puffer.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["train_puffer"] = mod
    spec.loader.exec_module(mod)
    out = mod.main(["--scenario", "ramp", "--n-envs", "4", "--n-robots", "2", "--max-cycles", "20", "--horizon", "8",
                    "--minibatch-size", "64", "--max-steps", "400", "--hidden", "8", "--out-dir", str(tmp_path)])
    state = torch.load(out / "model.pt", weights_only=True)
    assert (out / "progress.csv").read_text().count("\n") >= 2 and "decoder_mean.weight" in state


def test_the_shield_cuts_the_actions_and_the_rewards_are_scaled():
    """``shield="safety_cut"`` steps the vector env with the shield's cut of the actions (read from
    the observations they were chosen from); ``reward_scale`` multiplies every reward; bad values
    are refused by name."""
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.policies.base import SafetyShield

    pe = make_puffer_env("cliff_goal", n_envs=2, n_robots=3, seed=4, max_cycles=60, shield="safety_cut",
                         reward_scale=0.01)
    ve = tse.vector_env("cliff_goal", n_envs=2, n_robots=3, seed=4, max_cycles=60)
    shield = SafetyShield(tse.parallel_env(scenario="cliff_goal", n_robots=3, max_cycles=60))
    o = pe.reset()[0].copy()
    ve.reset()
    cut_any = False
    for _ in range(60):
        act = o[:, 7:9].astype(np.float64) * 2.0  # toward the target, over the cliff
        cut = shield(act, o)
        cut_any |= bool(np.abs(cut - np.clip(act, -1, 1)).max() > 1e-3)
        vo, vr, *_ = ve.step(cut.reshape(2, 3, 2))
        o, r, *_ = pe.step(act)
        o = o.copy()
        np.testing.assert_allclose(r, vr.reshape(-1) * np.float32(0.01), rtol=1e-6)
    assert cut_any
    with pytest.raises(ArgumentError, match="shield"):
        make_puffer_env("ramp", shield="bogus")
    with pytest.raises(ArgumentError, match="reward_scale"):
        make_puffer_env("ramp", reward_scale=0.0)


def _train_puffer():
    import importlib.util
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("train_puffer", root / "agents" / "train_puffer.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclass looks its module up
    spec.loader.exec_module(mod)
    return mod


def _tiny_run(out, *extra):
    _train_puffer().main(["--scenario", "ramp", "--n-envs", "2", "--n-robots", "2", "--max-cycles", "40",
                          "--horizon", "8", "--minibatch-size", "32", "--max-minutes", "0.05", "--snapshot-minutes",
                          "0.01", "--hidden", "8", "--torch-threads", "1", "--out-dir", str(out), *extra])


def test_train_puffer_writes_a_checked_pickle_free_policy_and_snapshots(tmp_path):
    """agents/train_puffer.py: a tiny run exports the actor (its deterministic action, behind the
    shield) to OUT/policy, checked against torch's, with snapshots for the learning curve."""
    import json

    from tin_swarm_env.policies.learned import load_policy

    out = tmp_path / "run"
    _tiny_run(out)
    meta = json.loads((out / "policy" / "policy.json").read_text())
    assert meta["shield"] == "safety_cut" and meta["network"]["layer_sizes"][1:] == [8, 8, 2]
    run = json.loads((out / "run.json").read_text())
    assert run["export_max_action_gap"] <= 1e-4 and run["library"] == "pufferlib"
    assert sorted(p.name for p in (out / "policy").iterdir()) == ["policy.json", "weights.npz"]
    assert list((out / "snapshots").glob("m*/policy/policy.json"))
    env = tse.parallel_env(scenario="ramp", n_robots=2)
    obs, _ = env.reset(seed=0)
    a = load_policy(out / "policy", env).act_batch(np.stack(list(obs.values())))
    assert a.shape == (2, 2) and np.isfinite(a).all()


def test_the_mirror_actor_is_equivariant_and_exports_to_a_mirror_file(tmp_path):
    """``--symmetry mirror``: the torch actor's mean is mirror-equivariant exactly (by construction),
    and its file (``"symmetry": "mirror"``) acts as it does (the run's export check) and is
    equivariant too."""
    import json

    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies.learned import load_policy
    from tin_swarm_env.policies.symmetry import mirror_map

    out = tmp_path / "mirror"
    _tiny_run(out, "--symmetry", "mirror", "--shield", "none")
    meta = json.loads((out / "policy" / "policy.json").read_text())
    assert meta["symmetry"] == "mirror" and meta.get("shield", "none") == "none"
    assert json.loads((out / "run.json").read_text())["export_max_action_gap"] <= 1e-4
    env = tse.parallel_env(scenario="ramp", n_robots=2)
    pol = load_policy(out / "policy", env)
    o = np.random.default_rng(0).uniform(-1, 1, (100, env.layout.size))
    np.testing.assert_allclose(pol.act_batch(env.layout.mirror(o)), mirror_action(pol.act_batch(o)), atol=1e-6)
    mod = _train_puffer()
    pe = make_puffer_env("ramp", n_envs=1, n_robots=2)
    net = mod.tanh_mlp_class()(pe, hidden_size=8, mirror=mirror_map(env.layout))
    with torch.no_grad():
        net.decoder_mean.weight.mul_(100.0)  # means far from zero, so a wrong mirror would show
        x = torch.as_tensor(o, dtype=torch.float32)
        a, b = net.mean(x).numpy(), net.mean(torch.as_tensor(env.layout.mirror(o), dtype=torch.float32)).numpy()
        va, vb = net.forward_eval(x)[1], net.forward_eval(torch.as_tensor(env.layout.mirror(o), dtype=torch.float32))[1]
    np.testing.assert_allclose(b, mirror_action(a), atol=1e-4)
    np.testing.assert_allclose(va.numpy(), vb.numpy(), atol=1e-5)
    assert np.abs(a[:, 1]).max() > 0.1


def test_train_puffer_trains_on_a_mix_and_exports_behind_another_shield(tmp_path):
    """``--scenario ramp,cliff_goal``: the vector env's mix (copies take them in turn);
    ``--export-shield safety_cut_scan``: trained behind safety_cut, the file names the scan shield
    and the export check holds behind it."""
    import json

    out = tmp_path / "run"
    _tiny_run(out, "--scenario", "ramp,cliff_goal", "--export-shield", "safety_cut_scan")
    meta = json.loads((out / "policy" / "policy.json").read_text())
    run = json.loads((out / "run.json").read_text())
    assert meta["shield"] == "safety_cut_scan" and run["args"]["shield"] == "safety_cut"
    assert run["args"]["scenario"] == "ramp,cliff_goal" and run["export_max_action_gap"] <= 1e-4


def test_the_mirror_gru_steps_as_it_trains_is_equivariant_over_histories_and_exports(tmp_path):
    """``--cell gru --symmetry mirror``: PuffeRL's one-step forward (its state carried in ``lstm_h``)
    gives the training forward's sequence step by step; a mirrored history gives mirrored actions
    and the same values at every step; the run writes a recurrent mirror file that acts as torch
    does over sequences (the run's export check) and keeps its memory per row."""
    import json

    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies.learned import load_policy
    from tin_swarm_env.policies.symmetry import mirror_map

    env = tse.parallel_env(scenario="ramp", n_robots=2)
    mod = _train_puffer()
    pe = make_puffer_env("ramp", n_envs=1, n_robots=2)
    net = mod.mirror_gru_class()(pe, hidden_size=8, mirror=mirror_map(env.layout))
    assert net.hidden_size == 16  # both streams' states side by side in PuffeRL's lstm_h
    rng = np.random.default_rng(0)
    x = torch.as_tensor(rng.uniform(-1, 1, (3, 12, env.layout.size)), dtype=torch.float32)  # (B, T, d)
    xm = torch.as_tensor(env.layout.mirror(x.numpy()), dtype=torch.float32)
    with torch.no_grad():
        net.actor[2].weight.mul_(300.0)  # means far from zero, so a wrong mirror would show
        dist, value = net(x, {"lstm_h": None, "lstm_c": None})
        dist_m, value_m = net(xm, {"lstm_h": None, "lstm_c": None})
        state, steps, values = {"lstm_h": None}, [], []
        for t in range(12):
            d, v = net.forward_eval(x[:, t], state)
            steps.append(d.loc)
            values.append(v)
    mean = dist.loc.numpy().reshape(3, 12, 2)
    assert value.shape == (3, 12) and state["lstm_h"].shape == (3, 16) and np.abs(mean[..., 1]).max() > 0.1
    np.testing.assert_allclose(torch.stack(steps, 1).numpy(), mean, atol=1e-5)
    np.testing.assert_allclose(torch.stack(values, 1).numpy(), value.numpy(), atol=1e-5)
    np.testing.assert_allclose(dist_m.loc.numpy().reshape(3, 12, 2), mirror_action(mean), atol=1e-5)
    np.testing.assert_allclose(value_m.numpy(), value.numpy(), atol=1e-5)
    out = tmp_path / "gru"
    _tiny_run(out, "--cell", "gru", "--symmetry", "mirror")
    meta = json.loads((out / "policy" / "policy.json").read_text())
    assert meta["network"]["type"] == "recurrent" and meta["network"]["cell"] == "gru"
    assert meta["symmetry"] == "mirror" and meta["network"]["layer_sizes"] == [8, 8, 2]
    assert json.loads((out / "run.json").read_text())["export_max_action_gap"] <= 1e-4
    pol = load_policy(out / "policy", env)
    o = rng.uniform(-1, 1, (5, 4, env.layout.size))  # 5 steps of 4 robots
    a = [pol.act_batch(o[t]) for t in range(5)]
    pol.reset()
    b = [pol.act_batch(env.layout.mirror(o[t])) for t in range(5)]
    np.testing.assert_allclose(b, mirror_action(np.array(a)), atol=1e-9)


def test_the_apf_prior_adds_apfs_commands_and_forgets_a_copy_that_resets():
    """``prior="apf"`` / ``"apf_mirror"``: zero corrections drive every copy exactly as the prior
    deployed in a file drives an episode of its own (the reference: one prior per copy, rows 0..n-1, so
    robot ``i`` has robot ``i``'s side preference, reset with its copy); a bad name is refused by name."""
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.policies.residual import make_prior

    one = tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=30)
    for name in ("apf", "apf_mirror"):
        _prior_drives_each_copy_as_its_own_episode(name, [make_prior(name, one), make_prior(name, one)])
    with pytest.raises(ArgumentError, match="prior"):
        make_puffer_env("ramp", prior="bogus")


def _prior_drives_each_copy_as_its_own_episode(name, ref):
    pe = make_puffer_env("ramp", n_envs=2, n_robots=3, seed=5, max_cycles=30, prior=name)
    ve = tse.vector_env("ramp", n_envs=2, n_robots=3, seed=5, max_cycles=30)
    pe.reset()
    vo = ve.reset()
    resets = 0
    for _ in range(75):
        live = ve.live_mask
        a = np.stack([ref[c](np.where(live[c][:, None], vo[c], np.float32(0))) for c in range(2)])
        for c in range(2):
            ref[c].driven(a[c])
        vo, _, _, _, vi = ve.step(a)
        for c in np.flatnonzero(vi["_final"]):
            ref[c].reset()
            resets += 1
        o, *_ = pe.step(np.zeros((6, 2)))
        frozen = ~vi["live"].reshape(-1) & ~np.repeat(vi["_final"], 3)
        np.testing.assert_array_equal(o[~frozen], vo.reshape(6, -1)[~frozen], err_msg=name)
    assert resets >= 4


def test_train_puffer_trains_a_residual_over_apf_mirror_and_exports_it(tmp_path):
    """``--prior apf_mirror``: the exported file names its prior and matches torch plus the prior; the
    actor's head stays as it started through ``--critic-warmup-minutes``; a recurrent residual is refused."""
    import json

    out = tmp_path / "run"
    _tiny_run(out, "--prior", "apf_mirror", "--symmetry", "mirror", "--init-logstd", "-1.6",
              "--critic-warmup-minutes", "1")
    meta = json.loads((out / "policy" / "policy.json").read_text())
    run = json.loads((out / "run.json").read_text())
    assert meta["prior"] == "apf_mirror" and meta["symmetry"] == "mirror" and run["export_max_action_gap"] <= 1e-4
    sd = torch.load(out / "model.pt")
    np.testing.assert_allclose(sd["decoder_logstd"].numpy(), -1.6, rtol=1e-6)  # never updated (warm-up)
    with pytest.raises(SystemExit, match="--cell none"):
        _tiny_run(tmp_path / "gru", "--prior", "apf", "--cell", "gru")
