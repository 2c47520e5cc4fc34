"""Evaluation (apps/evaluate.py): per-robot-episode metrics and their 95 % intervals, model labels
and policy rows, the table's columns and held-out seeds, the default output name, and the checks
made before the first episode."""

from __future__ import annotations

import os

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.evaluate import EVAL_SEED0, ci95, episode_metrics, parse_models, policy_rows
from tin_swarm_env.apps.rollout import Outcome
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.world.state import Reason


def test_episode_metrics_and_ci_are_over_robot_episodes():
    R = Reason
    o = Outcome(seed=0, reasons=np.array([R.ARRIVED, R.FELL, R.TIMEOUT, R.ARRIVED], np.int8),
                steps=np.array([10, 4, 50, 30]), returns=np.array([1.0, -5.0, 0.0, 2.0]),
                collisions=np.array([0, 1, 2, 1]), battery_left=np.ones(4), n_steps=50, seconds=0.0)
    m = episode_metrics(o)
    assert m["arrived"].tolist() == [1, 0, 0, 1] and m["fell"].tolist() == [0, 1, 0, 0]
    assert m["timed_out"].tolist() == [0, 0, 1, 0] and m["contacts"].tolist() == [0, 1, 2, 1]
    assert np.nanmean(m["steps_to_arrive"]) == 20 and np.isnan(m["steps_to_arrive"][1])
    mean, h = ci95(m["steps_to_arrive"])  # two values: 10, 30 -> t(0.975, 1) * std / sqrt(2)
    assert mean == 20 and h == pytest.approx(12.706205 * np.std([10, 30], ddof=1) / np.sqrt(2), rel=1e-6)
    assert ci95([np.nan]) != ci95([np.nan]) or np.isnan(ci95([np.nan])[0])


def test_model_labels_and_rows():
    assert parse_models("bc=runs/a/policy, runs/b/policy,runs/c/model.zip,x.zip") == [
        ("bc", "runs/a/policy"), ("b", "runs/b/policy"), ("c (zip)", "runs/c/model.zip"), ("x (zip)", "x.zip")]
    rows = policy_rows("random,APF,geodesic")
    assert rows[:2] == ["random", "apf"]
    assert ("geodesic" in rows) == hasattr(tse.policies, "GeodesicPolicy")
    with pytest.raises(ArgumentError, match="unknown"):
        policy_rows("apf,ppo")


def test_evaluation_refuses_a_zip_without_trust_and_a_missing_model(tmp_path):
    from tin_swarm_env.apps.evaluate import Args as EvalArgs
    from tin_swarm_env.apps.evaluate import evaluate

    z = tmp_path / "model.zip"
    z.write_bytes(b"PK")
    with pytest.raises(ArgumentError, match="pickle"):
        evaluate(EvalArgs(scenarios="flat", seeds=1, robots=2, policies="", models=str(z), out=str(tmp_path / "e")))
    with pytest.raises(ArgumentError, match="no such file or directory"):
        evaluate(EvalArgs(scenarios="flat", seeds=1, models=str(tmp_path / "nope"), out=str(tmp_path / "e")))


def test_evaluation_table_has_the_columns_and_uses_held_out_seeds(tmp_path):
    from tin_swarm_env.apps.evaluate import Args as EvalArgs
    from tin_swarm_env.apps.evaluate import evaluate

    rows = evaluate(EvalArgs(scenarios="flat", seeds=2, robots=3, policies="random,apf", out=str(tmp_path / "e")))
    assert [r["policy"] for r in rows] == ["random", "apf"] and rows[0]["seed_offset"] == EVAL_SEED0
    md = (tmp_path / "e.md").read_text()
    for col in ("arrived", "fell", "timed out", "steps to arrive", "contacts/robot", "return/robot"):
        assert f" {col} |" in md
    # apf on flat: every robot-episode's outcome counted once (arrived + fell + timed out + battery = 1)
    assert rows[1]["arrived"] + rows[1]["fell"] + rows[1]["timed_out"] <= 1.0 + 1e-12


def test_eval_default_output_is_named_after_the_scenarios(tmp_path, monkeypatch, capsys):
    from tin_swarm_env.apps.evaluate import default_out

    assert default_out(["cliff_goal", "ramp"]) == os.path.join("runs", "eval_cliff_goal_ramp")
    assert default_out(["dir/my.toml"]) == os.path.join("runs", "eval_my")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tiny.toml").write_text('max_cycles = 5\n[terrain]\nsource = "flat"\nsize_m = [60.0, 60.0]\n'
                                        '[robots]\ncount = 2\n[targets]\npositions = [[50.0, 30.0]]\n')
    assert main(["eval", "tiny.toml", "--seeds", "2", "--policies", "apf,RANDOM"]) == 0
    md = (tmp_path / "runs" / "eval_tiny.md").read_text()
    assert "| tiny.toml | apf |" in md and "| tiny.toml | random |" in md
    assert (tmp_path / "runs" / "eval_tiny.csv").exists() and (tmp_path / "runs" / "eval_tiny.png").exists()


def test_eval_checks_models_before_the_first_episode(tmp_path, monkeypatch, capsys):
    import tin_swarm_env.apps.evaluate as ev

    def no_episodes(*a, **k):
        raise AssertionError("an episode ran before the options were checked")

    monkeypatch.setattr(ev, "rollout", no_episodes)
    assert main(["eval", "flat", "--model", str(tmp_path / "nope"), "--out", str(tmp_path / "e")]) == 2
    assert "--model" in capsys.readouterr().err
    (tmp_path / "m.zip").write_bytes(b"PK")
    assert main(["eval", "flat", "--model", str(tmp_path / "m.zip"), "--out", str(tmp_path / "e")]) == 2
    assert "--trust-pickle" in capsys.readouterr().err
    assert main(["eval", "flat", "--out", str(tmp_path / "no" / "e")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not list(tmp_path.glob("e.*"))
