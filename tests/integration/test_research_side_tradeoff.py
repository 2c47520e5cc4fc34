"""research/side_tradeoff.py (run by hand, research/side_tradeoff.md): the study's episodes are the ones it
says, its table adds them up exactly, one short episode runs through it, and bad arguments are refused."""

import argparse

import numpy as np
import pytest

from tin_swarm_env.training.rollout import Outcome
from tin_swarm_env.world.state import Reason

from tin_swarm_env.training.evaluation import EVAL_SEED0


@pytest.fixture
def st(repo_script):
    return repo_script("research/side_tradeoff.py")


def test_jobs_cover_every_side_cost_fork_set_and_jacksboro_seed(st):
    jobs = st.jobs_for([0.0, 0.75], [0, 100], 3, 2)
    assert len(jobs) == 2 * (2 * 3 + 2)
    fork = sorted(j[2] for j in jobs if j[0] == "fork" and j[1] == 0.75)
    assert fork == [EVAL_SEED0 + o + s for o in (0, 100) for s in range(3)]
    assert sorted(j[2] for j in jobs if j[0] == "jacksboro" and j[1] == 0.0) == [0, 1]
    assert all(j[4] == st.JACKSBORO_STEPS[-1] for j in jobs if j[0] == "jacksboro")
    assert {j[5] for j in jobs} == {0.0} and {j[5] for j in st.jobs_for([0.5], [0], 1, 1, side_leave=60.0)} == {60.0}


def test_table_adds_the_episodes_up(st):
    s0 = EVAL_SEED0
    res = [(("fork", 0.5, s0, None, None), 20, [20, 20], 0),
           (("fork", 0.5, s0 + 1, None, None), 20, [10, 10], 0),  # set 0: 30 of 40
           (("fork", 0.5, s0 + 100, None, None), 20, [19, 19], 1),
           (("fork", 0.5, s0 + 101, None, None), 20, [20, 20], 0),  # set 100: 39 of 40
           (("jacksboro", 0.5, 1, None, 1800), 200, [133, 165], 0),
           (("jacksboro", 0.5, 0, None, 1800), 200, [133, 160], 2)]
    lines = st.table(res, [0.5], [0, 100], 2)
    assert len(lines) == 3
    row = [c.strip() for c in lines[2].strip("|").split("|")]
    assert row[0] == "0.5"
    assert row[1] == "75.0% / 97.5%"
    assert row[2] == "86.2%"  # 69 of 80
    assert row[3] == f"{s0 + 1} (10 lost), {s0 + 100} (1 lost)"
    assert row[4] == "66.5%"
    assert row[5] == "80.0 / 82.5"  # by seed
    assert row[6] == "3"


def test_arrived_by_counts_a_robot_arriving_on_the_checkpoint_step(st):
    A, T, F = int(Reason.ARRIVED), int(Reason.TIMEOUT), int(Reason.FELL)
    out = Outcome(seed=0, reasons=np.array([A, A, A, T, F, A], np.int8), steps=np.array([900, 901, 1800, 1800, 10, 5]),
                  returns=np.zeros(6), collisions=np.zeros(6, np.int64), battery_left=np.ones(6), n_steps=1800,
                  seconds=0.0)
    assert st.arrived_by(out, (900, 1800)) == [2, 4]
    assert st.arrived_by(out, (4,)) == [0]


def test_one_short_jacksboro_episode_counts_at_both_checkpoints(st, monkeypatch):
    monkeypatch.setattr(st, "JACKSBORO_STEPS", (3, 6))
    job, n, by, fell = st.episode(("jacksboro", 0.75, 0, 4, 6, 0.0))
    assert n == 4 and 0 <= by[0] <= by[1] <= 4 and fell == 0


def test_one_short_episode_runs(st):
    job, n, by, fell = st.episode(("fork", 0.75, EVAL_SEED0, 4, 60, 30.0))
    assert n == 4 and 0 <= by[0] == by[1] <= 4 and 0 <= fell <= 4


@pytest.mark.parametrize("text", ["", "a,1", "-1", "nan"])
def test_bad_side_costs_are_refused(st, text):
    with pytest.raises(argparse.ArgumentTypeError):
        st._floats(text)


@pytest.mark.parametrize("text", ["", "x", "-100"])
def test_bad_offsets_are_refused(st, text):
    with pytest.raises(argparse.ArgumentTypeError):
        st._offsets(text)


@pytest.mark.parametrize("option", ["--seeds", "--jacksboro-seeds", "--jobs"])
def test_a_count_below_one_is_refused_naming_its_option(st, option, capsys):
    with pytest.raises(SystemExit):
        st.main([option, "0"])
    assert option in capsys.readouterr().err


def test_ideal_row_reads_the_idealised_robots_steps(st, monkeypatch):
    import sensing_bound as BOUND  # put on the path by repo_script's load of side_tradeoff

    calls = []

    def fake(env, rows, sensing, k, res):
        calls.append((list(rows), sensing, res))
        return [(s, 0.0, 0) for s in (100, 300, 1001, 200)] + [(50, 0.0, 0)] * (len(rows) - 4)

    monkeypatch.setattr(BOUND, "ideal_robots", fake)
    row = [c.strip() for c in st.ideal_row(1_000_112).strip("|").split("|")]
    n = len(calls[0][0])
    assert calls[0][1:] == ("disk", 1.0) and n == 20
    assert row == ["1000112", f"{np.median([100, 300, 1001, 200] + [50] * (n - 4)):.0f}", "1001", f"{n - 1} of {n}",
                   "1000"]


def test_jobs_take_realdem_sets_and_the_chart_overrides(st):
    jobs = st.jobs_for([0.75], [0], 2, 1, realdem_sets=[100], chart=[("min_cell_m", 3.0)])
    assert sorted(j[2] for j in jobs if j[0] == "realdem") == [EVAL_SEED0 + 100, EVAL_SEED0 + 101]
    assert len(jobs) == 2 + 2 + 1
    assert {j[6] for j in jobs} == {(("min_cell_m", 3.0),)}
    assert {j[6] for j in st.jobs_for([0.75], [0], 1, 1)} == {()}


def test_the_chart_overrides_reach_the_policy(st, monkeypatch):
    seen = []
    real = st.APFPolicy

    def spy(env, chart):
        seen.append(chart)
        return real(env, chart=chart)

    monkeypatch.setattr(st, "APFPolicy", spy)
    job, n, by, fell = st.episode(("fork", 0.5, EVAL_SEED0, 4, 5, 0.0, (("min_cell_m", 3.0), ("cells", 128))))
    assert n == 4 and (seen[0].min_cell_m, seen[0].cells, seen[0].side_cost) == (3.0, 128, 0.5)


def test_table_gives_realdem_its_own_columns(st):
    s0 = EVAL_SEED0
    res = [(("fork", 0.75, s0, None, None, 0.0, ()), 20, [20, 20], 0),
           (("realdem", 0.75, s0 + 100, None, None, 0.0, ()), 20, [15, 15], 1),
           (("realdem", 0.75, s0 + 101, None, None, 0.0, ()), 20, [20, 20], 0),
           (("jacksboro", 0.75, 0, None, 1800, 0.0, ()), 200, [133, 165], 0)]
    lines = st.table(res, [0.75], [0], 2, [100])
    assert "realdem: arrived per set" in lines[0] and lines[1].count("|") == lines[0].count("|")
    row = [c.strip() for c in lines[2].strip("|").split("|")]
    assert row[1:4] == ["100.0%", "100.0%", "-"]
    assert row[4:7] == ["87.5%", "87.5%", f"{s0 + 100} (5 lost)"]  # 35 of 40
    assert row[7:] == ["66.5%", "82.5", "1"]


@pytest.mark.parametrize("text", ["min_cell_m", "foo=1", "side_cost=1", "cells=x", "min_cell_m=-1"])
def test_bad_chart_overrides_are_refused(st, text):
    with pytest.raises(argparse.ArgumentTypeError):
        st._chart_items(text)


def test_chart_overrides_parse_to_typed_pairs(st):
    assert st._chart_items("min_cell_m=3,cells=256") == (("min_cell_m", 3.0), ("cells", 256))


def test_trace_figure_draws_one_panel_per_chart(st, tmp_path):
    out = tmp_path / "t.png"
    got = st.trace_figure(EVAL_SEED0, [("default chart", {}), ("coarse", {"min_cell_m": 3.0})], out, robots=4, cycles=5)
    assert len(got) == 2 and all(0 <= g <= 4 for g in got)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv", [["--trace", "1000129"], ["--trace", "1,2", "--chart", "min_cell_m=3"]])
def test_trace_needs_one_seed_and_a_chart(st, argv, capsys):
    with pytest.raises(SystemExit):
        st.main(argv)
    assert "--trace" in capsys.readouterr().err
