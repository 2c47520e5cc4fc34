"""VIP significance and selection (thesis 2.1)."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tin_swarm_env.terrain import Dem, build_tin, vertical_error, vip_select, vip_significance


def grid(z, dx=1.0, dy=1.0):
    z = np.asarray(z, dtype=float)
    return Dem(z, dx * np.arange(z.shape[1]), dy * np.arange(z.shape[0]))


def perp(z0, za, zb, d):
    """Perpendicular distance from (0, z0) to the line through (-d, za) and (d, zb)."""
    # line: a*x + b*z + c = 0 through the two points
    a, b = zb - za, -2 * d
    c = -(a * -d + b * za)
    return abs(a * 0 + b * z0 + c) / math.hypot(a, b)


def slow_significance(z, dx, dy, border):
    rows, cols = z.shape
    out = np.zeros_like(z)
    pairs = [(1, 0, dy), (0, 1, dx), (1, 1, math.hypot(dx, dy)), (1, -1, math.hypot(dx, dy))]
    for r in range(rows):
        for c in range(cols):
            vals = []
            for dr, dc, d in pairs:
                ra, ca, rb, cb = r - dr, c - dc, r + dr, c + dc
                if 0 <= ra < rows and 0 <= rb < rows and 0 <= ca < cols and 0 <= cb < cols:
                    vals.append(perp(z[r, c], z[ra, ca], z[rb, cb], d))
            out[r, c] = np.mean(vals) if vals else 0.0
            if border == "none" and (r in (0, rows - 1) or c in (0, cols - 1)):
                out[r, c] = 0.0
    for r, c in [(0, 0), (0, cols - 1), (rows - 1, 0), (rows - 1, cols - 1)]:
        out[r, c] = np.inf
    return out


def test_thesis_figure_2_1_centre_value():
    # a 3x3 window: centre 10 with all neighbours 8 (flat pairs) -> each pair distance 2
    z = np.full((3, 3), 8.0)
    z[1, 1] = 10.0
    s = vip_significance(grid(z))
    assert s[1, 1] == pytest.approx(2.0)
    # tilted pair: neighbours 0 and 2 at +-1 m, centre 3 -> vertical offset 2,
    # perpendicular = 2 * 2 / sqrt(4 + 4) = sqrt(2)
    z = np.array([[0, 0, 0], [0, 3, 2], [0, 0, 0]], dtype=float)
    s = vip_significance(grid(z))
    # pairs: N-S (0,0): 3; W-E (0,2): sqrt2; diagonals (0,0): 3 each
    assert s[1, 1] == pytest.approx((3 + math.sqrt(2) + 3 + 3) / 4)


@given(arrays(np.float64, st.tuples(st.integers(2, 7), st.integers(2, 7)),
              elements=st.floats(-500, 500, allow_nan=False)),
       st.floats(0.5, 100), st.floats(0.5, 100), st.sampled_from(["line", "none"]))
def test_vectorised_equals_slow_loop(z, dx, dy, border):
    fast = vip_significance(grid(z, dx, dy), border=border)
    slow = slow_significance(z, dx, dy, border)
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)


def test_plane_has_zero_significance_and_border_rule():
    yy, xx = np.mgrid[0:5, 0:6]
    z = 3.0 * xx - 2.0 * yy
    s = vip_significance(grid(z))
    inner = s[~np.isinf(s)]
    np.testing.assert_allclose(inner, 0.0, atol=1e-12)
    # a bump on the border row: 'line' sees it through the along-border pair, 'none' does not
    z = np.zeros((4, 5))
    z[0, 2] = 7.0
    assert vip_significance(grid(z), border="line")[0, 2] == pytest.approx(7.0)
    assert vip_significance(grid(z), border="none")[0, 2] == 0.0


def test_selection_by_count_and_threshold():
    rng = np.random.default_rng(3)
    z = rng.normal(0, 10, (20, 30))
    dem = grid(z, 10, 10)
    for n in (4, 10, 57, 600):
        keep = vip_select(dem, max_vertices=n, backbone=0.0)
        assert keep.sum() == n
        assert keep[0, 0] and keep[0, -1] and keep[-1, 0] and keep[-1, -1]
    keep = vip_select(dem, max_vertices=57, backbone=0.0)
    s = vip_significance(dem)
    # every kept non-corner cell is at least as significant as every dropped one
    kept = s[keep & np.isfinite(s)]
    dropped = s[~keep]
    assert kept.min() >= dropped.max()
    keep_t = vip_select(dem, min_significance_m=5.0, backbone=0.0)
    np.testing.assert_array_equal(keep_t, s >= 5.0)
    with pytest.raises(ValueError, match="exactly one"):
        vip_select(dem)
    with pytest.raises(ValueError, match=">= 4"):
        vip_select(dem, max_vertices=3)


def test_backbone_lattice_includes_borders_and_keeps_the_count():
    rng = np.random.default_rng(4)
    dem = grid(rng.normal(0, 1, (40, 50)), 5, 5)
    keep = vip_select(dem, max_vertices=300, backbone=0.5)
    assert keep.sum() == 300
    assert keep[0].sum() >= 4 and keep[-1].sum() >= 4 and keep[:, 0].sum() >= 4


def test_plain_vip_keeps_no_border_points_and_backbone_fixes_jacksboro(jacksboro):
    """The measured failure of thesis VIP on jacksboro, and the fix."""
    plain = vip_select(jacksboro, max_vertices=10000, border="none", backbone=0.0)
    border = np.zeros_like(plain)
    border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
    assert plain[border].sum() == 4  # the corners only
    st_plain, _ = vertical_error(build_tin(jacksboro, max_vertices=10000, border="none", backbone=0.0), jacksboro)
    st_def, _ = vertical_error(build_tin(jacksboro, max_vertices=10000), jacksboro)
    assert st_plain.max_m > 500
    assert st_def.max_m < st_plain.max_m / 3
    assert st_def.rms_m < 0.6 * st_plain.rms_m
