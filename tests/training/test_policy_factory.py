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
    assert isinstance(apf, APFPolicy) and apf.params.fields == ("robot", "target") and apf.search == "bug"
    chart = make_policy(env, "APF-chart")
    assert isinstance(chart, APFPolicy) and chart.search == "chart"
    r = make_policy(env, "random", seed=4)
    assert isinstance(r, RandomPolicy)
    np.testing.assert_array_equal(r.act_batch(np.zeros((3, 5))), RandomPolicy(seed=4).act_batch(np.zeros((3, 5))))
    assert isinstance(make_policy(env, "GEODESIC"), GeodesicPolicy)
