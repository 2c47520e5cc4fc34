"""Stalled and looping (training/trajectory.py): hand-made trajectories with exact answers, the ring
buffer against a plain list, and rollout's Outcome on a real episode."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.training.trajectory import LOOP_FRACTION, LOOP_STEPS, STALL_STEPS, Track, stalled_looping

BODY = 1.0  # body length, m


def straight(k, speed):
    """(k + 1, 2): driving east at ``speed`` m per step."""
    return np.stack([np.arange(k + 1) * speed, np.zeros(k + 1)], axis=1)


def circle(k, radius, steps_per_lap):
    a = 2 * np.pi * np.arange(k + 1) / steps_per_lap
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)


def robots(*trajs):
    return np.stack(trajs, axis=1)  # (k + 1, n, 2)


def test_hand_made_trajectories():
    k = LOOP_STEPS
    still = np.zeros((k + 1, 2))
    driving = straight(k, 0.5)  # 250 m net over 250 m driven
    # a full lap of 100 steps, 5 times: ends where it started 500 steps ago (net 0) and where it was
    # 100 steps ago (net 0): stalled, by definition, although it drove 5 laps
    lap = circle(k, 10.0, 100)
    # 4 laps in 500 steps of a 125-step loop: 100 steps ago it was 0.8 laps back (net 2 r sin(0.8 pi)
    # = 11.76 m), 500 steps ago at the same point (net 0 < 0.1 * 251 m driven): looping
    loop = circle(k, 10.0, 125)
    # creeping 0.009 m per step: 0.9 m in 100 steps < 1 body length: stalled
    creep = straight(k, 0.009)
    # just over a body length in the last 100 steps: 1.01 m; straight, so not looping either
    slow = straight(k, 0.0101)
    # back and forth along 20 m, 40 steps each way (0.5 m per step): at step 500, 500 = 12.5 legs,
    # so it sits mid-way on a leg: 10 m from the start, 250 m driven: looping (10 < 25); 100 steps ago
    # (step 400, a multiple of 80) it was at the start: net 10 m, more than a body length: not stalled
    t = np.arange(k + 1)
    phase = (t % 80) * 0.5
    shuttle = np.stack([np.where(phase <= 20, phase, 40 - phase), np.zeros(k + 1)], axis=1)
    w = robots(still, driving, lap, loop, creep, slow, shuttle)
    stalled, looping = stalled_looping(w, BODY)
    assert stalled.tolist() == [True, False, True, False, True, False, False]
    assert looping.tolist() == [False, False, False, True, False, False, True]


def test_threshold_edges_are_strict():
    # exactly one body length in 100 steps is not stalled ("under one body length"); 1/64 m per
    # step is exact in binary, so the net displacement is exactly 100/64 m
    w = robots(straight(STALL_STEPS, 1 / 64))
    assert stalled_looping(w, 100 / 64)[0].tolist() == [False]
    assert stalled_looping(w, 100 / 64 + 1e-9)[0].tolist() == [True]
    # out 50 m and back 45 m: net 5 m of 95 m driven (a window shorter than 100 steps: not stalled)
    out_back = np.concatenate([straight(50, 1.0), straight(50, 1.0)[1:] * [-1, 0] + [50, 0]])
    w = robots(out_back[:96])  # 50 out, 45 back: net 5 m, path 95 m
    assert stalled_looping(w, BODY)[1].tolist() == [True]
    exact = robots(np.array([[0.0, 0.0], [50.0, 0.0], [0.0, 0.0], [10.0, 0.0]]))  # net 10 of path 100
    assert stalled_looping(exact, 0.01)[1].tolist() == [True]  # net 10 < 0.1 * 110
    exact = robots(np.array([[0.0, 0.0], [45.0, 0.0], [0.0, 0.0], [10.0, 0.0]]))  # net 10 == 0.1 * 100
    assert LOOP_FRACTION * 100.0 == 10.0 and stalled_looping(exact, 0.01)[1].tolist() == [False]


def test_short_episodes_use_the_whole_episode_and_candidates_mask():
    w = robots(np.zeros((11, 2)), straight(10, 1.0))  # 10 steps only
    stalled, looping = stalled_looping(w, BODY)
    assert stalled.tolist() == [True, False] and looping.tolist() == [False, False]
    stalled, _ = stalled_looping(w, BODY, candidates=np.array([False, True]))
    assert stalled.tolist() == [False, False]
    one = robots(np.zeros((1, 2)))  # the reset position only
    assert stalled_looping(one, BODY)[0].tolist() == [True]
    with pytest.raises(ValueError, match="window must be"):
        stalled_looping(np.zeros((5, 3)), BODY)
    with pytest.raises(ValueError, match="body_length_m"):
        stalled_looping(w, 0.0)


@settings(max_examples=30, deadline=None)
@given(n_push=st.integers(1, 1300), seed=st.integers(0, 2**32 - 1))
def test_ring_buffer_keeps_the_last_pushes_in_order(n_push, seed):
    rng = np.random.default_rng(seed)
    pos = rng.normal(size=(n_push, 3, 2))
    tr = Track(3)
    for p in pos:
        tr.push(p)
    want = pos[-(LOOP_STEPS + 1):]
    assert np.array_equal(tr.window(), want)
    s1, l1 = tr.stalled_looping(BODY)
    s2, l2 = stalled_looping(want, BODY)
    assert np.array_equal(s1, s2) and np.array_equal(l1, l2)


def test_rollout_reports_stalled_robots_beside_the_reasons():
    import tin_swarm_env as tse
    from tin_swarm_env.training.rollout import rollout
    from tin_swarm_env.world.state import Reason

    class Still:
        def act_batch(self, obs):
            return np.zeros((len(obs), 2), dtype=np.float32)

    env = tse.parallel_env(scenario="flat", n_robots=4, max_cycles=120)
    out = rollout(env, Still(), 0)
    assert out.count(Reason.TIMEOUT) == 4
    assert out.stalled.tolist() == [True] * 4 and not out.looping.any()
    sh = out.shares()
    assert sh["timed_out"] == 1.0 and sh["stalled"] == 1.0 and sh["looping"] == 0.0 and sh["arrived"] == 0.0


def test_eval_and_run_tables_carry_the_stalled_and_looping_columns():
    from tin_swarm_env.apps.run import EpisodeStats, format_table
    from tin_swarm_env.training.evaluation import METRICS, episode_metrics
    from tin_swarm_env.training.rollout import Outcome
    from tin_swarm_env.world.state import Reason as R

    o = Outcome(seed=0, reasons=np.array([R.ARRIVED, R.TIMEOUT, R.TIMEOUT, R.TIMEOUT], np.int8),
                steps=np.array([10, 50, 50, 50]), returns=np.zeros(4), collisions=np.zeros(4, int),
                battery_left=np.ones(4), n_steps=50, seconds=0.0, stalled=np.array([False, True, False, False]),
                looping=np.array([False, False, True, False]))
    m = episode_metrics(o)
    assert m["stalled"].tolist() == [0, 1, 0, 0] and m["looping"].tolist() == [0, 0, 1, 0]
    assert {"stalled", "looping"} <= {k for k, _, _ in METRICS}
    assert o.shares() == {"arrived": 0.25, "fell": 0.0, "battery": 0.0, "timed_out": 0.75, "stalled": 0.25,
                          "looping": 0.25}
    table = format_table([EpisodeStats.from_outcome(1, o)])
    assert "| timed out | stalled | looping |" in table and "| 3 | 1 | 1 |" in table
