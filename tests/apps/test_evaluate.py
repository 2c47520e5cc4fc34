"""Evaluation (apps/evaluate.py): per-robot-episode metrics and their 95 % intervals, model labels
and policy rows, the table's columns and held-out seeds, the default output name, the checks
made before the first episode, the files it writes (printed and returned), and its bar plot's axes
and legend."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.evaluate import (EVAL_SEED0, METRICS, Args, bar_figure, ci95, episode_metrics, evaluate,
                                         parse_models, policy_rows)
from tin_swarm_env.apps.suite import run_suite
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.training.rollout import Outcome
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
    import tin_swarm_env.training.evaluation as ev

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


def test_eval_prints_and_returns_every_file_it_writes(tmp_path, capsys):
    out = tmp_path / "e"
    rows = evaluate(Args(scenarios="flat", seeds=1, robots=2, policies="apf", out=str(out)))
    want = [out.with_suffix(".md"), out.with_suffix(".csv"), out.with_suffix(".png")]
    assert rows.files == want and all(p.is_file() and p.stat().st_size > 0 for p in want)
    assert [r["policy"] for r in rows] == ["apf"]  # still the rows
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-3:] == [f"wrote {p}" for p in want]  # at the end, one path a line
    assert sorted(tmp_path.iterdir()) == sorted(want)  # nothing else (no .part file left)


def test_eval_out_is_a_stem_and_an_existing_directory_is_refused(tmp_path):
    """``--out DIR`` (an existing directory) is refused by name before any episode; a dot in the stem
    stays in the names (``a.b`` -> ``a.b.md``), and a suffix of its own is the stem's (``e.md`` -> ``e.md``)."""
    with pytest.raises(ArgumentError, match=r"--out .*: is a directory; give a file stem"):
        evaluate(Args(scenarios="flat", seeds=1, robots=2, policies="apf", out=str(tmp_path)))
    assert list(tmp_path.iterdir()) == [] and not (tmp_path.parent / f"{tmp_path.name}.md").exists()
    rows = evaluate(Args(scenarios="flat", seeds=1, robots=2, policies="apf", out=str(tmp_path / "a.b")))
    assert [p.name for p in rows.files] == ["a.b.md", "a.b.csv", "a.b.png"]
    rows = evaluate(Args(scenarios="flat", seeds=1, robots=2, policies="apf", out=str(tmp_path / "e.md")))
    assert [p.name for p in rows.files] == ["e.md", "e.csv", "e.png"]


def test_the_command_line_prints_the_files_and_needs_a_scenario_or_a_suite(tmp_path, capsys):
    assert main(["eval", "flat", "--seeds", "1", "--robots", "2", "--policies", "random", "--out",
                 str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-3:] == [f"wrote {tmp_path / 'c'}{ext}" for ext in (".md", ".csv", ".png")]
    assert main(["eval", "--policies", "random", "--out", str(tmp_path / "d")]) == 2
    assert "give at least one scenario (or --suite standard)" in capsys.readouterr().err
    with pytest.raises(ArgumentError, match="--quick applies to --suite only"):
        evaluate(Args(scenarios="flat", quick=True, out=str(tmp_path / "q")))
    with pytest.raises(ArgumentError, match="run_suite"):
        evaluate(Args(suite="standard", out=str(tmp_path / "s")))
    assert not list(tmp_path.glob("[dqs]*"))


def _rows(fell=0.0, ret=0.0):
    rows = []
    for scen in ("ramp", "hill"):
        for k, pol in enumerate(("random", "apf", "a-long-policy-name")):
            r = {"scenario": scen, "policy": pol}
            for key, _, _ in METRICS:
                r[key], r[key + "_ci95"] = 0.0, 0.0
            r["arrived"], r["arrived_ci95"] = 0.3 * k, 0.05
            r["fell"], r["return"] = fell, ret
            rows.append(r)
    return rows


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_rate_panels_show_0_to_100_percent_even_when_all_zero_and_the_legend_covers_no_bar():
    fig = bar_figure(_rows(fell=0.0, ret=0.0))
    arrived, falls, ret = fig.axes[:3]
    for ax in (arrived, falls):
        lo, hi = ax.get_ylim()
        assert lo == 0.0 and hi >= 1.0  # the whole share, not -0.04..0.04 round an all-zero panel
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert labels[0] == "0%" and "100%" in labels
    lo, hi = ret.get_ylim()
    assert lo <= -1.0 + 1e-9 and hi >= 1.0 - 1e-9  # no spread: a fixed range round 0
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert len(fig.legends) == 1
    legend = fig.legends[0].get_window_extent(renderer)
    for ax in fig.axes[:3]:
        assert not _overlap(legend, ax.get_window_extent(renderer))  # beside the panels, over no bar
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["random", "apf", "a-long-policy-name"]
    # each rate bar carries its value
    assert "60%" in [t.get_text() for t in arrived.texts]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_a_return_panel_with_spread_keeps_its_own_scale():
    import matplotlib.pyplot as plt

    fig = bar_figure(_rows(fell=0.02, ret=-40.0))
    lo, hi = fig.axes[2].get_ylim()
    assert lo < -40.0 and hi >= 0.0
    assert fig.axes[1].get_ylim() == (0.0, pytest.approx(1.12))
    plt.close(fig)


def test_bar_plot_writes_a_png(tmp_path):
    from tin_swarm_env.apps.evaluate import bar_plot

    p = bar_plot(_rows(), tmp_path / "b.png")
    assert p == Path(tmp_path / "b.png") and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert np.all([not f.name.endswith(".part.png") for f in tmp_path.iterdir()])


def test_the_script_takes_scenarios_comma_separated():
    from tin_swarm_env.apps.args import parse_dataclass

    a = parse_dataclass(Args, ["--scenarios", "flat,ramp", "--seeds", "2", "--suite", "standard", "--quick"])
    assert (a.scenarios, a.seeds, a.suite, a.quick) == ("flat,ramp", 2, "standard", True)



def test_eval_plays_mirror_images_and_a_given_episode_length(tmp_path):
    from tin_swarm_env.apps.evaluate import check_args

    scen = tmp_path / "tiny.toml"
    scen.write_text('max_cycles = 400\n[terrain]\nsource = "flat"\nsize_m = [60.0, 80.0]\n[robots]\ncount = 2\n'
                    'spawn_region = [2.0, 2.0, 10.0, 20.0]\n[targets]\npositions = [[50.0, 70.0]]\n')
    played, _, _ = check_args(Args(scenarios=str(scen), mirror=True, policies="apf", out=str(tmp_path / "c")))
    assert [label for label, _ in played] == [str(scen), f"{scen} (mirror ns)"]
    (_, cfg), (_, mir) = played
    # north-south over the flat plane [0, 60] x [0, 80]: y -> 80 - y, x kept
    assert tuple(cfg.targets.positions[0]) == (50.0, 70.0) and tuple(mir.targets.positions[0]) == (50.0, 10.0)
    assert tuple(mir.robots.spawn_region) == (2.0, 60.0, 10.0, 78.0)
    rows = evaluate(Args(scenarios=str(scen), seeds=1, policies="apf", mirror=True, max_cycles=3,
                         out=str(tmp_path / "e")))
    assert [r["scenario"] for r in rows] == [str(scen), f"{scen} (mirror ns)"]
    assert all(r["max_cycles"] == 3 and r["timed_out"] == 1.0 for r in rows)  # 3 steps: nobody gets 60 m
    rows = evaluate(Args(scenarios=str(scen), seeds=1, policies="apf", mirror=True, out=str(tmp_path / "f")))
    assert all(r["max_cycles"] == 400 and r["arrived"] == 1.0 for r in rows)  # both ways, both robots arrive
    with pytest.raises(ArgumentError, match="--max-cycles must be an integer >= 0, got -1"):
        evaluate(Args(scenarios=str(scen), max_cycles=-1, out=str(tmp_path / "g")))
    for bad in ({"mirror": True}, {"max_cycles": 10}):
        with pytest.raises(ArgumentError, match="does not apply to --suite"):
            run_suite(Args(suite="standard", out=str(tmp_path / "s"), **bad))
    assert not list(tmp_path.glob("[gs]*"))


def test_eval_by_family_plays_each_generated_family_and_its_mirror(tmp_path):
    from tin_swarm_env.apps.evaluate import check_args

    gen = tmp_path / "gen.toml"
    gen.write_text('[terrain]\nsource = "generated"\nfamilies = ["fork", "canyon"]\n[robots]\ncount = 2\n')
    played, _, _ = check_args(Args(scenarios=f"flat,{gen}", by_family=True, mirror=True, policies="apf",
                                   out=str(tmp_path / "c")))
    assert [label for label, _ in played] == ["flat", "flat (mirror ns)", f"{gen}: fork", f"{gen}: fork (mirror ns)",
                                              f"{gen}: canyon", f"{gen}: canyon (mirror ns)"]
    assert [c.terrain.families for _, c in played[2:]] == [("fork",)] * 2 + [("canyon",)] * 2
    assert [c.terrain.mirror for _, c in played[2:]] == ["", "ns", "", "ns"]
    played, _, _ = check_args(Args(scenarios="generated", by_family=True, policies="apf", out=str(tmp_path / "d")))
    assert [label for label, _ in played] == [f"generated: {f}" for f in tse.scenario.generators.ALL_FAMILIES]
    with pytest.raises(ArgumentError, match="does not apply to --suite"):
        run_suite(Args(suite="standard", by_family=True, out=str(tmp_path / "s")))


def test_the_csv_has_the_median_steps_to_arrive(tmp_path, monkeypatch):
    """steps_to_arrive_median: the median over the robots that arrived (NaN when none did)."""
    import tin_swarm_env.training.evaluation as ev

    runs = iter([np.array([10.0, np.nan, 30.0]), np.array([np.nan, 20.0, 40.0])])

    def fake(o):
        st = next(runs)
        n = len(st)
        z = np.zeros(n)
        return {"arrived": np.isfinite(st).astype(float), "fell": z, "timed_out": (~np.isfinite(st)).astype(float),
                "stalled": z, "looping": z, "steps_to_arrive": st, "contacts": z, "return": z}

    monkeypatch.setattr(ev, "episode_metrics", fake)
    rows = evaluate(Args(scenarios="flat", seeds=2, robots=3, policies="apf", out=str(tmp_path / "m")))
    assert rows[0]["steps_to_arrive_median"] == 25.0  # median of 10, 30, 20, 40
    assert rows[0]["steps_to_arrive"] == 25.0 and rows[0]["arrived"] == 4 / 6
    assert "steps_to_arrive_median" in (tmp_path / "m.csv").read_text().splitlines()[0]
