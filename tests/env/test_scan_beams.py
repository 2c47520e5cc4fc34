"""The scan's beams (:func:`~tin_swarm_env.env.observation.scan_beams`): each contact crossed with
the beams of its wedge only (:func:`~tin_swarm_env.env.observation.beam_span`) gives the same bits
as every beam crossed with every contact (the plain loop below), compiled and as plain Python, on
random segments and on the ones that strain the wedge: ends at the robot, segments through it,
edge-on ones, long and tiny ones, and headings far from 0."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.env.observation import ANGLE_ERROR, SPAN_MARGIN, approx_angle, beam_span, scan_beams


def every_beam(K, ends, danger, x, y, head, R):
    """The scan by every beam against every dangerous segment (the obvious loop)."""
    out = np.empty(K)
    bearings = 2 * np.pi * np.arange(K) / K
    for k in range(K):
        a = head + bearings[k]
        dx, dy = np.cos(a), np.sin(a)
        best = R
        for j in range(len(ends)):
            if danger[j] == 0.0:
                continue
            ex, ey = ends[j, 2] - ends[j, 0], ends[j, 3] - ends[j, 1]
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            wx, wy = ends[j, 0] - x, ends[j, 1] - y
            t = (wx * ey - wy * ex) / den
            u = (wx * dy - wy * dx) / den
            if -1e-12 <= u <= 1.0 + 1e-12 and 0.0 <= t < best:
                best = t
        out[k] = best / R
    return out


def _run(kernel, K, ends, danger, x, y, head, R):
    obs = np.full((1, K + 3), -7.0)
    start = np.array([0, len(ends)], dtype=np.int64)
    idx = np.arange(len(ends), dtype=np.int64)
    kernel(obs, 0, 3, K, start, idx, ends, 2 * np.pi * np.arange(K) / K, danger, np.array([[x, y]]),
           np.array([head]), math.cos(head), math.sin(head), R, np.full((K, 4), np.nan))
    return obs[0, 3:]


coord = st.floats(-80.0, 80.0, allow_nan=False)


@st.composite
def segments(draw, x, y):
    """A segment near the robot at (x, y), of one of the shapes that strain the wedge."""
    kind = draw(st.sampled_from(["free", "free", "end_at_robot", "through_robot", "edge_on", "near_end", "tiny",
                                 "long"]))
    a = np.array([draw(coord), draw(coord)])
    b = np.array([draw(coord), draw(coord)])
    p = np.array([x, y])
    if kind == "end_at_robot":
        a = p.copy()
    elif kind == "through_robot":
        b = 2 * p - a
    elif kind == "edge_on":
        b = p + draw(st.floats(1.1, 3.0)) * (a - p)
    elif kind == "near_end":
        a = p + draw(st.floats(-1e-9, 1e-9)) * np.array([1.0, draw(st.floats(-1.0, 1.0))])
    elif kind == "tiny":
        b = a + draw(st.floats(-1e-6, 1e-6))
    elif kind == "long":
        b = a + 1e4 * (b - a)
    return [a[0], a[1], b[0], b[1]]


@settings(max_examples=400, deadline=None)
@given(st.data(), st.sampled_from([1, 2, 3, 4, 5, 8, 16, 32, 33, 64, 256]), coord, coord,
       st.floats(-1e4, 1e4, allow_nan=False), st.integers(0, 12))
def test_the_wedge_scan_equals_every_beam_against_every_segment(data, K, x, y, head, m):
    ends = np.array([data.draw(segments(x, y)) for _ in range(m)], dtype=np.float64).reshape(-1, 4)
    danger = np.array([data.draw(st.sampled_from([1.0, 1.0, 0.0])) for _ in range(m)])
    want = every_beam(K, ends, danger, x, y, head, 60.0)
    np.testing.assert_array_equal(_run(scan_beams.py_func, K, ends, danger, x, y, head, 60.0), want)
    np.testing.assert_array_equal(_run(scan_beams, K, ends, danger, x, y, head, 60.0), want)


def test_the_wedge_scan_on_a_dense_random_field():
    """Many segments around many robots: every beam's range the same bits (and some beams hit)."""
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(200):
        a = rng.uniform(-60, 60, (40, 2))
        ends = np.column_stack([a, a + rng.normal(0, 8, (40, 2))])
        danger = (rng.random(40) < 0.8).astype(np.float64)
        x, y, head = *rng.uniform(-20, 20, 2), rng.uniform(-10, 10)
        for K in (7, 32):
            want = every_beam(K, ends, danger, x, y, head, 60.0)
            np.testing.assert_array_equal(_run(scan_beams, K, ends, danger, x, y, head, 60.0), want)
            hits += int((want < 1.0).sum())
    assert hits > 1000


def test_approx_angle_is_within_its_error():
    ang = np.linspace(-math.pi, math.pi, 200_001)
    for r in (1e-9, 1.0, 1e6):
        got = np.array([approx_angle(r * math.cos(t), r * math.sin(t)) for t in ang[::97]])
        want = np.arctan2(r * np.sin(ang[::97]), r * np.cos(ang[::97]))
        err = np.abs((got - want + np.pi) % (2 * np.pi) - np.pi)
        assert err.max() < ANGLE_ERROR


def test_beam_span_covers_the_wedge_and_no_more_than_it_needs():
    """A segment seen across 0.3 rad at bearing 1 rad from the heading (5.09 .. 6.62 steps of 32): beam
    6 lies in it, beam 5 within SPAN_MARGIN of it, and the span takes no more."""
    step = 2 * math.pi / 32
    h = 0.25
    a = 30 * np.array([math.cos(h + 1.0), math.sin(h + 1.0)])
    b = 30 * np.array([math.cos(h + 1.3), math.sin(h + 1.3)])
    lo, hi = beam_span(a[0], a[1], b[0], b[1], math.cos(h), math.sin(h), 32)
    assert lo <= math.ceil((1.0 - SPAN_MARGIN) / step) == 5 and hi >= math.floor((1.3 + SPAN_MARGIN) / step) == 6
    assert hi - lo + 1 <= 3
    assert beam_span(a[0], a[1], b[0], b[1], math.cos(h), math.sin(h), 32) == \
        beam_span(b[0], b[1], a[0], a[1], math.cos(h), math.sin(h), 32)  # either end first
    assert beam_span(0.0, 0.0, 5.0, 5.0, 1.0, 0.0, 32) == (0, 31)  # an end at the robot: every beam
    assert beam_span(-5.0, 1e-9, 5.0, 0.0, 1.0, 0.0, 32) == (0, 31)  # the robot on the segment: every beam
