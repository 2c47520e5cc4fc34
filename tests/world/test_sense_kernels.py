"""The parallel sensing, collision and locomotion kernels: bit-identical for any thread count
and to the same loops run as plain Python (``py_func``, the serial reference), on random swarms."""

import math
from contextlib import contextmanager

import numba
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tin_swarm_env.world import BatteryParams, RobotParams, SensorParams, World, WorldParams, sensing, spawn_positions
from tin_swarm_env.world import batch_kernels as BK
from tin_swarm_env.world import locomotion as L
from tin_swarm_env.world import reference as REF
from tin_swarm_env.world import sense_kernels as SK
from tin_swarm_env.world import step_kernel as SPK
from tin_swarm_env.world import world as world_mod
from tin_swarm_env.world.state import Reason

THREADS = min(2, numba.config.NUMBA_NUM_THREADS)


@contextmanager
def threads(k):
    old = numba.get_num_threads()
    numba.set_num_threads(k)
    try:
        yield
    finally:
        numba.set_num_threads(old)


@contextmanager
def plain_python(monkeypatch):
    """Every parallel kernel of a world step and sensing replaced by its uncompiled loop."""
    with monkeypatch.context() as m:
        m.setattr(world_mod, "step_copies", SPK.step_copies.py_func)
        for name in ("move_all", "collisions"):
            m.setattr(SPK, name, getattr(SPK, name).py_func)
        for name in ("_sense_passes", "_sense1", "_sense2"):
            m.setattr(BK, name, getattr(BK, name).py_func)
        m.setattr(L, "move_walk", L.move_walk.py_func)
        m.setattr(REF, "move_kernel", REF.move_kernel.py_func)
        yield


def _world(random_tin, seed, sensor, k_ent=3, n=30):
    rng = np.random.default_rng(seed)
    p = WorldParams(robot=RobotParams(max_slope_deg=25.0, max_climb_deg=40.0, radius_m=8.0),
                    sensor=SensorParams(**sensor), battery=BatteryParams(), break_angle_deg=10.0)
    w = World(random_tin(seed, 40, zscale=60), p)
    if (~w.steep).sum() == 0:
        return None, None, None
    pos = spawn_positions(w.tin, w.steep, n, rng)
    ents = spawn_positions(w.tin, w.steep, 2 * k_ent, rng)
    s = w.reset(rng, pos, targets=ents[:k_ent], assets=ents[k_ent:], targets_mobile=True)
    s.status[rng.random(n) < 0.15] = Reason.FELL
    s.status[rng.random(n) < 0.15] = Reason.BATTERY
    return w, s, rng


def _flat(readings):
    """Every array of a SensorReadings, in a fixed order."""
    out = []
    for part in (readings.robots, readings.targets, readings.assets, readings.breaks):
        out += [np.asarray(getattr(part, f)) for f in part.__dataclass_fields__]
    return out + [readings.tilt_rad, readings.slope_deg, readings.aspect_deg]


def _flat_step(state, events):
    return [state.positions, state.headings, state.tri_idx, state.heights, state.battery_j, state.status,
            state.collisions, events.collisions, events.collision_pairs, events.motion_event]


def _assert_same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes()  # bit for bit (NaN and -0.0 included)


def _run(w, s, cmds):
    out = []
    for c in cmds:
        s, ev = w.step(s, c)
        out += _flat_step(s, ev) + _flat(w.sense(s))
    return out


@settings(max_examples=12)
@given(st.integers(0, 10_000), st.integers(2, 40), st.floats(30, 400), st.floats(30, 360), st.booleans(),
       st.integers(1, 12))
def test_step_and_sensing_are_bit_identical_for_1_and_2_threads_and_plain_python(random_tin, seed, n, range_m, fov,
                                                                                 los, k):
    sensor = {"range_m": range_m, "fov_deg": fov, "check_los": los, "max_candidates": k}
    w, s, rng = _world(random_tin, seed, sensor, n=n)
    assume(w is not None)  # a random TIN with no drivable triangle has nowhere to spawn
    cmds = rng.uniform(-1.2, 1.2, (3, n, 2))
    with threads(1):
        one = _run(w, s, cmds)
    with threads(THREADS), pytest.MonkeyPatch.context() as mp:
        mp.setattr(world_mod, "SERIAL_BELOW", 0)  # small swarms run on one thread: here the parallel path
        two = _run(w, s, cmds)
    _assert_same(one, two)
    with pytest.MonkeyPatch.context() as mp, plain_python(mp):
        ref = _run(w, s, cmds[:1])
    _assert_same(one[:len(ref)], ref)


def test_mutual_sight_is_walked_once_and_copied_to_both_slots():
    """Two robots facing each other across a ridge and two in the open: each pair's two
    slots agree, and equal the Tin's own line of sight."""
    v = np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0], [50, 0, 30], [50, 100, 30]], float)
    from tin_swarm_env.terrain import Tin

    tin = Tin(v, [[0, 4, 5], [0, 5, 3], [4, 1, 2], [4, 2, 5]])
    robot = RobotParams(max_slope_deg=60.0, max_climb_deg=60.0)
    w = World(tin, WorldParams(robot=robot, sensor=SensorParams(range_m=150)))
    pos = np.array([[10, 20], [90, 20], [10, 80], [30, 80]], float)
    s = w.reset(0, pos, headings=np.array([0.0, math.pi, 0.0, math.pi]))
    seen = w.sense(s).robots.as_set()
    z = s.heights + w.params.sensor.height_m
    los = tin.line_of_sight(np.column_stack([pos[[0, 2]], z[[0, 2]]]), np.column_stack([pos[[1, 3]], z[[1, 3]]]))
    assert not los[0] and los[1]
    assert {(2, 3), (3, 2)} <= seen and not {(0, 1), (1, 0)} & seen


def test_break_contacts_are_nearest_first_and_complete(random_tin):
    w, s, _ = _world(random_tin, 5, {"range_m": 150.0}, n=25)
    b = w.sense(s).breaks
    seg = w.breaks.segments[:, :, :2]
    for i in range(s.n_robots):
        rows = slice(b.start[i], b.start[i + 1])
        assert np.all(b.observer[rows] == i)
        assert np.all(np.diff(b.distance_m[rows]) >= 0)
        if s.status[i] != 0:
            assert b.start[i + 1] == b.start[i]
            continue
        _, d = sensing_closest(s.positions[i], seg)
        assert set(b.break_idx[rows].tolist()) == set(np.flatnonzero(d <= 150.0).tolist())


def sensing_closest(p, seg):
    from tin_swarm_env.terrain.breaks import closest_on_segments

    return closest_on_segments(p, seg[:, 0], seg[:, 1])


def test_contacts_nearest_fast_path_equals_the_sort(random_tin):
    w, s, _ = _world(random_tin, 11, {"range_m": 300.0}, n=40)
    r = w.sense(s)
    for part in (r.robots, r.targets, r.breaks):
        rows_fast = sensing._rows(part, s.n_robots, 4)
        rows_sort = sensing.nearest_k(part.observer, part.distance_m, s.n_robots, 4)
        np.testing.assert_array_equal(rows_fast, rows_sort)
        slow = type(part)(*(getattr(part, f) for f in part.__dataclass_fields__ if f != "start"))  # no CSR
        for a, b in zip(part.nearest(s.n_robots, 4), slow.nearest(s.n_robots, 4), strict=True):
            np.testing.assert_array_equal(a, b)


@settings(max_examples=15)
@given(st.integers(0, 10_000), st.integers(1, 60))
def test_fused_move_kernel_equals_the_numpy_locomotion(random_tin, seed, n):
    """World.step's fused pass against locomotion.move (the numpy reference): positions,
    triangles, events and speeds bit for bit, headings to rounding (numpy's vectorised atan2)."""
    w, s, rng = _world(random_tin, seed, {"range_m": 60.0}, n=n)
    assume(w is not None)
    P = w.params
    T = SK.terrain_arrays(w.tin)
    events = set()
    for _ in range(4):
        c = rng.uniform(-1.5, 1.5, (n, 2)) * rng.uniform(0, 30)
        ref = L.move(w.tin, w.steep, s.positions, s.tri_idx, s.headings, s.status, c, P.robot, P.dt_s)
        got = REF.move_kernel(T, w.steep, s.positions, s.tri_idx, s.headings, s.heights, s.active, c,
                            P.robot.max_speed_mps, P.robot.max_climb_deg, math.radians(P.robot.turn_rate_dps) * P.dt_s,
                            P.dt_s)
        for k in (0, 1, 3, 4):
            np.testing.assert_array_equal(got[k], ref[k])
        np.testing.assert_allclose(got[2], ref[2], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(got[5], w.tin.height_in(ref[0], ref[1]))
        events |= set(got[4].tolist())
        s, _ = w.step(s, c)


@settings(max_examples=20)
@given(st.integers(0, 10_000), st.integers(0, 300), st.integers(1, 12))
def test_compact_keeps_the_visible_slots_in_order_with_their_bearings(seed, n, k):
    rng = np.random.default_rng(seed)
    m = max(n, 1)
    idx = rng.integers(-5, m, (n, k))
    dist = rng.uniform(0, 100, (n, k))
    vis = (rng.random((n, k)) < 0.7).astype(np.int8)
    cnt = rng.integers(0, k + 1, n)
    px, py, ex, ey = (rng.uniform(0, 100, m) for _ in range(4))
    head = rng.uniform(-math.pi, math.pi, m)
    want = SK.compact(idx, dist, vis, cnt, px, py, head, ex, ey)
    _assert_same(list(SK.compact.py_func(idx, dist, vis, cnt, px, py, head, ex, ey)), list(want))
    rows = [(i, int(idx[i, s]), dist[i, s],
             (math.atan2(ey[idx[i, s]] - py[i], ex[idx[i, s]] - px[i]) - head[i] + math.pi) % (2 * math.pi) - math.pi)
            for i in range(n) for s in range(cnt[i]) if idx[i, s] >= 0 and vis[i, s]]
    assert [(int(a), int(b), c, d) for a, b, c, d in zip(*want[:4])] == rows
    assert want[4].tolist() == [0] + np.cumsum([sum(1 for r in rows if r[0] == i) for i in range(n)]).tolist()


def test_small_swarms_run_on_one_thread_and_large_ones_on_all(random_tin, monkeypatch):
    """World.step and World.sense drop to one numba thread below SERIAL_BELOW robots (and
    restore the count after), and keep every thread from SERIAL_BELOW on; the results are the same."""
    w, s, rng = _world(random_tin, 3, {"range_m": 60.0}, n=20)
    seen = []
    kernel = world_mod.step_copies

    def spy(*a):
        seen.append(numba.get_num_threads())
        return kernel(*a)

    monkeypatch.setattr(world_mod, "step_copies", spy)
    cmds = rng.uniform(-1, 1, (1, 20, 2))
    with threads(THREADS):
        small = _run(w, s, cmds)
        assert seen == [1] and numba.get_num_threads() == THREADS
        monkeypatch.setattr(world_mod, "SERIAL_BELOW", 20)
        large = _run(w, s, cmds)
        assert seen == [1, THREADS]
    _assert_same(small, large)


def _exact_in_view(dx, dy, heading, half_fov):
    return abs((math.atan2(dy, dx) - heading + math.pi) % (2 * math.pi) - math.pi) <= half_fov


@settings(max_examples=40)
@given(st.integers(0, 10_000), st.floats(1.0, 360.0))
def test_the_dot_product_field_of_view_decides_as_the_bearing_test(seed, fov_deg):
    """Points on the edge of the field of view (bearings within 1e-16..1e-6 rad of +-fov/2, and
    exactly on it), at 1 mm..10 km, and at zero distance: the same decision as the atan2 test."""
    rng = np.random.default_rng(seed)
    half_fov = math.radians(fov_deg) / 2 + 1e-12
    cos_hf = math.cos(half_fov)
    n = 400
    head = rng.uniform(-math.pi, math.pi, n)
    off = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-16, -6, n)
    off[:40] = 0.0
    side = rng.choice([-1.0, 1.0], n)
    ang = head + side * (half_fov + off)
    d = 10.0 ** rng.uniform(-3, 4, n)
    dx, dy = d * np.cos(ang), d * np.sin(ang)
    dx[:5] = dy[:5] = 0.0
    got, want = [], []
    for i in range(n):
        dist = math.sqrt(dx[i] * dx[i] + dy[i] * dy[i])
        got.append(SK.in_view(dx[i], dy[i], dist, math.cos(head[i]), math.sin(head[i]), head[i], half_fov, cos_hf))
        want.append(_exact_in_view(dx[i], dy[i], head[i], half_fov))
    assert got == want
    assert (0 < sum(want) < n) or half_fov >= math.pi  # both sides of the edge were met


def test_deep_inside_means_the_sight_start_search_keeps_the_triangle(random_tin):
    """For points deep inside their triangle, the nudged start point of every sight line (1e-6 m,
    or 1e-3 of a shorter segment) is located in that same triangle; points on an edge or a vertex
    are never deep."""
    tin = random_tin(3, 60)
    T = SK.terrain_arrays(tin)
    margin = SK.deep_margin(tin)
    rng = np.random.default_rng(0)
    v = tin.vertices[:, :2]
    deep_seen = 0
    for t in rng.integers(0, tin.n_triangles, 200):
        a, b, c = v[tin.triangles[t]]
        for w in (rng.dirichlet([1, 1, 1]), np.array([1 - 1e-9, 5e-10, 5e-10]), np.array([0.5, 0.5, 0.0]),
                  np.array([1.0, 0.0, 0.0]), np.array([0.5 - 1e-8, 0.5, 1e-8])):
            x, y = w @ np.array([a, b, c])
            deep = SK.deep_inside(T, x, y, int(t), margin)
            if w.min() == 0.0:
                assert not deep
            if not deep:
                continue
            deep_seen += 1
            for length in 10.0 ** rng.uniform(-9, 3, 20):
                ang = rng.uniform(-math.pi, math.pi)
                dx, dy = length * math.cos(ang), length * math.sin(ang)
                f = min(1e-6 / math.hypot(dx, dy), 1e-3)
                assert SK.locate1(T, x + dx * f, y + dy * f, int(t)) == t
    assert deep_seen > 150


def test_an_entity_s_sight_is_tin_line_of_sight_and_compiled_out_of_line(random_tin):
    """sight_of_entity (what entity_row calls for each target and asset in view) answers as the TIN's own
    line of sight, and is a call, not an inlined copy: inlined, the sensing pass's parallel loop carried two
    more copies of the triangle walk, and compiled ~80 s longer (2026-12-03, empty cache)."""
    assert SK.sight_of_entity.targetoptions.get("inline", "never") == "never"
    tin = random_tin(5, 80)
    T = SK.terrain_arrays(tin)
    rng = np.random.default_rng(1)
    x0, y0, x1, y1 = tin.bounds
    a = rng.uniform([x0, y0], [x1, y1], (300, 2))
    b = rng.uniform([x0, y0], [x1, y1], (300, 2))
    za = tin.height_at(a) + rng.uniform(0, 30, 300)
    zb = tin.height_at(b) + rng.uniform(0, 30, 300)
    ta = tin.locate(a)
    want = tin.line_of_sight(np.column_stack([a, za]), np.column_stack([b, zb]))
    got = [SK.sight_of_entity(T, *a[k], za[k], *b[k], zb[k], int(ta[k]), False) for k in range(300)]
    assert 0 < sum(want) < 300  # both answers met
    np.testing.assert_array_equal(np.array(got, dtype=bool), np.asarray(want, dtype=bool))


_SORT = []


def _sort_contacts():
    """A compiled caller of the inline ``sort_contacts`` (made once)."""
    if not _SORT:
        from tin_swarm_env.world.sense_kernels import sort_contacts

        @numba.njit
        def run(d, s, c, p0, m):
            sort_contacts(d, s, c, p0, m)

        _SORT.append(run)
    return _SORT[0]


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 120), st.integers(0, 2 ** 31), st.integers(1, 6))
def test_sort_contacts_orders_by_distance_then_index(m, seed, levels):
    """Insertion below SORT_BY_INSERTION, a merge sort above: both the (distance, index) order of
    np.lexsort, with many ties (distances drawn from a few levels), the rows before p0 untouched."""
    from tin_swarm_env.world.sense_kernels import SORT_BY_INSERTION

    run = _sort_contacts()
    rng = np.random.default_rng(seed)
    p0 = 3
    d = np.concatenate([[9.0, 8.0, 7.0], rng.integers(0, levels, m) * 0.5])
    s = np.concatenate([[5, 4, 3], np.sort(rng.choice(10 * m + 10, m, replace=False))]).astype(np.int64)
    c = rng.normal(size=(m + p0, 2))
    c[p0:, 0] = s[p0:]  # a point that travels with its segment
    order = np.lexsort((s[p0:], d[p0:]))
    want_d, want_s = d[p0:][order], s[p0:][order]
    run(d, s, c, p0, m)
    np.testing.assert_array_equal(d[p0:], want_d)
    np.testing.assert_array_equal(s[p0:], want_s)
    np.testing.assert_array_equal(c[p0:, 0], want_s)
    assert d[:p0].tolist() == [9.0, 8.0, 7.0] and s[:p0].tolist() == [5, 4, 3]
    assert SORT_BY_INSERTION < 120  # both branches are drawn


# -- the break grid: each cell lists every segment within range of a point of it, in index order

@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 31), st.floats(1.0, 80.0), st.integers(1, 60), st.sampled_from([1.0, 20.0, 150.0]))
def test_the_break_grid_lists_every_segment_in_range_of_a_point_of_its_cell(seed, r, m, spread):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-100, 100, (m, 2))
    b = a + rng.normal(0, spread, (m, 2))
    ax, ay, bx, by = (np.ascontiguousarray(v) for v in (a[:, 0], a[:, 1], b[:, 0], b[:, 1]))
    x0, y0, inv, nx, ny, start, items = SK.break_grid(ax, ay, bx, by, r, -120.0, -120.0, 120.0, 120.0)
    cs = 1.0 / inv
    grid_pts = [(x0 + i * cs, y0 + j * cs) for i in range(0, nx, max(nx // 6, 1)) for j in range(0, ny, max(ny // 6, 1))]
    for x, y in np.concatenate([rng.uniform(-125, 125, (200, 2)), np.array(grid_pts).reshape(-1, 2)]):
        lo, hi, gridded = SK.break_range(start, x0, y0, inv, nx, ny, 0, m, x, y)
        got = items[lo:hi] if gridded else np.arange(m)
        assert np.all(np.diff(got) > 0)  # ascending segment index
        near = [e for e in range(m) if SK._closest(x, y, ax[e], ay[e], bx[e], by[e])[2] <= r]
        assert set(near) <= set(got.tolist())


def test_cell_distance_is_the_distance_to_the_square():
    """Against a dense sampling of the square and the segment (the sampled distance is an upper bound
    within the sampling step); a segment across the square is within a diagonal."""
    rng = np.random.default_rng(1)
    u = np.linspace(0.0, 1.0, 81)
    for _ in range(200):
        ax, ay, bx, by = rng.uniform(-30, 30, 4)
        cx, cy, cs = *rng.uniform(-10, 10, 2), rng.uniform(0.5, 8.0)
        sx, sy = ax + u * (bx - ax), ay + u * (by - ay)
        qx = np.clip(sx, cx, cx + cs)
        qy = np.clip(sy, cy, cy + cs)
        sampled = np.hypot(sx - qx, sy - qy).min()
        d = SK.cell_distance(ax, ay, bx, by, cx, cy, cs)
        step = np.hypot(bx - ax, by - ay) / 80
        if sampled <= step:  # across (or at) the square: within a diagonal
            assert d <= max(sampled + 1e-9, cs * math.sqrt(2) + 1e-9)
        else:
            assert sampled - step - 1e-9 <= d <= sampled + 1e-9


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2 ** 31), st.floats(0.5, 200.0), st.sampled_from([0.0, 1e-3, 1.0, 50.0, 1e4]),
       st.sampled_from([0.0, 1e3, 5e6]), st.floats(-1e-6, 1e-6))
def test_range_class_agrees_with_the_exact_distance_outside_its_band(seed, r, length, base, rel):
    """On points at random and at the range's edge (within 1e-6 of it, on either side: the band and
    just outside it), near segments of every length, at coordinates up to UTM's."""
    rng = np.random.default_rng(seed)
    lo2, hi2 = r * r * (1 - SK.RANGE_BAND), r * r * (1 + SK.RANGE_BAND)
    for _ in range(20):
        a = base + rng.uniform(-100, 100, 2)
        b = a + length * rng.normal(0, 1, 2)
        u = rng.uniform(-0.5, 1.5)
        foot = a + min(max(u, 0.0), 1.0) * (b - a)
        n = rng.normal(0, 1, 2)
        if 0.0 < u < 1.0 and np.hypot(*(b - a)) > 0:
            n = np.array([-(b - a)[1], (b - a)[0]])
        p = foot + r * (1 + rel) * n / np.hypot(*n)
        for x, y in (p, base + rng.uniform(-150, 150, 2)):
            d = SK._closest(x, y, a[0], a[1], b[0], b[1])[2]
            v = SK.range_class(x, y, a[0], a[1], b[0], b[1], lo2, hi2)
            assert v == 2 or (v == 1) == (d <= r)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2 ** 31), st.floats(0.5, 200.0), st.sampled_from([0.0, 1e-3, 1.0, 50.0, 1e4]),
       st.sampled_from([0.0, 1e3, 5e6]), st.floats(-1e-6, 1e-6))
def test_out_of_range_is_range_class_saying_clearly_out(seed, r, length, base, rel):
    """The branch-free test is range_class's ``0`` (with ``lo2 = 0``): on points at random and at the
    range's edge, on segments of every length (points too), and at a segment's ends and its feet."""
    rng = np.random.default_rng(seed)
    hi2 = r * r * (1 + SK.RANGE_BAND)
    for _ in range(20):
        a = base + rng.uniform(-100, 100, 2)
        b = a + length * rng.normal(0, 1, 2)
        n = rng.normal(0, 1, 2)
        pts = [base + rng.uniform(-150, 150, 2), a, b, a + r * (1 + rel) * n / np.hypot(*n),
               b + r * (1 + rel) * n / np.hypot(*n)]
        if length:
            perp = np.array([-(b - a)[1], (b - a)[0]])
            pts.append(a + rng.uniform(0, 1) * (b - a) + r * (1 + rel) * perp / max(np.hypot(*perp), 1e-300))
        for x, y in pts:
            want = SK.range_class(x, y, a[0], a[1], b[0], b[1], 0.0, hi2) == 0
            assert SK.out_of_range(x, y, a[0], a[1], b[0], b[1], hi2) == want
            assert SK.out_of_range.py_func(x, y, a[0], a[1], b[0], b[1], hi2) == want


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([0.0, 1e-3, 1.0, 50.0, 1e4]), st.sampled_from([0.0, 1e3, 5e6]),
       st.sampled_from([1e-3, 1.0, 60.0, 500.0]))
def test_sq_dist_is_the_squared_distance_within_the_keep_tolerance(seed, length, base, spread):
    """sq_dist's ``num / den`` is the squared distance _closest gives (to its ends, feet and points at
    random; on segments of every length, points too, far from the origin), off by far less than the tolerance
    break_row's nearest-kept filter allows (:data:`KEEP_TOL` of a 1 m range): the filter never drops a
    segment that _closest would keep."""
    rng = np.random.default_rng(seed)
    for _ in range(20):
        a = base + rng.uniform(-100, 100, 2)
        b = a + length * rng.normal(0, 1, 2)
        for x, y in (a, b, (a + b) / 2, a + spread * rng.normal(0, 1, 2), b + spread * rng.normal(0, 1, 2)):
            num, den = SK.sq_dist(x, y, a[0], a[1], b[0], b[1])
            d = SK._closest(x, y, a[0], a[1], b[0], b[1])[2]
            assert den > 0.0 and num >= 0.0
            assert abs(np.sqrt(num / den) - d) < 1e-9 * (1 + d) + 1e-15 * (abs(x) + abs(y) + length) * 16
            assert abs(np.sqrt(num / den) - d) < SK.KEEP_TOL
            assert SK.out_of_range(x, y, a[0], a[1], b[0], b[1], 2.0) == (num > 2.0 * den)


# -- break_row: the vector env's break contacts kept as the observation reads them, with the scan

_ROW = []


def _break_row_runs():
    """Compiled runners: break_row over every segment (ungridded), and the list path it replaces
    (gather_breaks sorted, then the observation's scan_beams over the list)."""
    if not _ROW:
        from tin_swarm_env.env.observation import scan_beams

        @numba.njit
        def row(x, y, ax, ay, bx, by, items, r, S, OB, c, s):
            W = SK.break_scratch(S[3].shape[1])
            SK.break_row(0, x, y, (ax, ay, bx, by, items), 0, ax.shape[0], False, r, S, OB, c, s, W)

        @numba.njit
        def listed(x, y, ax, ay, bx, by, items, r, danger, ends, units, c, s, K):
            m = ax.shape[0]
            dist, seg, cl, obs = np.empty(m), np.empty(m, np.int64), np.empty((m, 2)), np.empty(m, np.int64)
            n = SK.count_breaks(x, y, ax, ay, bx, by, items, 0, m, False, r)
            SK.gather_breaks(0, x, y, ax, ay, bx, by, items, 0, m, False, r, 0, dist, seg, cl, obs)
            out = np.zeros((1, max(K, 1)))
            pos = np.array([[x, y]])
            start = np.array([0, n], dtype=np.int64)
            if K:
                scan_beams(out, 0, 0, K, start, seg, ends, units, danger, pos, c, s, r, np.empty((K, 3)))
            return n, dist[:n].copy(), seg[:n].copy(), cl[:n].copy(), out

        _ROW.extend([row, listed])
    return _ROW


@settings(max_examples=120, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([0, 1, 2, 7, 40, SK.BREAK_CHUNK, SK.BREAK_CHUNK + 1, 300]),
       st.integers(0, 4), st.sampled_from([0, 1, 5, 32]),
       st.sampled_from([0.0, 0.5, 4.0]), st.floats(-math.pi, math.pi))
def test_break_row_keeps_the_nearest_and_the_scan_of_the_listed_contacts(seed, m, kb, K, grain, heading):
    """break_row's ``kb`` slots are the first ``kb`` of the sorted contact list (distance, then index;
    ``grain`` > 0 puts segment ends on a grid of that step, so distances tie) and its scan is the
    observation's scan_beams over that list, bit for bit; empty slots read -1, a robot with no
    dangerous contact reads a clear scan (1)."""
    from tin_swarm_env.env.observation import ObsLayout

    row, listed = _break_row_runs()
    rng = np.random.default_rng(seed)
    a = rng.uniform(-70, 70, (m, 2))
    b = a + rng.normal(0, 15, (m, 2))
    if grain:
        a, b = np.round(a / grain) * grain, np.round(b / grain) * grain
    ax, ay, bx, by = (np.ascontiguousarray(v) for v in (a[:, 0], a[:, 1], b[:, 0], b[:, 1]))
    ends = np.ascontiguousarray(np.column_stack([a, b]))
    danger = (rng.uniform(size=m) < 0.7).astype(np.float64)
    units = ObsLayout(k_scan=K).scan_units()
    c, s = math.cos(heading), math.sin(heading)
    items = np.zeros(0, dtype=np.int64)
    r = 60.0
    S = (np.full((1, kb), 7, np.int64), np.zeros((1, kb)), np.zeros((1, kb, 2)), np.zeros((1, K)))
    row(0.0, 0.0, ax, ay, bx, by, items, r, S, (danger, ends, units), c, s)
    n, dist, seg, cl, scan = listed(0.0, 0.0, ax, ay, bx, by, items, r, danger, ends, units, c, s, K)
    k = min(kb, n)
    np.testing.assert_array_equal(S[0][0, :k], seg[:k])
    np.testing.assert_array_equal(S[1][0, :k], dist[:k])
    np.testing.assert_array_equal(S[2][0, :k], cl[:k])
    assert (S[0][0, k:] == -1).all()
    if K:
        np.testing.assert_array_equal(S[3][0], scan[0, :K])
        if not (danger[seg] != 0).any():
            assert (S[3][0] == 1.0).all()
