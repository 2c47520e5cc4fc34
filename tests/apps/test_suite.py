"""tin_swarm_env/apps/suite.py: the standard evaluation suite runs (``--quick``) and prints one
leaderboard row per policy, its figures are averaged as documented, its splits are the table the docs
show, and it refuses the options it fixes."""

from __future__ import annotations

import csv
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from tin_swarm_env.apps import suite as S
from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.evaluate import EVAL_SEED0, Args
from tin_swarm_env.errors import ArgumentError

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT / "agents" / "models" / "shared"


def _table_rows(text: str) -> list[str]:
    return [line.split("|")[1].strip() for line in text.splitlines() if re.match(r"\| \S.* \| [0-9.–]+ \|", line)]


def test_quick_suite_prints_one_leaderboard_row_per_policy_and_the_files(tmp_path, capsys):
    out = tmp_path / "board"
    assert main(["eval", "--suite", "standard", "--quick", "--model", f"shipped={SHARED}", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    board, _, wrote = text.rpartition("| policy |")[2].partition("\nwrote ")
    assert _table_rows("| policy |" + board) == ["random", "apf", "geodesic", "shipped"]
    files = [out.with_suffix(".md"), out.with_suffix(".csv"), out.with_name("board_maps.csv")]
    assert text.strip().splitlines()[-3:] == [f"wrote {p}" for p in files]
    rows = list(csv.DictReader(open(files[1])))
    assert [r["policy"] for r in rows] == ["random", "apf", "geodesic", "shipped"]
    for key in ("arrived", "fell", "stuck", "median_steps", "mirrored", "mirror_gap", *(s.key for s in S.SPLITS)):
        assert key in rows[0]
    maps = list(csv.DictReader(open(files[2])))
    # every policy on the first map of every split, as built and mirrored, with the quick settings
    assert len(maps) == 4 * len(S.SPLITS) * len(S.PLAYED)
    assert {(m["map"], m["mirror"]) for m in maps} == {(s.maps[0].label, k) for s in S.SPLITS for k in S.PLAYED}
    assert {(m["seeds"], m["robots"], m["steps"]) for m in maps} == {("1", "3", "60")}
    md = files[0].read_text()
    assert md.startswith("Measured with `") and "load average" in md.splitlines()[0]
    assert _table_rows(md.split("Per map")[0]) == ["random", "apf", "geodesic", "shipped"]


def test_the_suite_is_deterministic_for_a_policy(tmp_path, monkeypatch):
    got = []
    for k in range(2):
        if k == 1:  # the second run "goes over" its budget: the file says so
            monkeypatch.setattr(S, "BUDGET_S", 0.0)
        rows = S.run_suite(Args(scenarios="", suite="standard", quick=True, policies="random,apf",
                                out=str(tmp_path / f"r{k}")))
        got.append([{key: repr(v) for key, v in r.items() if key != "seconds"} for r in rows])  # nan == nan
        assert rows.files[0].is_file()
    assert got[0] == got[1]
    assert "Over the budget" not in (tmp_path / "r0.md").read_text()
    assert re.search(r"Over the budget of 0 s for one policy: random took \d+ s, apf took \d+ s\.",
                     (tmp_path / "r1.md").read_text())
    maps = [[{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(open(tmp_path / f"r{k}_maps.csv"))]
            for k in range(2)]
    assert maps[0] == maps[1]


def _ep(arrived, fell=0.0, stuck=0.0, steps=()):
    return {"arrived": arrived, "fell": fell, "stuck": stuck, "steps": np.asarray(steps, dtype=float)}


def test_leaderboard_figures_are_averaged_as_documented():
    splits = (S.Split("a", "A", "", ()), S.Split("b", "B", "", ()))
    by = {("a", ""): [_ep(1.0, steps=[10, 20]), _ep(0.5, fell=0.5, steps=[30])],  # split a: 0.75 arrived
          ("a", "ns"): [_ep(0.5, stuck=0.5, steps=[40])],                        # mirrored a: 0.5
          ("b", ""): [_ep(0.0, stuck=1.0)],                                      # split b: 0
          ("b", "ns"): [_ep(0.25, steps=[50]), _ep(0.25, fell=0.25, steps=[60])]}  # mirrored b: 0.25
    r = S.leaderboard("p", splits, by, 12.34)
    assert r["a"] == 0.75 and r["b"] == 0.0
    assert r["mirrored"] == pytest.approx((0.5 + 0.25) / 2)
    assert r["mirror_gap"] == pytest.approx(0.375 - 0.375)
    assert r["arrived"] == pytest.approx((0.75 + 0.5 + 0.0 + 0.25) / 4)
    assert r["fell"] == pytest.approx((0.25 + 0.0 + 0.0 + 0.125) / 4)
    assert r["stuck"] == pytest.approx((0.0 + 0.5 + 1.0 + 0.0) / 4)
    assert r["median_steps"] == 35.0  # over every arrived robot: 10 20 30 40 50 60
    assert r["seconds"] == 12.3
    md = S.leaderboard_markdown([r], splits)
    assert md.splitlines()[2] == "| p | 37.5 | 9.4 | 37.5 | 35 | 75.0 | 0.0 | 37.5 | +0.0 | 12 |"
    assert len(md.splitlines()[0].split("|")) == len(md.splitlines()[1].split("|"))


def test_the_split_table_is_the_one_the_docs_show():
    spec = importlib.util.spec_from_file_location("gen_tables", ROOT / "docs" / "gen_tables.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    shown = (ROOT / "docs" / "generated" / "suite_splits.md").read_text()
    assert shown == gen.HEADER + S.splits_markdown()
    page = (ROOT / "docs" / "baselines.md").read_text()
    for include in ('--8<-- "docs/generated/suite_splits.md"', '--8<-- "docs/figures/standard_suite.md"',
                    "::: tin_swarm_env.apps.suite"):
        assert include in page
    for s in S.SPLITS:
        for m in s.maps:
            assert f"| {m.label} |" in shown
    n = sum(m.seeds for s in S.SPLITS for m in s.maps) * len(S.PLAYED)
    assert f"{n} episodes per policy" in shown and f"{n} episodes per policy" in S.__doc__


def test_the_splits_hold_out_what_the_shipped_policy_did_not_train_on():
    from tin_swarm_env.scenario.generators import ALL_FAMILIES
    from tin_swarm_env.scenario.mirror import reflect_region, reflect_xy, terrain_bounds

    recipe = (ROOT / "agents" / "reproduce_shared.sh").read_text()
    assert "--scenario generated,generated,cliff_goal,ramp" in recipe
    by_key = {s.key: s for s in S.SPLITS}
    train = {f for m in by_key["train_seeds"].maps for f in m.families}
    held = {f for m in by_key["held_out"].maps for f in m.families}
    assert train == {"canyon", "mesa", "hills"} and held == {"fork", "trap"}
    assert train | held == set(ALL_FAMILIES) and not train & held
    assert not {m.scenario for m in by_key["held_out"].maps} & {"cliff_goal", "ramp"}  # trained on
    assert [m.scenario for m in by_key["dem"].maps] == ["jacksboro"]
    assert {m.scenario for m in by_key["thesis"].maps} == {"cliff_goal", "ramp", "hill"}
    assert S.PLAYED == ("", "ns")
    for s in S.SPLITS:  # every map loads, both ways, and its mirror image is a mirror image
        for m in s.maps:
            cfg, mir = S.map_config(m), S.map_config(m, "ns")
            assert mir.terrain.mirror == "ns" and cfg.terrain.mirror == ""
            assert cfg.terrain.families == (tuple(m.families) if m.families else cfg.terrain.families)
            if cfg.terrain.source != "generated":
                b = terrain_bounds(cfg)
                assert np.array_equal(mir.targets.positions, reflect_xy(cfg.targets.positions, "ns", b))
                assert mir.robots.spawn_region == reflect_region(cfg.robots.spawn_region, "ns", b)
    assert EVAL_SEED0 == 1_000_000


@pytest.mark.parametrize("kw, match", [
    ({"scenarios": "ramp"}, "give no scenarios"),
    ({"seeds": 3}, "--seeds: does not apply to --suite"),
    ({"robots": 5}, "--robots: does not apply"),
    ({"seed_offset": 0}, "--seed-offset: does not apply"),
    ({"policies": "", "models": ""}, "nothing to evaluate"),
    ({"models": "x=/no/such/dir"}, "no such file or directory"),
    ({"policies": "apf", "models": f"apf={SHARED}"}, "two rows named"),
])
def test_the_suite_refuses_what_it_fixes_before_any_episode(kw, match, tmp_path):
    args = Args(**{"scenarios": "", "suite": "standard", "quick": True, "out": str(tmp_path / "o"), **kw})
    with pytest.raises(ArgumentError, match=match):
        S.run_suite(args)
    assert list(tmp_path.iterdir()) == []


def test_an_unknown_suite_is_refused_by_the_option(tmp_path, capsys):
    with pytest.raises(ArgumentError, match="--suite 'easy': choose from standard"):
        Args(suite="easy")
    assert main(["eval", "--suite", "easy", "--out", str(tmp_path / "x")]) == 2
    assert "--suite" in capsys.readouterr().err


def test_a_missing_scenario_file_of_the_suite_is_named(monkeypatch, tmp_path):
    monkeypatch.setattr(S, "REPO", tmp_path)
    with pytest.raises(ArgumentError, match="canyon_left.*scenarios/canyon_left.toml"):
        S.check_suite(Args(scenarios="", suite="standard", out=str(tmp_path / "o")))
