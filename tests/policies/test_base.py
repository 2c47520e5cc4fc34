"""Shared policy pieces (policies/base.py): ``keep_clear`` against a slow obvious check."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

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
