"""FieldPack: cost-to-go fields of different TINs queried in one pass give each field's own distances."""

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.env.field_pack import EUCLID, NO_FIELD, FieldPack, distance_copies
from tin_swarm_env.terrain import CostToGoStack


def test_distances_are_each_fields_own_and_the_straight_line():
    envs = [tse.parallel_env(s, n_robots=3) for s in ("cliff_goal", "hill", "ramp")]
    fields = []
    for e in envs:
        e.reset_arrays(seed=0)
        fields.append(e.target_fields)
    pack = FieldPack([f for fs in fields for f in fs])
    pack.extend(fields[0])  # already there: nothing added
    assert len(pack) == sum(len(f) for f in fields)
    rng = np.random.default_rng(1)
    for e, fs in zip(envs, fields):
        x0, y0, x1, y1 = e.tin.bounds
        xy = np.column_stack([rng.uniform(x0, x1, 80), rng.uniform(y0, y1, 80)])
        tri = e.tin.locate(xy)
        which = rng.integers(-1, len(fs), 80)
        want = CostToGoStack(fs).distance_at(xy, tri, which)
        fid = np.array([pack.index(fs[k]) if k >= 0 else NO_FIELD for k in which], dtype=np.int64)
        got = distance_copies(pack, fid, xy, tri.astype(np.int64), np.zeros((1, 2)), np.zeros(80, np.int64),
                              np.empty(80))
        np.testing.assert_array_equal(got, want)
        assert np.isfinite(got).any()
    tpos = np.array([[3.0, 4.0]])
    got = distance_copies(pack, np.array([EUCLID, NO_FIELD]), np.zeros((2, 2)), np.zeros(2, np.int64), tpos,
                          np.zeros(2, np.int64), np.empty(2))
    assert got[0] == 5.0 and got[1] == np.inf
