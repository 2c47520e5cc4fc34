"""Shared policy pieces (policies/base.py): ``keep_clear`` against a slow obvious check, and the compiled
cut against the array version it replaced, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies.base import keep_clear


def _keep_clear_reference(a, rel, valid, gap, step, share):
    """Slow obvious check: after the move the robot is no nearer than allowed to any slot."""
    for j in range(rel.shape[0]):
        if valid[j] and np.hypot(*rel[j]) > 1e-9:
            u = rel[j] / np.hypot(*rel[j])
            assert a @ u <= max(np.hypot(*rel[j]) - gap, 0) / (share * step) + 1e-9


@given(st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.booleans()), min_size=1, max_size=4),
       st.floats(-1, 1), st.floats(-1, 1), st.floats(0.5, 5))
@settings(max_examples=200, deadline=None)
def test_keep_clear_never_closes_a_gap_too_fast_nor_adds_motion(slots, ax, ay, step):
    rel = np.array([[s[0], s[1]] for s in slots])[None]
    valid = np.array([[s[2] for s in slots]], dtype=float)
    a0 = np.array([[ax, ay]])
    a = keep_clear(a0, rel, valid, 1.5, step, passes=50)[0]
    _keep_clear_reference(a, rel[0], valid[0], 1.5, step, 2.0)
    assert np.hypot(*a) <= np.hypot(ax, ay) + 1e-9  # only removes


def _keep_clear_arrays(action, rel, valid, gap_m, step_m, share=2.0, passes=2):
    """:func:`keep_clear` as it was written in numpy before it was compiled (kept here as the
    reference of the compiled one: the same bits)."""
    a = np.array(action, dtype=np.float64)
    d = np.sqrt(np.sum(rel * rel, axis=-1))
    ok = (np.asarray(valid) > 0.5) & (d > 1e-9)
    u = rel / np.maximum(d, 1e-9)[..., None]
    limit = np.maximum(d - gap_m, 0.0) / (share * step_m)
    for _ in range(passes):
        for j in range(rel.shape[1]):
            excess = np.sum(a * u[:, j], axis=-1) - limit[:, j]
            cut = np.where(ok[:, j] & (excess > 0), excess, 0.0)
            a -= cut[:, None] * u[:, j]
    return a


_coord = st.floats(-30, 30) | st.sampled_from([0.0, -0.0, 1e-10, 1.5, -1.5])


@given(st.integers(1, 6), st.integers(0, 5), st.data(), st.sampled_from([1.0, 2.0]), st.integers(1, 3))
@settings(max_examples=150, deadline=None)
def test_the_compiled_cut_is_the_array_cut_bit_for_bit(n, k, data, share, passes):
    rel = np.array(data.draw(st.lists(_coord, min_size=n * k * 2, max_size=n * k * 2)), dtype=np.float64)
    rel = rel.reshape(n, k, 2)
    valid = np.array(data.draw(st.lists(st.sampled_from([0.0, 1.0, True, False]), min_size=n * k,
                                        max_size=n * k)), dtype=float).reshape(n, k)
    a0 = np.array(data.draw(st.lists(st.floats(-1, 1) | st.just(-0.0), min_size=2 * n, max_size=2 * n))).reshape(n, 2)
    got = keep_clear(a0, rel, valid, 1.5, 0.5, share=share, passes=passes)
    ref = _keep_clear_arrays(a0, rel, valid, 1.5, 0.5, share=share, passes=passes)
    assert got.tobytes() == ref.tobytes()  # the same bits, signed zeros included
    assert a0.tobytes() == np.array(a0).tobytes()  # the input is not written


def test_keep_clear_refuses_mismatched_shapes_by_name():
    with pytest.raises(ArgumentError, match="keep_clear"):
        keep_clear(np.zeros((3, 2)), np.zeros((2, 4, 2)), np.ones((2, 4)), 1.5, 0.5)
