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
    with pytest.raises(ArgumentError, match="keep_clear: action"):
        keep_clear(np.zeros((3, 2)), np.zeros((2, 4, 2)), np.ones((2, 4)), 1.5, 0.5)
    with pytest.raises(ArgumentError, match="keep_clear: valid"):
        keep_clear(np.zeros((2, 2)), np.zeros((2, 4, 2)), np.ones((2, 3)), 1.5, 0.5)


def test_keep_clear_takes_no_rows_and_a_valid_that_broadcasts_as_the_array_cut_did():
    assert keep_clear(np.zeros((0, 2)), np.zeros((0, 3, 2)), np.zeros((0, 3)), 1.5, 0.5).shape == (0, 2)
    a, rel = np.array([[1.0, 0.2], [-0.3, 0.9]]), np.array([[[1.0, 1.0], [0.5, -3.0], [2.0, 0.1]]] * 2)
    valid = np.array([1.0, 0.0, 1.0])  # one row of slots for every robot
    assert keep_clear(a, rel, valid, 1.5, 0.5).tobytes() == _keep_clear_arrays(a, rel, valid, 1.5, 0.5).tobytes()


def _decode_by_readers(obs, layout, R):
    """:func:`decode` as it was written before it read each field by its column numbers: every field
    through the layout's readers (kept here as the reference of the indexed one: the same bits)."""
    from tin_swarm_env.policies.base import DecodedObs

    obs = np.asarray(obs, dtype=np.float64)
    dist = layout.target_distance_m(obs, R)
    slope = np.radians(layout.field(obs, "own", "slope")[:, 0] * 90.0)
    b_danger = (layout.field(obs, "breaks", "valid") * layout.field(obs, "breaks", "danger")) > 0.5
    t = layout.field(obs, "scan", "d") * R
    ang = layout.scan_bearings()
    unit = np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    return DecodedObs(
        has_t=layout.field(obs, "own", "target_valid")[:, 0] > 0.5, dist=dist,
        rel_t=layout.field(obs, "own", "target_dir") * dist[:, None], dz=layout.target_dz_m(obs),
        grad_z=np.tan(slope)[:, None] * layout.field(obs, "own", "uphill"),
        speed=layout.field(obs, "own", "speed")[:, 0],
        r_rel=layout.vectors(obs, "robots") * R, r_valid=layout.field(obs, "robots", "valid"),
        b_rel=layout.vectors(obs, "breaks") * R, b_normal=layout.vectors(obs, "breaks", "nx", "ny"),
        b_danger=b_danger, b_border=b_danger & (layout.field(obs, "breaks", "drop") == 0.0),
        a_rel=layout.vectors(obs, "assets") * R, a_valid=layout.field(obs, "assets", "valid"),
        s_rel=t[..., None] * unit, s_hit=(t < R * (1 - 1e-6)) & np.any(obs != 0, axis=-1)[:, None], s_dir=unit)


@given(st.integers(0, 4), st.integers(0, 3), st.integers(0, 5), st.integers(0, 2), st.sampled_from([0, 8, 32]),
       st.integers(0, 6), st.integers(0, 2**31 - 1), st.sampled_from([30.0, 60.0, 150.0]))
@settings(max_examples=80, deadline=None)
def test_decode_reads_every_field_as_the_layout_readers_do_bit_for_bit(kr, kt, kb, ka, ks, n, seed, R):
    """Every layout (parts with no slot, the scan on and off), random observations with rows of
    zeros (robots out of the episode), exact zeros and ones among the values: :func:`decode` gives the
    same arrays, bit for bit, as reading each field through the layout's readers."""
    from dataclasses import fields as dc_fields

    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.policies.base import decode

    lay = ObsLayout(k_robots=kr, k_targets=kt, k_breaks=kb, k_assets=ka, k_scan=ks)
    rng = np.random.default_rng(seed)
    obs = rng.uniform(-1, 1, (n, lay.size)).astype(np.float32)
    obs[rng.random(obs.shape) < 0.2] = 0.0
    obs[rng.random(obs.shape) < 0.1] = 1.0
    if n:
        obs[rng.integers(0, n)] = 0.0
    got, ref = decode(obs, lay, R), _decode_by_readers(obs, lay, R)
    for f in dc_fields(ref):
        a, b = getattr(got, f.name), getattr(ref, f.name)
        assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes(), f.name


def test_decode_refuses_observations_of_another_layout_by_shape():
    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.policies.base import decode

    lay = ObsLayout()
    with pytest.raises(ArgumentError, match=rf"decode: observations \(n, {lay.size}\)"):
        decode(np.zeros((2, lay.size + 1)), lay, 60.0)


def test_the_first_scenarios_shield_is_every_copys_in_a_mix():
    """The adapters shield a mix's rows with its first scenario's SafetyShield: on a goal and a
    containment mix (different tasks and standoffs), each copy's own shield cuts its rows the same."""
    import tin_swarm_env as tse
    from tin_swarm_env.policies.base import SafetyShield

    vec = tse.vector_env(["cliff_goal", "containment"], n_envs=4, n_robots=5, seed=1)
    obs = vec.reset().reshape(20, -1)
    act = np.random.default_rng(0).uniform(-1, 1, (20, 2))
    first = SafetyShield(tse.parallel_env("cliff_goal", n_robots=5))
    got = first(act, obs)
    assert got.dtype == np.float32 and not np.array_equal(got, act.astype(np.float32))  # the cut did something
    for c in range(4):
        rows = slice(5 * c, 5 * c + 5)
        own = SafetyShield(tse.parallel_env(["cliff_goal", "containment"][c % 2], n_robots=5))
        np.testing.assert_array_equal(got[rows], own(act[rows], obs[rows]))


def _scan_env():
    import tin_swarm_env as tse

    return tse.parallel_env("agents/scenarios/train_generated.toml", n_robots=4)


def test_the_scan_shield_keeps_robots_off_a_beams_hit_ahead():
    """A hand-built case: every beam open but the one straight ahead, which meets a dangerous break
    0.6 m away (less than one body diameter, edge_m = 1 m): "safety_cut_scan" stops the forward
    command (the limit is max(0.6 - 1, 0) / step = 0) and keeps the sideways one; "safety_cut"
    (break slots only, none here) lets both through."""
    from tin_swarm_env.policies.base import make_shield

    env = _scan_env()
    lay = env.layout
    obs, _ = env.reset(seed=0)
    o = np.zeros((2, lay.size), dtype=np.float32)  # no robot, target, break or asset slot valid
    cols = [lay.names().index(f"scan[{k}].d") for k in range(lay.k_scan)]
    ahead = int(np.argmax(lay.scan_units()[:, 0]))
    o[:, cols] = 1.0
    o[:, cols[ahead]] = 0.6 / make_shield("safety_cut", env).range_m
    a = np.array([[1.0, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(make_shield("safety_cut", env)(a, o), a, atol=1e-7)
    cut = make_shield("safety_cut_scan", env)(a, o)
    assert cut[0, 0] <= 1e-7 and abs(cut[0, 1]) <= 1e-7
    np.testing.assert_allclose(cut[1], [0.0, 1.0], atol=1e-7)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_scan_shield_is_exactly_mirror_equivariant(seed):
    """Its beams are cut one after another and the mirror image permutes them: the cut made both
    ways and averaged commutes with the mirror bit for bit, on arbitrary observations."""
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies.base import make_shield

    env = _scan_env()
    rng = np.random.default_rng(seed)
    o = rng.uniform(-1, 1, (400, env.layout.size)).astype(np.float32)
    a = rng.uniform(-1, 1, (400, 2))
    sh = make_shield("safety_cut_scan", env)
    x = sh(a, o)
    assert x.dtype == np.float32
    np.testing.assert_array_equal(mirror_action(x), sh(mirror_action(a), env.layout.mirror(o)))
    assert np.abs(x - make_shield("safety_cut", env)(a, o)).max() > 0.1  # the beams cut something


def test_make_shield_names_a_bad_shield():
    from tin_swarm_env.policies.base import make_shield

    with pytest.raises(ArgumentError, match="x.json: shield must be one of .*'safety_cut_scan'.*got 'scan'"):
        make_shield("scan", _scan_env(), "x.json")
    assert make_shield("none", _scan_env()) is None
    import tin_swarm_env as tse
    from tin_swarm_env.scenario import load_scenario

    from tin_swarm_env.env.observation import ObsLayout

    no_scan = tse.parallel_env(load_scenario("ramp").with_layout(ObsLayout(k_scan=0)))
    with pytest.raises(ArgumentError, match="'safety_cut_scan' needs an observation layout with a terrain scan"):
        make_shield("safety_cut_scan", no_scan)
