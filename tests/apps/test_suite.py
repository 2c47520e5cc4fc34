"""``tin-swarm eval --suite`` (tin_swarm_env/apps/suite.py): the standard evaluation suite runs
(``--quick``) and prints one leaderboard row per policy, the same on every run, and it refuses the
options it fixes before any episode."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from tin_swarm_env.apps import suite as S
from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.evaluate import Args
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.training import suite as suite_lib

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
    for key in ("arrived", "fell", "stuck", "median_steps", "mirrored", "mirror_gap", *(s.key for s in suite_lib.SPLITS)):
        assert key in rows[0]
    maps = list(csv.DictReader(open(files[2])))
    # every policy on the first map of every split, as built and mirrored, with the quick settings
    assert len(maps) == 4 * len(suite_lib.SPLITS) * len(suite_lib.PLAYED)
    assert {(m["map"], m["mirror"]) for m in maps} == {(s.maps[0].label, k) for s in suite_lib.SPLITS for k in suite_lib.PLAYED}
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
    monkeypatch.setattr(suite_lib, "REPO", tmp_path)
    with pytest.raises(ArgumentError, match="canyon_left.*scenarios/canyon_left.toml"):
        S.check_suite(Args(scenarios="", suite="standard", out=str(tmp_path / "o")))
