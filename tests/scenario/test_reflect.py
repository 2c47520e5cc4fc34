"""Reflections (scenario/_reflect.py): points, regions and axis composition by hand; a mirrored TIN has
the original's elevation and slope at the reflected point; a mirrored DEM is its grid reversed."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.scenario._reflect import MIRRORS, compose, mirror_dem, mirror_tin, reflect_region, reflect_xy
from tin_swarm_env.terrain import Dem, Tin


def test_reflections_by_hand():
    b = (10.0, 20.0, 110.0, 70.0)  # middle (60, 45)
    p = [[10.0, 20.0], [30.0, 60.0]]
    assert reflect_xy(p, "ns", b).tolist() == [[10.0, 70.0], [30.0, 30.0]]
    assert reflect_xy(p, "ew", b).tolist() == [[110.0, 20.0], [90.0, 60.0]]
    assert reflect_xy(p, "both", b).tolist() == [[110.0, 70.0], [90.0, 30.0]]
    assert reflect_xy(p, "", b).tolist() == p
    assert reflect_region((20.0, 25.0, 40.0, 35.0), "ns", b) == (20.0, 55.0, 40.0, 65.0)
    assert reflect_region((20.0, 25.0, 40.0, 35.0), "ew", b) == (80.0, 25.0, 100.0, 35.0)
    assert reflect_region(None, "ns", b) is None
    assert [compose(a, a) for a in MIRRORS] == ["", "", "", ""]
    assert compose("ns", "ew") == "both" and compose("both", "ns") == "ew" and compose("", "ew") == "ew"
    with pytest.raises(ArgumentError, match="'x'"):
        reflect_xy(p, "x", b)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), axis=st.sampled_from(["ns", "ew", "both"]))
def test_mirrored_tin_has_the_original_elevation_and_slope_at_the_mirrored_point(seed, axis):
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-50, 150, 40), rng.uniform(5, 60, 40), rng.uniform(0, 30, 40)])
    tin = Tin.from_points(pts)
    m = mirror_tin(tin, axis)
    x0, y0, x1, y1 = tin.bounds
    assert m.bounds == pytest.approx(tin.bounds, abs=1e-12)
    q = rng.uniform((x0, y0), (x1, y1), (300, 2))
    q = q[tin.locate(q) >= 0]  # points of the convex hull
    qm = reflect_xy(q, axis, tin.bounds)
    assert (m.locate(qm) >= 0).all()
    np.testing.assert_allclose(m.height_at(qm), tin.height_at(q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(m.slope_at(qm), tin.slope_at(q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(m.areas.sum(), tin.areas.sum(), rtol=1e-12)
    assert mirror_tin(tin, "") is tin


def test_mirrored_dem_is_the_grid_reversed():
    z = np.arange(12.0).reshape(3, 4)
    d = Dem(z, [0.0, 1.0, 2.0, 3.0], [0.0, 2.0, 4.0])
    assert mirror_dem(d, "ns").z.tolist() == z[::-1].tolist()
    assert mirror_dem(d, "ew").z.tolist() == z[:, ::-1].tolist()
    assert mirror_dem(d, "both").z.tolist() == z[::-1, ::-1].tolist()
    assert mirror_dem(d, "ns").x.tolist() == d.x.tolist() and mirror_dem(d, "ns").y.tolist() == d.y.tolist()
