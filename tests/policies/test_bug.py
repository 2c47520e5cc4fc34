"""The boundary search under APF (policies/bug.py). Its memory and gap finder step by step on
hand-built observations; then on hand-built terrains (small DEM arrays, mirrored): a U trap opening to
either side, a comb (dead-end bays before the one pass), ten robots queued along one wall toward
one pass, a fork with a dead-end ramp into a walled pocket; and the odometry the search rests on.

Step budgets are stated per test, as multiples of the geodesic steps at top speed (one metre a
step here: 2 m/s, 0.5 s)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout  # noqa: E402
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.base import decode  # noqa: E402
from tin_swarm_env.policies.bug import BugMemory, BugParams, bug_update, odometry  # noqa: E402
from tin_swarm_env.scenario import scenario_from_dict
from tin_swarm_env.training.rollout import rollout  # noqa: E402
from tin_swarm_env.world.fields import FieldParams as FP  # noqa: E402
from tin_swarm_env.world.state import Reason  # noqa: E402

CELL = 4.0


def _grid(w, h):
    x, y = np.arange(0.0, w + 1e-9, CELL), np.arange(0.0, h + 1e-9, CELL)
    return x, y, *np.meshgrid(x, y)


def _box(X, Y, x0, x1, y0, y1):
    return (X >= x0) & (X <= x1) & (Y >= y0) & (Y <= y1)


def utrap():
    """A trench 10 m deep, 8 m wide, round the spawn on the east, south and west: open north (the
    robots' left going east to the target)."""
    x, y, X, Y = _grid(320.0, 240.0)
    z = np.zeros_like(X)
    z[_box(X, Y, 150, 158, 60, 180) | _box(X, Y, 50, 158, 60, 68) | _box(X, Y, 50, 58, 60, 180)] = -10.0
    return z, x, y, [80.0, 90.0, 130.0, 150.0], [280.0, 120.0]


def comb():
    """A wall (a 10 m ridge) from border to border with one pass near the north end, and four
    spurs to the west of it: the straight line to the target ends in a dead-end bay, and the
    way to the pass leads in and out of two more."""
    x, y, X, Y = _grid(320.0, 240.0)
    z = np.zeros_like(X)
    wall = _box(X, Y, 180, 188, 0, 240) & ~_box(X, Y, 176, 192, 196, 216)
    for yy in (40, 80, 120, 160):
        wall |= _box(X, Y, 120, 188, yy, yy + 8)
    z[wall] = 10.0
    return z, x, y, [20.0, 60.0, 90.0, 140.0], [300.0, 100.0]


def queue():
    """A wall from border to border with one 16 m pass; the robots spawn in a strip along it."""
    x, y, X, Y = _grid(260.0, 240.0)
    z = np.zeros_like(X)
    z[_box(X, Y, 120, 128, 0, 240) & ~_box(X, Y, 116, 132, 180, 196)] = 10.0
    return z, x, y, [96.0, 20.0, 114.0, 150.0], [200.0, 60.0]


def fork():
    """A 20 m plateau whose cliff has two ramps down: the northern one into a pocket walled on
    its three other sides (a dead end), the southern one to the floor and the target."""
    x, y, X, Y = _grid(360.0, 280.0)
    z = np.where(X < 140, 20.0, 0.0)
    rz = 20 * np.clip(1 - (X - 140) / 80, 0, 1)
    z = np.where(_box(X, Y, 140, 220, 60, 84), rz, z)
    inner = _box(X, Y, 140, 252, 158, 232)
    z = np.where(_box(X, Y, 140, 260, 150, 240) & ~inner, 30.0, z)
    z = np.where(inner, 0.0, z)
    z = np.where(_box(X, Y, 140, 220, 180, 204), rz, z)
    return z, x, y, [30.0, 110.0, 100.0, 170.0], [330.0, 140.0]


def _config(tmp_path, name, terrain, mirror_y=False, mirror_x=False, robots=10, max_cycles=1500, k_scan=0):
    z, x, y, spawn, target = terrain
    if mirror_y:  # the other side: the way round swaps left and right
        z, spawn, target = z[::-1], [spawn[0], y[-1] - spawn[3], spawn[2], y[-1] - spawn[1]], [target[0], y[-1] - target[1]]
    if mirror_x:  # travelling west
        z, spawn, target = z[:, ::-1], [x[-1] - spawn[2], spawn[1], x[-1] - spawn[0], spawn[3]], [x[-1] - target[0], target[1]]
    np.savez(tmp_path / f"{name}.npz", z=z, x=x, y=y)
    return scenario_from_dict({
        "name": name, "task": "goal", "max_cycles": max_cycles,
        "terrain": {"source": "dem", "path": f"{name}.npz", "method": "delaunay"},
        "robots": {"count": robots, "spawn_region": spawn, "max_slope_deg": 30.0, "min_separation_m": 3.0},
        "targets": {"positions": [target], "arrival_radius_m": 8.0},
        **({"observation": {"k_scan": k_scan}} if k_scan else {})}, source=name, base_dir=str(tmp_path))


def _run(cfg, seed=0, search="bug"):
    env = tse.parallel_env(scenario=cfg)
    pol = APFPolicy(env, search=search.split("+")[0])
    out = rollout(env, pol, seed)
    return out, pol


# (terrain, max_cycles): geodesic steps at top speed ~ 250 (U), 330 (comb), 300 (queue)
CASES = [(utrap, 1000), (comb, 1600), (queue, 800)]


# APFPolicy's two boundary searches (policies/bug.py, policies/chart.py), and the chart search with
# the observation's terrain scan of 32 beams ([observation] k_scan)
SEARCHES = ["bug", "chart", "chart+scan"]


def _scan(search):
    return 32 if search.endswith("+scan") else 0


@pytest.mark.parametrize("search", SEARCHES)
@pytest.mark.parametrize("mirror_y", [False, True], ids=["open-left", "open-right"])
@pytest.mark.parametrize("make,steps", CASES, ids=[c[0].__name__ for c in CASES])
def test_every_robot_gets_out_and_arrives(tmp_path, make, steps, mirror_y, search):
    out, pol = _run(_config(tmp_path, make.__name__, make(), mirror_y=mirror_y, max_cycles=steps, k_scan=_scan(search)),
                    search=search)
    assert out.count(Reason.FELL) == 0
    assert out.count(Reason.ARRIVED) == out.n_robots, (out.counts(), out.steps.tolist())
    assert not out.stalled.any() and not out.looping.any() and not pol.unreachable.any()


@pytest.mark.parametrize("search", SEARCHES)
def test_the_u_trap_travelling_west(tmp_path, search):
    out, pol = _run(_config(tmp_path, "utrap_w", utrap(), mirror_x=True, max_cycles=1000, k_scan=_scan(search)),
                    search=search)
    assert out.count(Reason.FELL) == 0 and out.count(Reason.ARRIVED) == out.n_robots, out.counts()


@pytest.mark.parametrize("search", SEARCHES)
@pytest.mark.parametrize("mirror_y", [False, True], ids=["dead-end-left", "dead-end-right"])
def test_fork_with_a_dead_end_ramp_every_robot_arrives(tmp_path, mirror_y, search):
    """Every robot arrives within 1500 steps (5x the geodesic ~300 at top speed), none falls, stalls,
    loops or gives up. Robots that take the dead-end ramp first search the pocket and climb out; the
    way to the real ramp needs ~200 m more distance to go than the hit point: a first leg of the
    doubling search shorter than that (``BugParams.min_budget`` of one sensor range, 60 m) turned
    them back and forth along the cliff until the time ran out (5 of 10 arrived)."""
    out, pol = _run(_config(tmp_path, "fork", fork(), mirror_y=mirror_y, max_cycles=1500, k_scan=_scan(search)),
                    search=search)
    assert out.count(Reason.FELL) == 0 and not pol.unreachable.any()
    assert out.count(Reason.ARRIVED) == out.n_robots, (out.counts(), out.steps.tolist())
    assert not out.stalled.any() and not out.looping.any()


def test_odometry_recovers_the_heading_from_the_observation_alone():
    # psi (the heading each robot integrates from its command, its reported speed and its
    # target's bearing) equals the true heading change, to float32 rounding of the observation
    env = tse.parallel_env(scenario="cliff_goal", n_robots=6)
    obs = env.reset_arrays(seed=3)
    pol = APFPolicy(env)
    h0 = env.world_state.headings.copy()
    for _ in range(150):
        obs, *_ = env.step_arrays(pol.act_batch(obs))
    pol.act_batch(obs)
    live = env.live_mask
    err = (pol.memory.psi - (env.world_state.headings - h0) + np.pi) % (2 * np.pi) - np.pi
    assert live.sum() >= 3 and np.abs(err[live]).max() < 1e-4
    assert np.abs(env.world_state.headings - h0)[live].max() > 0.1  # they did turn


def _step(mem, obs, layout, R, params=None):
    """One step of the boundary search; returns the side each robot follows (0 none)."""
    params = FP() if params is None else params
    d = decode(obs, layout, R)
    rows = np.arange(len(obs))
    q, moved = odometry(mem, rows, d, 1.0)
    pull = d.rel_t / np.hypot(*d.rel_t[0])
    return bug_update(mem, rows, d, pull, params, BugParams(), togo=d.dist, q=q, moved=moved, crowd_m=8.0,
                      range_m=R)[2]


def test_bug_memory_chooses_the_side_toward_the_target_either_way(obs_row):
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)  # a cliff edge 5 m ahead, running across
    for ty, want in ((30.0, 1), (-30.0, -1)):  # target ahead-left: follow it on the right (turn left)
        mem = BugMemory.empty(1)
        side = _step(mem, obs_row(layout, R, (100.0, ty), [cliff]), layout, R)
        assert mem.side[0] == want and side[0] == want
    # the pull away from the cliff: not blocked, nothing to follow
    mem = BugMemory.empty(1)
    assert _step(mem, obs_row(layout, R, (-100.0, 10.0), [cliff]), layout, R)[0] == 0 and mem.side[0] == 0


def test_bug_memory_turns_back_at_the_border_and_when_stalled(obs_row):
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff]), layout, R)
    assert mem.side[0] == 1  # heading along +y with the cliff on its right
    # the border (zero drop) lies ahead along the cliff, 6 m away: turn back
    border = (0.0, 6.0, 0.0, -1.0, 0.0)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff, border]), layout, R)
    assert mem.side[0] == -1
    # a cliff (not the border) ahead is a corner to follow round: no turn
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff]), layout, R)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff, (0.0, 6.0, 0.0, -1.0, 40.0)]), layout, R)
    assert mem.side[0] == 1
    # standing still while following, no robot near, for stall_steps steps: turn back
    p = FP(stall_steps=5)
    mem = BugMemory.empty(1)
    for _ in range(5):
        _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff], speed=0.0), layout, R, p)
    assert mem.side[0] == -1
    # ... but not when a robot stands next to it (a queue, not a dead end)
    mem = BugMemory.empty(1)
    for _ in range(10):
        _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff], robots=[(0.0, 2.0)], speed=0.0), layout, R, p)
    assert mem.side[0] == 1


def test_bug_memory_an_end_on_both_sides_shows_the_target_unreachable(obs_row):
    # following with the cliff on its right (heading +y), the border ahead: the boundary ends
    # on this side, it turns back; the border ahead the other way too: unreachable, it stops
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff]), layout, R)
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff, (0.0, 6.0, 0.0, -1.0, 0.0)]), layout, R)
    assert mem.side[0] == -1 and mem.ended_first[0] and not mem.unreachable[0]
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff]), layout, R)
    assert mem.side[0] == -1 and not mem.unreachable[0]
    _step(mem, obs_row(layout, R, (100.0, 30.0), [cliff, (0.0, -6.0, 0.0, 1.0, 0.0)]), layout, R)
    assert mem.side[0] == 0 and mem.ended_other[0] and mem.unreachable[0]


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


def _follow_step(mem, obs, layout, R, fov_deg=360.0):
    """One step of the boundary search for one robot; returns the closest point it follows
    (body frame, zeros when none) and its side."""
    d = decode(obs, layout, R)
    rows = np.arange(len(obs))
    q, moved = odometry(mem, rows, d, 1.0)
    pull = d.rel_t / np.hypot(*d.rel_t[0])
    rel, _, side = bug_update(mem, rows, d, pull, FP(), BugParams(), togo=d.dist, q=q, moved=moved, crowd_m=8.0,
                              range_m=R, pass_m=3.0, step_m=1.0, fov_deg=fov_deg)
    return rel[0], side[0]


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_a_follower_goes_round_its_own_end_not_across_the_gap(obs_row, s):
    # following a cliff 5 m ahead (target ahead to the side s), the cliff drops out of the break
    # slots and the only break seen is the end of another one, 5.9 m off across an open gap (more
    # than pass_m from the followed point): the robot keeps to the point it followed (it goes round
    # that end), it does not jump the gap to a break on its other side
    layout, R = ObsLayout(), 60.0
    mem = BugMemory.empty(1)
    rel, side = _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [(5.0, 0.0, -1.0, 0.0, 50.0)]), layout, R)
    assert side == s and np.allclose(rel, [5.0, 0.0])
    mem.probed[:] = True  # it has used its one clear-view leave: the open view does not end the search here
    other_end = (-2.0, 5.5 * s, 0.0, -1.0 * s, 50.0)
    rel, side = _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [other_end]), layout, R)
    assert side == s and np.allclose(rel, [5.0, 0.0], atol=1e-6), rel
    # the same break seen square on (not an end: a wall it runs into) is taken up
    mem2 = BugMemory.empty(1)
    _follow_step(mem2, obs_row(layout, R, (100.0, 30.0 * s), [(5.0, 0.0, -1.0, 0.0, 50.0)]), layout, R)
    mem2.probed[:] = True
    wall = (0.0, 5.5 * s, 0.0, -1.0 * s, 50.0)
    rel, side = _follow_step(mem2, obs_row(layout, R, (100.0, 30.0 * s), [wall]), layout, R)
    assert side == s and np.allclose(rel, [0.0, 5.5 * s], atol=1e-6), rel


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_a_point_seen_square_on_and_lost_behind_defers_no_corner_ahead(obs_row, s):
    # following a cliff seen square on 5 m off (target to the side s), the robot turns round (the
    # target's bearing swings by 180 degrees, so its odometry heading does too): the cliff's point now
    # lies behind it, in the blind sector of a 270-degree sensor, and drops out of its slots. The
    # cliff runs on out of view; the end of a break 5.9 m off on the way ahead closes a corner with
    # it and is followed (deferring it kept robots turning to and fro in such corners for good)
    layout, R = ObsLayout(), 60.0
    fov = 270.0
    mem = BugMemory.empty(1)
    rel, side = _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [(5.0, 0.0, -1.0, 0.0, 50.0)]), layout, R,
                             fov)
    assert side == s and np.allclose(rel, [5.0, 0.0])
    mem.probed[:] = True  # no clear-view leave here
    # in the body frame turned by 180 degrees: the remembered point at (-5, 0), behind; the other
    # break's end at (2, -5.5 s), its normal (0, s)
    rel, side = _follow_step(mem, obs_row(layout, R, (-100.0, -30.0 * s), [(2.0, -5.5 * s, 0.0, 1.0 * s, 50.0)]),
                             layout, R, fov)
    assert side == s and np.allclose(rel, [2.0, -5.5 * s], atol=1e-6), rel
    # the same, with the remembered point still in view (the robot has not turned): deferred, it
    # keeps to the point it followed (it goes round that end)
    mem = BugMemory.empty(1)
    _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [(5.0, 0.0, -1.0, 0.0, 50.0)]), layout, R, fov)
    mem.probed[:] = True
    rel, side = _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [(-2.0, 5.5 * s, 0.0, -1.0 * s, 50.0)]),
                             layout, R, fov)
    assert side == s and np.allclose(rel, [5.0, 0.0], atol=1e-6), rel


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_an_end_met_on_the_way_back_to_h_ends_neither_side(obs_row, s):
    # following with the cliff on side s, the border ahead: the first side ends, it turns back. On
    # its way back, 20 m short of H, it meets the border again (the corner it turned in) or stalls
    # (a queue): that is boundary it has driven, so neither side ends and it goes on back to H
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    target = (100.0, 30.0 * s)
    for case in ("border", "stall"):
        mem = BugMemory.empty(1)
        _step(mem, obs_row(layout, R, target, [cliff]), layout, R)
        assert mem.side[0] == s
        _step(mem, obs_row(layout, R, target, [cliff, (0.0, 6.0 * s, 0.0, -1.0 * s, 0.0)]), layout, R)
        assert mem.side[0] == -s and mem.ended_first[0] and not mem.unreachable[0]
        mem.hit[0] -= (0.0, 20.0 * s)  # it has come 20 m along the cliff from H (along s y)
        mem.far[0] = True
        if case == "border":  # the cliff out of its slots, the border the one break it sees: it follows it
            _step(mem, obs_row(layout, R, target, [(0.0, 6.0 * s, 0.0, -1.0 * s, 0.0)]), layout, R)
        else:
            for _ in range(5):
                _step(mem, obs_row(layout, R, target, [cliff], speed=0.0), layout, R, FP(stall_steps=5))
        assert mem.side[0] == -s and not mem.ended_other[0] and not mem.unreachable[0], case
        # back at H it goes on along the other side, where the border ahead does end it: unreachable
        mem.hit[0] += (0.0, 20.0 * s)
        _step(mem, obs_row(layout, R, target, [cliff]), layout, R)
        _step(mem, obs_row(layout, R, target, [cliff, (0.0, -6.0 * s, 0.0, 1.0 * s, 0.0)]), layout, R)
        assert mem.side[0] == 0 and mem.ended_other[0] and mem.unreachable[0], case


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_taking_a_search_up_again_follows_the_break_that_blocks(obs_row, s):
    # a search starts at a cliff ahead; the robot leaves on a clear view (10 m on, the cliff's point
    # off its way); then a wall square across its way blocks it again, not nearer than H: it takes
    # the search up again (same side) along the wall that blocks it, not along a nearer break behind
    # it that last step's direction to the old cliff happens to match
    layout, R = ObsLayout(), 60.0
    mem = BugMemory.empty(1)
    _, side = _follow_step(mem, obs_row(layout, R, (100.0, 30.0 * s), [(5.0, 0.0, -1.0, 0.0, 50.0)]), layout, R)
    assert side == s
    side = _drive(mem, obs_row(layout, R, (100.0, 40.0 * s), []), layout, R, (0.0, -10.0 * s))
    assert side == 0 and mem.side[0] == 0  # it left
    blocking = (4.0, 1.2 * s, -0.958, -0.287 * s, 50.0)
    behind = (-1.0, -3.5 * s, 0.275, 0.962 * s, 50.0)  # nearer, beside and behind it
    mem.last_act[:] = 0.0  # it stood still since
    rel, side = _follow_step(mem, obs_row(layout, R, (100.0, 40.0 * s), [behind, blocking]), layout, R)
    assert side == s and np.allclose(rel, [4.0, 1.2 * s], atol=1e-6), rel



def _drive(mem, obs, layout, R, move):
    """One step of the boundary search for one robot that drove ``move`` (body frame, metres; its
    heading unchanged) since its last step; returns its side (0 none)."""
    move = np.asarray(move, dtype=float)
    mem.last_act[0] = move / np.hypot(*move)
    d = decode(obs, layout, R)
    rows = np.arange(1)
    q, moved = odometry(mem, rows, d, float(np.hypot(*move)))
    assert np.isclose(mem.psi[0], 0.0)  # the odometry agrees: it did not turn
    pull = d.rel_t / np.hypot(*d.rel_t[0])
    return bug_update(mem, rows, d, pull, FP(), BugParams(), togo=d.dist, q=q, moved=moved, crowd_m=8.0,
                      range_m=R)[2][0]


def _round_square(c, a, off, step, start):
    """Points ``step`` apart (by arc) on the path ``off`` outside the square of half-size ``a`` round
    ``c``, clockwise from the south end of its west side (``start`` metres on); each with the square's
    closest point and the unit normal from there to the point."""
    side, quarter = 2 * a, np.pi * off / 2
    per = 4 * (side + quarter)
    out = []
    for k in range(10_000):
        t = (start + k * step) % per
        for j, (d, n) in enumerate((((0, 1), (-1, 0)), ((1, 0), (0, 1)), ((0, -1), (1, 0)), ((-1, 0), (0, -1)))):
            if t < side + quarter:
                break
            t -= side + quarter
        corner = c + np.array(n) * a - np.array(d) * a  # the corner this edge starts from
        if t < side:
            q = corner + np.array(d) * t
            p, nrm = q + np.array(n) * off, np.array(n, float)
        else:  # round the next corner
            q = corner + np.array(d) * side
            ang = (t - side) / off
            n2 = np.array(d, float)
            nrm = np.cos(ang) * np.array(n, float) + np.sin(ang) * n2
            p = q + nrm * off
        out.append((p, q, nrm))
        if k * step > 3 * per:
            return out, per
    return out, per


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["island-right", "island-left"])
def test_a_robot_that_circles_an_island_after_a_wrong_leave_may_leave_it(obs_row, s):
    # the target at the origin, the robot heading +x throughout (it moves without turning). A
    # search starts at a cliff at (-100, -30 s), H, 104 m from the target; the robot leaves on a
    # clear view 10 m on and meets a closed boundary (a 20 m square island round (-90, -75 s)) on its far
    # side, 133 m out: the leave proved wrong, it takes its search up and may not leave on a clear
    # view again. Following the island (never back at H, never on the m-line, never nearer than H)
    # it would go round it to the end (fork seed 45). It finds the loop (Brent's cycle finding: a
    # place on its way, moved on at doubling distances, passed again the same way) within two laps,
    # after one lap at least, and then leaves on a clear view. (Passing that place the other way,
    # after a turn, finds no loop: tests/policies/test_apf.py's queue along a wall.)
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    flip = np.array([1.0, s])
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0 * s), [cliff]), layout, R)
    assert mem.side[0] == s and np.isclose(mem.rec[0], np.hypot(100.0, 30.0))
    # 10 m on (the cliff's point it followed now 11 m off, beside the way to the target): a clear view
    assert _drive(mem, obs_row(layout, R, (100.0, 40.0 * s), []), layout, R, (0.0, -10.0 * s)) == 0
    assert mem.side[0] == 0
    path, per = _round_square(np.array([-90.0, -75.0]), 10.0, 5.0, 4.0, 0.0)
    last = np.array([-100.0, -40.0 * s])
    driven = 0.0
    for k, (p, q, nrm) in enumerate(path):
        p, q, nrm = p * flip, q * flip, nrm * flip
        brk = (*(q - p), *nrm, 50.0)
        side = _drive(mem, obs_row(layout, R, tuple(-p), [brk]), layout, R, tuple(p - last))
        if k == 0:  # it met the island: its search taken up, not a fresh one
            assert side == s and np.isclose(mem.rec[0], np.hypot(100.0, 30.0)) and mem.probed[0]
        else:
            driven += np.hypot(*(p - last))
        last = p
        if side == 0:
            break
    assert side == 0 and per < driven < 2 * per, (side, driven, per)
    assert np.hypot(*(p - q)) == pytest.approx(5.0) and (p * flip)[1] > -75.0  # on the near half, 5 m off


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_a_followed_break_lost_from_the_slots_for_a_step_is_no_clear_view(obs_row, s):
    # following a cliff 5 m ahead (the target ahead, to the side s), the cliff drops out of the break
    # slots for one step (the robot turning in place, nearer breaks crowding the slots): the point it
    # followed still lies in the way to the target (4.8 m along it, 1.4 m across), so it does not
    # leave on a "clear view" (it used to, met the cliff again the next step, and its one clear-view
    # leave of the search was spent: fork seed 45, mesa). Seen 10 m on, off the way, the view is clear
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0 * s), [cliff]), layout, R)
    assert mem.side[0] == s
    _step(mem, obs_row(layout, R, (100.0, 30.0 * s), []), layout, R)
    assert mem.side[0] == s and not mem.probed[0]
    assert _drive(mem, obs_row(layout, R, (100.0, 40.0 * s), []), layout, R, (0.0, -10.0 * s)) == 0


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["island-right", "island-left"])
def test_the_first_time_round_to_h_turns_back_the_second_says_unreachable(obs_row, s):
    # the target stands inside a 20 m square island (steep all round: unreachable); the robot meets
    # the island at H and follows it round (blocked all the way, never nearer than rec - margin_m).
    # Back at H going the way it set off (one lap, 111 m), it turns back and goes round the other way
    # (a boundary sensed through K_b slots can hide an opening, e.g. a ramp mouth walked past on a
    # mesa, that the other way shows; standing still there was a false verdict); back at H again it
    # has driven the boundary both ways and says the target is unreachable (it stops). Before: it
    # said so at the first return
    layout, R = ObsLayout(), 60.0
    flip = np.array([1.0, s])
    path, per = _round_square(np.array([0.0, 0.0]), 10.0, 5.0, 2.0, 0.0)
    path = [(p * flip, q * flip, n * flip) for p, q, n in path]
    k0 = int(per // 2.0) + 1  # start one lap in, so that the way back has a lap of path behind it
    mem = BugMemory.empty(1)
    p, q, n = path[k0]
    assert _step(mem, obs_row(layout, R, tuple(-p), [(*(q - p), *n, 50.0)]), layout, R)[0] == s
    last, driven, k = p, 0.0, k0
    while mem.side[0] == s and driven < 2 * per:
        k += 1
        p, q, n = path[k]
        _drive(mem, obs_row(layout, R, tuple(-p), [(*(q - p), *n, 50.0)]), layout, R, tuple(p - last))
        driven += np.hypot(*(p - last))
        last = p
    assert mem.side[0] == -s and not mem.unreachable[0] and per - 6.0 < driven < per + 6.0, (driven, per)
    back = 0.0
    while not mem.unreachable[0] and back < 2 * per:
        k -= 1
        p, q, n = path[k]
        _drive(mem, obs_row(layout, R, tuple(-p), [(*(q - p), *n, 50.0)]), layout, R, tuple(p - last))
        back += np.hypot(*(p - last))
        last = p
        assert mem.unreachable[0] or mem.side[0] == -s
    # round the other way: from where it turned (within home_m of H) to within home_m of H again
    assert mem.unreachable[0] and mem.side[0] == 0 and per - 12.0 < back < per + 6.0, (back, per)


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["island-right", "island-left"])
def test_a_robot_round_a_closed_boundary_leaves_it_at_its_nearest_place_on_the_next_lap(obs_row, s):
    # the target at the origin, the robot heading +x throughout. A search starts at a cliff at
    # (-100, -30 s), H, 104 m out; the robot leaves on a clear view 10 m on and meets a closed boundary
    # (a 20 m square island round (-180, -40 s)) on its far side, 201 m out: not nearer than H, so it
    # takes its search up. Round the island it is never nearer than 167 m, so no rule of the search
    # can take it off (not margin_m nearer than H on the m-line, not leave_gain nearer, the clear
    # view reaches 60 m: 107 m > rec - margin_m): it would go round to the end (fork seeds 19, 40).
    # The loop finder sees it pass its first place again going the same way after one lap (111 m);
    # on the next lap it leaves where the lap came nearest the target (Bug1), not before
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    flip = np.array([1.0, s])
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, (100.0, 30.0 * s), [cliff]), layout, R)
    assert _drive(mem, obs_row(layout, R, (100.0, 40.0 * s), []), layout, R, (0.0, -10.0 * s)) == 0
    path, per = _round_square(np.array([-180.0, -40.0]), 10.0, 5.0, 2.0, 0.0)
    lap = np.array([np.hypot(*p) for p, _, _ in path[: int(per // 2.0)]])
    nearest = path[int(np.argmin(lap))][0] * flip
    last = np.array([-100.0, -40.0 * s])
    driven = 0.0
    for k, (p, q, nrm) in enumerate(path):
        p, q, nrm = p * flip, q * flip, nrm * flip
        side = _drive(mem, obs_row(layout, R, tuple(-p), [(*(q - p), *nrm, 50.0)]), layout, R, tuple(p - last))
        if k == 0:  # met the island: its search taken up, not a fresh one
            assert side == s and np.isclose(mem.rec[0], np.hypot(100.0, 30.0)) and mem.probed[0]
        else:
            driven += np.hypot(*(p - last))
        last = p
        if side == 0 or driven > 4 * per:
            break
    assert side == 0 and per < driven < 2 * per, (side, driven, per)
    assert np.hypot(*p) < lap.min() + 1.0 and np.hypot(*(p - nearest)) < 5.0, (p, nearest, lap.min())
    assert mem.lvl[0] == pytest.approx(np.hypot(*p), abs=0.01)  # the next such leave must be nearer


@pytest.mark.parametrize("s", [1.0, -1.0], ids=["wall-right", "wall-left"])
def test_swinging_to_and_fro_along_a_wall_is_no_lap(obs_row, s):
    # following a cliff 5 m ahead (the target ahead, to the side s), 20 m on from H the robot swings to
    # and fro along it, 1 m each way (the corner 2-cycle under the safety cut): every other step it passes the places
    # of its leg again going the way it follows the cliff, 30 m and more of driving after them, but it
    # goes round nothing: no lap is found, no Bug1 leave, its leg goes on (mesa seed 8: it "left" at
    # the corner and started a fresh search there, its budget and ends cleared)
    layout, R = ObsLayout(), 60.0
    cliff = (5.0, 0.0, -1.0, 0.0, 50.0)
    tgt, p = np.array([100.0, 30.0 * s]), np.zeros(2)
    mem = BugMemory.empty(1)
    _step(mem, obs_row(layout, R, tuple(tgt - p), [cliff]), layout, R)
    assert mem.side[0] == s
    for k in range(100):
        move = np.array([0.0, s if k < 20 or k % 2 == 0 else -s])
        p = p + move
        side = _drive(mem, obs_row(layout, R, tuple(tgt - p), [cliff]), layout, R, tuple(move))
        assert side == s and not mem.b1[0] and np.isinf(mem.lvl[0]), k
        assert mem.g_len[0] == pytest.approx(k + 1.0), (k, mem.g_len[0])


@pytest.mark.parametrize("key", ["margin_m", "home_arc_m", "stall_crowded", "ring_cos"])
def test_bug_params_refuse_non_positive_values_by_name(key):
    with pytest.raises(ValueError, match=f"BugParams.{key} must be .*> 0"):
        BugParams(**{key: 0})
