"""A model or policy file scored while it trains (training/scoring.py): the held-out seeds of every
scenario of the run, the same figures on every call, and one row per evaluation appended."""

from __future__ import annotations

import time

from tin_swarm_env.training.config import Args
from tin_swarm_env.training.scoring import evaluate_policy_file


def test_a_policy_is_scored_on_every_scenario_of_the_run_the_same_every_time():
    from tin_swarm_env.policies import APFPolicy

    args = Args(scenario="flat,ramp", n_robots=2, max_cycles=30)
    a = evaluate_policy_file(APFPolicy, args, episodes=1)
    b = evaluate_policy_file(APFPolicy, args, episodes=1)
    assert a == b and set(a) == {"return", "arrived", "fell"}
    assert 0.0 <= a["arrived"] <= 1.0 and 0.0 <= a["fell"] <= 1.0
    seen = []

    def policy_of(env):
        seen.append(env.n)
        return APFPolicy(env)

    evaluate_policy_file(policy_of, args, episodes=2)
    assert seen == [2, 2]  # one policy per scenario of the run


def test_eval_row_appends_one_row_of_the_model(monkeypatch):
    import tin_swarm_env.training.scoring as sc

    monkeypatch.setattr(sc, "evaluate_model", lambda model, args, episodes: (1.5, 0.25, 0.5))
    rows = []
    row = sc.eval_row(object(), Args(eval_episodes=2), rows, time.perf_counter(), 64)
    assert rows == [row] and row["timesteps"] == 64 and (row["return"], row["arrived"], row["fell"]) == (1.5, 0.25, 0.5)
    assert 0.0 <= row["minutes"] < 1.0
