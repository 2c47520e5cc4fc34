"""Golden figures on the real jacksboro DEM (matplotlib's sample).

If one of these changes, a reduction changed: check bench/terrain.py and update on purpose."""

import numpy as np
import pytest

from tin_swarm_env.terrain import build_tin, vertical_error

GOLDEN = [
    # kwargs, vertices, triangles, max error m, rms error m
    (dict(method="vip", max_vertices=5000), 5000, 9771, 159.5, 25.80798536),
    (dict(method="vip", max_vertices=5000, border="none", backbone=0.0), 5000, 9994, 526.88805970, 50.77660719),
    (dict(method="greedy", max_vertices=5000), 5000, 9841, 37.75510204, 12.42699186),
    (dict(method="greedy", max_error_m=20.0), 12069, 23871, 20.0, 7.13373226),
]


@pytest.mark.parametrize("kw,nv,nt,emax,erms", GOLDEN, ids=lambda x: str(x) if isinstance(x, dict) else None)
def test_jacksboro_golden(jacksboro, kw, nv, nt, emax, erms):
    tin = build_tin(jacksboro, **kw)
    st, err = vertical_error(tin, jacksboro)
    assert (tin.n_vertices, tin.n_triangles) == (nv, nt)
    assert st.n_outside == 0 and st.n_cells == 344 * 403
    assert st.max_m == pytest.approx(emax, rel=1e-6)
    assert st.rms_m == pytest.approx(erms, rel=1e-6)
    # every vertex lies on the DEM: zero error at the cells it came from
    assert np.isclose(err, 0, atol=1e-6).sum() >= nv


def test_greedy_error_equals_hmm_own_figure(jacksboro):
    """Our scaled TIN has exactly the vertical error pydelatin/hmm reports for itself."""
    from pydelatin import Delatin

    for n in (1000, 10000):
        d = Delatin(np.ascontiguousarray(jacksboro.z[::-1], dtype=np.float32), width=403, height=344,
                    max_error=0.0, max_points=n)
        st, _ = vertical_error(build_tin(jacksboro, method="greedy", max_vertices=n), jacksboro)
        assert st.max_m == pytest.approx(d.error, rel=1e-5)
