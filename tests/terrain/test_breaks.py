"""Terrain breaks on hand-built TINs with known answers."""

import numpy as np
import pytest

from tin_swarm_env.terrain import ANGLE, BORDER, STEEP, Tin


def cliff_tin():
    """Flat plateau at 100 m for x <= 100, a 1-triangle-wide cliff face down to 0 m at
    x = 110, flat floor beyond, over y in [0, 100]."""
    xs = np.array([0.0, 100.0, 110.0, 200.0])
    zs = np.array([100.0, 100.0, 0.0, 0.0])
    pts = [(x, y, z) for x, z in zip(xs, zs) for y in (0.0, 100.0)]
    return Tin.from_points(np.array(pts))


def test_cliff_edges_face_the_safe_side_with_the_drop():
    tin = cliff_tin()
    assert set(np.round(tin.slope_deg)) == {0.0, round(np.degrees(np.arctan(10.0)))}
    br = tin.breaks(max_slope_deg=30, break_angle_deg=None)
    steep = br.kinds == STEEP
    assert steep.sum() == 2
    seg = br.segments[steep]
    xs = sorted(seg[:, 0, 0])
    assert xs == [100.0, 110.0]
    for s, n, d in zip(seg, br.normals[steep], br.drops_m[steep]):
        if s[0, 0] == 100.0:  # cliff top: safe side is the plateau (west), ground falls away
            np.testing.assert_allclose(n, [-1, 0], atol=1e-12)
            assert d == pytest.approx(100.0)
        else:  # cliff foot: safe side is the floor (east), ground rises: a wall
            np.testing.assert_allclose(n, [1, 0], atol=1e-12)
            assert d == pytest.approx(-100.0)
    border = br.kinds == BORDER
    assert border.sum() == int((tin.neighbors < 0).sum())
    # border normals point inward
    mid = br.segments[border, :, :2].mean(axis=1)
    probe = mid + 1e-3 * br.normals[border]
    assert np.all(tin.locate(probe) >= 0)


def test_angle_breaks_between_two_traversable_planes():
    # a gentle roof ridge along y: both sides 10 deg, so 20 deg between their normals
    g = np.tan(np.radians(10))
    pts = np.array([[0, 0, 0], [0, 100, 0], [100, 0, 100 * g], [100, 100, 100 * g],
                    [200, 0, 0], [200, 100, 0]], float)
    tin = Tin.from_points(pts)
    br = tin.breaks(max_slope_deg=30, break_angle_deg=15)
    ang = br.kinds == ANGLE
    assert ang.sum() == 1
    np.testing.assert_allclose(br.segments[ang][0, :, 0], [100, 100])
    assert br.drops_m[ang][0] == pytest.approx(100 * g)
    assert tin.breaks(max_slope_deg=30, break_angle_deg=25).kinds.tolist().count(ANGLE) == 0
    # diagonal edges inside each flat side are no break
    assert (tin.breaks(30, 15).kinds != BORDER).sum() == 1


def test_nearest_break():
    tin = cliff_tin()
    br = tin.breaks(max_slope_deg=30, break_angle_deg=None)
    d, j = br.nearest([[90.0, 50.0], [50.0, 50.0]], range_m=20)
    assert d[0] == pytest.approx(10.0) and br.kinds[j[0]] == STEEP
    assert j[1] == -1 and np.isinf(d[1])
    with pytest.raises(ValueError, match="max_slope_deg"):
        tin.breaks(max_slope_deg=0)


def test_closest_on_segments_clamps_to_the_end_points():
    from tin_swarm_env.terrain.breaks import closest_on_segments

    a, b = np.array([0.0, 0.0]), np.array([10.0, 0.0])
    pts = np.array([[-3.0, 4.0], [4.0, -2.0], [13.0, 4.0], [10.0, 0.0]])
    c, d = closest_on_segments(pts, a, b)
    np.testing.assert_array_equal(c, [[0.0, 0.0], [4.0, 0.0], [10.0, 0.0], [10.0, 0.0]])
    np.testing.assert_array_equal(d, [5.0, 2.0, 5.0, 0.0])
