"""build_tin (terrain/build.py): golden figures on the real jacksboro DEM (matplotlib's sample).

If one of these changes, a reduction changed: check bench/terrain.py and update on purpose.

The figures were first read off the code, so each is also recomputed here by a method that
shares no code with the package: the vertical error with matplotlib's own triangle finder and
linear interpolator (``matplotlib.tri.LinearTriInterpolator`` over the TIN's triangles, at every
DEM cell centre), and the triangle count by Euler's formula: a triangulation of a disc with
``V`` vertices of which ``B`` lie on its boundary has ``F = 2 V - B - 2`` triangles (``V - E + F
= 1`` with ``3 F + B = 2 E``, each interior edge shared by two triangles, each boundary edge by one)."""

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
    # independent: matplotlib's interpolation over the same triangles
    import matplotlib.tri as mtri

    v = tin.vertices
    interp = mtri.LinearTriInterpolator(mtri.Triangulation(v[:, 0], v[:, 1], tin.triangles), v[:, 2])
    xy = jacksboro.cell_centres()
    z = np.ma.filled(interp(xy[:, 0], xy[:, 1]).astype(float), np.nan)
    e = z - jacksboro.z.ravel()
    assert np.isfinite(e).all()  # every cell centre inside the TIN
    # rounding: matplotlib's barycentric sums and ours differ by ~1e-12 m on ~100 m heights
    assert np.abs(e).max() == pytest.approx(emax, rel=1e-6)
    assert np.sqrt(np.mean(e * e)) == pytest.approx(erms, rel=1e-6)
    # independent: Euler's formula (boundary edges: those of exactly one triangle)
    edges = np.sort(tin.triangles[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert nt == 2 * nv - int((uses == 1).sum()) - 2
