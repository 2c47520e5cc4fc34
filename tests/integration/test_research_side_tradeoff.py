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
