"""Residual policy files (``"prior": "apf"``): APF's command plus the network's, then the clip and
the shield; APF's odometry integrates what was executed (tin_swarm_env/policies/residual.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import mirror_action
from tin_swarm_env.errors import ArgumentError, PolicyFileError
from tin_swarm_env.policies import APFPolicy, load_policy, save_policy
from tin_swarm_env.policies.base import make_shield
from tin_swarm_env.policies.residual import APFPrior, MirrorAPFPrior, add_prior, make_prior
from tin_swarm_env.training.rollout import rollout


def _layers(d, scale, seed=0, hidden=8):
    rng = np.random.default_rng(seed)
    return [(rng.normal(0, scale, (hidden, d)), rng.normal(0, scale, hidden)),
            (rng.normal(0, scale, (2, hidden)), rng.normal(0, scale, 2))]


def _file(tmp_path, env, scale, prior="apf", **kw):
    return save_policy(tmp_path / "res", _layers(env.layout.size, scale), layout=env.layout, scenario="ramp",
                       prior=prior, **kw)


def _history(env, seed=0, steps=40):
    """Real observations ``(steps, n, d)`` of an APF episode (the robots meet slopes and each other)."""
    apf, out = APFPolicy(env), []
    obs = env.reset_arrays(seed=seed)
    for _ in range(steps):
        out.append(obs.copy())
        obs, *_ = env.step_arrays(apf.act_batch(obs))
    return np.stack(out)


def test_a_zero_network_drives_exactly_as_apf(tmp_path):
    """With every weight 0 the file is APF itself: the same episode, robot for robot, step for step."""
    env = tse.parallel_env(scenario="ramp", n_robots=4, max_cycles=150)
    pol = load_policy(_file(tmp_path, env, 0.0), env)
    a = rollout(env, pol, seed=3)
    b = rollout(env, APFPolicy(env), seed=3)
    np.testing.assert_array_equal(a.reasons, b.reasons)
    np.testing.assert_array_equal(a.steps, b.steps)
    np.testing.assert_array_equal(a.returns, b.returns)


def test_the_action_is_the_shielded_clip_of_apf_plus_the_network_and_apf_integrates_it(tmp_path):
    """Each step: ``shield(clip(apf(o) + g(o)))``, with a reference APF told the executed command (its
    odometry); the network alone is the same weights without the prior."""
    env = tse.parallel_env(scenario="ramp", n_robots=5, max_cycles=80)
    path = _file(tmp_path, env, 0.3, shield="safety_cut_scan")
    pol = load_policy(path, env)
    net = save_policy(tmp_path / "net", _layers(env.layout.size, 0.3), layout=env.layout, scenario="ramp")
    g = load_policy(net, env)
    ref, shield = APFPolicy(env), make_shield("safety_cut_scan", env)
    obs = env.reset_arrays(seed=1)
    pol.reset()
    for _ in range(60):
        corr = np.clip(g._mean(obs), -1, 1)
        want = shield(np.clip(ref.act_batch(obs).astype(np.float64) + corr, -1, 1).astype(np.float32), obs)
        ref.memory.last_act[:] = want
        got = pol.act_batch(obs)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(pol.prior.apf.memory.last_act, want)
        obs, *_ = env.step_arrays(got)
    assert np.abs(g._mean(obs)).max() > 0.05  # the network's share is not negligible


def test_the_default_apf_is_not_equivariant_but_apf_mirror_and_its_files_are_exactly():
    """On cliff_goal the default APF's two images part at the first step (which way round the cliff);
    ``apf_mirror`` (two streams, one chosen per robot by its shorter way) maps mirror histories onto
    mirror actions exactly, and so does a residual file over it with a mirror network."""
    env = tse.parallel_env(scenario="cliff_goal", n_robots=6, max_cycles=200)
    h = _history(env, seed=2)
    apf, twin_apf = APFPolicy(env), APFPolicy(env)
    gap = max(np.abs(twin_apf.act_batch(env.layout.mirror(o)) - mirror_action(apf.act_batch(o))).max() for o in h)
    assert gap > 0.1
    p, q = MirrorAPFPrior(env), MirrorAPFPrior(env)
    for t, o in enumerate(h):
        x, y = p(o), q(env.layout.mirror(o))
        np.testing.assert_array_equal(y, mirror_action(x), err_msg=f"step {t}")
        p.driven(x)
        q.driven(y)
    assert (p.choice != 0).any()  # some robots chose a stream
    np.testing.assert_array_equal(q.choice, -p.choice)


@pytest.mark.parametrize("shield", ["none", "safety_cut_scan"])
def test_a_mirror_residual_file_over_apf_mirror_is_equivariant_over_a_history(tmp_path, shield):
    env = tse.parallel_env(scenario="cliff_goal", n_robots=6, max_cycles=200)
    path = _file(tmp_path, env, 0.3, symmetry="mirror", shield=shield, prior="apf_mirror")
    pol, twin = load_policy(path, env), load_policy(path, env)
    for t, o in enumerate(_history(env, seed=2)):
        np.testing.assert_array_equal(twin.act_batch(env.layout.mirror(o)), mirror_action(pol.act_batch(o)),
                                      err_msg=f"step {t}")


def test_forget_restarts_some_rows_as_a_fresh_apf_would():
    """``APFPrior.forget(rows)``: those robots act as on their first step, the others keep their memory."""
    env = tse.parallel_env(scenario="cliff_goal", n_robots=4, max_cycles=200)
    h = _history(env, seed=0, steps=50)
    p, q = APFPrior(env), APFPrior(env)
    for o in h[:30]:
        p(o)
        q(o)
    p.forget([1, 3])
    fresh = APFPrior(env)
    differs = False  # the memory matters: the forgotten rows act otherwise than the kept ones would
    for t, o in enumerate(h[30:]):
        a, b, c = p(o), q(o), fresh(o)
        np.testing.assert_array_equal(a[[0, 2]], b[[0, 2]], err_msg=f"kept rows, step {t}")
        np.testing.assert_array_equal(a[[1, 3]], c[[1, 3]], err_msg=f"forgotten rows, step {t}")
        differs |= not np.array_equal(a[[1, 3]], b[[1, 3]])
    assert differs


def test_add_prior_clips_and_bad_priors_are_refused_by_name(tmp_path):
    np.testing.assert_array_equal(add_prior([[0.8, -0.5]], [[0.5, -0.7]]), np.float32([[1.0, -1.0]]))
    # the correction is clipped to the action box first (as the trainer clipped its samples)
    np.testing.assert_array_equal(add_prior([[-1.0, 0.25]], [[3.0, -0.5]]), np.float32([[0.0, -0.25]]))
    env = tse.parallel_env(scenario="ramp", n_robots=2)
    with pytest.raises(ArgumentError, match="'bogus'"):
        make_prior("bogus", env)
    with pytest.raises(ArgumentError, match="needs the env"):
        make_prior("apf", None)
    assert make_prior("none", env) is None
    with pytest.raises(ArgumentError, match=r"shape \(2, 2\)"):
        APFPrior(env).driven(np.zeros((3, 2)), rows=[0, 1])


def test_the_file_names_its_prior_and_bad_prior_keys_are_refused(tmp_path):
    env = tse.parallel_env(scenario="ramp", n_robots=2)
    path = _file(tmp_path, env, 0.1)
    meta = json.loads((path / "policy.json").read_text())
    assert meta["prior"] == "apf"
    assert "prior='apf'" in repr(load_policy(path, env))
    for bad, match in (("bogus", "key 'prior' is 'bogus'"), (3, "key 'prior' must be")):
        (path / "policy.json").write_text(json.dumps({**meta, "prior": bad}))
        with pytest.raises(PolicyFileError, match=match):
            load_policy(path, env)
    rec = save_policy(tmp_path / "rec", _layers(8, 0.1), layout=env.layout, scenario="ramp",
                      cell=("gru", {"cell_W_ih": np.zeros((24, env.layout.size)), "cell_W_hh": np.zeros((24, 8)),
                                    "cell_b_ih": np.zeros(24), "cell_b_hh": np.zeros(24)}))
    rmeta = json.loads((rec / "policy.json").read_text())
    (rec / "policy.json").write_text(json.dumps({**rmeta, "prior": "apf"}))
    with pytest.raises(PolicyFileError, match=r"rec.*needs an 'mlp' network with the mean head.*'recurrent'"):
        load_policy(rec, env)
    head = {"type": "categorical", "actions": [[0.0, 0.0], [1.0, 0.0]], "acting": "mode", "seed": 0}
    with pytest.raises(PolicyFileError, match="needs an 'mlp' network with the mean head"):
        save_policy(tmp_path / "cat", _layers(env.layout.size, 0.1), layout=env.layout, scenario="ramp",
                    prior="apf", head=head)
