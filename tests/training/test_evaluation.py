"""Evaluation rows (training/evaluation.py): one row of a policy over seeds (every metric a mean and a
95 % half-width, the same on every run), the intervals, the rows to evaluate checked by name and
label, and the progress bar."""

from __future__ import annotations

import types

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.training.evaluation import (
    EVAL_SEED0,
    METRICS,
    ci95,
    evaluation_row,
    parse_models,
    policy_entries,
    progress_bar,
)


def test_an_evaluation_row_holds_every_metric_and_is_the_same_on_every_run():
    from tin_swarm_env.policies import APFPolicy

    rows = []
    for _ in range(2):
        env = tse.parallel_env(scenario="flat", n_robots=3, max_cycles=40)
        rows.append(evaluation_row(env, APFPolicy(env), "flat", "apf", 2, EVAL_SEED0, progress=False))
    r = rows[0]
    assert (r["scenario"], r["policy"], r["seeds"], r["robots"], r["seed_offset"], r["max_cycles"]) == \
        ("flat", "apf", 2, 3, EVAL_SEED0, 40)
    for key, _, _ in METRICS:
        assert key in r and key + "_ci95" in r
    for key in ("arrived", "fell", "timed_out"):
        assert 0.0 <= r[key] <= 1.0
    assert r["arrived"] + r["fell"] + r["timed_out"] <= 1.0 + 1e-12
    assert repr(rows[0]) == repr(rows[1])  # nan == nan: repr


def test_ci95_is_the_student_t_half_width():
    m, h = ci95([1.0, 2.0, 3.0, np.nan])
    assert m == 2.0 and h == pytest.approx(4.302652729911275 * 1.0 / np.sqrt(3))
    assert ci95([5.0]) == (5.0, 0.0)
    assert all(np.isnan(ci95([np.nan])))


def test_the_rows_to_evaluate_are_checked_by_name_and_label(tmp_path):
    args = types.SimpleNamespace(policies="APF,random", models="", trust_pickle=False)
    assert policy_entries(args) == [("apf", "apf", None), ("random", "random", None)]
    assert parse_models("runs/x/policy,b=runs/y/model.zip") == [("x", "runs/x/policy"), ("b", "runs/y/model.zip")]
    with pytest.raises(ArgumentError, match="--policies: unknown"):
        policy_entries(types.SimpleNamespace(policies="oracle", models="", trust_pickle=False))
    with pytest.raises(ArgumentError, match="nothing to evaluate"):
        policy_entries(types.SimpleNamespace(policies="", models="", trust_pickle=False))


def test_progress_bar_is_tqdm():
    import tqdm

    bar = progress_bar(10, "x")
    assert isinstance(bar, tqdm.tqdm)
    bar.close()
    assert progress_bar(10, "x", enabled=False) is None
