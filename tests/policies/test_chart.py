"""The chart search under APF (policies/chart.py): the planner against a slow obvious Dijkstra on
random small charts, hand-built charts with exact answers, the border's half-plane and the
argument checks. The compiled step (chart_update -> _chart_rows): its marks against the numpy
version it replaced (kept here as the reference), the stored way against the planner's own answer,
and when it plans again on hand-built charts with exact answers (a wall that appears on the way: it
plans round it; one far from it: it does not plan; off its way: it plans; at the point it heads
for: the next point along its way, no plan). The hand-built terrains (U trap, comb, queue, fork,
mirrored) run with both searches in test_bug.py."""

from __future__ import annotations

import dataclasses
import heapq
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.base import DecodedObs
from tin_swarm_env.policies.chart import (
    _ROW_FIELDS,
    OPEN,
    PINCH_ONE_CELL,
    ROUTE_PER_CELL,
    SEEN,
    STUCK,
    WALL,
    ChartMemory,
    ChartParams,
    _astar,
    _mark_border,
    _mark_row,
    _reset,
    _search,
    _store_way,
    _way_length,
    chart_update,
    plan,
    robot_side,
)


def dijkstra(g, s, t, wall_cost=2.0, pinch=False):
    """The least cost from cell s to cell t over open cells, 8-connected, no corner cutting, a step
    into a cell with a shut neighbour costing ``wall_cost`` more (inf: no way); ``pinch``: an open
    cell other than t, not on the chart's edge, between two shut cells on opposite sides (a gap one
    cell wide) is not entered either."""
    c = g.shape[0]

    def shut(a, b):
        return 0 <= a < c and 0 <= b < c and g[a, b] != 0

    def pinched(a, b):
        inside = 0 < a < c - 1 and 0 < b < c - 1
        pairs = ((1, 0), (0, 1), (1, 1), (1, -1))
        return inside and any(shut(a + ea, b + eb) and shut(a - ea, b - eb) for ea, eb in pairs)

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
                if pinch and (na, nb) != t and pinched(na, nb):
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


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.45))
def test_with_pinch_the_search_leaves_out_gaps_one_cell_wide_as_a_plain_dijkstra_does(seed, density):
    """``_search(..., pinch=True)`` over open cells costs what the plain Dijkstra costs when it never
    enters a cell between two shut cells on opposite sides (but the target's cell)."""
    rng = np.random.default_rng(seed)
    c = 12
    g = (rng.random((c, c)) < density).astype(np.uint8)
    s, t = (int(rng.integers(0, c)), 0), (int(rng.integers(0, c)), c - 1)
    g[s] = g[t] = 0
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    found, cost, touched, nt = _search(g, *s, *t, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, PINCH_ONE_CELL)
    ref = dijkstra(g, s, t, pinch=True)
    assert found == (ref < math.inf)
    if found:
        assert cost == pytest.approx(ref)
    _reset(dist, prev, closed, touched, nt, c)
    assert dijkstra(g, s, t) <= ref  # leaving cells out never makes a way shorter


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


@pytest.mark.parametrize("key", ["side_cost", "side_margin", "side_leave_m"])
def test_chart_params_take_no_side_preference_and_refuse_a_negative_one_by_name(key):
    assert getattr(ChartParams(**{key: 0.0}), key) == 0.0
    for bad in (-1.0, math.nan):
        with pytest.raises(ValueError, match=f"ChartParams.{key}"):
            ChartParams(**{key: bad})


def _wall_across(c=21):
    """A chart with a wall across the straight way from cell (18, 10) to the target's (10, 10): column
    14, rows 4..16, the same way round either end."""
    g = np.zeros((c, c), np.uint8)
    g[14, 4:17] = WALL
    return g


def _way_cells(g, s, t, side):
    c = g.shape[0]
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    found, cost, _, _ = _search(g, *s, *t, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, False, *side)
    cells, v = [], t[0] * c + t[1]
    while v != s[0] * c + s[1]:
        cells.append(divmod(int(v), c))
        v = prev[v // c, v % c]
    return found, cost, cells


def test_a_side_preference_takes_the_way_round_its_own_end_of_a_wall_at_the_plain_cost():
    """Robot at (18, 10), its start on the line east of the target (u = (1, 0)): with ``u`` as is it pays
    for cells at b < 10 - margin (its left, facing the target) and goes round the wall's b = 16 end; with
    ``-u`` round the b = 4 end; either way at the cost of the way with no preference (a mirror image)."""
    g = _wall_across()
    s, t = (18, 10), (10, 10)
    found0, cost0, _ = _way_cells(g, s, t, (0.0, 0.0, 0.0, 0.0))
    for sgn in (1.0, -1.0):
        found, cost, cells = _way_cells(g, s, t, (1.0, sgn, 0.0, 2.0))
        assert found and found0 and cost == pytest.approx(cost0)
        assert all(sgn * (b - 10) >= -2 for _, b in cells)  # never on the side it does not prefer
        assert any(sgn * (b - 10) >= 7 for _, b in cells)  # round its own end of the wall (b = 16 or 4)


def test_a_side_found_shut_is_left_for_the_other_at_its_price():
    """The wall's preferred end shut (the wall runs to the chart's edge on that side): the way goes round
    the other end, paying ``1 + side_cost`` per cell length over there."""
    g = _wall_across()
    g[14, 4:] = WALL
    s, t = (18, 10), (10, 10)
    _, plain, _ = _way_cells(g, s, t, (0.0, 0.0, 0.0, 0.0))
    found, cost, cells = _way_cells(g, s, t, (1.0, 1.0, 0.0, 2.0))
    assert found and any(b <= 3 for _, b in cells)
    assert plain < cost < 2.0 * plain + 1e-9


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

    p = ChartParams(cells=32, extend=0.01)  # link 1.5 cells, inset 0.5 cell, behind 0.8 cell (the defaults)
    rows = np.array([0])

    def chart(ys):
        mem = ChartMemory.empty(1, 32, 3)
        mem.cell[:] = 1.0  # cells 1 m wide; cell index = floor(x / 1 m) + 16
        for y in ys:  # a wall x = 11.2 m, normal -x (the robot on its west side), seen square on at y
            d, q = _seen((5.0, y), [(11.2, y)], [(-1.0, 0.0)])
            chart_update(mem, rows, d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
        return sorted(map(tuple, np.argwhere(mem.grid[0] == WALL).tolist()))

    # seen at y 0.9 m (row 16) then 2.3 m (row 18), 1.4 m apart: the join shuts row 17 of the wall
    # (column 27: x 11.7 m, half a cell beyond it) between them; column 28 is the cell behind each (x 12.5 m)
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

    p = ChartParams(cells=32)  # inset 0.5 cell, behind 0.8 cell
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = 1.0  # cells 1 m wide; cell index = floor(x / 1 m) + 16
    d, q = _seen((-10.5, 0.5), [], [])  # robot 10 m west of its target, heading 0 (frame F = body frame)
    k = 4  # beams east, north, west, south: east meets a wall 5.8 m ahead, north one 2.8 m away, the others nothing
    d.s_rel = np.array([[[5.8, 0.0], [0.0, 2.8], [-60.0, 0.0], [0.0, -60.0]]])
    d.s_hit = np.array([[True, True, False, False]])
    d.s_dir = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    assert d.s_rel.shape == (1, k, 2)
    chart_update(mem, np.array([0]), d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
    walls = sorted(map(tuple, np.argwhere(mem.grid[0] == WALL).tolist()))
    # east hit at x -4.7 m: half a cell on, x -4.2 m (column 11), the cell behind that at x -3.4 m (column 12),
    # row 16 (y 0.5); north hit at y 3.3: y 3.8 (row 19) and behind it y 4.6 (row 20), column 5 (x -10.5)
    assert walls == [(5, 19), (5, 20), (11, 16), (12, 16)]


def test_a_cell_mostly_on_the_safe_side_of_a_break_stays_open():
    """A gap 2.75 cells wide between two cliffs (10 m between pillars at 3.6 m cells): the cell that
    holds a break point is shut only if the point lies in its safe half; each mark is half a cell
    beyond the break. Before, the cell holding the point was shut: the gap was charted 2 cells wide,
    and on a diagonal (no corner cut) shut."""
    from tin_swarm_env.policies.chart import ChartMemory, chart_update

    p = ChartParams(cells=32, extend=0.01)
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = 1.0  # cells 1 m wide; cell index = floor(x / 1 m) + 16
    # at x -5.5 m (column 10): a cliff's edge at y -1.2 (its ground south, normal +y) and one at y 1.55
    d, q = _seen((-10.5, 0.5), [(-5.5, -1.2), (-5.5, 1.55)], [(0.0, 1.0), (0.0, -1.0)])
    chart_update(mem, np.array([0]), d, q, np.zeros(1), p, 60.0, 1.0, 2.0, np.array([False]))
    walls = sorted(map(tuple, np.argwhere(mem.grid[0] == WALL).tolist()))
    # marks at y -1.7 (row 14) and -2.5 (row 13); y 2.05 and 2.85 (row 18): rows 15-17 open. Row 17
    # (y 1 to 2) holds the north point but lies 55% on the gap's side: open (it was shut before)
    assert walls == [(10, 13), (10, 14), (10, 18)]


def test_scan_alone_is_charted_and_keeps_robots_off_the_cliff():
    """A scenario with a terrain scan and no break slots: the chart search reads the beams, so its
    robots keep off cliff_goal's cliff (0 fell, most arrive: 17 of 20 on seed 0 at 256 cells; 14 at
    the default 512, where the 32 beams' marks are sparser for the finer cells), where the bug
    search, which reads only break slots, is the fields alone and drives every robot off it."""
    import dataclasses

    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.training.rollout import rollout
    from tin_swarm_env.world.state import Reason

    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(observation=dataclasses.replace(cfg.observation, k_breaks=0, k_scan=32))
    env = tse.parallel_env(scenario=cfg)
    for cells, most in ((256, 15), (512, 12)):
        pol = APFPolicy(env, search="chart", chart=ChartParams(cells=cells))
        out = rollout(env, pol, 0)
        assert (pol.charts.grid == 1).any()  # the beams' hits were charted
        assert not (out.reasons == Reason.FELL).any()
        assert (out.reasons == Reason.ARRIVED).sum() >= most
    bug = APFPolicy(env, search="bug")
    out = rollout(env, bug, 0)
    assert len(bug.memory.side) == 0 and (out.reasons == Reason.FELL).all()


def _rot(psi, v):
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1)


def reference_marks(grid, cell, q, psi, d, p: ChartParams, last_pts, last_ok):
    """The numpy marks of the chart search as they were before the compiled step (commit a5f377a's
    ``chart_update`` up to the stall count), for robots ``0..m-1``: the grids ``(m, C, C)`` are
    marked in place; returns which changed and this step's points (the next ``last_pts``)."""
    c = grid.shape[1]
    h = c // 2
    rel = d.b_rel
    k = rel.shape[1]
    pts = q[:, None, :] + _rot(psi[:, None].repeat(k, 1).ravel(), rel.reshape(-1, 2)).reshape(rel.shape)
    nrm = _rot(psi[:, None].repeat(k, 1).ravel(), d.b_normal.reshape(-1, 2)).reshape(rel.shape)
    dist = np.sqrt(np.sum(rel * rel, axis=-1))
    unit = -rel / np.maximum(dist, 1e-9)[..., None]
    square = np.abs(np.sum(unit * d.b_normal, axis=-1)) > np.cos(np.radians(5.0))
    tang = np.stack([-nrm[..., 1], nrm[..., 0]], axis=-1)
    w = cell[:, None, None]
    ok = d.b_danger
    mark = pts - p.inset * w * nrm  # inset cells beyond the break
    ext, oks = [mark, mark - p.behind * w * nrm], [ok, ok]
    for s in (-p.extend, p.extend):
        ext.append(mark + s * w * tang)
        oks.append(ok & square)
    gap = np.sqrt(np.sum((pts[:, :, None, :] - last_pts[:, None, :, :]) ** 2, axis=-1))
    gap = np.where(last_ok[:, None, :], gap, np.inf)
    j = np.argmin(gap, axis=-1)
    near = ok & (np.take_along_axis(gap, j[..., None], axis=-1)[..., 0] < p.link * w[..., 0])
    other = np.take_along_axis(last_pts, j[..., None].repeat(2, -1), axis=1)
    for f in (0.25, 0.5, 0.75):
        ext.append(mark + f * (other - pts))
        oks.append(near)
    ks = d.s_rel.shape[1]
    turn = psi[:, None].repeat(ks, 1).ravel()
    hits = q[:, None, :] + _rot(turn, d.s_rel.reshape(-1, 2)).reshape(d.s_rel.shape)
    beam = _rot(turn, np.broadcast_to(d.s_dir, d.s_rel.shape).reshape(-1, 2)).reshape(d.s_rel.shape)
    ext += [hits + p.inset * w * beam, hits + (p.inset + p.behind) * w * beam]
    oks += [d.s_hit, d.s_hit]
    at, on = np.concatenate(ext, axis=1), np.concatenate(oks, axis=1)
    cw = cell[:, None]
    on = on & ~((np.floor(at[..., 0] / cw) == 0) & (np.floor(at[..., 1] / cw) == 0))
    changed = np.zeros(len(q), bool)
    for r in range(len(q)):
        for x, y in at[r][on[r]]:
            a, b = int(np.floor(x / cell[r])) + h, int(np.floor(y / cell[r])) + h
            if 0 <= a < c and 0 <= b < c and grid[r, a, b] != WALL:
                grid[r, a, b], changed[r] = WALL, True
        for (px, py), (nx, ny) in zip(pts[r][d.b_border[r] & ok[r]], nrm[r][d.b_border[r] & ok[r]]):
            w = cell[r]
            xs = (np.arange(c) - h + 0.5) * w
            a, b = int(np.floor((px - 2 * w * nx) / w)) + h, int(np.floor((py - 2 * w * ny) / w)) + h
            if 0 <= a < c and 0 <= b < c and grid[r, a, b] == WALL:
                continue
            shut = ((xs[:, None] - px) * nx + (xs[None, :] - py) * ny < -0.5 * w) & (grid[r] != WALL)
            changed[r] |= shut.any()
            grid[r][shut] = WALL
    return changed, pts


def _obs(rng, m, k, ks, span):
    """Random observations of ``m`` robots: ``k`` break slots, ``ks`` scan beams, points within ``span`` m."""
    rel = rng.uniform(-span, span, (m, k, 2))
    ang = rng.uniform(0, 2 * np.pi, (m, k))
    nrm = np.stack([np.cos(ang), np.sin(ang)], -1)
    sq = rng.random((m, k)) < 0.3  # some seen square on: the normal points at the robot
    dist = np.maximum(np.hypot(rel[..., 0], rel[..., 1]), 1e-9)
    nrm[sq] = -rel[sq] / dist[sq][:, None]
    danger = rng.random((m, k)) < 0.7
    bang = np.arange(ks) * 2 * np.pi / max(ks, 1)
    s_dir = np.stack([np.cos(bang), np.sin(bang)], -1)
    s_rel = rng.uniform(0, span, (m, ks))[..., None] * s_dir
    return DecodedObs(has_t=np.ones(m, bool), dist=np.full(m, 10.0), rel_t=np.zeros((m, 2)), dz=np.zeros(m),
                      grad_z=np.zeros((m, 2)), speed=np.ones(m), r_rel=np.zeros((m, 0, 2)), r_valid=np.zeros((m, 0)),
                      b_rel=rel, b_normal=nrm, b_danger=danger, b_border=danger & (rng.random((m, k)) < 0.1),
                      a_rel=np.zeros((m, 0, 2)), a_valid=np.zeros((m, 0)), s_rel=s_rel,
                      s_hit=rng.random((m, ks)) < 0.6, s_dir=s_dir)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_compiled_marks_are_the_numpy_marks(seed):
    """Over a few steps of random sightings (break slots, border points, scan hits, points joined
    to last step's), the compiled marks shut exactly the cells the numpy version shut, say which
    charts changed, and keep the same points for the next step."""
    rng = np.random.default_rng(seed)
    m, k, ks, c = 4, 3, 8, 32
    p = ChartParams(cells=c)
    cell = rng.uniform(0.5, 3.0, m)
    grid_ref, grid = np.zeros((m, c, c), np.uint8), np.zeros((m, c, c), np.uint8)
    lp_ref, lo_ref = np.zeros((m, k, 2)), np.zeros((m, k), bool)
    lp, lo = lp_ref.copy(), lo_ref.copy()
    prm = np.array([p.behind, p.extend, p.link, np.cos(np.radians(5.0)), p.inset])
    for _ in range(3):
        d = _obs(rng, m, k, ks, 12.0)
        q, psi = rng.uniform(-20, 20, (m, 2)), rng.uniform(-np.pi, np.pi, m)
        want, pts = reference_marks(grid_ref, cell, q, psi, d, p, lp_ref, lo_ref)
        lp_ref, lo_ref = pts, d.b_danger.copy()
        got = [_mark_row(grid[r], cell[r], q[r, 0], q[r, 1], np.cos(psi[r]), np.sin(psi[r]), d.b_rel[r],
                         d.b_normal[r], d.b_danger[r], d.b_border[r], lp[r], lo[r], d.s_rel[r], d.s_dir,
                         d.s_hit[r], prm) for r in range(m)]
        assert got == want.tolist()
        np.testing.assert_array_equal(grid, grid_ref)
        np.testing.assert_array_equal(lp, lp_ref)
        np.testing.assert_array_equal(lo, lo_ref)


def _route_cost(g, route, wall_cost=2.0):
    """The cost of a way ``route`` (flat cells, start first) as the planner counts it."""
    c = g.shape[0]
    cost = 0.0
    for u, v in zip(route[:-1], route[1:]):
        (a, b), (na, nb) = divmod(int(u), c), divmod(int(v), c)
        assert max(abs(na - a), abs(nb - b)) == 1 and g[na, nb] == OPEN  # 8-connected, over open cells
        cost += np.sqrt(2.0) if na != a and nb != b else 1.0
        block = g[max(na - 1, 0):na + 2, max(nb - 1, 0):nb + 2]
        cost += wall_cost if (block != OPEN).any() else 0.0
    return cost


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.4))
def test_the_stored_way_is_the_planned_way(seed, density):
    """The way written into a robot's route runs from its cell to the target's over open cells and
    costs what the A* says; each cell's shut count is its 3 x 3 block's; a short buffer holds its start."""
    rng = np.random.default_rng(seed)
    c = 16
    g = (rng.random((c, c)) < density).astype(np.uint8)
    s, t = tuple(int(x) for x in rng.integers(0, c, 2)), (c // 2, c // 2)
    g[t] = 0
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    found, cost, touched, nt = _search(g, *s, *t, 2.0, 0.0, 0.0, 0.0, dist, prev, closed)
    assert found == plan(g, *s, *t, 1e9)[0]
    if found:
        n = _way_length(prev, c, *s, *t)
        route, shut = np.zeros(n, np.int32), np.zeros(n, np.uint8)
        assert _store_way(g, prev, *s, *t, n, route, shut) == n
        assert divmod(int(route[0]), c) == s and divmod(int(route[-1]), c) == t
        assert _route_cost(g, route) == pytest.approx(cost)
        for v, k in zip(route, shut):
            a, b = divmod(int(v), c)
            assert k == (g[max(a - 1, 0):a + 2, max(b - 1, 0):b + 2] != OPEN).sum()
        short, sh = np.zeros(3, np.int32), np.zeros(3, np.uint8)
        assert _store_way(g, prev, *s, *t, n, short, sh) == min(n, 3)
        assert (short[:min(n, 3)] == route[:3]).all()
    _reset(dist, prev, closed, touched, nt, c)
    assert (dist == 1e30).all() and (prev == -1).all() and not closed.any()


def _one(q, pts=(), normals=()):
    """One robot at ``q`` (frame F = body frame, heading 0) seeing dangerous break points ``pts``
    (F, relative to the target) with their ``normals`` (3 slots), no scan."""
    rel, nrm, danger = np.zeros((1, 3, 2)), np.zeros((1, 3, 2)), np.zeros((1, 3), bool)
    for j, (pt, nm) in enumerate(zip(pts, normals)):
        rel[0, j], nrm[0, j], danger[0, j] = np.subtract(pt, q), nm, True
    q = np.asarray([q], float)
    d = DecodedObs(has_t=np.array([True]), dist=np.hypot(*q[0])[None], rel_t=-q, dz=np.zeros(1),
                   grad_z=np.zeros((1, 2)), speed=np.ones(1), r_rel=np.zeros((1, 0, 2)), r_valid=np.zeros((1, 0)),
                   b_rel=rel, b_normal=nrm, b_danger=danger, b_border=np.zeros((1, 3), bool),
                   a_rel=np.zeros((1, 0, 2)), a_valid=np.zeros((1, 0)))
    return d, q


P = ChartParams(cells=32, ahead_m=3.0)  # cells 1 m wide (set below): the way point 3 cells ahead
P_ONE_CELL = dataclasses.replace(P, unseen_gap=0.0)  # the rule before unseen_gap: gaps one cell wide left out


def _step(mem, q, pts=(), normals=()):
    d, qq = _one(q, pts, normals)
    chart_update(mem, np.array([0]), d, qq, np.zeros(1), P, 60.0, 1.0, 2.0, np.array([False]))


def _fresh():
    """A robot 10 m west of its target (cell (5, 16); the target's cell is (16, 16)) that has planned once."""
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = 1.0
    _step(mem, (-10.5, 0.5))
    assert mem.plans[0] == 1 and mem.way[0].tolist() == [-7.5, 0.5]  # 3 cells east, on its straight way
    assert mem.route_len[0] == 12
    return mem


def test_a_wall_that_appears_on_the_way_makes_it_plan_round_it():
    mem = _fresh()
    _step(mem, (-10.5, 0.5), [(-3.9, 0.5)], [(-1.0, 0.0)])  # a wall across row 16 at column 12, seen square on
    assert mem.plans[0] == 2
    shut = {tuple(x) for x in np.argwhere(mem.grid[0] != OPEN)}
    assert (12, 16) in shut
    route = [divmod(int(v), 32) for v in mem.route[0, :mem.route_len[0]]]
    assert route[0] == (5, 16) and route[-1] == (16, 16) and not shut & set(route)
    assert _route_cost(mem.grid[0], mem.route[0, :mem.route_len[0]]) == pytest.approx(
        plan(mem.grid[0], 5, 16, 16, 16, 1e9)[3])  # the least-cost way round it


def test_a_wall_far_from_the_way_changes_the_chart_but_not_the_way():
    mem = _fresh()
    way, route = mem.way.copy(), mem.route.copy()
    _step(mem, (-10.5, 0.5), [(-3.9, 10.5)], [(-1.0, 0.0)])  # column 12 again, but 10 rows north of the way
    assert mem.grid[0, 12, 26] == WALL
    assert mem.plans[0] == 1 and (mem.way == way).all() and (mem.route == route).all()
    _step(mem, (-10.5, 0.5), [(-3.9, 1.5)], [(-1.0, 0.0)])  # beside the way (row 17, column 12): it plans
    assert mem.plans[0] == 2


def test_off_its_way_it_plans_and_at_its_way_point_it_takes_the_next_one_without_planning():
    mem = _fresh()
    _step(mem, (-8.5, 0.5))  # 2 cells on, within two cells of the point it heads for: the next point
    assert mem.plans[0] == 1 and mem.way[0].tolist() == [-5.5, 0.5] and mem.route_at[0] == 2
    _step(mem, (-6.5, 0.5))  # 1 cell short of it: still in line
    assert mem.plans[0] == 1 and mem.way[0].tolist() == [-3.5, 0.5]
    _step(mem, (-6.5, 4.5))  # pushed 4 cells off its way: it plans from where it is
    assert mem.plans[0] == 2 and mem.route[0, 0] == 9 * 32 + 20


def test_a_robot_at_its_target_cell_heads_for_the_target_and_does_not_plan_again():
    mem = _fresh()
    for x in (-7.5, -4.5, -1.5, 0.5, 0.5):
        _step(mem, (x, 0.5))
    assert mem.plans[0] == 1 and mem.way[0].tolist() == [0.0, 0.0]


def test_memory_per_robot_is_as_documented():
    """ChartMemory's docstring: C^2 + 5 ROUTE_PER_CELL C + 17 K + 107 bytes a robot (68 254 at 256 cells, K = 3)."""
    mem = ChartMemory.empty(1, 256, 3)
    per_robot = sum(getattr(mem, f).nbytes for f in _ROW_FIELDS)
    assert per_robot == 256**2 + 5 * ROUTE_PER_CELL * 256 + 17 * 3 + 107 == 68254
    assert "68 254" in ChartMemory.__doc__


def _plan_row_on(g, sa, sb, pinch=False):
    from tin_swarm_env.policies.chart import _plan_row

    c = g.shape[0]
    work = (np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), np.bool_))
    route = np.zeros(ROUTE_PER_CELL * c, np.int32)
    shut = np.zeros(ROUTE_PER_CELL * c, np.uint8)
    found, n, k, forgot = _plan_row(g, sa, sb, 3.0, 2.0, 0.0, 0.0, 0.0, *work, route, shut,
                                    PINCH_ONE_CELL if pinch else 0.0)
    return found, [(int(v) // c, int(v) % c) for v in route[:n]], forgot


def test_with_no_open_way_it_takes_the_way_through_the_fewest_walls_and_keeps_its_chart():
    """A pass narrower than a cell is charted shut by its two sides: with no open way the robot plans
    through the fewest wall cells (the thin place of a wall two cells thick elsewhere), forgetting
    nothing; once it has stalled there (stuck), through the next fewest."""
    from tin_swarm_env.policies.chart import STUCK

    g = np.zeros((16, 16), np.uint8)  # target at the centre (8, 8); the robot at (1, 8)
    g[4:6, :] = WALL  # a wall across the whole chart, two cells thick ...
    g[5, 13] = 0  # ... but for one cell at column 13 (the narrow pass charted shut)
    before = g.copy()
    found, way, forgot = _plan_row_on(g, 1, 8)
    assert found and not forgot
    assert (g == before).all()  # no wall forgotten (the rule before forgot the 7 x 7 walls round it)
    crossed = [(a, b) for a, b in way if g[a, b] == WALL]
    assert crossed == [(4, 13)]  # one wall cell, at the thin place
    g[4, 13] = STUCK  # it drove there and stalled: the next way crosses two wall cells, not the stuck one
    found, way, forgot = _plan_row_on(g, 1, 8)
    assert found and not forgot and (4, 13) not in way
    assert sum(g[a, b] == WALL for a, b in way) == 2
    g[:] = 0
    g[4, :] = WALL  # a wall one cell thick with an open gap at its far end, column 0
    g[4, 0] = 0
    found, way, _ = _plan_row_on(g, 1, 8)
    assert found and all(g[a, b] == 0 for a, b in way)  # an open way, however long, before any wall


def test_a_wall_mark_never_turns_a_stuck_cell_back_and_a_stall_marks_walls_stuck():
    from tin_swarm_env.policies.chart import STUCK, _stall_row, _wall_at

    g = np.zeros((8, 8), np.uint8)
    g[5, 4] = STUCK
    assert not _wall_at(g, 1.0, 1.5, 0.5) and g[5, 4] == STUCK  # cell (5, 4) is x in [1, 2), y in [0, 1)
    g[6, 4] = WALL
    anchor = np.zeros(2)
    stall, stuck = _stall_row(g, 1.0, 0.5, 0.5, np.array([2.5, 0.5]), anchor, 10, 5, 0.5, True)
    assert stuck and g[6, 4] == STUCK  # the wall it drove into on its straight way is stuck now


def _pillar_chart(p: ChartParams, d0: float = 231.0, range_m: float = 60.0):
    """The chart (its cells sized as a robot's first step sizes them, ``d0`` m from its target) of a
    hexagonal field of cliff pillars 16 m across, 26 m between centres (10 m gaps), every edge point
    seen from 4 m off it (each point as the compiled marks chart it): bench/apf_unseen.py's pillars,
    the target 30 m east of the field. Returns the chart, the cell width and the start's cell."""
    c = p.cells
    w = max(p.min_cell_m, 2 * (p.reach * d0 + p.range_reach * range_m) / c)
    g = np.zeros((c, c), np.uint8)
    prm = np.array([p.behind, p.extend, p.link, np.cos(np.radians(5.0)), p.inset])
    none = np.zeros((0, 2))
    for j in range(-6, 7):
        for x in np.arange(-167.0 + (13.0 if j % 2 else 0.0), -27.0, 26.0):  # the target at (0, 0)
            for th in np.linspace(0.0, 2 * np.pi, 72, endpoint=False):
                n = np.array([np.cos(th), np.sin(th)])
                q = np.array([x, j * 13.0 * np.sqrt(3)]) + 12.0 * n  # 4 m off the edge, facing it
                _mark_row(g, w, q[0], q[1], 1.0, 0.0, -4.0 * n[None], n[None], np.array([True]),
                          np.array([False]), np.zeros((1, 2)), np.zeros(1, bool), none, none,
                          np.zeros(0, bool), prm)
    h = c // 2
    return g, w, (int(np.floor(-d0 / w)) + h, h)


def test_a_pillar_field_with_10_m_gaps_is_charted_open_at_the_default_cells():
    """The pillars' way is nearly straight (233 m against 231 m): at the default 512 cells (1.8 m at
    231 m to go) the chart keeps it open, through the field; at 256 cells (3.6 m) the marks shut every
    gap (cells holding a break point shut, as before ``inset``) and the way goes round the field (its
    north end, 150 m off the line: the robots searched along the field's face and ran out of time)."""
    p = ChartParams()
    assert p.cells == 512
    g, w, (sa, sb) = _pillar_chart(p)
    assert w == pytest.approx(2 * (1.5 * 231.0 + 120.0) / 512)
    found = plan(g, sa, sb, 256, 256, 3.0)[0]
    way = _plan_row_on(g, sa, sb)[1]
    off_line = max(abs(b - 256) for _, b in way) * w
    assert found and off_line < 20.0  # through the field, within 20 m of the straight line
    way = _plan_row_on(g, sa, sb, pinch=True)[1]  # the pinch rule forced on: gaps one cell wide left out
    assert all(g[a, b] == OPEN for a, b in way)  # an open way: the 10 m gaps are wider than one cell
    assert max(abs(b - 256) for _, b in way) * w < 20.0
    g, w, (sa, sb) = _pillar_chart(ChartParams(cells=256, inset=0.0))  # the chart before
    way = _plan_row_on(g, sa, sb)[1]
    assert max(abs(b - 128) for _, b in way) * w > 100.0  # round the field
    g, w, (sa, sb) = _pillar_chart(ChartParams(cells=256))  # inset alone opens it on these perfect sightings
    way = _plan_row_on(g, sa, sb)[1]  # (not in the closed loop: the beams' marks shut it, 1 robot of 10 arrived)
    assert max(abs(b - 128) for _, b in way) * w < 20.0


def _walled(mem):
    """Robot 0's chart (32 cells, target cell (16, 16)): a wall two cells thick across it at columns
    10-11, with a hole one cell wide on the robot's straight way (row 16) and a gap two cells wide at
    rows 24-25."""
    g = mem.grid[0]
    g[10:12, :] = WALL
    g[10:12, 24:26] = OPEN
    g[10:12, 16] = OPEN


@pytest.mark.parametrize("pass_m, cell, through_hole", [(0.0, 1.0, True), (3.0, 1.0, False), (3.0, 1.19, False),
                                                         (3.0, 1.21, True), (2.4, 1.0, True)])
def test_on_a_fine_chart_the_way_keeps_out_of_a_gap_one_cell_wide(pass_m, cell, through_hole):
    """With the one-cell rule (unseen_gap 0), a gap one cell wide is left out of the plan where a pass (pass_m) is at
    least pinch_cells (2.5) cells wide: the way goes round by the gap two cells wide; with no such gap it crosses
    the narrow one as it would a wall, forgetting nothing. On a coarser chart, or with no pass_m, it goes through
    the narrow gap (a real pass, perhaps)."""
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = cell
    _walled(mem)
    d, q = _one((-10.5 * cell, 0.5 * cell))  # cell (5, 16)
    chart_update(mem, np.array([0]), d, q, np.zeros(1), P_ONE_CELL, 60.0, 1.0, 2.0, np.array([False]), pass_m=pass_m)
    route = [divmod(int(v), 32) for v in mem.route[0, :mem.route_len[0]]]
    assert route[0] == (5, 16) and route[-1] == (16, 16) and mem.forgot[0] == 0
    assert all(mem.grid[0][a, b] == OPEN for a, b in route)
    assert ((10, 16) in route) == through_hole
    assert any(a == 10 and b in (24, 25) for a, b in route) == (not through_hole)
    if not through_hole:  # the wide gap shut too: the way through the fewest walls takes the narrow gap
        mem = ChartMemory.empty(1, 32, 3)
        mem.cell[:] = cell
        _walled(mem)
        mem.grid[0, 10:12, 24:26] = WALL
        chart_update(mem, np.array([0]), d, q, np.zeros(1), P_ONE_CELL, 60.0, 1.0, 2.0, np.array([False]),
                     pass_m=pass_m)
        route = [divmod(int(v), 32) for v in mem.route[0, :mem.route_len[0]]]
        assert (10, 16) in route and (11, 16) in route and mem.forgot[0] == 0
        assert (mem.grid[0, 10:12, 16] == OPEN).all()  # crossed at a wall's price, not charted shut


def test_a_target_in_a_gap_one_cell_wide_is_still_reached_over_open_cells():
    """The target's own cell is never left out of the plan: here it lies between two wall cells."""
    c = 16
    g = np.zeros((c, c), np.uint8)
    g[7, 8] = g[9, 8] = WALL  # north and south of the target's cell (8, 8): it is pinched, its row is not
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    found, cost, touched, nt = _search(g, 8, 1, 8, 8, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, PINCH_ONE_CELL)
    assert found and cost == pytest.approx(dijkstra(g, (8, 1), (8, 8)))  # as without the rule
    _reset(dist, prev, closed, touched, nt, c)
    g[7, 7] = g[9, 7] = WALL  # (8, 7) now lies between (7, 7) and (9, 7): the way comes round by (8, 9)
    found, cost, touched, nt = _search(g, 8, 1, 8, 8, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, PINCH_ONE_CELL)
    ref = dijkstra(g, (8, 1), (8, 8), pinch=True)
    assert found and cost == pytest.approx(ref) and ref > dijkstra(g, (8, 1), (8, 8))


def _ringed(rng, c, walled):
    """A chart ``c`` cells a side with random walls and stuck cells, the target's cell (c // 2, c // 2)
    open inside a ring of walls (a way in through it when not ``walled``; some rings have a hole one
    cell wide, which the pinch rule shuts)."""
    g = (rng.random((c, c)) < rng.uniform(0.0, 0.3)).astype(np.uint8)
    g[rng.random((c, c)) < 0.03] = 2
    h = c // 2
    yy, xx = np.mgrid[0:c, 0:c]
    r = np.hypot(yy - h, xx - h)
    rad = rng.uniform(2.0, c / 3)
    g[(r >= rad) & (r < rad + 1.5)] = WALL
    if not walled:
        g[h, int(h + rad):int(h + rad + 2)] = OPEN
        if rng.random() < 0.5:  # a gap two cells wide, else one
            g[h + 1, int(h + rad):int(h + rad + 2)] = OPEN
    g[h, h] = OPEN
    return g


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.booleans(), st.booleans())
def test_the_flood_from_the_target_says_walled_in_exactly_when_the_search_finds_no_open_way(seed, walled, pinch):
    """_walled_in (a flood over the cells the A* may enter, from the target) is True exactly when the
    A* over open cells finds no way, with or without the pinch rule; with a small budget it may only
    say False; it leaves its work array as it found it."""
    from tin_swarm_env.policies.chart import _walled_in

    pinch = PINCH_ONE_CELL if pinch else 0.0
    rng = np.random.default_rng(seed)
    c = 24
    g = _ringed(rng, c, walled)
    s = (int(rng.integers(0, c)), int(rng.integers(0, c)))
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    found, _, touched, nt = _search(g, *s, c // 2, c // 2, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, pinch)
    _reset(dist, prev, closed, touched, nt, c)
    assert _walled_in(g, *s, c // 2, c // 2, pinch, c * c, closed) == (not found)
    assert not closed.any()
    if found:
        assert not _walled_in(g, *s, c // 2, c // 2, pinch, 3, closed)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.booleans(), st.booleans())
def test_planning_with_the_flood_first_gives_the_same_way_and_chart_as_without(seed, walled, pinch):
    """_plan_row with the flood (flood > 0) answers as without it, bit for bit: found, the way stored
    (cells and shut counts), the point to head for, whether it forgot, and the chart it leaves
    (stuck cells forgotten, or the whole chart, the same), with the target walled in or not."""
    from tin_swarm_env.policies.chart import _plan_row

    rng = np.random.default_rng(seed)
    c = 24
    g = _ringed(rng, c, walled)
    s = (int(rng.integers(0, c)), int(rng.integers(0, c)))
    out = []
    for flood in (0, c * c, 5):
        gg = g.copy()
        work = (np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), np.bool_))
        route, shut = np.zeros(ROUTE_PER_CELL * c, np.int32), np.zeros(ROUTE_PER_CELL * c, np.uint8)
        found, n, k, forgot = _plan_row(gg, *s, 3.0, 2.0, 0.0, 0.0, 0.0, *work, route, shut,
                                        PINCH_ONE_CELL if pinch else 0.0, flood)
        out.append((found, n, k, forgot, route[:n].tolist(), shut[:n].tolist(), gg.tobytes()))
        assert (work[0] == 1e30).all() and (work[1] == -1).all() and not work[2].any()
    assert out[0] == out[1] == out[2]


def test_a_target_walled_in_is_planned_to_through_the_fewest_walls_with_or_without_the_flood():
    """The case the flood is for (a crater charted round its target): no open way; the flood from the
    target closes inside the ring and the A* over open cells is skipped; the way through the fewest
    walls is the same as without the flood."""
    from tin_swarm_env.policies.chart import _plan_row, _walled_in

    c = 32
    g = np.zeros((c, c), np.uint8)
    g[10:22, 10:22] = WALL
    g[12:20, 12:20] = OPEN  # a ring two cells thick round the target's cell (16, 16)
    g[10, 16] = OPEN  # thinner in one place: one wall cell to cross there
    closed = np.zeros((c, c), np.bool_)
    assert _walled_in(g, 2, 16, 16, 16, False, c * c, closed) and not closed.any()
    assert not _walled_in(g, 14, 14, 16, 16, False, c * c, closed)  # from inside the ring: open
    out = []
    for flood in (0, c * c):
        work = (np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), np.bool_))
        route, shut = np.zeros(ROUTE_PER_CELL * c, np.int32), np.zeros(ROUTE_PER_CELL * c, np.uint8)
        found, n, k, forgot = _plan_row(g, 2, 16, 3.0, 2.0, 0.0, 0.0, 0.0, *work, route, shut, False, flood)
        out.append((found, n, k, forgot, route[:n].tolist(), shut[:n].tolist()))
    assert out[0] == out[1]
    way = [divmod(v, c) for v in out[0][4]]
    assert out[0][0] and not out[0][3] and [(a, b) for a, b in way if g[a, b] == WALL] == [(11, 16)]


def _search_unpruned(g, sa, sb, ta, tb, wall_cost, ha, hb, turn, cross=0.0, pinch=False, side=(0.0, 0.0, 0.0, 0.0)):
    """The A* of :func:`_search` as it was before it skipped a neighbour that cannot improve (kept here
    as the reference, in Python, on the same heap): ``(found, cost, dist, prev, pushes)``."""
    from tin_swarm_env.policies.chart import STUCK, _beside_wall, _pinched, heap_pop, heap_push

    c = g.shape[0]
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    hk, hv = np.empty(16 * c * c), np.empty(16 * c * c, np.int64)
    s2 = np.sqrt(2.0)

    def h(a, b):
        dx, dy = abs(a - ta), abs(b - tb)
        return max(dx, dy) + (s2 - 1.0) * min(dx, dy)

    dist[sa, sb] = 0.0
    hk[0], hv[0], hn, found, pushes = h(sa, sb), sa * c + sb, 1, False, []
    while hn > 0:
        v, hn = heap_pop(hk, hv, hn)
        a, b = v // c, v % c
        if closed[a, b]:
            continue
        closed[a, b] = True
        if a == ta and b == tb:
            found = True
            break
        for da in range(-1, 2):
            for db in range(-1, 2):
                na, nb = a + da, b + db
                if (da == 0 and db == 0) or na < 0 or nb < 0 or na >= c or nb >= c or closed[na, nb]:
                    continue
                v = g[na, nb]
                if pinch and v == OPEN and not (na == ta and nb == tb) and _pinched(g, na, nb, pinch):
                    v = WALL
                if v == STUCK or (v == WALL and cross <= 0.0):
                    continue
                step = s2 if da != 0 and db != 0 else 1.0
                nd = dist[a, b] + step
                if v == WALL:
                    nd += cross
                if da != 0 and db != 0:
                    c1, c2 = g[a + da, b], g[a, b + db]
                    if c1 == STUCK or c2 == STUCK or (cross <= 0.0 and (c1 != 0 or c2 != 0)):
                        continue
                    if c1 == WALL or c2 == WALL:
                        nd += cross
                if a == sa and b == sb and turn > 0:
                    nd += turn * 0.5 * (1.0 - (da * ha + db * hb) / step)
                side_cost, ux, uy, margin = side
                if side_cost > 0 and ux * (nb - tb + 0.5) - uy * (na - ta + 0.5) < -margin:  # the side not preferred
                    nd += side_cost * step
                if _beside_wall(g, na, nb):
                    nd += wall_cost
                if nd < dist[na, nb]:
                    dist[na, nb], prev[na, nb] = nd, a * c + b
                    hn = heap_push(hk, hv, hn, nd + h(na, nb), na * c + nb)
                    pushes.append((na * c + nb, nd))
    return found, (dist[ta, tb] if found else math.inf), dist, prev, pushes


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.5), st.sampled_from([(0.0, False), (0.0, True), (40.0, False),
                                                                        (40.0, True)]),
       st.floats(0.0, 6.0), st.floats(-math.pi, math.pi), st.sampled_from([0.0, 0.5, 1.0, 3.0]),
       st.floats(-math.pi, math.pi), st.sampled_from([0.0, 2.0]))
def test_the_search_skips_only_neighbours_that_cannot_improve_the_same_bits_as_the_full_loop(seed, density, mode,
                                                                                         turn, heading, side_cost,
                                                                                         home, margin):
    """Every stuck, wall and open mix (``cross`` 0 and > 0, ``pinch`` on and off, a turn cost from the
    start): the search that tests a neighbour's cost before its wall price finds the same cost, the
    same ``dist`` and ``prev`` bit for bit as the loop that priced every neighbour in full (so every
    robot's way, and every figure, is unchanged)."""
    rng = np.random.default_rng(seed)
    c = 14
    g = rng.choice(np.array([0, 1, 2], np.uint8), size=(c, c), p=[1 - density, density * 0.8, density * 0.2])
    s, t = (int(rng.integers(0, c)), int(rng.integers(0, c))), (c // 2, c // 2)
    g[s] = g[t] = 0
    cross, pinch = mode
    pinch = PINCH_ONE_CELL if pinch else 0.0
    ha, hb = math.cos(heading), math.sin(heading)
    side = (side_cost, math.cos(home), math.sin(home), margin)
    found, cost, ref_dist, ref_prev, _ = _search_unpruned(g, *s, *t, 2.0, ha, hb, turn, cross, pinch, side)
    dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
    got = _search(g, *s, *t, 2.0, ha, hb, turn, dist, prev, closed, cross, pinch, *side)
    assert got[0] == found and (got[1] == cost or (math.isinf(got[1]) and math.isinf(cost)))
    assert np.array_equal(dist, ref_dist) and np.array_equal(prev, ref_prev)


def _work_sets(t, c):
    return np.full((t, c, c), 1e30), np.full((t, c, c), -1, np.int64), np.zeros((t, c, c), np.bool_)


@pytest.mark.parametrize("scenario", ["cliff_goal", "containment"])
def test_the_charts_are_the_same_bits_in_one_run_or_in_several(scenario):
    """chart_update takes its robots in T runs side by side, each on its own A* work set: one run,
    three, or one robot's rows in an order of its own, the memory after 60 steps is the same bit for
    bit (a robot's step reads and writes its own memory only)."""
    import numba

    env = tse.parallel_env(scenario=scenario, n_robots=7)
    states = []
    k = numba.get_num_threads()
    for t, order in ((1, None), (3, None), (4, [6, 2, 0, 5, 1, 4, 3])):
        pol = APFPolicy(env, search="chart")
        pol.charts.work = _work_sets(t, pol.chart.cells)
        obs = env.reset_arrays(seed=3)
        numba.set_num_threads(min(t, k))  # (more threads than sets would make more sets)
        try:
            for _ in range(60):
                if order is None:
                    a = pol.act_batch(obs)
                else:
                    a = np.empty((len(obs), 2), np.float32)
                    a[order] = pol.act_batch(obs[order], rows=order)
                obs = env.step_arrays(a)[0]
        finally:
            numba.set_num_threads(k)
        assert pol.charts.work[0].shape[0] == t
        states.append({f: getattr(pol.charts, f).copy() for f in _ROW_FIELDS})
    assert states[0]["plans"].sum() > 7  # it planned (more than once each on the whole)
    for s in states[1:]:
        for f in _ROW_FIELDS:
            assert np.array_equal(s[f], states[0][f]), f


def _rows_of(d: DecodedObs, r) -> DecodedObs:
    """Rows ``r`` of a decoded observation (the scan's beam directions are not per row)."""
    return DecodedObs(**{f: (v if f == "s_dir" or v is None else v[r]) for f, v in d.__dict__.items()})


@pytest.mark.parametrize("rows", [[0, 1, 0, 2, 2], [2, 0, -3, 1]])
def test_rows_that_name_a_robot_twice_are_taken_one_after_another(rows):
    """Rows naming one robot twice (or one from the end; not what a policy is given, but not refused):
    each row's step, its plan included, is taken before the next row's, as when each row is its own
    call, on any number of work sets."""
    from tin_swarm_env.policies.base import decode

    env = tse.parallel_env(scenario="containment", n_robots=3)
    pol = APFPolicy(env, search="chart")
    obs = env.reset_arrays(seed=3)
    for _ in range(40):  # charts with walls and ways on them
        obs = env.step_arrays(pol.act_batch(obs))[0]
    d = decode(obs[np.asarray(rows) % 3], pol.layout, pol.shield.range_m)
    q = np.random.default_rng(0).uniform(-40, 40, (len(rows), 2))
    psi = np.linspace(-2.0, 2.0, len(rows))
    args = (pol.chart, pol.shield.range_m, pol.shield.step_m, 2 * pol.shield.edge_m, np.zeros(len(rows), bool))
    mems = []
    for t, one_by_one in ((2, False), (1, True)):
        mem = ChartMemory(**{f: getattr(pol.charts, f).copy() for f in _ROW_FIELDS})
        mem.work = _work_sets(t, pol.chart.cells)
        if one_by_one:
            for r in range(len(rows)):
                chart_update(mem, [rows[r]], _rows_of(d, [r]), q[[r]], psi[[r]], *args[:4], args[4][[r]])
        else:
            chart_update(mem, rows, d, q, psi, *args)
        mems.append(mem)
    assert mems[1].plans.sum() > pol.charts.plans.sum()  # some row planned
    for f in _ROW_FIELDS:
        assert np.array_equal(getattr(mems[0], f), getattr(mems[1], f)), f


def test_plan_refuses_a_negative_wall_cost_by_name():
    g = np.zeros((5, 5), np.uint8)
    with pytest.raises(ArgumentError, match="plan: wall_cost"):
        plan(g, 0, 0, 4, 4, 5.0, -0.7)


def test_the_work_sets_follow_numbas_thread_count_up_and_stay_when_it_falls():
    import numba

    mem = ChartMemory.empty(2, 16)
    k = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        assert mem.work_arrays()[0].shape == (1, 16, 16)
    finally:
        numba.set_num_threads(k)
    assert mem.work_arrays()[0].shape == (k, 16, 16)  # more threads: more sets (1 when numba has one)
    numba.set_num_threads(1)
    try:
        assert mem.work_arrays()[0].shape == (k, 16, 16)  # fewer: the sets it has serve
    finally:
        numba.set_num_threads(k)


def _pair_at(q):
    """A two-row observation of robots standing at ``q`` (west of their target) and their positions
    ``(d, qq)``, as :func:`chart_update` takes them for rows (6, 7)."""
    d1, q1 = _one(q)
    d = DecodedObs(**{f.name: (None if getattr(d1, f.name) is None else np.concatenate([getattr(d1, f.name)] * 2))
                      for f in dataclasses.fields(d1)})
    return d, np.concatenate([q1, q1])


def _pair_memory(q):
    """Memory for 8 robots with 1 m cells (a chart made here, not at a first step: where each started is
    set to ``q`` too), and :func:`_pair_at` ``q``."""
    mem = ChartMemory.empty(8, 32, 3)
    mem.cell[:] = 1.0
    d, qq = _pair_at(q)
    mem.home[:] = qq[:1]
    return mem, d, qq


def _split(params, rows=(6, 7), q=(-10.5, 0.5), wall=True):
    """Robots ``rows`` (of 8) at ``q``, west of their target, a wall across their straight way the same
    length either side (column 12, rows 8..24 about row 16; ``wall=False``: none): the rows of the chart
    each robot's way passes."""
    mem, d, qq = _pair_memory(q)
    rows = np.array(rows)
    chart_update(mem, rows, d, qq, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))
    if wall:
        mem.grid[:, 12, 8:25] = WALL
        mem.dirty[:] = True
        chart_update(mem, rows, d, qq, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))
    return [[divmod(int(v), 32)[1] for v in mem.route[i, :mem.route_len[i]]] for i in rows]


def test_robot_side_splits_the_robots_of_every_target_about_evenly():
    """Robot i goes to target i mod the target count: every such class is split within 4 robots of even
    (up to 4 targets at 200 robots, 20 robots of one target), where i's parity would give one target of
    two all one side."""
    assert [robot_side(i) for i in range(8)] == [1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0, 1.0]
    for n, targets in ((200, 1), (200, 2), (200, 3), (200, 4), (20, 1), (40, 2)):
        for t in range(targets):
            assert abs(sum(robot_side(i) for i in range(t, n, targets))) <= 4


def test_two_robots_of_one_target_split_round_the_two_ends_of_a_wall():
    """Robot 6 (left, :func:`robot_side`) goes round the wall's left end facing east (chart rows above 24),
    robot 7 round its right end (rows below 8), whatever rows of the step they are in; with no side
    preference, or one whose margin spans the chart, both take one end."""
    assert (robot_side(6), robot_side(7)) == (-1.0, 1.0)
    for rows in ((6, 7), (7, 6)):
        left, right = _split(P, rows)[::1 if rows[0] == 6 else -1]
        assert max(left) > 24 and min(left) >= 15
        assert min(right) < 8 and max(right) <= 17
    for params in (dataclasses.replace(P, side_cost=0.0), dataclasses.replace(P, side_margin=40.0)):
        a, b = _split(params)
        assert (min(a) < 8) == (min(b) < 8)  # no preference: one way for both


def test_where_a_robot_started_is_kept_at_its_first_step_and_not_moved_after():
    """Set with its chart at its first step; kept through moves, stalls (standing still for longer than
    ``stall_steps``) and replanning (at ``side_leave_m`` 0, the default: it keeps its side)."""
    mem = ChartMemory.empty(1, 32, 3)
    _step(mem, (-10.5, 0.5))
    assert mem.home[0].tolist() == [-10.5, 0.5] and mem.cell[0] > 0
    _step(mem, (-6.5, 3.5))
    for _ in range(3 * P.stall_steps):
        _step(mem, (-6.5, 3.5), [(-3.9, 3.5)], [(-1.0, 0.0)])
    assert mem.plans[0] > 1 and mem.home[0].tolist() == [-10.5, 0.5]


def test_open_ground_costs_no_side_price_whatever_the_distance_to_go():
    """No wall: both robots of :func:`_split`'s start keep to the straight way's row (16), its cells within
    ``side_margin`` of the line from where they started, however far that is (the direction is a unit
    vector: a distance-scaled one would price the row next to the line for one of them)."""
    for q in ((-10.5, 0.5), (-12.5, 0.5)):
        assert [set(r) for r in _split(P, q=q, wall=False)] == [{16}, {16}]


def _homes_after_wall(params, q2=(-10.5, 0.5)):
    """Robots 6 and 7 of :func:`_split` (left and right): where each started, as kept after the wall
    across their straight way made them plan again at ``q2``, the cells left then of the way each had
    (from the cell of ``q2`` on it) and the length of its new way."""
    mem, d, qq = _pair_memory((-10.5, 0.5))
    rows = np.array([6, 7])
    chart_update(mem, rows, d, qq, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))
    at = int(np.floor(q2[0])) + 16, int(np.floor(q2[1])) + 16  # q2's cell (1 m cells, the target at (16, 16))
    before = np.array([mem.route_len[i] - list(mem.route[i, :mem.route_len[i]]).index(at[0] * 32 + at[1])
                       for i in rows])
    d2, qq2 = _pair_at(q2)
    chart_update(mem, rows, d2, qq2, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))  # on along its way
    assert (mem.route_len[rows] - mem.route_at[rows] == before).all()  # where it is on it, as counted here
    mem.grid[:, 12, 8:25] = WALL
    mem.dirty[:] = True
    chart_update(mem, rows, d2, qq2, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))
    return mem.home[rows].copy(), before, mem.route_len[rows].copy()


def test_a_robot_leaves_its_side_when_its_plan_grows_by_more_than_side_leave_m():
    """The wall makes each robot's way round one end longer than the straight way it had: by more than
    ``side_leave_m`` (cells 1 m wide) its start is forgotten (no side from then on), by less it is kept;
    at 0 (the default) always kept."""
    for q2 in ((-10.5, 0.5), (-6.5, 0.5)):  # planned again where it started, and 4 cells on along its way
        _, before, after = _homes_after_wall(P, q2)
        grow = after - before
        assert (grow > 2).all()  # the plan did grow (both ways round are longer than the straight one)
        for leave, kept in ((0.0, True), (float(grow.min()) - 0.5, False), (float(grow.max()) + 0.5, True)):
            home, _, _ = _homes_after_wall(dataclasses.replace(P, side_leave_m=leave), q2)
            assert (np.abs(home).sum(axis=1) > 0).tolist() == [kept, kept], (q2, leave, grow, home)


def test_a_robot_that_left_its_side_plans_as_if_it_had_none():
    """Robots 6 and 7 leave their sides on the plan the wall forces (each round its own end); made to plan
    again from there (no turn price to speak of: ``turn_m`` 1e-9, so that the way each had does not hold
    it), both take the shorter end, as robots with no side preference do."""
    params = dataclasses.replace(P, side_leave_m=1.0, turn_m=1e-9)
    mem, d, qq = _pair_memory((-10.5, 0.5))
    rows = np.array([6, 7])
    ends = []
    for wall in (False, True, True):
        if wall:  # one row longer south (row 7) than north (24): the north end is the shorter way
            mem.grid[:, 12, 7:25] = WALL
        mem.dirty[:] = True
        chart_update(mem, rows, d, qq, np.zeros(2), params, 60.0, 1.0, 2.0, np.zeros(2, bool))
        ends.append([min(divmod(int(v), 32)[1] for v in mem.route[i, :mem.route_len[i]]) < 8 for i in rows])
    assert ends[1][0] != ends[1][1]  # the plan that grew: each round its own side's end
    assert (mem.home[rows] == 0).all()
    assert ends[2] == [False, False]  # the next: no side, both round the shorter (north) end


def test_a_gap_narrower_than_the_width_is_pinched_unless_a_beam_passed_over_it():
    """_pinched: a gap between shut cells across a row, a column or a diagonal is left out when it is
    narrower than ``pinch`` cells (a diagonal's cells count sqrt 2), not when a scan beam has passed
    over the cell (the SEEN bit), and one cell wide at PINCH_ONE_CELL, as the rule before it."""
    from tin_swarm_env.policies.chart import _pinched

    g = np.zeros((12, 12), np.uint8)
    g[5, 3] = g[5, 6] = WALL  # cells (5, 4) and (5, 5): a gap two cells wide along the row
    assert _pinched(g, 5, 4, 2.5) and _pinched(g, 5, 5, 2.5)
    assert not _pinched(g, 5, 4, 2.0) and not _pinched(g, 5, 4, PINCH_ONE_CELL)
    g[5, 4] |= SEEN
    assert not _pinched(g, 5, 4, 2.5) and _pinched(g, 5, 5, 2.5)
    d = np.zeros((12, 12), np.uint8)
    d[3, 3] = d[6, 6] = WALL  # (4, 4) and (5, 5): two cells across a diagonal, 2.83 cells wide
    assert _pinched(d, 4, 4, 3.0) and not _pinched(d, 4, 4, 2.5)
    one = np.zeros((12, 12), np.uint8)
    one[4, 4] = one[6, 6] = WALL  # (5, 5): one cell across a diagonal
    assert _pinched(one, 5, 5, PINCH_ONE_CELL) and not _pinched(one, 5, 4, PINCH_ONE_CELL)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(0.0, 1.0))
def test_no_cell_is_pinched_below_one_cell(seed, pinch):
    """_pinched with ``pinch <= 1``: no cell of any chart is pinched (a gap between shut cells spans at
    least one cell), which lets the plan skip the test there (_unseen_pinch gives 0 there)."""
    from tin_swarm_env.policies.chart import _pinched

    rng = np.random.default_rng(seed)
    g = rng.choice(np.array([OPEN, WALL, STUCK, SEEN], np.uint8), size=(10, 10), p=[0.4, 0.3, 0.1, 0.2])
    assert not any(_pinched(g, a, b, pinch) for a in range(10) for b in range(10))


def test_the_unseen_pinch_is_the_gap_in_cells_where_it_is_wider_than_a_cell():
    """_unseen_pinch: a 3 m gap on 1 m cells is 3 cells; on cells 3 m or wider no gap can be left out (0), so
    the plan skips the test and the beams mark nothing (a 2 m beam from the centre of a 3 m chart cell), nor on
    a chart not yet sized (w = 0), where the rule once divided by zero."""
    from tin_swarm_env.policies.chart import _mark_prm, _prm, _unseen_pinch

    assert _unseen_pinch(3.0, 1.0) == 3.0 and _unseen_pinch(3.0, 3.0) == 0.0 and _unseen_pinch(0.0, 1.0) == 0.0
    assert _unseen_pinch(3.0, 0.0) == 0.0  # a chart not yet sized (w = 0: before the first step) leaves none out
    prm = _mark_prm(_prm(ChartParams(), 60.0, 1.0, 1.0, pass_m=3.0))
    none = np.zeros((0, 2))
    for w, marked in ((1.0, True), (3.0, False), (0.0, False)):
        g = np.zeros((32, 32), np.uint8)
        _mark_row(g, w, 0.5 * w, 0.5 * w, 1.0, 0.0, none, none, np.zeros(0, bool), np.zeros(0, bool), none,
                  np.zeros(0, bool), np.array([[8.0 * w, 0.0]]), np.array([[1.0, 0.0]]), np.array([False]), prm)
        assert bool((g == SEEN).any()) == marked


def test_beams_mark_the_open_cells_they_pass_over_up_to_a_cell_short_of_their_end():
    """_mark_seen: a beam 10 m long east from (0.5, 0.5) on 1 m cells marks SEEN the open cells it
    passes over from half a cell out to a cell short of its end (x = 1 .. 9.5), not the cell where it
    ends (x = 10.5) nor beyond, nor the robot's own cell, and leaves a wall a wall."""
    from tin_swarm_env.policies.chart import _mark_seen

    c = 32
    h = c // 2
    g = np.zeros((c, c), np.uint8)
    g[h + 4, h] = WALL
    _mark_seen(g, 1.0, 0.5, 0.5, 1.0, 0.0, np.array([[10.0, 0.0]]), np.array([[1.0, 0.0]]))
    row = g[:, h]
    assert row[h + 4] == WALL
    assert all(row[h + k] == SEEN for k in (1, 2, 3, 5, 6, 7, 8, 9))
    assert row[h + 10] == OPEN and row[h + 11] == OPEN and row[h] == OPEN and row[h - 1] == OPEN
    assert (g[:, h + 1] == OPEN).all()


def _cells_crossed(x0, y0, dx, dy, t0, t1, c, eps):
    """The slow reference of _mark_seen's walk: the chart cells (a, b) the segment ``(x0, y0) + t (dx, dy)``,
    ``t0 <= t < t1`` (cell units), crosses, each cell grown by ``eps`` on every side first (``eps > 0``: the
    cells it crosses or passes within ``eps`` of; ``eps < 0``: those whose inside, ``|eps|`` in from every
    edge, it crosses over more than ``|eps|`` of its length: a segment that runs along an edge, a hair to one
    side, is a cell of either side as rounding has it), found by clipping the segment to each cell near it."""
    out = set()
    xs, ys = (x0 + t0 * dx, x0 + t1 * dx), (y0 + t0 * dy, y0 + t1 * dy)
    for a in range(max(int(math.floor(min(xs))) - 1, 0), min(int(math.floor(max(xs))) + 1, c - 1) + 1):
        for b in range(max(int(math.floor(min(ys))) - 1, 0), min(int(math.floor(max(ys))) + 1, c - 1) + 1):
            lo, hi = t0, t1
            for p0, d, k in ((x0, dx, a), (y0, dy, b)):
                k0, k1 = k - eps, k + 1 + eps
                if d == 0.0:
                    if not k0 <= p0 < k1:
                        lo = hi
                    continue
                with np.errstate(over="ignore"):  # a direction a hair off an axis: an edge at +-inf
                    e0, e1 = sorted(((k0 - p0) / d, (k1 - p0) / d))
                lo, hi = max(lo, e0), min(hi, e1)
            if hi - lo > -eps:
                out.add((a, b))
    return out


@settings(max_examples=200, deadline=None)
@given(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0), st.floats(0.0, 2 * math.pi), st.floats(0.0, 2 * math.pi),
       st.floats(0.0, 40.0), st.sampled_from([0.7, 1.0, 1.37]))
def test_beams_mark_every_cell_their_segment_crosses_and_no_other(qx, qy, psi, phi, length, w):
    """_mark_seen against a slow reference (the cells each segment crosses, clipped cell by cell): a beam
    at angle ``phi`` in the body frame of a robot at ``q`` heading ``psi``, ``length`` m long, marks SEEN
    every chart cell its segment from half a cell out to a cell short of its end crosses over a positive
    length, and no cell it does not come within a hair of (a cell it only touches, at a corner or where it
    starts on an edge, may go either way), the chart's edge included (cells off the chart are skipped)."""
    from tin_swarm_env.policies.chart import _mark_seen

    c = 32
    h = c // 2
    g = np.zeros((c, c), np.uint8)
    d = np.array([[math.cos(phi), math.sin(phi)]])
    _mark_seen(g, w, qx, qy, math.cos(psi), math.sin(psi), length * d, d)
    bx = math.cos(psi) * d[0, 0] - math.sin(psi) * d[0, 1]
    by = math.sin(psi) * d[0, 0] + math.cos(psi) * d[0, 1]
    got = {(int(a), int(b)) for a, b in zip(*np.nonzero(g == SEEN))}
    end = length / w - 1.0
    must = _cells_crossed(qx / w + h, qy / w + h, bx, by, 0.5, end, c, -1e-9) if end > 0.5 + 1e-9 else set()
    may = _cells_crossed(qx / w + h, qy / w + h, bx, by, 0.5, end, c, 1e-9) if end > 0.5 else set()
    assert must <= got <= may


def test_beams_along_a_column_and_several_beams_at_once():
    """_mark_seen by hand: from (0.5, 0.5) on 1 m cells, one call with three beams (north 6 m, south 4 m,
    west 3.2 m: each from half a cell out to a cell short of its end) marks cells 1..5 up the column, 1..3
    down it and 1..2 west, not the robot's own cell (the south and west beams start on its edge and leave
    it at once); a wall in the way stays a wall. A robot at a position that is not a number marks nothing
    (and the walk ends)."""
    from tin_swarm_env.policies.chart import _mark_seen

    c = 32
    h = c // 2
    g = np.zeros((c, c), np.uint8)
    g[h, h + 2] = WALL
    units = np.array([[0.0, 1.0], [0.0, -1.0], [-1.0, 0.0]])
    _mark_seen(g, 1.0, 0.5, 0.5, 1.0, 0.0, units * np.array([[6.0], [4.0], [3.2]]), units)
    want = {(h, h + k) for k in (1, 3, 4, 5)} | {(h, h - k) for k in (1, 2, 3)} | {(h - 1, h), (h - 2, h)}
    assert {(int(a), int(b)) for a, b in zip(*np.nonzero(g == SEEN))} == want
    assert g[h, h + 2] == WALL and g[h, h] == OPEN
    g2 = np.zeros((c, c), np.uint8)
    _mark_seen(g2, 1.0, np.nan, np.nan, 1.0, 0.0, units * 6.0, units)
    assert not g2.any()


def test_the_search_goes_through_a_narrow_gap_only_once_it_has_been_seen_through():
    """A wall across the chart with one gap two cells wide: with gaps narrower than 2.5 cells left out
    the search over open cells finds no way; with a beam's SEEN bit on the gap it goes through it, and a
    wall marked on a seen cell shuts it again (_wall_at)."""
    from tin_swarm_env.policies.chart import _wall_at

    c = 16
    h = c // 2
    g = np.zeros((c, c), np.uint8)
    g[h - 3, :] = WALL
    g[h - 3, 7] = g[h - 3, 8] = OPEN

    def search():
        dist, prev, closed = np.full((c, c), 1e30), np.full((c, c), -1, np.int64), np.zeros((c, c), bool)
        return _search(g, 2, 7, h, h, 2.0, 0.0, 0.0, 0.0, dist, prev, closed, 0.0, 2.5)[0]

    assert not search()
    g[h - 3, 7] |= SEEN
    g[h - 3, 8] |= SEEN
    assert search()
    g2 = g.copy()
    assert _wall_at(g2, 1.0, (h - 3 - h) + 0.5, (8 - h) + 0.5) and g2[h - 3, 8] == WALL


def test_unseen_gap_reaches_the_plan_and_the_marks():
    """ChartParams.unseen_gap (default 1): 0 leaves the constants as before (no seen marks, the one-cell rule);
    > 0 puts the widest gap left out, in metres, where the plan reads it and turns the beam marks on."""
    from tin_swarm_env.policies.chart import _mark_prm, _prm

    off = _prm(ChartParams(unseen_gap=0.0), 60.0, 1.0, 1.0, pass_m=3.0)
    on = _prm(ChartParams(unseen_gap=1.0), 60.0, 1.0, 1.0, pass_m=3.0)
    assert off[18] == 0.0 and on[18] == 3.0 and (off[:18] == on[:18]).all()
    assert _mark_prm(off)[5] == 0.0 and _mark_prm(on)[5] == 3.0


@pytest.mark.parametrize("unseen_gap, beam, through", [(1.0, False, False), (1.0, True, True), (0.0, False, True)])
def test_with_unseen_gap_the_way_goes_through_a_narrow_gap_only_once_a_beam_has_passed_over_it(unseen_gap, beam,
                                                                                                through):
    """chart_update with ``ChartParams.unseen_gap`` 1 (pass_m 3 m, cells 1 m): a gap two cells wide across a
    wall (rows 15-16) is left out until a scan beam east along row 16 passes over it, and then the way goes
    through it (its cells carry the SEEN bit); a gap four cells wide (rows 24-27) is never left out. With
    unseen_gap 0 the one-cell rule keeps the two-cell gap."""
    mem = ChartMemory.empty(1, 32, 3)
    mem.cell[:] = 1.0
    g = mem.grid[0]
    g[10:12, :] = WALL
    g[10:12, 15:17] = OPEN
    g[10:12, 24:28] = OPEN
    d, q = _one((-10.5, 0.5))  # cell (5, 16)
    if beam:  # one beam east (body frame = F, heading 0), ending 15 m on with no hit
        d = dataclasses.replace(d, s_rel=np.array([[[15.0, 0.0]]]), s_hit=np.array([[False]]),
                                s_dir=np.array([[1.0, 0.0]]))
    params = dataclasses.replace(P, unseen_gap=unseen_gap)
    chart_update(mem, np.array([0]), d, q, np.zeros(1), params, 60.0, 1.0, 2.0, np.array([False]), pass_m=3.0)
    route = [divmod(int(v), 32) for v in mem.route[0, :mem.route_len[0]]]
    assert route[0] == (5, 16) and route[-1] == (16, 16) and mem.forgot[0] == 0
    assert any(a == 10 and b in (15, 16) for a, b in route) == through
    assert any(a == 10 and 24 <= b <= 27 for a, b in route) == (not through)
    assert bool(mem.grid[0][10, 16] & SEEN) == beam and not mem.grid[0][10, 15] & SEEN



def test_unseen_gap_is_on_by_default():
    """The default chart leaves unseen gaps narrower than one pass out of the plan (ChartParams.unseen_gap 1),
    and APFPolicy's default chart is that one."""
    assert ChartParams().unseen_gap == 1.0
    env = tse.parallel_env(scenario="cliff_goal", n_robots=2)
    assert APFPolicy(env).chart.unseen_gap == 1.0
