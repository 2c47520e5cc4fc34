"""Policies by name or path (apps/policy_factory.py): a pickle-free policy directory, a policy.json,
and the built-in names."""

from __future__ import annotations

import numpy as np

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
    from tin_swarm_env.apps.policy_factory import make_policy
    from tin_swarm_env.policies import MLPPolicy

    assert isinstance(make_policy(env, str(tmp_path / "pol" / "policy.json")), MLPPolicy)
    assert type(make_policy(env, "Random", seed=0)).__name__ == "RandomPolicy"
