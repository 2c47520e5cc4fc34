"""wrap_pi against Python's and numba's float modulo, bit for bit (sign of zero, NaN included)."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from tin_swarm_env.world.angles import TWO_PI, wrap_pi


@njit
def _wrap_all(a):
    out = np.empty_like(a)
    for i in range(a.shape[0]):
        out[i] = wrap_pi(a[i])
    return out


@njit
def _mod_all(a):
    out = np.empty_like(a)
    for i in range(a.shape[0]):
        out[i] = (a[i] + math.pi) % (2 * math.pi) - math.pi
    return out


def _edges():
    """Every branch boundary of wrap_pi (x = a + pi at 0, C, 2C, -C) and its float neighbours."""
    base = [0.0, -0.0, math.pi, -math.pi, TWO_PI, -TWO_PI, 3 * math.pi, -3 * math.pi, 2 * TWO_PI, 5 * math.pi,
            TWO_PI - math.pi, 2 * TWO_PI - math.pi, -TWO_PI - math.pi, 1e-300, -1e-300, 5e-324, 1e300, -1e300,
            math.inf, -math.inf, math.nan]
    a = np.array(base)
    out = [a]
    up, down = a.copy(), a.copy()
    for _ in range(4):
        up, down = np.nextafter(up, np.inf), np.nextafter(down, -np.inf)
        out += [up, down]
    return np.concatenate(out)


def _same(x, y):
    return np.asarray(x, np.float64).tobytes() == np.asarray(y, np.float64).tobytes()


def test_wrap_pi_equals_the_modulo_at_every_branch_boundary():
    a = _edges()
    want = np.array([(v + math.pi) % (2 * math.pi) - math.pi for v in a.tolist()])  # Python's float %
    assert _same(_wrap_all(a), want)
    assert _same(_mod_all(a), want)
    assert _same(np.array([wrap_pi.py_func(v) for v in a.tolist()]), want)
    with np.errstate(invalid="ignore"):
        assert _same((a + np.pi) % (2 * np.pi) - np.pi, want)  # numpy's, as the numpy references use it


@settings(max_examples=200)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=50),
       st.lists(st.floats(-4 * math.pi, 4 * math.pi), min_size=1, max_size=50))
def test_wrap_pi_equals_the_modulo_on_any_float(anything, angles):
    a = np.array(anything + angles)
    want = np.array([(v + math.pi) % (2 * math.pi) - math.pi for v in a.tolist()])
    assert _same(_wrap_all(a), want)


def test_wrap_pi_lands_in_minus_pi_to_pi_and_keeps_the_angle():
    a = np.random.default_rng(0).uniform(-20, 20, 10_000)
    w = _wrap_all(a)
    assert np.all((w >= -math.pi) & (w <= math.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
