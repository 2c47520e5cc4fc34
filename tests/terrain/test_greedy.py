"""The greedy mesher (terrain/greedy.py) against pydelatin/hmm's own error figure."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.terrain import build_tin, vertical_error


def test_greedy_error_equals_hmm_own_figure(jacksboro):
    """Our scaled TIN has exactly the vertical error pydelatin/hmm reports for itself."""
    from pydelatin import Delatin

    for n in (1000, 10000):
        d = Delatin(np.ascontiguousarray(jacksboro.z[::-1], dtype=np.float32), width=403, height=344,
                    max_error=0.0, max_points=n)
        st, _ = vertical_error(build_tin(jacksboro, method="greedy", max_vertices=n), jacksboro)
        assert st.max_m == pytest.approx(d.error, rel=1e-5)
