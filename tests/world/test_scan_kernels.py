"""The terrain scan's per-robot code (world/scan_kernels.py): beam directions turned by the heading,
and one segment crossed with the beams of its wedge, on hand-built cases with exact answers; many
segments' wedges in passes (scan_wedges) against one segment at a time on random fields; the branch-free
beam_span against the branching one it replaced. (The
wedge against every beam on random segments: tests/env/test_observation.py; break_row against the
list path: tests/world/test_sense_kernels.py.)"""

import math

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.world.scan_kernels import SPAN_MARGIN, beam_span, scan_contact, scan_start, scan_wedges


@pytest.mark.parametrize("heading", [0.0, 0.7, -2.5, math.pi])
def test_scan_start_sets_every_beam_to_the_range_along_the_heading_turned_by_its_bearing(heading):
    K = 8
    b = np.full((K, 3), np.nan)
    scan_start(b, math.cos(heading), math.sin(heading), ObsLayout(k_scan=K).scan_units(), 60.0, K)
    ang = heading + 2 * np.pi * np.arange(K) / K
    assert (b[:, 0] == 60.0).all()
    np.testing.assert_allclose(b[:, 1], np.cos(ang), atol=1e-15)
    np.testing.assert_allclose(b[:, 2], np.sin(ang), atol=1e-15)


def test_scan_contact_crosses_only_the_beams_of_its_wedge_and_keeps_the_nearer():
    """Heading east, 4 beams (east, north, west, south): a wall x = 10 (y -5..5) is met by the east
    beam at 10; a wall y = 7 (x -1..1) by the north beam at 7; a farther wall x = 20 leaves the east
    beam at 10 (the nearer kept); the west and south beams meet nothing."""
    K = 4
    b = np.empty((K, 3))
    scan_start(b, 1.0, 0.0, ObsLayout(k_scan=K).scan_units(), 60.0, K)
    scan_contact(b, 20.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # x = 20, from (20, -5) up 10
    assert b[0, 0] == 20.0
    scan_contact(b, 10.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # x = 10
    scan_contact(b, -1.0, 7.0, 2.0, 0.0, 1.0, 0.0, K)  # y = 7
    assert b[:, 0].tolist() == [10.0, 7.0, 60.0, 60.0]
    scan_contact(b, 30.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # farther again: no change
    assert b[0, 0] == 10.0


def test_scan_wedges_crosses_the_hand_built_walls_as_scan_contact():
    """The walls above at once: the east beam at 10 (the nearer of x = 10 and x = 20), the north at 7."""
    K = 4
    b = np.empty((K, 3))
    scan_start(b, 1.0, 0.0, ObsLayout(k_scan=K).scan_units(), 60.0, K)
    geo = np.ascontiguousarray(np.array([[20.0, -5.0, 0.0, 10.0], [10.0, -5.0, 0.0, 10.0], [-1.0, 7.0, 2.0, 0.0]]).T)
    scan_wedges(b, geo, 3, np.full((8, 2), -1, np.int64), 1.0, 0.0, K, np.full((2, 3), 99, np.int64))
    assert b[:, 0].tolist() == [10.0, 7.0, 60.0, 60.0]


@numba.njit
def _both(geo, units, c, s, K, R):
    """The scan of the segments ``geo`` one at a time (scan_contact) and by scan_wedges."""
    one = np.empty((K, 3))
    two = np.empty((K, 3))
    scan_start(one, c, s, units, R, K)
    scan_start(two, c, s, units, R, K)
    for j in range(geo.shape[0]):
        scan_contact(one, geo[j, 0], geo[j, 1], geo[j, 2], geo[j, 3], c, s, K)
    m = geo.shape[0]
    scan_wedges(two, np.ascontiguousarray(geo.T), m, np.empty((2 * m + 2, 2), np.int64), c, s, K,
                np.empty((2, m), np.int64))
    return one[:, 0].copy(), two[:, 0].copy()


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([1, 2, 3, 4, 7, 32, 33, 64]), st.integers(0, 60),
       st.floats(-10.0, 10.0), st.sampled_from(["free", "near", "through", "tiny"]))
def test_scan_wedges_equals_one_segment_at_a_time(seed, K, m, heading, kind):
    """Random segments around the robot (anywhere, some ends next to it, some through it, tiny ones):
    every beam's best is the same bits as scan_contact's, compiled and as plain Python."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-70, 70, (m, 2))
    e = rng.normal(0, 15, (m, 2))
    if kind == "near":
        a = rng.uniform(-1e-3, 1e-3, (m, 2)) * rng.choice([1.0, 1e-6], (m, 1))
    elif kind == "through":
        e = -2 * a
    elif kind == "tiny":
        e = rng.normal(0, 1e-6, (m, 2))
    geo = np.ascontiguousarray(np.column_stack([a, e]))
    units = ObsLayout(k_scan=K).scan_units()
    c, s = math.cos(heading), math.sin(heading)
    one, two = _both(geo, units, c, s, K, 60.0)
    assert one.view(np.int64).tolist() == two.view(np.int64).tolist()
    one, two = _both.py_func(geo, units, c, s, K, 60.0)
    assert one.view(np.int64).tolist() == two.view(np.int64).tolist()


def _approx_angle_ref(x, y):
    """approx_angle as it was, with branches (the reference for the branch-free one)."""
    ax, ay = abs(x), abs(y)
    a = min(ax, ay) / max(ax, ay)
    s = a * a
    r = ((-0.0464964749 * s + 0.15931422) * s - 0.327622764) * s * a + a
    if ay > ax:
        r = 0.5 * math.pi - r
    if x < 0.0:
        r = math.pi - r
    return -r if y < 0.0 else r


def _beam_span_ref(ax, ay, bx, by, c, s, K):
    """beam_span as it was, with early returns (the reference for the branch-free one)."""
    step = 2.0 * math.pi / K
    tiny2 = 2e-12 * ((bx - ax) ** 2 + (by - ay) ** 2 + 1.0)
    if ax * ax + ay * ay < tiny2 or bx * bx + by * by < tiny2:
        return 0, K - 1
    fa = _approx_angle_ref(c * ax + s * ay, c * ay - s * ax)
    fb = _approx_angle_ref(c * bx + s * by, c * by - s * bx)
    if ax * by - ay * bx < 0.0:
        fa, fb = fb, fa
    span = fb - fa
    if span < 0.0:
        span += 2.0 * math.pi
    if span > math.pi - 2.0 * step:
        return 0, K - 1
    lo = math.ceil((fa - SPAN_MARGIN) * (K / (2.0 * math.pi)))
    hi = math.floor((fa + span + SPAN_MARGIN) * (K / (2.0 * math.pi)))
    if hi - lo + 1 >= K:
        return 0, K - 1
    return int(lo), int(hi)


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([1, 2, 3, 4, 7, 32, 33, 64]), st.floats(-10.0, 10.0),
       st.sampled_from(["free", "near", "through", "tiny", "axis", "zero"]))
def test_branch_free_beam_span_is_the_branching_one(seed, K, heading, kind):
    """The branch-free beam_span (compiled and as plain Python) gives the (lo, hi) of the branching one it
    replaced on segments anywhere, with an end next to or at the robot, through it, tiny, on the axes."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-70, 70, (40, 2))
    e = rng.normal(0, 15, (40, 2))
    if kind == "near":
        a = rng.uniform(-1e-3, 1e-3, (40, 2)) * rng.choice([1.0, 1e-6], (40, 1))
    elif kind == "through":
        e = -2 * a
    elif kind == "tiny":
        e = rng.normal(0, 1e-6, (40, 2))
    elif kind == "axis":
        a = np.round(a / 10) * 10
        a[:, rng.integers(2)] = 0.0
        e = np.round(e / 5) * 5
    elif kind == "zero":
        a[::2] = 0.0
    c, s = math.cos(heading), math.sin(heading)
    for (ax, ay), (ex, ey) in zip(a, e):
        want = _beam_span_ref(ax, ay, ax + ex, ay + ey, c, s, K)
        assert beam_span(ax, ay, ax + ex, ay + ey, c, s, K) == want
        assert beam_span.py_func(ax, ay, ax + ex, ay + ey, c, s, K) == want
