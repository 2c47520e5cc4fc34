"""research/sensing_bound.py (run by hand): its planner against a slow obvious reference, and its
idealised robot on hand-built rasters with exact answers."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import lil_matrix
from scipy.sparse.csgraph import dijkstra

ROOT = Path(__file__).resolve().parents[2]


def _study():
    spec = importlib.util.spec_from_file_location("research_sensing_bound", ROOT / "research" / "sensing_bound.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("research_sensing_bound", mod)  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


B = _study()


def _reference(blocked, s, t):
    """Dijkstra over the 8-connected open cells, a diagonal only where both cells it cuts are open."""
    nx, ny = blocked.shape
    g = lil_matrix((nx * ny, nx * ny))
    for a in range(nx):
        for b in range(ny):
            if blocked[a, b]:
                continue
            for da in (-1, 0, 1):
                for db in (-1, 0, 1):
                    na, nb = a + da, b + db
                    if (da, db) == (0, 0) or not (0 <= na < nx and 0 <= nb < ny) or blocked[na, nb]:
                        continue
                    if da and db and (blocked[a + da, b] or blocked[a, b + db]):
                        continue
                    g[a * ny + b, na * ny + nb] = np.hypot(da, db)
    return dijkstra(g.tocsr(), indices=s[0] * ny + s[1])[t[0] * ny + t[1]]


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 9), st.integers(2, 9), st.integers(0, 2 ** 32 - 1), st.floats(0.0, 0.5))
def test_shortest_way_has_the_reference_length_and_is_a_way(nx, ny, seed, p):
    rng = np.random.default_rng(seed)
    blocked = rng.random((nx, ny)) < p
    s, t = (0, 0), (nx - 1, ny - 1)
    blocked[s] = blocked[t] = False
    way, length = B.shortest_way(blocked, *s, *t)
    ref = _reference(blocked, s, t)
    assert length == pytest.approx(ref) if np.isfinite(ref) else (np.isinf(length) and len(way) == 0)
    if len(way):
        assert tuple(way[0]) == s and tuple(way[-1]) == t and not blocked[way[:, 0], way[:, 1]].any()
        steps = np.diff(way, axis=0)
        assert np.abs(steps).max() == 1 and np.all(np.abs(steps).sum(1) > 0)
        assert np.hypot(*steps.T).sum() == pytest.approx(length)
        for (a, b), (da, db) in zip(way[:-1], steps, strict=True):  # no corner cutting
            assert not (da and db and (blocked[a + da, b] or blocked[a, b + db]))


def _wall_with_gap(gap_at):
    """A 60 x 60 m raster of 1 m cells: a wall along y = 30 m from x = 0 to 60 but for a 4 m gap at x
    in [gap_at, gap_at + 4); one break along the wall (normal toward the start, y < 30)."""
    unsafe = np.zeros((60, 60), bool)
    unsafe[:, 30] = True
    unsafe[gap_at:gap_at + 4, 30] = False
    seg = np.array([[[0.0, 30.0], [float(gap_at), 30.0]], [[gap_at + 4.0, 30.0], [60.0, 30.0]]])
    return B.Raster(unsafe=unsafe, res=1.0, x0=0.0, y0=0.0, seg=seg, danger=np.array([True, True]),
                    normal=np.array([[0.0, -1.0], [0.0, -1.0]]))


def _meets(seg, a, b, eps=1e-7):
    """The segment meets cell (a, b)'s closed square grown by ``eps`` (Liang-Barsky clip: slow, obvious)."""
    p, d = seg[0], seg[1] - seg[0]
    t0, t1 = 0.0, 1.0
    for k, lo, hi in ((0, a - eps, a + 1 + eps), (1, b - eps, b + 1 + eps)):
        if abs(d[k]) < 1e-15:
            if not lo <= p[k] <= hi:
                return False
            continue
        u, v = sorted(((lo - p[k]) / d[k], (hi - p[k]) / d[k]))
        t0, t1 = max(t0, u), min(t1, v)
    return t0 <= t1


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(st.floats(0.0, 12.0), st.integers(0, 24).map(lambda k: k / 2)), min_size=4, max_size=4))
def test_mark_crossed_marks_exactly_the_cells_a_dangerous_break_meets(xy):
    """Endpoints anywhere, and on cell corners and edges (half-integers: a walk that overshot its end
    there once marked the segment's extension)."""
    seg = np.array([[xy[:2], xy[2:]]])
    unsafe = np.zeros((12, 12), bool)
    B.mark_crossed(unsafe, seg, np.array([True]), 1.0)
    t = np.linspace(0.0, 1.0, 40001)[:, None]
    pts = np.minimum(seg[0, 0] + t * (seg[0, 1] - seg[0, 0]), 11.999999)
    hit = np.zeros_like(unsafe)
    hit[pts[:, 0].astype(int), pts[:, 1].astype(int)] = True
    assert unsafe[hit].all()  # every cell the segment passes through
    for a, b in zip(*np.nonzero(unsafe)):
        assert _meets(seg[0], a, b)  # and no cell it does not meet
    spared = np.zeros_like(unsafe)
    B.mark_crossed(spared, seg, np.array([False]), 1.0)
    assert not spared.any()  # a break that is not dangerous marks nothing


def test_mark_crossed_stops_at_a_segment_ending_on_a_cell_corner():
    unsafe = np.zeros((40, 40), bool)
    B.mark_crossed(unsafe, np.array([[[0.0, 30.0], [10.0, 20.0]]]), np.array([True]), 1.0)
    a, b = np.nonzero(unsafe)
    assert a.max() <= 10 and b.min() >= 19 and len(a) <= 33  # the diagonal's cells and the neighbours at its 11 corners


def test_a_pinch_between_two_steep_triangles_is_shut():
    """Two narrow steep wedges touching at one vertex V, one pointing up and one down: the open
    ground left and right meets only at V. Cells judged by their centres leave a way through V
    (the raster artefact); with the wedges' edges marked (mark_crossed) there is none."""
    v, half = np.array([10.0, 10.0]), np.radians(10.0)
    ang = np.arctan2(np.arange(20)[None, :] + 0.5 - v[1], np.arange(20)[:, None] + 0.5 - v[0])
    steep = (np.abs(ang - np.pi / 2) < half) | (np.abs(ang + np.pi / 2) < half)
    assert np.isfinite(B.shortest_way(steep, 2, 10, 17, 10)[1])  # centres only: a way through V
    ends = [v + 14 * np.array([np.cos(t), np.sin(t)]) for t in
            (np.pi / 2 - half, np.pi / 2 + half, -np.pi / 2 - half, -np.pi / 2 + half)]
    seg = np.array([[v, e] for e in ends])
    unsafe = steep.copy()
    B.mark_crossed(unsafe, seg, np.ones(4, bool), 1.0)
    assert not unsafe[2, 10] and not unsafe[17, 10]
    assert np.isinf(B.shortest_way(unsafe, 2, 10, 17, 10)[1])


def test_on_open_ground_the_robot_drives_straight_at_top_speed():
    ras = B.Raster(unsafe=np.zeros((40, 40), bool), res=1.0, x0=0.0, y0=0.0, seg=np.zeros((0, 2, 2)),
                   danger=np.zeros(0, bool), normal=np.zeros((0, 2)))
    for sensing in ("disk", "segments", "points"):
        kw = dict(sensing=sensing, k=3, range_m=10.0, step_m=1.0, arrive_m=0.5)
        assert B.drive(ras, (5.5, 5.5), (5.5, 35.5), max_steps=100, **kw) == (30, 0)  # 30 m at 1 m a step
        assert B.drive(ras, (5.5, 5.5), (5.5, 35.5), max_steps=20, **kw) == (21, 0)  # not by then


@pytest.mark.parametrize("gap_at", [8, 48])  # the gap to the left and to the right of the straight line
def test_a_robot_that_sees_the_wall_whole_goes_to_the_gap_sooner_than_one_that_sees_points(gap_at):
    ras = _wall_with_gap(gap_at)
    start, target = (30.5, 5.5), (30.5, 55.5)
    kw = dict(k=3, range_m=25.0, step_m=1.0, arrive_m=0.5, max_steps=1000)
    (disk, f1), (seg, f2), (pts, f3) = (B.drive(ras, start, target, sensing=s, **kw)
                                        for s in ("disk", "segments", "points"))
    assert f1 == f2 == f3 == 0
    # the least it can drive: to the wall row (y = 30) within the gap, across it, on to the target
    xs = np.linspace(gap_at, gap_at + 4, 401)
    least = np.hypot(xs - start[0], 30 - start[1]).min() + 1 + np.hypot(xs - target[0], target[1] - 31).min()
    way, length = B.shortest_way(ras.unsafe, 30, 5, 30, 55)  # on the raster, knowing the map (cells = m)
    assert len(way) and least <= min(disk, seg, pts) and pts < 1000
    # seeing the wall from 25 m, the disk and segments robots turn toward the gap before they reach the
    # wall: each drives at most the known-map way plus its first 25 m toward the wall and back
    assert max(disk, seg) <= length + 2 * 25
    assert pts > max(disk, seg)  # seeing only the wall's closest point, it finds the gap later


def test_a_robot_whose_marks_shut_every_way_forgets_them_and_never_arrives_where_none_is():
    ras = B.Raster(unsafe=np.zeros((20, 20), bool), res=1.0, x0=0.0, y0=0.0, seg=np.zeros((0, 2, 2)),
                   danger=np.zeros(0, bool), normal=np.zeros((0, 2)))
    ras.unsafe[:, 10] = True  # a wall right across
    n, forgot = B.drive(ras, (5.5, 2.5), (5.5, 17.5), sensing="disk", k=3, range_m=5.0, step_m=1.0, arrive_m=0.5,
                        max_steps=500)
    assert n == 501 and forgot > 0
    ras.unsafe[0, 10] = False  # a gap at the wall's end, 5 m off the straight line
    n, forgot = B.drive(ras, (5.5, 2.5), (5.5, 17.5), sensing="disk", k=3, range_m=5.0, step_m=1.0, arrive_m=0.5,
                        max_steps=500)
    assert n < 40 and forgot == 0


def test_bad_options_are_refused_by_name(capsys):
    for argv, word in ((["--seed-offsets", "a"], "--seed-offsets"), (["--jacksboro-window", "1,2,0,4"],
                                                                      "--jacksboro-window"),
                       (["--res", "0"], "--res"), (["--chart-cells", "2"], "--chart-cells"),
                       (["--chart-cells", ""], "--chart-cells")):
        with pytest.raises(SystemExit):
            B.main(argv)
        assert word in capsys.readouterr().err
