"""The network layers of a policy file (policies/network.py): the compiled dense kernel equals its plain
version and numpy."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 7), d=st.integers(1, 9), m=st.integers(1, 9), seed=st.integers(0, 2**32 - 1))
def test_dense_kernel_equals_its_plain_version_and_numpy(n, d, m, seed):
    from tin_swarm_env.policies.learned import dense

    rng = np.random.default_rng(seed)
    x, W, b = rng.normal(size=(n, d)) * 3, rng.normal(size=(m, d)), rng.normal(size=m)
    got = dense(x, W, b)
    assert got.shape == (n, m) and got.dtype == np.float64
    np.testing.assert_allclose(got, dense.py_func(x, W, b), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got, x @ W.T + b, rtol=1e-12, atol=1e-12)
