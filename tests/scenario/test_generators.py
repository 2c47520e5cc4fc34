"""Generated terrains (scenario/generators.py): reproducibility, solvability, the detour side,
parameter validation.

Solvability is checked here against a small stand-in for ``terrain.cost_to_go``: connectivity of
the DEM cells whose slope to each 4-neighbour is at most the robots' limit (a grid BFS, done by
``scipy.ndimage.label``). The last tests use the real greedy TIN and its triangle adjacency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage, sparse, stats
from scipy.sparse.csgraph import dijkstra

from tin_swarm_env.scenario import generators as gen
from tin_swarm_env.scenario.config import ScenarioError
from tin_swarm_env.scenario.generators import DEFAULT_RANGES, PARAMS, generate, replay, validate_ranges

MAX_SLOPE = 30.0


# -- the grid stand-in for cost_to_go ---------------------------------------------------------


def passable_cells(dem, max_slope_deg=MAX_SLOPE):
    """(rows, cols) bool: no 4-neighbour step steeper than ``max_slope_deg``."""
    step = math.tan(math.radians(max_slope_deg)) * dem.dx
    z = dem.z
    steep = np.zeros(z.shape, dtype=bool)
    sx, sy = np.abs(np.diff(z, axis=1)) > step, np.abs(np.diff(z, axis=0)) > step
    steep[:, :-1] |= sx
    steep[:, 1:] |= sx
    steep[:-1] |= sy
    steep[1:] |= sy
    return ~steep


def cell(dem, xy):
    """(row, col) of the cell nearest to ``xy`` (2,)."""
    return int(round((xy[1] - dem.y[0]) / dem.dy)), int(round((xy[0] - dem.x[0]) / dem.dx))


def connected(mask, a_rc, b_rc):
    lab, _ = ndimage.label(mask)
    return bool(lab[a_rc] > 0 and lab[a_rc] == lab[b_rc])


def lateral(task):
    """(rows, cols) m: each cell's signed distance from the line spawn centre -> target, + = left."""
    s, t = task.spawn_centre, task.targets[0]
    d = (t - s) / np.linalg.norm(t - s)
    X, Y = np.meshgrid(task.dem.x, task.dem.y)
    return d[0] * (Y - s[1]) - d[1] * (X - s[0])


def spawn_cells(task):
    x0, y0, x1, y1 = task.spawn_region
    X, Y = np.meshgrid(task.dem.x, task.dem.y)
    return (X >= x0) & (X <= x1) & (Y >= y0) & (Y <= y1)


def grid_solvable(task):
    ok = passable_cells(task.dem)
    lab, _ = ndimage.label(ok)
    goal = lab[cell(task.dem, task.targets[0])]
    inside = spawn_cells(task)
    return bool(goal > 0 and np.all(lab[inside] == goal))


def task_for(family, seed, **ranges):
    return generate(np.random.default_rng(seed), families=(family,), ranges={family: ranges} if ranges else None)


# -- reproducibility --------------------------------------------------------------------------


def same(a, b):
    return (np.array_equal(a.dem.z, b.dem.z) and np.array_equal(a.dem.x, b.dem.x) and np.array_equal(a.dem.y, b.dem.y)
            and a.spawn_region == b.spawn_region and np.array_equal(a.targets, b.targets)
            and np.array_equal(a.passes, b.passes) and a.params == b.params and a.family == b.family
            and a.detour_side == b.detour_side and a.seed == b.seed)


@pytest.mark.parametrize("families", [("canyon",), ("mesa",), ("hills",), ("canyon", "mesa", "hills")])
def test_same_seed_same_task_bit_for_bit_and_different_seeds_differ(families):
    a = generate(np.random.default_rng(7), families)
    b = generate(np.random.default_rng(7), families)
    assert same(a, b)
    others = [generate(np.random.default_rng(s), families) for s in (8, 9)]
    for o in others:
        assert not same(a, o)
        assert a.dem.z.shape != o.dem.z.shape or not np.array_equal(a.dem.z, o.dem.z)


@pytest.mark.parametrize("family", ["canyon", "mesa", "hills"])
def test_replay_rebuilds_the_task_from_family_params_and_seed(family):
    for seed in range(3):
        t = task_for(family, seed)
        assert t.seed is not None and t.dem.source == f"generated:{family}"
        assert same(replay(t), t)
    direct = gen.FAMILIES[family](np.random.default_rng(0))
    assert direct.seed is None
    with pytest.raises(ValueError, match="seed"):
        replay(direct)


def test_generate_consumes_one_stream_in_order():
    """Consecutive draws from one generator are consecutive tasks; the next draw depends on the state."""
    rng = np.random.default_rng(3)
    first, second = generate(rng), generate(rng)
    rng2 = np.random.default_rng(3)
    assert same(generate(rng2), first) and same(generate(rng2), second)
    assert not same(first, second)


# -- geometry ---------------------------------------------------------------------------------


@pytest.mark.parametrize("family", ["canyon", "mesa", "hills"])
def test_every_task_is_solvable_on_the_grid_and_inside_the_map(family):
    for seed in range(30):
        t = task_for(family, seed)
        assert grid_solvable(t), (family, seed, t.params)
        x0, y0, x1, y1 = t.spawn_region
        lo, hi = t.dem.x[0], t.dem.x[-1]
        assert lo <= x0 < x1 <= hi and lo <= y0 < y1 <= hi
        assert x1 - x0 == pytest.approx(t.params["spawn_m"]) == y1 - y0
        assert np.all((t.targets >= lo) & (t.targets <= hi))
        assert t.dem.shape[0] == t.dem.shape[1] == int(round(t.params["size_m"] / t.params["cell_m"])) + 1
        assert np.all(np.isfinite(t.dem.z))


@pytest.mark.parametrize("family", ["canyon", "mesa"])
def test_the_straight_line_is_blocked_and_the_cliff_is_steep(family):
    for seed in range(30):
        t = task_for(family, seed)
        ok = passable_cells(t.dem)
        s, g = t.spawn_centre, t.targets[0]
        cells = [cell(t.dem, s + f * (g - s)) for f in np.linspace(0, 1, 2000)]
        assert not all(ok[rc] for rc in cells), (family, seed)
        # the steepest cell-to-cell step on the line is a cliff, >= (90 + 30) / 2 = 60 deg
        z = np.array([t.dem.z[rc] for rc in cells])
        assert np.degrees(np.arctan(np.abs(np.diff(z)).max() / t.params["cell_m"])) >= 60.0 - 1e-9
        assert not connected(ok & (np.abs(lateral(t)) < 3 * t.params["cell_m"]), cell(t.dem, s), cell(t.dem, g))


@pytest.mark.parametrize("family,max_slope", [("canyon", 30.0), ("mesa", 30.0), ("canyon", 20.0), ("mesa", 40.0)])
def test_passes_are_gentle_at_most_half_the_robots_limit(family, max_slope):
    for seed in range(15):
        t = generate(np.random.default_rng(seed), (family,), max_slope_deg=max_slope)
        assert t.params["max_slope_deg"] == max_slope
        gy, gx = np.gradient(t.dem.z, t.dem.dx)
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
        assert len(t.passes) in (1, 2)
        for a, b in t.passes:
            za, zb = (t.dem.z[cell(t.dem, p)] for p in (a, b))
            assert za > zb + 5.0  # high end first
            on = np.array([slope[cell(t.dem, a + f * (b - a))] for f in np.linspace(0.02, 0.98, 200)])
            assert on.max() <= max_slope / 2 + 1e-6, (family, seed, on.max())
        # the ground around spawn and target carries only the noise: <= max_slope / 10
        assert slope[spawn_cells(t)].max() <= max_slope / 10 + 1e-6


@pytest.mark.parametrize("family", ["canyon", "mesa"])
def test_spawn_on_top_or_bottom_puts_the_spawn_above_or_below_the_target(family):
    for spawn_on in ("top", "bottom"):
        for seed in range(5):
            t = task_for(family, seed, spawn_on=[spawn_on])
            zs, zt = t.dem.z[cell(t.dem, t.spawn_centre)], t.dem.z[cell(t.dem, t.targets[0])]
            assert (zs > zt + 5) if spawn_on == "top" else (zt > zs + 5)


def test_headings_turn_the_same_canyon_by_quarter_turns():
    fixed = {k: v[0] for k, v in DEFAULT_RANGES["canyon"].items() if k not in ("heading", "side", "spawn_on")}
    fixed.update(noise_m=0.0, side="left", spawn_on="top")
    tasks = {h: gen.canyon(np.random.default_rng(0), heading=h, **fixed) for h in gen.HEADINGS}
    zn = tasks["north"].dem.z
    turns = {}
    for h, t in tasks.items():
        d = t.targets[0] - t.spawn_centre
        assert np.dot(d / np.linalg.norm(d), gen.HEADINGS[h]) > 0.95  # travel goes the named way
        ks = [k for k in range(4) if np.array_equal(np.rot90(zn, k), t.dem.z)]
        assert len(ks) == 1
        turns[h] = ks[0]
        assert t.detour_side == "left"
    assert sorted(turns.values()) == [0, 1, 2, 3]


def test_hills_have_steep_features_but_open_spawn_and_target():
    for seed in range(10):
        t = task_for("hills", seed, n_blocks=[3, 3], n_pits=[2, 2])
        gy, gx = np.gradient(t.dem.z, t.dem.dx)
        assert np.degrees(np.arctan(np.hypot(gx, gy))).max() > 60  # blocks and pits have cliffs
        assert t.detour_side == "none" and t.passes.shape == (0, 2, 2)
        assert grid_solvable(t)


# -- the detour side --------------------------------------------------------------------------


def detour_routes(t):
    """(via left, via right): whether the target stays reachable from the spawn centre when every
    cell more than 3 cells to the right (left) of the straight line is closed."""
    ok, lat = passable_cells(t.dem), lateral(t)
    w0 = 3 * t.params["cell_m"]
    a, b = cell(t.dem, t.spawn_centre), cell(t.dem, t.targets[0])
    return connected(ok & (lat > -w0), a, b), connected(ok & (lat < w0), a, b)


EXPECTED = {"left": (True, False), "right": (False, True), "both": (True, True)}


def test_canyon_detours_left_and_right_equally_often_and_really_go_that_way():
    sides = []
    for seed in range(200):
        t = task_for("canyon", seed)
        assert t.detour_side == t.params["side"]
        assert detour_routes(t) == EXPECTED[t.detour_side], (seed, t.params)
        sides.append(t.detour_side)
    n_left, n_right = sides.count("left"), sides.count("right")
    assert 0.4 <= n_left / (n_left + n_right) <= 0.6
    assert stats.binomtest(n_left, n_left + n_right, 0.5).pvalue > 0.01
    assert 0.2 <= sides.count("both") / len(sides) <= 0.45


def test_mesa_detours_really_go_the_labelled_way():
    sides = []
    for seed in range(60):
        t = task_for("mesa", seed)
        assert t.detour_side == t.params["side"]
        assert detour_routes(t) == EXPECTED[t.detour_side], (seed, t.params)
        sides.append(t.detour_side)
    assert {"left", "right", "both"} <= set(sides)


def test_family_weights_and_the_uniform_mix():
    counts = {f: 0 for f in PARAMS}
    for seed in range(90):
        counts[generate(np.random.default_rng(seed)).family] += 1
    assert stats.chisquare(list(counts.values())).pvalue > 0.01
    assert all(generate(np.random.default_rng(s), {"canyon": 0.0, "mesa": 2.0}).family == "mesa" for s in range(5))


# -- solvable callback ------------------------------------------------------------------------


def test_solvable_redraws_from_the_same_stream_and_gives_up_after_max_tries():
    calls = []

    def reject_two(task):
        calls.append(task)
        return len(calls) > 2

    got = generate(np.random.default_rng(5), solvable=reject_two)
    rng = np.random.default_rng(5)
    plain = [generate(rng) for _ in range(3)]
    assert len(calls) == 3 and same(got, plain[2])
    assert all(same(c, p) for c, p in zip(calls, plain, strict=True))
    with pytest.raises(ScenarioError, match="no solvable task in 4 draws"):
        generate(np.random.default_rng(5), solvable=lambda t: False, max_tries=4)


def test_a_draw_that_does_not_fit_its_map_is_drawn_again_and_counts_toward_max_tries():
    """User ranges pass validate_ranges one key at a time; a canyon 30 m high on a 5 deg ramp
    fits only a map of about 375 m or more, so most draws of size 100-400 m misfit."""
    r = {"canyon": {"size_m": [100.0, 400.0], "cliff_m": [30.0, 30.0], "ramp_slope_deg": [5.0, 5.0]}}
    t = generate(np.random.default_rng(2), families=("canyon",), ranges=r)  # seed 2: the 2nd draw fits
    assert t.params["size_m"] > 375.0
    assert same(replay(t), t)
    with pytest.raises(ScenarioError, match="no solvable task in 1 draws .*last misfit: canyon: a pass"):
        generate(np.random.default_rng(2), families=("canyon",), ranges=r, max_tries=1)


def tin_route(task, tin):
    """Side ("left"/"right") of the shortest route over passable triangles from the spawn centre to
    the target (triangle adjacency, centroid hops), read where the route is halfway down; None when
    there is none."""
    passable = tin.slope_deg <= MAX_SLOPE
    n = len(tin.triangles)
    cen = tin.vertices[tin.triangles].mean(axis=1)  # (T, 3)
    t_idx, o_idx = np.repeat(np.arange(n), 3), tin.neighbors.ravel()
    keep = (o_idx >= 0) & passable[t_idx] & passable[np.maximum(o_idx, 0)]
    w = np.linalg.norm(cen[t_idx[keep], :2] - cen[o_idx[keep], :2], axis=1) + 1e-9
    graph = sparse.csr_matrix((w, (t_idx[keep], o_idx[keep])), shape=(n, n))
    s, g = tin.locate(np.array([task.spawn_centre, task.targets[0]]))
    if not (passable[s] and passable[g]):
        return None
    dist, pred = dijkstra(graph, indices=s, return_predecessors=True)
    if not np.isfinite(dist[g]):
        return None
    path = [g]
    while path[-1] != s:
        path.append(pred[path[-1]])
    z = cen[path, 2]
    mid = cen[path[int(np.argmin(np.abs(z - (z[0] + z[-1]) / 2)))], :2]
    d, r = task.targets[0] - task.spawn_centre, mid - task.spawn_centre
    return "left" if d[0] * r[1] - d[1] * r[0] > 0 else "right"


@pytest.mark.parametrize("family", ["canyon", "mesa", "hills"])
def test_tin_tasks_with_a_solvable_check_are_solvable_on_the_greedy_tin(family):
    """What the integrator does with cost_to_go: mesh each draw (greedy, 0.5 m) and keep it only if
    the target is reachable over passable triangles; the route then goes the labelled way, the
    straight line crosses a triangle the robots cannot drive, and 50 robots fit the spawn region."""
    from tin_swarm_env.terrain import build_tin
    from tin_swarm_env.world.spawn import spawn_positions

    tins = {}

    def solvable(task):
        tins[id(task)] = tin = build_tin(task.dem, method="greedy", max_error_m=0.5)
        return tin_route(task, tin) is not None

    for seed in range(8):
        t = generate(np.random.default_rng(seed), (family,), solvable=solvable)
        tin = tins[id(t)]
        side = tin_route(t, tin)
        if t.detour_side in ("left", "right"):
            assert side == t.detour_side, (seed, t.params)
        # the spawn region holds 50 robots 2 m apart on drivable triangles (the world's own sampler)
        steep = tin.slope_deg > MAX_SLOPE
        pos = spawn_positions(tin, steep, 50, np.random.default_rng(seed), region=t.spawn_region, min_separation_m=2.0)
        assert pos.shape == (50, 2)
        if family != "hills":
            s, g = t.spawn_centre, t.targets[0]
            line = s + np.linspace(0, 1, 1000)[:, None] * (g - s)
            assert tin.slope_deg[tin.locate(line)].max() > MAX_SLOPE


# -- parameters and their validation ----------------------------------------------------------


def test_every_parameter_is_in_the_module_docstring_table():
    rows = [ln.split() for ln in gen.__doc__.splitlines() if ln[:1] and not ln.startswith("=")]
    listed = {(r[0], r[1]) for r in rows if len(r) > 1}
    common = set(PARAMS["canyon"]) & set(PARAMS["mesa"]) & set(PARAMS["hills"])
    for fam, spec in PARAMS.items():
        for key in spec:
            assert (("(all)", key) if key in common else (fam, key)) in listed, (fam, key)


def test_draws_stay_inside_the_ranges():
    rng = np.random.default_rng(0)
    ranges = validate_ranges({"hills": {"n_blocks": [2, 3], "size_m": 250, "heading": ["east", "west"]}})
    seen = set()
    for _ in range(200):
        p = gen.draw_params(rng, "hills", ranges["hills"])
        assert p["n_blocks"] in (2, 3) and isinstance(p["n_blocks"], int)
        assert p["size_m"] == 250.0 and p["heading"] in ("east", "west")
        lo, hi = DEFAULT_RANGES["hills"]["hill_m"]
        assert lo <= p["hill_m"] <= hi
        seen.add(p["n_blocks"])
    assert seen == {2, 3}


@pytest.mark.parametrize("ranges,match", [
    ({"volcano": {}}, r"unknown terrain family 'volcano'"),
    ({"canyon": {"cliff_hieght_m": [1, 2]}}, r"family 'canyon' has no parameter 'cliff_hieght_m'"),
    ({"canyon": {"size_m": [400, 200]}}, r"canyon\.size_m: range \[400, 200\]"),
    ({"canyon": {"size_m": [200]}}, r"canyon\.size_m must be a \[lo, hi\] pair"),
    ({"canyon": {"size_m": ["a", "b"]}}, r"canyon\.size_m must be a \[lo, hi\] pair"),
    ({"canyon": {"size_m": [True, 300]}}, r"canyon\.size_m must be a \[lo, hi\] pair"),
    ({"canyon": {"cell_m": [0.0, 2.0]}}, r"canyon\.cell_m: range \[0\.0, 2\.0\] must have lo <= hi within"),
    ({"canyon": {"cell_m": [1.0, float("nan")]}}, r"canyon\.cell_m must be a \[lo, hi\] pair"),
    ({"hills": {"n_pits": [1.5, 3]}}, r"hills\.n_pits must be a \[lo, hi\] pair of integers"),
    ({"canyon": {"side": ["up"]}}, r"canyon\.side must be a non-empty list of \['left', 'right', 'both'\]"),
    ({"canyon": {"side": []}}, r"canyon\.side must be a non-empty list"),
    ({"mesa": "big"}, r"ranges for family 'mesa' must be a table"),
])
def test_bad_ranges_name_the_family_and_the_key(ranges, match):
    with pytest.raises(ScenarioError, match=r"^scen\.toml: " + match):
        generate(np.random.default_rng(0), ranges=ranges, where="scen.toml")


def test_other_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ScenarioError, match="unknown terrain family 'dunes'"):
        generate(rng, families=("canyon", "dunes"))
    with pytest.raises(ScenarioError, match="ranges given for family 'mesa', which is not among"):
        generate(rng, families=("canyon",), ranges={"mesa": {"size_m": 300}})
    with pytest.raises(ScenarioError, match="weights must be finite"):
        generate(rng, families={"canyon": -1.0})
    with pytest.raises(ScenarioError, match="no terrain families"):
        generate(rng, families=())
    with pytest.raises(ScenarioError, match="max_tries must be >= 1"):
        generate(rng, max_tries=0)
    with pytest.raises(ScenarioError, match="canyon: family 'canyon' has no parameter 'radius_frac'"):
        gen.canyon(rng, radius_frac=0.3)
    with pytest.raises(ScenarioError, match=r"mesa\.side must be a non-empty list"):
        gen.mesa(rng, side="up")
    with pytest.raises(ScenarioError, match="max_slope_deg must be within"):
        gen.hills(rng, max_slope_deg=80.0)
    # parameters that each pass their own bounds but do not fit together
    with pytest.raises(ScenarioError, match="canyon: a pass .* does not fit a 100 m map"):
        gen.canyon(rng, size_m=100.0, cliff_m=30.0, ramp_slope_deg=5.0)
    with pytest.raises(ScenarioError, match="mesa: the spawn region or target on top does not fit"):
        gen.mesa(rng, size_m=100.0, radius_frac=0.1, spawn_on="top", spawn_m=40.0)


@pytest.mark.parametrize("max_slope,cliff_deg", [(30.0, 60.0), (40.0, 65.0)])
def test_a_low_cliff_is_raised_until_it_is_steeper_than_the_cliff_minimum(max_slope, cliff_deg):
    for family, key in (("canyon", "cliff_m"), ("mesa", "mesa_m")):
        t = gen.FAMILIES[family](np.random.default_rng(0), **{key: 2.0}, cell_m=4.0, size_m=300.0, noise_m=0.0,
                                 max_slope_deg=max_slope)
        s, g = t.spawn_centre, t.targets[0]
        z = np.array([t.dem.z[cell(t.dem, s + f * (g - s))] for f in np.linspace(0, 1, 1000)])
        step_deg = np.degrees(np.arctan(np.abs(np.diff(z)).max() / 4.0))
        assert cliff_deg - 1e-9 <= step_deg < cliff_deg + 1.0
