"""WorldPack: several worlds' arrays in one, indices shifted so that triangle walks stay in their world."""

import numpy as np
from numba import njit

import tin_swarm_env as tse
from tin_swarm_env.world.batch_kernels import terrain_of
from tin_swarm_env.world.pack import join, pack_worlds
from tin_swarm_env.world.sense_kernels import locate1, terrain_arrays


@njit(cache=True)
def _locate_in(T0, w, x, y, hint):
    return locate1(terrain_of(T0, w), x, y, hint)


@njit(cache=True)
def _locate_one(T, x, y, hint):
    return locate1(T, x, y, hint)


def _worlds():
    a = tse.parallel_env("ramp", n_robots=2).world
    b = tse.parallel_env("cliff_goal", n_robots=2).world
    c = tse.parallel_env("hill", n_robots=2).world
    return a, b, c


def test_walks_and_buckets_find_each_worlds_own_triangles():
    worlds = _worlds()
    pk = pack_worlds(worlds)
    rng = np.random.default_rng(0)
    for w, world in enumerate(worlds):
        x0, y0, x1, y1 = world.tin.bounds
        pts = np.column_stack([rng.uniform(x0, x1, 60), rng.uniform(y0, y1, 60)])
        want = world.tin.locate(pts)
        T = terrain_arrays(world.tin)
        lo, hi = pk.tri_off[w], pk.tri_off[w + 1]
        for (x, y), t in zip(pts, want):
            got_bucket = _locate_in(pk.T0, w, x, y, -1)  # through the world's own bucket grid
            got_walk = _locate_in(pk.T0, w, x, y, lo)  # walked from the world's first triangle
            assert got_bucket == (t + lo if t >= 0 else -1) == got_walk
            assert t < 0 or lo <= got_walk < hi
            assert _locate_one(T, x, y, -1) == t


def test_arrays_are_the_worlds_arrays_shifted():
    worlds = _worlds()
    pk = pack_worlds(worlds)
    a = pk.a
    for w, world in enumerate(worlds):
        t0, t1 = pk.tri_off[w], pk.tri_off[w + 1]
        v0 = a["tris"][t0:t1].min()
        np.testing.assert_array_equal(a["tris"][t0:t1] - v0, world.tin.triangles - world.tin.triangles.min())
        nb = world.tin.neighbors
        np.testing.assert_array_equal(a["nbrs"][t0:t1], np.where(nb >= 0, nb + t0, -1))
        np.testing.assert_array_equal(a["steep"][t0:t1], world.steep)
        b0, b1 = pk.brk_off[w], pk.brk_off[w + 1]
        np.testing.assert_array_equal(a["normals"][b0:b1], world.breaks.normals.reshape(-1, 2))
        assert b1 - b0 == len(world.breaks.segments)
    # joining packs one at a time gives the same arrays as packing them at once
    step = join([join([pack_worlds(worlds[:1]), pack_worlds(worlds[1:2])]), pack_worlds(worlds[2:])])
    assert step.worlds == pk.worlds
    for k in pk.a:
        np.testing.assert_array_equal(step.a[k], pk.a[k], err_msg=k)
    assert pk.index(worlds[1]) == 1 and worlds[2] in pk and pk.nbytes > 0


def test_every_pack_has_the_same_array_types_so_the_passes_compile_once():
    """numba types a read-only array apart from a writable one, and compiles a pass again for each new
    combination (minutes for the sensing pass). One world's pack (some arrays the TIN's own, read-only), a
    join's concatenations and an append's buffers must give the kernels the same types: every array
    read-only. (Before, the env's pack and the vector env's differed in ``tris``/``nbrs``, so every pass
    compiled twice.)"""
    from numba import typeof

    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.world.batch_kernels import _NO_UNITS
    from tin_swarm_env.world.pack import pack_one

    a, b, c = _worlds()
    one = pack_one(a)
    joined = join([pack_one(b), pack_one(c)])
    grown = joined.copy()
    grown.append(a)
    for pk in (one, joined, grown):
        assert all(not v.flags.writeable for v in pk.a.values()), [k for k, v in pk.a.items() if v.flags.writeable]
        for part in ("T0", "B", "OB", "tilt"):
            assert typeof(getattr(pk, part)) == typeof(getattr(one, part)), part
    assert typeof(a.tin.planes) == typeof(one.T0[5])  # the env's observation reads the planes, the vector env grad
    assert typeof(_NO_UNITS) == typeof(ObsLayout().scan_units())  # the env without rows, the vector env with
    grown.append(b)  # the buffers stay writable: an append still grows a pack in place
    assert len(grown.worlds) == 4 and not grown.a["tris"].flags.writeable
