"""env/reward.py by hand: every reward term alone with an exact value, the arrival radius at and
just beyond it, the ring tolerance at and just beyond it, and the precedence of the end reasons.

The weights are all different (and none is 1) so a term paid with another's weight, with the
wrong sign or twice is seen. Values are exact in float32 (sums of a few small binary fractions),
so the comparisons are exact except where a float64 sum is rounded to float32 (``rel=1e-6``, the
float32 epsilon is 1.2e-7)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.reward import compute_rewards, distance_to_go, reward_params, step_rewards, target_distance
from tin_swarm_env.scenario import RewardWeights
from tin_swarm_env.world.state import Reason

W = RewardWeights(progress="euclidean", progress_per_m=2.0, arrival=10.0, on_ring_per_step=0.25,
                  ring_tolerance_m=2.0, fall=-100.0, battery_empty=-5.0, collision=-3.0, energy_per_kj=-0.5)
RADIUS = 5.0
STANDOFF = 20.0
FAR = [500.0, 500.0]  # a position far from the target at the origin: no arrival


def cfg(task="goal"):
    return SimpleNamespace(task=task, rewards=W,
                           targets=SimpleNamespace(standoff_m=STANDOFF, arrival_radius_m=RADIUS))


def case(positions, fell=None, emptied=None, collisions=None, energy_j=None, target_idx=None):
    n = len(positions)
    state = SimpleNamespace(n_robots=n, positions=np.asarray(positions, dtype=float),
                            targets=SimpleNamespace(positions=np.array([[0.0, 0.0]])))
    ev = SimpleNamespace(fell=np.zeros(n, bool) if fell is None else np.asarray(fell, bool),
                         emptied=np.zeros(n, bool) if emptied is None else np.asarray(emptied, bool),
                         collisions=np.zeros(n, np.int64) if collisions is None else np.asarray(collisions),
                         energy_j=np.zeros(n) if energy_j is None else np.asarray(energy_j, float))
    tidx = np.zeros(n, np.int64) if target_idx is None else np.asarray(target_idx, np.int64)
    return state, ev, tidx


def rewards(task, before, after, state, ev, tidx, live=None):
    live = np.ones(state.n_robots, bool) if live is None else np.asarray(live, bool)
    return compute_rewards(cfg(task), np.asarray(before, float), np.asarray(after, float), state, ev, tidx, live)


def test_goal_progress_is_the_metres_gained_times_the_weight_and_zero_where_a_distance_is_inf():
    state, ev, tidx = case([FAR] * 5, target_idx=[0, 0, 0, 0, -1])
    r, term, why = rewards("goal", [10, 10, np.inf, 10, 10], [7, 12.5, 5, np.inf, 3], state, ev, tidx)
    # +3 m, -2.5 m, unreachable before, unreachable after, no target assigned
    assert r.tolist() == [6.0, -5.0, 0.0, 0.0, 0.0]
    assert not term.any() and (why == Reason.NONE).all()


def test_containment_progress_is_the_metres_gained_toward_the_ring_from_either_side():
    # distance before/after -> error |d - 20| before/after: 30->25 (10->5), 10->15 (10->5),
    # 20->24 (0->4, away from the ring), 40->45 (20->25, away)
    state, ev, tidx = case([FAR] * 4)
    r, term, _ = rewards("containment", [30, 10, 20, 40], [25, 15, 24, 45], state, ev, tidx)
    assert r.tolist() == [10.0, 10.0, -8.0, -10.0]
    assert not term.any()


def test_ring_bonus_within_the_tolerance_inclusive_and_not_just_beyond():
    # errors after the step: 0, 2 (at the tolerance), 2.25 (beyond), 1.5 from inside the ring
    state, ev, tidx = case([FAR] * 4)
    r, _, _ = rewards("containment", [20, 22, 22.25, 18.5], [20, 22, 22.25, 18.5], state, ev, tidx)
    assert r.tolist() == [0.25, 0.25, 0.0, 0.25]


def test_containment_never_arrives_even_on_the_target():
    state, ev, tidx = case([[0.0, 0.0]])
    r, term, why = rewards("containment", [20], [20], state, ev, tidx)
    assert not term.any() and why[0] == Reason.NONE and r[0] == 0.25  # on the ring (d = standoff)


def test_arrival_at_the_radius_counts_and_just_beyond_it_does_not():
    # the target at the origin, radius 5: (5, 0) and (3, 4) are exactly 5 m away, (5.001, 0) and (0, -5.01) beyond
    state, ev, tidx = case([[5.0, 0.0], [3.0, 4.0], [5.001, 0.0], [0.0, -5.01], [0.0, 0.0]])
    d = target_distance(state, tidx)
    assert d.tolist() == [5.0, 5.0, 5.001, 5.01, 0.0]
    r, term, why = rewards("goal", [8, 8, 8, 8, 8], [8, 8, 8, 8, 8], state, ev, tidx)
    assert why.tolist() == [Reason.ARRIVED, Reason.ARRIVED, Reason.NONE, Reason.NONE, Reason.ARRIVED]
    assert term.tolist() == [True, True, False, False, True]
    assert r.tolist() == [10.0, 10.0, 0.0, 0.0, 10.0]


def test_arrival_is_judged_on_the_straight_line_not_the_distance_to_go():
    # the distance to go says 100 m (a detour), the robot stands 1 m from the target: it arrived
    state, ev, tidx = case([[1.0, 0.0], FAR])
    r, _, why = rewards("goal", [100, 1], [100, 1], state, ev, tidx)
    assert why.tolist() == [Reason.ARRIVED, Reason.NONE] and r.tolist() == [10.0, 0.0]


def test_a_robot_without_a_target_never_arrives():
    state, ev, tidx = case([[0.0, 0.0]], target_idx=[-1])
    r, term, why = rewards("goal", [np.inf], [np.inf], state, ev, tidx)
    assert r.tolist() == [0.0] and not term[0] and why[0] == Reason.NONE


@pytest.mark.parametrize("task", ["goal", "containment"])
def test_collision_fall_battery_and_energy_terms_alone(task):
    # each robot far from the target and not moving relative to it: progress 0 (goal) / error 480.7 m
    # both steps (containment: no ring bonus); one term per robot
    state, ev, tidx = case([FAR] * 5, collisions=[1, 2, 0, 0, 0], fell=[0, 0, 1, 0, 0], emptied=[0, 0, 0, 1, 0],
                           energy_j=[0, 0, 0, 0, 3000.0])
    d = target_distance(state, tidx)
    r, term, why = rewards(task, d, d, state, ev, tidx)
    assert r.tolist() == [-3.0, -6.0, -100.0, -5.0, -1.5]
    assert why.tolist() == [Reason.NONE, Reason.NONE, Reason.FELL, Reason.BATTERY, Reason.NONE]
    assert term.tolist() == [False, False, True, True, False]


def test_terms_add_up():
    # 2 m of progress, one collision, 1 kJ, arrived: 4 - 3 - 0.5 + 10
    state, ev, tidx = case([[1.0, 1.0]], collisions=[1], energy_j=[1000.0])
    r, term, why = rewards("goal", [9.0], [7.0], state, ev, tidx)
    assert r.tolist() == [10.5] and term[0] and why[0] == Reason.ARRIVED


def test_precedence_fall_beats_arrival_and_battery_arrival_beats_battery():
    # 0: arrives and empties (ARRIVED, +arrival, no battery penalty); 1: empties only (BATTERY);
    # 2: would arrive but fell (FELL, no arrival reward); 3: fell and emptied (FELL, both penalties);
    # 4: fell, emptied and at the target (FELL: fall + battery, no arrival)
    state, ev, tidx = case([[1.0, 0.0], FAR, [0.0, 1.0], FAR, [0.0, 0.0]], fell=[0, 0, 1, 1, 1],
                           emptied=[1, 1, 0, 1, 1])
    d = target_distance(state, tidx)
    r, term, why = rewards("goal", d, d, state, ev, tidx)
    assert why.tolist() == [Reason.ARRIVED, Reason.BATTERY, Reason.FELL, Reason.FELL, Reason.FELL]
    assert r.tolist() == [10.0, -5.0, -100.0, -105.0, -105.0]
    assert term.all()


def test_robots_not_live_get_nothing():
    state, ev, tidx = case([[0.0, 0.0], FAR], fell=[1, 1], collisions=[2, 2], energy_j=[1000.0, 1000.0])
    r, term, why = rewards("goal", [9, 9], [7, 7], state, ev, tidx, live=[False, True])
    assert r.tolist() == [0.0, -100.0 - 6.0 - 0.5 + 4.0]
    assert term.tolist() == [False, True] and why.tolist() == [Reason.NONE, Reason.FELL]
    assert r.dtype == np.float32 and why.dtype == np.int8


def test_distance_to_go_straight_line_and_inf_without_target():
    state, _, _ = case([[3.0, 4.0], [6.0, 8.0]], target_idx=[0, -1])
    state.tri_idx = np.zeros(2, np.int64)
    d = distance_to_go(state, np.array([0, -1]), [None])
    assert d.tolist() == [5.0, np.inf]


def test_env_pays_the_collision_penalty_per_robot_touched():
    """Through the env: two robots standing 0.5 m apart on the flat scenario (radius 0.5 m: in
    contact) against the same two 50 m apart; the difference of their step rewards is the
    collision weight (the progress, energy and battery terms are the same: both stand still,
    the same distances from the target)."""
    env = tse.parallel_env(scenario="flat", n_robots=2, max_cycles=5)
    w = env.config.rewards
    assert env.config.world.robot.radius_m * 2 > 0.5
    still = {a: np.zeros(2, np.float32) for a in env.possible_agents}
    tx, ty = env.config.targets.positions[0]
    out = []
    for gap in (0.5, 50.0):
        # both on a circle round the target (same distance to go), `gap` metres apart
        ang = 2 * np.arcsin(gap / 2 / 100.0)
        pos = [[tx - 100.0, ty], [tx - 100.0 * np.cos(ang), ty + 100.0 * np.sin(ang)]]
        env.reset(seed=0, options={"robot_positions": pos, "headings": [0.0, 0.0]})
        _, r, _, _, _ = env.step(still)
        out.append([r[a] for a in env.possible_agents])
    np.testing.assert_allclose(np.subtract(out[0], out[1]), [w.collision, w.collision], rtol=1e-6)
    assert w.collision < 0


@pytest.mark.parametrize("task", ["goal", "containment"])
@pytest.mark.parametrize("seed", range(8))
def test_compiled_rewards_equal_the_numpy_reference_bit_for_bit(task, seed):
    """Random swarms of 1..300 robots (the kernel's one-thread and parallel paths), random weights,
    robots without a target, not live (gone: fallen or arrived earlier), falling, emptying,
    arriving (some exactly on the radius), unreachable (inf) distances and the ring's tolerance
    edge: :func:`compute_rewards` equals env/reference.py's numpy version bit for bit."""
    from tin_swarm_env.env.reference import compute_rewards_reference

    rng = np.random.default_rng(seed)
    n = int(rng.choice([1, 7, 300]))
    m = int(rng.integers(1, 4))
    tpos = rng.uniform(-50, 50, (m, 2))
    tidx = rng.integers(-1, m, n)
    # a third of the robots near their target (inside, on or just beyond the radius), the rest anywhere
    pos = rng.uniform(-100, 100, (n, 2))
    near = (rng.random(n) < 0.33) & (tidx >= 0)
    ang = rng.uniform(0, 2 * np.pi, n)
    rad = rng.choice([0.0, 0.5 * RADIUS, RADIUS, np.nextafter(RADIUS, np.inf), 2 * RADIUS], n)
    pos[near] = tpos[tidx[near]] + np.c_[rad * np.cos(ang), rad * np.sin(ang)][near]
    on_axis = near & (rng.random(n) < 0.5)  # exactly RADIUS along x: the distance is exactly the radius
    pos[on_axis] = tpos[tidx[on_axis]] + np.c_[rad, np.zeros(n)][on_axis]
    before = rng.uniform(0, 60, n)
    after = before + rng.choice([-1.0, 0.0, 1.0], n) * rng.uniform(0, 3, n)
    ring = rng.random(n) < 0.2  # |after - standoff| exactly at the tolerance
    after[ring] = STANDOFF + rng.choice([-1, 1], ring.sum()) * W.ring_tolerance_m
    before[rng.random(n) < 0.1] = np.inf
    after[rng.random(n) < 0.1] = np.inf
    w = SimpleNamespace(ring_tolerance_m=W.ring_tolerance_m, **{k: float(rng.normal(0, 10)) for k in (
        "progress_per_m", "arrival", "on_ring_per_step", "fall", "battery_empty", "collision", "energy_per_kj")})
    c = SimpleNamespace(task=task, rewards=w, targets=SimpleNamespace(standoff_m=STANDOFF, arrival_radius_m=RADIUS))
    state = SimpleNamespace(n_robots=n, positions=pos, targets=SimpleNamespace(positions=tpos))
    ev = SimpleNamespace(fell=rng.random(n) < 0.2, emptied=rng.random(n) < 0.3,
                         collisions=rng.integers(0, 4, n), energy_j=rng.uniform(0, 50, n))
    live = rng.random(n) < 0.8
    got = compute_rewards(c, before, after, state, ev, tidx, live)
    want = compute_rewards_reference(c, before, after, state, ev, tidx, live)
    for g, e in zip(got, want):
        assert g.dtype == e.dtype and g.shape == e.shape
        assert g.tobytes() == e.tobytes()
    # the env's call: the same three, plus the step's bookkeeping, on a middle step and the last one
    r, term, why = want
    for timeout in (False, True):
        got = step_rewards(reward_params(c), before, after, state, ev, tidx, live, timeout)
        trunc = live & ~term & timeout
        reasons = why.copy()
        reasons[trunc] = Reason.TIMEOUT
        for g, e in zip(got, (r, term, reasons, trunc, live & ~term & ~trunc)):
            assert g.dtype == e.dtype and g.tobytes() == e.tobytes()
        assert got[5] == int((reasons == Reason.ARRIVED).sum())
    if task == "goal":  # the cases the draw is meant to cover occur
        assert (want[2] == Reason.ARRIVED).any() or n < 300
        assert (want[2] == Reason.FELL).any() or n < 300


def test_distance_to_go_mixes_fields_and_straight_lines_per_target():
    """Target 0 without a field (the straight line, equal bit for bit to target_distance), target 1
    with one (its query, given exactly the rows of its robots), no target: inf."""
    rng = np.random.default_rng(3)
    n = 50
    tidx = rng.integers(-1, 2, n)
    pos = rng.uniform(-80, 80, (n, 2))
    tri = rng.integers(0, 99, n)
    state = SimpleNamespace(n_robots=n, positions=pos, tri_idx=tri,
                            targets=SimpleNamespace(positions=np.array([[1.5, -2.0], [30.0, 7.0]])))
    seen = {}

    class Field:
        def distance_at(self, p, t):
            seen["p"], seen["t"] = p, t
            return 1000.0 + t

    d = distance_to_go(state, tidx, [None, Field()])
    straight = target_distance(state, tidx)
    assert d[tidx == 0].tobytes() == straight[tidx == 0].tobytes()
    assert (d[tidx == 1] == 1000.0 + tri[tidx == 1]).all()
    assert np.array_equal(seen["p"], pos[tidx == 1]) and np.array_equal(seen["t"], tri[tidx == 1])
    assert np.isinf(d[tidx == -1]).all() and (tidx == -1).any()
