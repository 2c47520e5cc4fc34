"""The chart search under APF (policies/chart.py): the planner against a slow obvious Dijkstra on
random small charts, hand-built charts with exact answers, the border's half-plane and the
argument checks. The hand-built terrains (U trap, comb, queue, fork, mirrored) run with both
searches in test_bug.py."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tin_swarm_env as tse
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.chart import WALL, ChartParams, _astar, _mark_border, plan


def dijkstra(g, s, t, wall_cost=2.0):
    """The least cost from cell s to cell t over open cells, 8-connected, no corner cutting, a step
    into a cell with a shut neighbour costing ``wall_cost`` more (inf: no way)."""
    c = g.shape[0]

    def shut(a, b):
        return 0 <= a < c and 0 <= b < c and g[a, b] != 0

    best = {s: 0.0}
    heap = [(0.0, s)]
    while heap:
        d, (a, b) = heapq.heappop(heap)
        if (a, b) == t:
            return d
        if d > best[(a, b)]:
            continue
        for da in (-1, 0, 1):
            for db in (-1, 0, 1):
                na, nb = a + da, b + db
                if (da, db) == (0, 0) or not (0 <= na < c and 0 <= nb < c) or g[na, nb] != 0:
                    continue
                if da and db and (shut(a + da, b) or shut(a, b + db)):
                    continue
                nd = d + (math.sqrt(2) if da and db else 1.0)
                if any(shut(na + ea, nb + eb) for ea in (-1, 0, 1) for eb in (-1, 0, 1)):
                    nd += wall_cost
                if nd < best.get((na, nb), math.inf):
                    best[(na, nb)] = nd
                    heapq.heappush(heap, (nd, (na, nb)))
    return math.inf


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.45))
def test_plan_costs_what_a_plain_dijkstra_costs(seed, density):
    rng = np.random.default_rng(seed)
    c = 12
    g = (rng.random((c, c)) < density).astype(np.uint8)
    s, t = (0, 0), (c - 1, c - 1)
    g[s] = g[t] = 0
    found, wa, wb, cost = plan(g, *s, *t, 1e9)
    ref = dijkstra(g, s, t)
    assert found == (ref < math.inf)
    if found:
        assert cost == pytest.approx(ref)
        assert g[wa, wb] == 0


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_one_set_of_work_arrays_serves_many_plans(seed):
    """The planning pass shares its work arrays between robots (_astar): each plan on them answers
    as a fresh one does, and leaves them as it found them (also when its list of touched cells
    outgrows its start; the heap's own growth, the same code, is not reached by these charts)."""
    rng = np.random.default_rng(seed)
    c = 40
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    for _ in range(4):
        g = (rng.random((c, c)) < rng.uniform(0.0, 0.4)).astype(np.uint8)
        s, t = tuple(rng.integers(0, c, 2)), tuple(rng.integers(0, c, 2))
        g[t] = 0
        got = _astar(g, *s, *t, 8.0, 2.0, 0.0, 0.0, 0.0, dist, prev, closed)
        assert got == plan(g, *s, *t, 8.0)
        assert (dist == 1e30).all() and (prev == -1).all() and not closed.any()
    # a target walled in: the search touches every one of 100 x 100 cells, more than the start of its
    # touched list (64 C + 64 entries), so that list grows
    c = 100
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    g = np.zeros((c, c), np.uint8)
    g[30:33, 30:33] = WALL
    g[31, 31] = 0
    assert _astar(g, 0, 0, 31, 31, 8.0, 2.0, 0.0, 0.0, 0.0, dist, prev, closed)[0] is False
    assert (dist == 1e30).all() and (prev == -1).all() and not closed.any()


def test_plan_goes_round_a_wall_through_its_one_gap():
    g = np.zeros((9, 9), np.uint8)
    g[4, :] = WALL
    g[4, 7] = 0  # the gap
    found, wa, wb, cost = plan(g, 1, 1, 7, 1, 1e9)
    assert found
    # down to the gap and back: the way passes (4, 7); a way point in line never lies across the wall
    assert (wa, wb) != (7, 1) and wa <= 4
    g[4, 7] = WALL
    assert plan(g, 1, 1, 7, 1, 1e9)[0] is False


def test_plan_never_cuts_a_corner_between_two_shut_cells():
    g = np.zeros((3, 3), np.uint8)
    g[0, 1] = g[1, 0] = WALL  # (0, 0) touches (1, 1) only across the corner
    assert plan(g, 0, 0, 2, 2, 1e9)[0] is False
    g[1, 0] = 0
    assert plan(g, 0, 0, 2, 2, 1e9)[0] is True


def test_open_ground_heads_straight_for_the_goal_within_reach():
    g = np.zeros((20, 20), np.uint8)
    found, wa, wb, cost = plan(g, 2, 2, 17, 2, 100.0)
    assert found and (wa, wb) == (17, 2) and cost == pytest.approx(15.0)
    _, wa, wb, _ = plan(g, 2, 2, 17, 2, 5.0)  # only 5 cells ahead
    assert (wa, wb) == (7, 2)


def test_a_border_point_closes_the_half_plane_beyond_it_and_nothing_else():
    c, w = 16, 1.0
    grid = np.zeros((1, c, c), np.uint8)
    # a border at x = 3 m (cell 8 + 3 = 11), the terrain on its -x side: normal (-1, 0)
    pts = np.array([[[3.0, 0.0]]])
    nrm = np.array([[[-1.0, 0.0]]])
    changed = _mark_border(grid, np.array([w]), np.array([0]), pts, nrm, np.array([[True]]))
    assert changed.tolist() == [True]
    xs = (np.arange(c) - c // 2 + 0.5) * w  # cell centres
    shut = grid[0] == WALL
    assert shut[xs > 3.5].all() and not shut[xs < 3.5].any()
    # seen again: nothing changes
    assert _mark_border(grid, np.array([w]), np.array([0]), pts, nrm, np.array([[True]])).tolist() == [False]


@pytest.mark.parametrize("key", ["cells", "reach", "range_reach", "min_cell_m", "ahead_m", "stall_steps"])
def test_chart_params_refuse_non_positive_values_by_name(key):
    with pytest.raises(ValueError, match=f"ChartParams.{key}"):
        ChartParams(**{key: 0})


def test_apf_refuses_an_unknown_search_by_name():
    env = tse.parallel_env(scenario="ramp")
    with pytest.raises(ValueError, match="search must be 'bug' or 'chart'"):
        APFPolicy(env, search="astar")


def _seen(q, pts, normals, border=None):
    """One robot at ``q`` (frame F = its body frame, heading 0) seeing dangerous break points ``pts``
    (F, relative to the target) with their ``normals``: a DecodedObs and the arguments of chart_update."""
    from tin_swarm_env.policies.base import DecodedObs

    k = 3
    rel = np.zeros((1, k, 2))
    nrm = np.zeros((1, k, 2))
    danger = np.zeros((1, k), bool)
    for j, (p, n) in enumerate(zip(pts, normals)):
        rel[0, j], nrm[0, j], danger[0, j] = np.subtract(p, q), n, True
    q = np.asarray([q], float)
    d = DecodedObs(has_t=np.array([True]), dist=np.hypot(*q[0])[None], rel_t=-q, dz=np.zeros(1),
                   grad_z=np.zeros((1, 2)), speed=np.ones(1), r_rel=np.zeros((1, 0, 2)), r_valid=np.zeros((1, 0)),
                   b_rel=rel, b_normal=nrm,
                   b_danger=danger, b_border=np.zeros((1, k), bool) if border is None else border,
                   a_rel=np.zeros((1, 0, 2)), a_valid=np.zeros((1, 0)))
    return d, q


def test_a_wall_driven_along_is_charted_without_holes_and_two_cells_thick():
    from tin_swarm_env.policies.chart import ChartMemory, chart_update

    p = ChartParams(cells=32, extend=0.01)  # link 1.5 cells, behind 0.8 cell (the defaults)
    rows = np.array([0])

    def chart(ys):
        mem = ChartMemory.empty(1, 32, 3)
        mem.cell[:] = 1.0  # cells 1 m wide; cell index = floor(x / 1 m) + 16
        for y in ys:  # a wall x = 11.5 m, normal -x (the robot on its west side), seen square on at y
            d, q = _seen((5.0, y), [(11.5, y)], [(-1.0, 0.0)])
            chart_update(mem, rows, d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
        return sorted(map(tuple, np.argwhere(mem.grid[0] == WALL).tolist()))

    # seen at y 0.9 m (row 16) then 2.3 m (row 18), 1.4 m apart: the join shuts row 17 of the wall
    # (column 27) between them; column 28 is the cell behind each point seen (x 12.3 m)
    assert chart([0.9, 2.3]) == [(27, 16), (27, 17), (27, 18), (28, 16), (28, 18)]
    # 1.6 m apart (over 1.5 cells): no join, row 17 stays open
    assert chart([0.9, 2.5]) == [(27, 16), (27, 18), (28, 16), (28, 18)]


def test_a_robot_that_stalls_charts_its_straight_way_stuck_after_stall_steps():
    from tin_swarm_env.policies.chart import STUCK, ChartMemory, chart_update

    p = ChartParams(cells=32, stall_steps=5)
    mem = ChartMemory.empty(1, 32, 3)
    rows = np.array([0])
    d, q = _seen((-10.0, 0.0), [], [])  # 10 m west of its target, nothing in sight, never moving
    counts = []
    for _ in range(8):
        chart_update(mem, rows, d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
        counts.append(int((mem.grid[0] == STUCK).sum()))
    w = mem.cell[0]
    assert counts[:5] == [0] * 5 and counts[5] > 0  # the 6th step without moving is over stall_steps
    a, b = np.nonzero(mem.grid[0] == STUCK)
    x = (a - 16 + 0.5) * w
    assert (np.abs((b - 16 + 0.5) * w) <= w).all() and (x > -10.0).all() and (x < 0.0).all()  # on its way east


def test_scan_hits_are_charted_with_the_cell_behind_each_and_misses_are_not():
    from tin_swarm_env.policies.chart import ChartMemory, chart_update

    p = ChartParams(cells=32)  # behind 0.8 cell
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = 1.0  # cells 1 m wide; cell index = floor(x / 1 m) + 16
    d, q = _seen((-10.5, 0.5), [], [])  # robot 10 m west of its target, heading 0 (frame F = body frame)
    k = 4  # beams east, north, west, south: east meets a wall 6 m ahead, north one 3 m away, the others nothing
    d.s_rel = np.array([[[6.0, 0.0], [0.0, 3.0], [-60.0, 0.0], [0.0, -60.0]]])
    d.s_hit = np.array([[True, True, False, False]])
    d.s_dir = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    assert d.s_rel.shape == (1, k, 2)
    chart_update(mem, np.array([0]), d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
    walls = sorted(map(tuple, np.argwhere(mem.grid[0] == WALL).tolist()))
    # east hit at x -4.5 m (column 11), the cell behind it at x -3.7 m (column 12), row 16 (y 0.5);
    # north hit at y 3.5 (row 19) and behind it y 4.3 (row 20), column 5 (x -10.5)
    assert walls == [(5, 19), (5, 20), (11, 16), (12, 16)]


def test_scan_alone_is_charted_and_keeps_robots_off_the_cliff():
    """A scenario with a terrain scan and no break slots: the chart search reads the beams, so its
    robots keep off cliff_goal's cliff (0 fell, most arrive: 19 of 20 on seed 0), where the bug
    search, which reads only break slots, is the fields alone and drives every robot off it."""
    import dataclasses

    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.training.rollout import rollout
    from tin_swarm_env.world.state import Reason

    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(observation=dataclasses.replace(cfg.observation, k_breaks=0, k_scan=32))
    env = tse.parallel_env(scenario=cfg)
    pol = APFPolicy(env, search="chart")
    out = rollout(env, pol, 0)
    assert (pol.charts.grid == 1).any()  # the beams' hits were charted
    assert not (out.reasons == Reason.FELL).any()
    assert (out.reasons == Reason.ARRIVED).sum() >= 15
    bug = APFPolicy(env, search="bug")
    out = rollout(env, bug, 0)
    assert len(bug.memory.side) == 0 and (out.reasons == Reason.FELL).all()
