"""The APF baseline on the thesis scenarios (a reduced seed/robot budget; bench/apf.py runs the
full 20-seed table)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tin_swarm_env as tse
from tin_swarm_env.policies import APFPolicy, RandomPolicy


def outcomes(scenario, fields, seeds, n_robots):
    tot = {"arrived": 0, "fell": 0, "battery": 0, "max_cycles": 0}
    for sd in seeds:
        env = tse.parallel_env(scenario=scenario, n_robots=n_robots)
        pol = APFPolicy(env, fields=fields)
        obs, _ = env.reset(seed=sd)
        while env.agents:
            obs, _, _, _, info = env.step(pol.act(obs))
            for i in info.values():
                if "reason" in i:
                    tot[i["reason"]] += 1
    return tot


ALL = ("robot", "target", "break", "height")
NO_BREAK = ("robot", "target", "height")


@pytest.mark.parametrize("scenario", ["ramp", "cliff_goal"])
def test_apf_with_all_fields_arrives_and_never_falls(scenario):
    t = outcomes(scenario, ALL, seeds=(0, 7, 13), n_robots=12)
    n = sum(t.values())
    assert n == 36
    assert t["arrived"] >= 0.9 * n, t
    assert t["fell"] == 0, t


@pytest.mark.parametrize("scenario", ["ramp", "cliff_goal"])
def test_without_the_break_field_robots_fall(scenario):
    t = outcomes(scenario, NO_BREAK, seeds=(0,), n_robots=12)
    assert t["fell"] > 0, t  # the thesis's "poor ending"


def test_containment_robots_settle_on_the_ring_spread_around_each_threat():
    for sd in (0, 1):
        env = tse.parallel_env(scenario="containment")
        pol = APFPolicy(env)
        obs, _ = env.reset(seed=sd)
        while env.agents:
            obs, *_ = env.step(pol.act(obs))
        s = env.world_state
        standoff = env.config.targets.standoff_m
        T = s.targets.positions
        for k in range(len(T)):
            v = s.positions[env.target_assignment == k] - T[k]
            d = np.hypot(v[:, 0], v[:, 1])
            assert abs(d.mean() - standoff) <= 0.1 * standoff
            ang = np.arctan2(v[:, 1], v[:, 0])
            resultant = np.hypot(np.cos(ang).mean(), np.sin(ang).mean())
            gaps = np.diff(np.sort(np.r_[ang, ang.min() + 2 * np.pi]))
            assert resultant < 0.5 and gaps.max() < np.pi, (sd, k, resultant, np.degrees(gaps.max()))


def test_apf_acts_from_the_observation_alone():
    env = tse.parallel_env(scenario="cliff_goal", n_robots=5)
    pol = APFPolicy(env)
    obs, _ = env.reset(seed=0)
    a1 = pol.act(obs)
    env._wstate = None  # no world state to peek at
    env._world = None
    a2 = pol.act(obs)
    for k in obs:
        np.testing.assert_array_equal(a1[k], a2[k])
    batch = pol.act_batch(np.stack(list(obs.values())))
    np.testing.assert_array_equal(batch[0], a1["robot_0"])
    assert all(env.action_space(k).contains(v) for k, v in a1.items())


def test_fields_subset_and_random_policy():
    env = tse.parallel_env(scenario="ramp", n_robots=3)
    obs, _ = env.reset(seed=0)
    pol = APFPolicy(env, fields=("robot", "target", "height"))
    f = pol.forces(np.stack(list(obs.values())))
    assert not np.any(f["break"]) and not np.any(f["follow"])
    with pytest.raises(ValueError, match="unknown field"):
        APFPolicy(env, fields=("robot", "gravity"))
    r1, r2 = RandomPolicy(env, seed=1).act(obs), RandomPolicy(env, seed=1).act(obs)
    assert all(np.array_equal(r1[k], r2[k]) and env.action_space(k).contains(r1[k]) for k in obs)


# -- the way round on either side, crowding ----------------------------------------------------

from tin_swarm_env.apps.rollout import rollout  # noqa: E402
from tin_swarm_env.env.observation import ObsLayout  # noqa: E402
from tin_swarm_env.policies.bug import BugMemory, BugParams, bug_update, odometry  # noqa: E402
from tin_swarm_env.policies.base import decode, keep_clear  # noqa: E402
from tin_swarm_env.world.fields import FieldParams as FP  # noqa: E402
from tin_swarm_env.world.fields import follow_field  # noqa: E402
from tin_swarm_env.world.state import Reason  # noqa: E402


def test_apf_finds_the_pass_on_either_side_of_an_unseen_canyon(canyon_config, canyon_variant):
    side, travel = canyon_variant
    # a cliff across the whole terrain, one pass at one end: half the robots first walk the
    # wrong way, meet the border in the corner and turn back
    env = tse.parallel_env(scenario=canyon_config(side, travel, robots=10))
    pol = APFPolicy(env)
    arrived = fell = 0
    for sd in (0, 1):
        out = rollout(env, pol, sd)
        arrived += out.count(Reason.ARRIVED)
        fell += out.count(Reason.FELL)
    assert fell == 0 and arrived >= 19, (side, travel, arrived, fell)


def _obs(layout, R, target_xy, breaks=(), robots=(), speed=1.0):
    """One hand-built observation row (body frame): target at ``target_xy`` m; breaks as
    (closest x, y, normal x, y, drop_m); robots as (x, y)."""
    o = np.zeros(layout.size)
    own = layout.own
    d = np.hypot(*target_xy)
    o[own["speed"]] = speed
    o[own["target_valid"]] = 1
    o[own["target_dir"]] = np.asarray(target_xy) / d
    o[own["target_dist"]] = d / (d + R)
    b = layout.breaks.start
    for k, (x, y, nx, ny, drop) in enumerate(breaks):
        o[b + 8 * k: b + 8 * k + 8] = [1, x / R, y / R, nx, ny, drop / (abs(drop) + 10), np.hypot(x, y) / R, 1]
    r = layout.robots.start
    for k, (x, y) in enumerate(robots):
        o[r + 4 * k: r + 4 * k + 4] = [1, x / R, y / R, np.hypot(x, y) / R]
    return o[None]


def _step(mem, obs, layout, R, params=None):
    """One step of the boundary search; returns the side each robot follows (0 none)."""
    params = FP() if params is None else params
    d = decode(obs, layout, R)
    rows = np.arange(len(obs))
    q, moved = odometry(mem, rows, d, 1.0)
    pull = d.rel_t / np.hypot(*d.rel_t[0])
    return bug_update(mem, rows, d, pull, params, BugParams(), togo=d.dist, q=q, moved=moved, crowd_m=8.0,
                      range_m=R)[2]


def test_bug_memory_chooses_the_side_toward_the_target_either_way():
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)  # a cliff edge 5 m ahead, running across
    for ty, want in ((30.0, 1), (-30.0, -1)):  # target ahead-left: follow it on the right (turn left)
        mem = BugMemory.empty(1)
        side = _step(mem, _obs(layout, R, (100.0, ty), [cliff]), layout, R)
        assert mem.side[0] == want and side[0] == want
    # the pull away from the cliff: not blocked, nothing to follow
    mem = BugMemory.empty(1)
    assert _step(mem, _obs(layout, R, (-100.0, 10.0), [cliff]), layout, R)[0] == 0 and mem.side[0] == 0


def test_bug_memory_turns_back_at_the_border_and_when_stalled():
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    mem = BugMemory.empty(1)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff]), layout, R)
    assert mem.side[0] == 1  # heading along +y with the cliff on its right
    # the border (zero drop) lies ahead along the cliff, 6 m away: turn back
    border = (0.0, 6.0, 0.0, -1.0, 0.0)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff, border]), layout, R)
    assert mem.side[0] == -1
    # a cliff (not the border) ahead is a corner to follow round: no turn
    mem = BugMemory.empty(1)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff]), layout, R)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff, (0.0, 6.0, 0.0, -1.0, 40.0)]), layout, R)
    assert mem.side[0] == 1
    # standing still while following, no robot near, for stall_steps steps: turn back
    p = FP(stall_steps=5)
    mem = BugMemory.empty(1)
    for _ in range(5):
        _step(mem, _obs(layout, R, (100.0, 30.0), [cliff], speed=0.0), layout, R, p)
    assert mem.side[0] == -1
    # ... but not when a robot stands next to it (a queue, not a dead end)
    mem = BugMemory.empty(1)
    for _ in range(10):
        _step(mem, _obs(layout, R, (100.0, 30.0), [cliff], robots=[(0.0, 2.0)], speed=0.0), layout, R, p)
    assert mem.side[0] == 1


def test_follow_field_hand_values():
    # break 5 m east (normal west), hold 5 m, step 0 -> straight along it: north for side +1
    rel, n, pull = np.array([[5.0, 0.0]]), np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])
    np.testing.assert_allclose(pull + follow_field(pull, rel, n, np.array([1]), 5.0, 0.0), [[0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(pull + follow_field(pull, rel, n, np.array([-1]), 5.0, 0.0), [[0.0, -1.0]],
                               atol=1e-12)
    np.testing.assert_allclose(follow_field(pull, rel, n, np.array([0]), 5.0, 0.0), [[0.0, 0.0]])
    # 10 m away: turned toward the break by 1 rad; a 2 m step at 10 m adds asin(0.1)
    b = 1 + math.asin(0.1)
    np.testing.assert_allclose(pull + follow_field(pull, 2 * rel, n, np.array([1]), 5.0, 2.0),
                               [[math.sin(b), math.cos(b)]], atol=1e-12)


def _keep_clear_reference(a, rel, valid, gap, step, share):
    """Slow obvious check: after the move the robot is no nearer than allowed to any slot."""
    for j in range(rel.shape[0]):
        if valid[j] and np.hypot(*rel[j]) > 1e-9:
            u = rel[j] / np.hypot(*rel[j])
            assert a @ u <= max(np.hypot(*rel[j]) - gap, 0) / (share * step) + 1e-9


@given(st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.booleans()), min_size=1, max_size=4),
       st.floats(-1, 1), st.floats(-1, 1), st.floats(0.5, 5))
@settings(max_examples=200, deadline=None)
def test_keep_clear_never_closes_a_gap_too_fast_nor_adds_motion(slots, ax, ay, step):
    rel = np.array([[s[0], s[1]] for s in slots])[None]
    valid = np.array([[s[2] for s in slots]], dtype=float)
    a0 = np.array([[ax, ay]])
    a = keep_clear(a0, rel, valid, 1.5, step, passes=50)[0]
    _keep_clear_reference(a, rel[0], valid[0], 1.5, step, 2.0)
    assert np.hypot(*a) <= np.hypot(ax, ay) + 1e-9  # only removes


def test_crowding_resolves_robots_do_not_push_into_each_other():
    # ramp, seed 0: 20 robots funnel round the plateau to one target; contacts were 1.1 per robot
    # before keep_clear and into_view (main at f0edd29), 0.5 after
    env = tse.parallel_env(scenario="ramp", n_robots=20)
    pol = APFPolicy(env)
    out = rollout(env, pol, 0)
    assert out.collisions.sum() / env.n <= 0.55


def test_bug_memory_an_end_on_both_sides_shows_the_target_unreachable():
    # following with the cliff on its right (heading +y), the border ahead: the boundary ends
    # on this side, it turns back; the border ahead the other way too: unreachable, it stops
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    mem = BugMemory.empty(1)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff]), layout, R)
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff, (0.0, 6.0, 0.0, -1.0, 0.0)]), layout, R)
    assert mem.side[0] == -1 and mem.ended_first[0] and not mem.unreachable[0]
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff]), layout, R)
    assert mem.side[0] == -1 and not mem.unreachable[0]
    _step(mem, _obs(layout, R, (100.0, 30.0), [cliff, (0.0, -6.0, 0.0, 1.0, 0.0)]), layout, R)
    assert mem.side[0] == 0 and mem.ended_other[0] and mem.unreachable[0]


# -- gaps between break ends (a narrow pass lined with break fragments) -----------------------


def _gap_obs(points, normals, target):
    """Decoded-observation stand-in: dangerous break slots at ``points`` with ``normals`` (body
    frame, robot at the origin) and the target at ``target``."""
    k = len(points)
    nrm = np.array([normals], dtype=float)
    return SimpleNamespace(b_rel=np.array([points], dtype=float), b_normal=nrm / np.hypot(nrm[..., :1], nrm[..., 1:]),
                           b_danger=np.ones((1, k), dtype=bool), rel_t=np.array([target], dtype=float),
                           has_t=np.array([True]))


def test_pass_gap_takes_a_gap_between_two_break_ends_and_nothing_else():
    from tin_swarm_env.policies.bug import pass_gap
    up = [0.0, 1.0]
    # a straight cliff along y = -5 with a 6 m gap (x in [-3, 3]); the robot 5 m above the gap
    g = pass_gap(_gap_obs([[-3.0, -5.0], [3.0, -5.0]], [up, up], [0.0, -100.0]), 3.0, 8.0)
    assert g["has"][0] and sorted(g["slots"][0]) == [0, 1]
    np.testing.assert_allclose(g["aim"][0], [0.0, -1.0], atol=1e-12)  # straight through its middle
    # the same gap seen off-centre: the aim points between the two ends, through the gap
    g = pass_gap(_gap_obs([[-1.0, -5.0], [5.0, -5.0]], [up, up], [0.0, -100.0]), 3.0, 8.0)
    a = g["aim"][0]
    assert g["has"][0] and a[1] < 0 and -1.0 / 5.0 < a[0] / -a[1] < 5.0 / 5.0
    # narrower than width_m, or the target on the robot's side, or too far: no gap
    assert not pass_gap(_gap_obs([[-1.0, -5.0], [1.0, -5.0]], [up, up], [0.0, -100.0]), 3.0, 8.0)["has"][0]
    assert not pass_gap(_gap_obs([[-3.0, -5.0], [3.0, -5.0]], [up, up], [0.0, 100.0]), 3.0, 8.0)["has"][0]
    assert not pass_gap(_gap_obs([[-3.0, -9.0], [3.0, -9.0]], [up, up], [0.0, -100.0]), 3.0, 8.0)["has"][0]
    # one straight wall in three pieces: the point seen square on lies between the two ends
    g = pass_gap(_gap_obs([[0.0, -5.0], [-3.0, -5.0], [3.0, -5.0]], [up, up, up], [0.0, -100.0]), 3.0, 8.0)
    assert not g["has"][0]
    # two pieces of one wall meeting at a vertex: one is seen square on, so it is no gap
    assert not pass_gap(_gap_obs([[0.0, -5.0], [4.0, -5.0]], [up, up], [0.0, -100.0]), 3.0, 8.0)["has"][0]
    # a concave corner (a wall along y = -5 meeting one along x = 6 at (6, -5)), seen from
    # inside: the two closest points seen are ends, but the corner where their lines meet (6.6,
    # -5.7) lies in the cone through the gap and closes it
    g = pass_gap(_gap_obs([[2.0, -5.2], [5.8, 2.0]], [[0.1, 1.0], [-1.0, -0.1]], [60.0, -100.0]), 3.0, 8.0)
    assert not g["has"][0]
    # ... while two ends whose lines meet away from the gap (at (7.9, -5)) leave it open
    g = pass_gap(_gap_obs([[-3.0, -5.0], [3.0, -6.0]], [up, [-0.2, 0.98]], [0.0, -100.0]), 3.0, 8.0)
    assert g["has"][0]


def test_a_robot_following_a_wall_drives_through_a_gap_in_it_once_per_following(canyon_config):
    # a cliff along y = -5 (body frame), the target beyond it: first seen square on (blocked: the
    # robot starts following), then a 6 m gap between two ends: the ends do not push the robot
    # back and its command points through the gap
    layout, R = ObsLayout(), 60.0
    env = tse.parallel_env(scenario=canyon_config("left", "east", robots=1))
    pol = APFPolicy(env)
    ends = [(-3.0, -5.0, 0.0, 1.0, 50.0), (3.0, -5.0, 0.0, 1.0, 50.0)]
    wall = [(0.0, -5.0, 0.0, 1.0, 50.0), *ends]
    pol.act_batch(_obs(layout, R, (0.0, -100.0), wall))
    side = pol.memory.side[0]
    assert side != 0 and pol.memory.gap[0] == 0
    a = pol.act_batch(_obs(layout, R, (0.0, -100.0), ends))[0]
    assert a[1] < -0.9 * np.hypot(*a) and np.hypot(*a) > 0.5, a  # through the gap, at speed
    assert pol.memory.side[0] == side and pol.memory.gap[0] == 1  # keeps its side meanwhile
    # the gap proved to be none (the wall is seen square on again): it is not tried again
    pol.act_batch(_obs(layout, R, (0.0, -100.0), wall))
    assert pol.memory.gap[0] == 2
    a = pol.act_batch(_obs(layout, R, (0.0, -100.0), ends))[0]
    assert pol.memory.gap[0] == 2 and not a[1] < -0.9 * np.hypot(*a), a
    # a robot with another one ahead toward the gap queues instead
    pol.reset()
    pol.act_batch(_obs(layout, R, (0.0, -100.0), wall))
    pol.act_batch(_obs(layout, R, (0.0, -100.0), ends, robots=[(0.0, -3.0)]))
    assert pol.memory.gap[0] == 0
