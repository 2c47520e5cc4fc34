"""The passes over copies: per-copy grids equal the single grid on each copy, and one step of two
copies on two worlds equals each world's own step (its one-copy case). (Sensing and observations
through them are checked end to end against separate parallel envs in tests/env/test_vector.py.)"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import tin_swarm_env as tse
from tin_swarm_env.world.grid import grid_build, grid_build_copies
from tin_swarm_env.world.pack import pack_worlds
from tin_swarm_env.world.step_kernel import step_copies
from tin_swarm_env.world.world import step_scalars


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 12), min_size=1, max_size=5), st.integers(0, 2 ** 31), st.floats(0.5, 40.0))
def test_grid_per_copy_is_the_single_grid_of_that_copy(sizes, seed, cell):
    rng = np.random.default_rng(seed)
    n = sum(sizes)
    off = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    x, y = rng.uniform(-50, 50, n), rng.uniform(0, 30, n)
    use = rng.random(n) < 0.8
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = grid_build_copies(x, y, use, off, cell)
    for c in range(len(sizes)):
        lo, hi = off[c], off[c + 1]
        x0, y0, inv, nx, ny, s1, it1, gx1, gy1 = grid_build(x[lo:hi], y[lo:hi], use[lo:hi], cell)
        assert (NX[c], NY[c]) == (nx, ny) and INV[c] == inv
        if use[lo:hi].any():
            assert (X0[c], Y0[c]) == (x0, y0)
        for k in range(nx * ny):
            got = items[start[base[c] + k]:start[base[c] + k + 1]]
            np.testing.assert_array_equal(got, it1[s1[k]:s1[k + 1]] + lo)
            np.testing.assert_array_equal(gx[start[base[c] + k]:start[base[c] + k + 1]], gx1[s1[k]:s1[k + 1]])


def test_one_step_of_two_copies_is_each_worlds_step():
    envs = [tse.parallel_env(s, n_robots=5) for s in ("cliff_goal", "hill")]
    states = []
    for e in envs:
        e.reset_arrays(seed=2)
        states.append(e.world_state)
    pk = pack_worlds([e.world for e in envs])
    rng = np.random.default_rng(0)
    cmd = rng.uniform(-1, 1, (10, 2))
    cat = lambda f: np.ascontiguousarray(np.concatenate([f(s) for s in states]))  # noqa: E731
    wor = np.repeat([0, 1], 5)
    tri = cat(lambda s: s.tri_idx) + pk.tri_off[wor]
    p = step_scalars(envs[0].world.params)
    out = step_copies(pk.T0, pk.steep, wor, wor.copy(), np.array([0, 5, 10]), cat(lambda s: s.positions), tri,
                      cat(lambda s: s.headings), cat(lambda s: s.heights), cat(lambda s: s.status),
                      cat(lambda s: s.battery_j), cmd, p)
    pos, tri2, head, h, speeds, event, moved, climb, batt, energy, status, fell, emptied, coll, pairs = out
    for c, (e, s) in enumerate(zip(envs, states)):
        new, ev = e.world.step(s, cmd[5 * c:5 * c + 5])
        rows = slice(5 * c, 5 * c + 5)
        np.testing.assert_array_equal(pos[rows], new.positions)
        np.testing.assert_array_equal(tri2[rows] - pk.tri_off[c], new.tri_idx)
        np.testing.assert_array_equal(head[rows], new.headings)
        np.testing.assert_array_equal(batt[rows], new.battery_j)
        np.testing.assert_array_equal(status[rows], new.status)
        np.testing.assert_array_equal(coll[rows], ev.collisions)
        np.testing.assert_array_equal(moved[rows], ev.moved_m)
        np.testing.assert_array_equal(event[rows], ev.motion_event)
