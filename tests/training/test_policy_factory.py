"""Policies by name or path (training/policy_factory.py): specs checked before any work (names in any case,
directories, policy.json, .zip only when trusted), the built-in baselines and a pickle-free directory."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.cli import main


def test_run_takes_a_pickle_free_policy_directory(tmp_path, capsys):
    from tin_swarm_env.policies import save_policy

    env = tse.parallel_env(scenario="flat", n_robots=2)
    d = env.layout.size
    rng = np.random.default_rng(0)
    save_policy(tmp_path / "pol", [(rng.normal(size=(8, d)), np.zeros(8)), (rng.normal(size=(2, 8)), np.zeros(2))],
                layout=env.layout, scenario="flat")
    assert main(["run", "flat", "--policy", str(tmp_path / "pol"), "--robots", "2", "--max-cycles", "4",
                 "--quiet"]) == 0
    assert "policy " + str(tmp_path / "pol") in capsys.readouterr().out
    from tin_swarm_env.policies import MLPPolicy
    from tin_swarm_env.training.policy_factory import make_policy

    assert isinstance(make_policy(env, str(tmp_path / "pol" / "policy.json")), MLPPolicy)
    assert type(make_policy(env, "Random", seed=0)).__name__ == "RandomPolicy"


def test_policy_specs_are_checked_before_any_work(tmp_path):
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.training.policy_factory import check_policy_spec

    assert [check_policy_spec(s) for s in ("APF", " random ", "Geodesic")] == ["apf", "random", "geodesic"]
    (tmp_path / "pol").mkdir()
    (tmp_path / "pol" / "policy.json").write_text("{}")
    assert check_policy_spec(str(tmp_path / "pol")) == check_policy_spec(str(tmp_path / "pol" / "policy.json")) == "dir"
    z = tmp_path / "m.ZIP"
    z.write_bytes(b"PK")
    with pytest.raises(ArgumentError, match=r"^--model .*m\.ZIP: refusing to load an SB3 \.zip without --trust"):
        check_policy_spec(str(z), option="--model")
    assert check_policy_spec(str(z), trust_pickle=True) == "sb3"
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(ArgumentError, match="is not a policy directory or an SB3 .zip; give apf, apf-bug, apf-chart, random, geodesic"):
        check_policy_spec(str(tmp_path / "notes.txt"))
    with pytest.raises(ArgumentError, match="--policy 'ppo': no such file or directory"):
        check_policy_spec("ppo")


def test_make_policy_builds_the_named_baselines():
    from tin_swarm_env.policies import APFPolicy, GeodesicPolicy, RandomPolicy
    from tin_swarm_env.training.policy_factory import make_policy

    env = tse.parallel_env(scenario="flat", n_robots=2)
    apf = make_policy(env, "apf", fields=["robot", "target"])
    assert isinstance(apf, APFPolicy) and apf.params.fields == ("robot", "target") and apf.search == "chart"
    chart = make_policy(env, "APF-chart")  # the default's old name
    assert isinstance(chart, APFPolicy) and chart.search == "chart"
    assert make_policy(env, "apf-bug").search == "bug"  # the bug search: the default before, a weaker baseline
    r = make_policy(env, "random", seed=4)
    assert isinstance(r, RandomPolicy)
    np.testing.assert_array_equal(r.act_batch(np.zeros((3, 5))), RandomPolicy(seed=4).act_batch(np.zeros((3, 5))))
    assert isinstance(make_policy(env, "GEODESIC"), GeodesicPolicy)


def test_a_policy_file_runs_on_the_layout_it_was_trained_on_and_another_is_refused_by_name(tmp_path):
    """The default observation has the terrain scan (32 beams); a policy file trained on the layout
    before it (no scan, 59 elements) gets an env built with its own layout (policy_scenario), acts
    there as on an env built by hand with that layout, and is refused, naming k_scan, on the default."""
    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.errors import PolicyFileError, ScenarioError
    from tin_swarm_env.policies import load_policy, policy_layout, save_policy
    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.training.policy_factory import make_policy, policy_scenario

    old = ObsLayout(k_scan=0)
    rng = np.random.default_rng(1)
    layers = [(rng.normal(size=(8, old.size)), np.zeros(8)), (rng.normal(size=(2, 8)), np.zeros(2))]
    p = save_policy(tmp_path / "old", layers, layout=old, scenario="ramp")
    assert policy_layout(p) == old and policy_layout(p / "policy.json") == old
    cfg = policy_scenario("ramp", str(p))
    assert cfg.observation.k_scan == 0 and cfg.name == "ramp"
    env = tse.parallel_env(scenario=cfg, n_robots=3)
    assert env.layout == old and env.layout.size == 59
    by_hand = tse.parallel_env(scenario=load_scenario("ramp").with_layout(old), n_robots=3)
    o, o2 = env.reset_arrays(seed=2), by_hand.reset_arrays(seed=2)
    np.testing.assert_array_equal(make_policy(env, str(p)).act_batch(o), load_policy(p, by_hand).act_batch(o2))
    default = tse.parallel_env(scenario="ramp", n_robots=3)
    assert default.layout.k_scan == 32 and default.layout.size == 91
    with pytest.raises(PolicyFileError, match=r"old.policy\.json: key 'observation\.layout' .*'k_scan': 32"):
        load_policy(p, default)
    assert policy_scenario("ramp", "apf") == "ramp"  # a built-in name runs on the scenario as given
    with pytest.raises(ScenarioError, match="with_layout"):
        load_scenario("ramp").with_layout(object())

