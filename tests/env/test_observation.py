"""The observation (env/observation.py): ObsLayout as its one description (offsets, names, scales,
decoders, saving), the compiled observation against the numpy reference, and its mirror symmetry."""

import json
import math

import numba
import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env import observation as O
from tin_swarm_env.env.observation import (
    ACTION_PARITY,
    DZ_SCALE_M,
    OWN_FIELDS,
    OWN_PARITY,
    SLOT_FIELDS,
    SLOT_PARITY,
    ObsLayout,
    mirror_action,
)
from tin_swarm_env.errors import ObservationLayoutError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import ObservationSpec, load_scenario, scenario_from_dict
from tin_swarm_env.scenario.config import DEFAULT_K_SCAN
from tin_swarm_env.terrain import Tin, save_tin
from tin_swarm_env.world.fields import HEIGHT_SCALE_M

from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.env.observation import ANGLE_ERROR, SPAN_MARGIN, approx_angle, beam_span, scan_beams


def test_field_names_offsets_and_size_agree():
    lay = ObsLayout(k_robots=2, k_targets=1, k_breaks=5, k_scan=0)
    names = lay.names()
    assert len(names) == lay.size == 11 + 4 * 2 + 4 * 1 + 8 * 5
    obs = np.arange(lay.size, dtype=float)[None]  # element i holds i: reading a field reads its index
    for part in SLOT_FIELDS:
        for f in SLOT_FIELDS[part]:
            idx = lay.field(obs, part, f)[0].astype(int)
            assert [names[i] for i in idx] == [f"{part}[{k}].{f}" for k in range(lay.count(part))]
    assert names[int(lay.field(obs, "own", "target_dz")[0, 0])] == "own.target_dz"
    np.testing.assert_array_equal(lay.vectors(obs, "breaks", "nx", "ny")[0, 1], [lay.breaks.start + 11,
                                                                                   lay.breaks.start + 12])
    with pytest.raises(ObservationLayoutError, match="breaks slots hold"):
        lay.field(obs, "breaks", "colour")
    with pytest.raises(ObservationLayoutError, match="k_robots"):
        ObsLayout(k_robots=-1)


def test_the_default_counts_are_the_scenario_specs():
    assert ObsLayout() == ObsLayout.from_spec(ObservationSpec())
    import inspect

    import tin_swarm_env.env.observation as o

    assert DZ_SCALE_M == HEIGHT_SCALE_M
    assert "10.0" not in inspect.getsource(o)  # one constant, imported from world.fields, not a second literal


def test_decoders_invert_the_encodings():
    lay = ObsLayout()
    R = 60.0
    d = np.array([0.0, 0.5, 12.0, 59.9, 300.0])
    dz = np.array([-40.0, -1.0, 0.0, 2.5, 80.0])
    obs = np.zeros((5, lay.size))
    obs[:, lay.own["target_dist"]] = (d / (d + R))[:, None]
    obs[:, lay.own["target_dz"]] = (dz / (np.abs(dz) + DZ_SCALE_M))[:, None]
    np.testing.assert_allclose(lay.target_distance_m(obs, R), d, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(lay.target_dz_m(obs), dz, rtol=1e-9, atol=1e-9)
    drop = np.array([-3.0, 0.0, 7.0])
    obs[0, lay.breaks] = 0.0
    s = lay.slots(obs, "breaks")
    s[0, :, lay.slot_index("breaks", "drop")] = drop / (np.abs(drop) + DZ_SCALE_M)
    obs[0, lay.breaks] = s[0].ravel()
    np.testing.assert_allclose(lay.drop_m(obs)[0], drop, atol=1e-9)


def test_to_dict_round_trips_through_json_and_reports_a_mismatch():
    lay = ObsLayout(k_robots=3, k_targets=0, k_breaks=4)
    d = json.loads(json.dumps(lay.to_dict()))
    assert ObsLayout.from_dict(d) == lay
    assert d["size"] == lay.size and d["scales"]["dz_scale_m"] == DZ_SCALE_M
    bad = dict(d, slots={**d["slots"], "breaks": ["valid", "x", "y"]})
    with pytest.raises(ObservationLayoutError, match="'slots'"):
        ObsLayout.from_dict(bad)
    with pytest.raises(ObservationLayoutError, match="k_breaks"):
        ObsLayout.from_dict({"k_robots": 1, "k_targets": 1})


def test_other_slot_counts_reach_the_encoder_and_apf_still_brings_robots_in():
    cfg = load_scenario("ramp")
    cfg = cfg.replace(observation=ObservationSpec(k_robots=2, k_targets=2, k_breaks=5))
    env = tse.parallel_env(scenario=cfg, n_robots=8)
    assert env.layout == ObsLayout(2, 2, 5) and env.observation_space("robot_0").shape == (env.layout.size,)
    pol = APFPolicy(env)
    obs, _ = env.reset(seed=3)
    saw_five = False
    reasons = []
    while env.agents:
        arr = np.stack(list(obs.values()))
        saw_five |= bool(np.any(env.layout.field(arr, "breaks", "valid")[:, 4] > 0))
        obs, _, _, _, infos = env.step(pol.act(obs))
        reasons += [i["reason"] for i in infos.values() if "reason" in i]
    assert len(reasons) == 8
    assert reasons.count("arrived") >= 7 and "fell" not in reasons, reasons
    assert saw_five  # the fifth break slot is filled somewhere on the way


# -- every field by hand at several headings (90 and -37 degrees among them) ----------------------

GX, GY = 0.1, -0.05  # the plane z = 0.1 x - 0.05 y: rises to the east, falls to the north


@pytest.fixture(scope="module")
def plane_env(tmp_path_factory):
    """A 400 m square plane (5 vertices, 4 triangles, all with the gradient (GX, GY)), sensor
    range 60 m and 360 deg: robot 0 at the centre (200, 200), robot 1 10 m east of it, robot 2
    20 m south; one target 50 m away at (230, 240). The border is 140 m away or more: no break slot."""
    from tin_swarm_env.scenario import scenario_from_dict
    from tin_swarm_env.terrain import Tin, save_tin

    xy = np.array([[0, 0], [400, 0], [400, 400], [0, 400], [200, 200]], float)
    tin = Tin.from_points(np.column_stack([xy, GX * xy[:, 0] + GY * xy[:, 1] + 50.0]))
    path = tmp_path_factory.mktemp("plane") / "plane.npz"
    save_tin(tin, path)
    cfg = scenario_from_dict({
        "name": "plane", "task": "goal", "max_cycles": 10,
        "terrain": {"source": "tin", "path": str(path)},
        "robots": {"count": 3}, "sensor": {"range_m": 60.0, "fov_deg": 360.0},
        "targets": {"positions": [[230.0, 240.0]], "arrival_radius_m": 1.0},
    }, source="plane")
    return tse.parallel_env(scenario=cfg)


def body(v, heading):
    """World vector -> body frame by projecting on the forward and left unit vectors."""
    fwd = np.array([math.cos(heading), math.sin(heading)])
    left = np.array([-math.sin(heading), math.cos(heading)])
    return np.array([fwd @ v, left @ v])


@pytest.mark.parametrize("heading_deg", [0.0, 90.0, -37.0, 180.0, 123.0])
def test_every_own_and_slot_field_by_hand(plane_env, heading_deg):
    env, L = plane_env, plane_env.layout
    h = math.radians(heading_deg)
    obs = env.reset_arrays(seed=0, options={"robot_positions": [[200.0, 200.0], [210.0, 200.0], [200.0, 180.0]],
                                            "headings": [h, 0.0, 0.0]})[0]
    R = 60.0
    g = np.array([GX, GY])
    gn = math.hypot(GX, GY)
    # tilt (thesis 3.1) from the surface normal: sin(tilt) = normal . left axis, positive when the
    # ground falls away on the robot's left; slope = atan |grad|
    normal = np.array([-GX, -GY, 1.0]) / math.sqrt(1 + gn * gn)
    left3 = np.array([-math.sin(h), math.cos(h), 0.0])
    tilt = math.asin(normal @ left3)
    target = np.array([30.0, 40.0])  # (230, 240) - (200, 200): 50 m
    dz = GX * 30.0 + GY * 40.0  # 1 m
    want = {
        "battery": [1.0], "speed": [0.0], "tilt": [tilt / (math.pi / 2)],
        "slope": [math.degrees(math.atan(gn)) / 90.0], "uphill": body(g, h) / gn,
        "target_valid": [1.0], "target_dir": body(target, h) / 50.0, "target_dist": [50.0 / (50.0 + R)],
        "target_dz": [dz / (abs(dz) + DZ_SCALE_M)],
    }
    for name, v in want.items():
        # float32 observation of values of order 1: 1e-6 is a few float32 ulps
        np.testing.assert_allclose(obs[L.own[name]], v, atol=1e-6, err_msg=name)
    rob = L.slots(obs, "robots")
    np.testing.assert_allclose(rob[0], [1.0, *(body(np.array([10.0, 0.0]), h) / R), 10.0 / R], atol=1e-6)
    np.testing.assert_allclose(rob[1], [1.0, *(body(np.array([0.0, -20.0]), h) / R), 20.0 / R], atol=1e-6)
    assert not rob[2:].any()
    tgt = L.slots(obs, "targets")
    np.testing.assert_allclose(tgt[0], [1.0, *(body(target, h) / R), 50.0 / R], atol=1e-6)
    assert not tgt[1:].any() and not L.slots(obs, "breaks").any()


def test_hand_values_written_out_at_90_degrees(plane_env):
    """The same at 90 degrees with the numbers written out: facing north, a point east of the
    robot is on its right (body y < 0), north is straight ahead."""
    env, L = plane_env, plane_env.layout
    obs = env.reset_arrays(seed=0, options={"robot_positions": [[200.0, 200.0], [210.0, 200.0], [200.0, 180.0]],
                                            "headings": [math.pi / 2, 0.0, 0.0]})[0]
    np.testing.assert_allclose(obs[L.own["target_dir"]], [0.8, -0.6], atol=1e-6)  # (30, 40) m: 40 ahead, 30 right
    gn = math.hypot(GX, GY)
    np.testing.assert_allclose(obs[L.own["uphill"]], [GY / gn, -GX / gn], atol=1e-6)  # uphill: east-south-east
    np.testing.assert_allclose(L.slots(obs, "robots")[0], [1.0, 0.0, -10 / 60, 10 / 60], atol=1e-6)
    np.testing.assert_allclose(L.slots(obs, "robots")[1], [1.0, -20 / 60, 0.0, 20 / 60], atol=1e-6)
    # facing north on ground that rises to the east: the downhill side (west) is on the left
    assert obs[L.own["tilt"]][0] > 0
    np.testing.assert_allclose(obs[L.own["tilt"]], [math.asin(GX / math.sqrt(1 + gn * gn)) / (math.pi / 2)],
                               atol=1e-6)


# -- the parallel encoder: bit-identical for any thread count and to its plain loop ----------------


def _episode(env, steps, seed=0):
    rng = np.random.default_rng(seed)
    out = [env.reset_arrays(seed=seed)]
    for _ in range(steps):
        obs, rew, term, trunc, reasons = env.step_arrays(rng.uniform(-1, 1, (env.n, 2)))
        out += [obs, rew, term, trunc, reasons]
    return out


@pytest.mark.parametrize("scenario", ["cliff_goal", "hill"])
def test_env_episode_is_bit_identical_for_1_and_2_threads_and_the_plain_encoder(scenario, monkeypatch):
    env = tse.parallel_env(scenario=scenario, n_robots=24)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = _episode(env, 15)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = _episode(env, 15)
    finally:
        numba.set_num_threads(old)
    monkeypatch.setattr(O, "fill_observations", O.fill_observations.py_func)
    ref = _episode(env, 3)
    for a, b in zip(one, two, strict=True):
        assert a.tobytes() == b.tobytes()
    for a, b in zip(one, ref, strict=False):
        assert a.tobytes() == b.tobytes()
    assert np.any(one[0] != 0)


# -- mirror symmetry: the observation of a mirrored world is the reflected observation of the original,
# on every slot ----------------------------------------------------------------------------------


ATOL = 1e-5


def test_mirror_signs_are_named_per_field_for_every_layout():
    lay = ObsLayout(k_robots=3, k_targets=2, k_breaks=4, k_assets=1, k_scan=0)
    signs = lay.mirror_signs()
    assert signs.shape == (lay.size,)
    negated = {n for n, s in zip(lay.names(), signs, strict=True) if s < 0}
    expect = {"own.tilt", "own.uphill[1]", "own.target_dir[1]"}
    expect |= {f"{p}[{k}].y" for p in SLOT_FIELDS for k in range(lay.count(p))}
    expect |= {f"breaks[{k}].ny" for k in range(4)}
    assert negated == expect
    assert set(np.unique(signs)) == {-1.0, 1.0}
    assert [n for n, _ in OWN_FIELDS] == list(OWN_PARITY) and set(SLOT_PARITY) >= {f for v in SLOT_FIELDS.values()
                                                                                   for f in v}
    assert ObsLayout(k_robots=0, k_targets=0, k_breaks=0, k_scan=0).mirror_signs().shape == (11,)


def test_mirror_is_an_exact_involution_and_the_action_map_negates_vy():
    lay = ObsLayout(k_assets=2)
    rng = np.random.default_rng(0)
    o = rng.uniform(-1, 1, (50, lay.size)).astype(np.float32)
    m = lay.mirror(o)
    assert m.dtype == np.float32
    np.testing.assert_array_equal(lay.mirror(m), o)
    np.testing.assert_array_equal(m[:, lay.own["uphill"]], o[:, lay.own["uphill"]] * [1, -1])
    np.testing.assert_array_equal(lay.field(m, "breaks", "ny"), -lay.field(o, "breaks", "ny"))
    np.testing.assert_array_equal(lay.field(m, "breaks", "nx"), lay.field(o, "breaks", "nx"))
    a = rng.uniform(-1, 1, (7, 2)).astype(np.float32)
    np.testing.assert_array_equal(mirror_action(a), np.column_stack([a[:, 0], -a[:, 1]]))
    np.testing.assert_array_equal(mirror_action(mirror_action(a)), a)
    assert ACTION_PARITY == (1.0, -1.0)
    with pytest.raises(ObservationLayoutError, match="size 59"):
        ObsLayout(k_scan=0).mirror(np.zeros((3, 60)))
    with pytest.raises(ObservationLayoutError, match="size 91"):  # the default layout: 59 + 32 scan beams
        ObsLayout().mirror(np.zeros((3, 59)))
    with pytest.raises(ObservationLayoutError, match="size 2"):
        mirror_action(np.zeros(3))


def _mirror_tin(tin: Tin) -> Tin:
    v = tin.vertices * np.array([1.0, -1.0, 1.0])
    return Tin(v, tin.triangles[:, [0, 2, 1]])


def _world_dict(path, name):
    return {"name": name, "task": "goal", "max_cycles": 50,
            "terrain": {"source": "tin", "path": str(path)},
            "robots": {"count": 40, "max_slope_deg": 30.0},
            "sensor": {"fov_deg": 240.0},
            "targets": {"positions": [[0.0, 0.0]], "arrival_radius_m": 2.0},
            "assets": {"positions": [[0.0, 0.0]]},
            "observation": {"k_scan": 0}}  # slots only: the scan's beams have their own mirror test below


def _sorted_slots(lay, obs, part):
    """Slots of ``part`` ordered by (d, then every other field, rounded to the tolerance): ties
    in distance are ordered by index in the env, which the mirrored TIN numbers differently."""
    s = lay.slots(obs, part)
    keys = np.round(s / ATOL).astype(np.int64)
    d = lay.slot_index(part, "d")
    order = [np.lexsort([keys[i, :, j] for j in reversed(range(s.shape[-1]))] + [keys[i, :, d]])
             for i in range(len(s))]
    return np.stack([s[i, o] for i, o in enumerate(order)])


def _comparable(lay, s, part):
    """``(n, K, w)`` bool: which fields of sorted slots ``s`` the test compares. All of them but
    where the last valid slot's distance ties with the slot before it (module docstring): there
    only valid, x, y and d of the tied slots."""
    out = np.ones(s.shape, dtype=bool)
    K = s.shape[1]
    if K < 2:
        return out
    d = s[..., lay.slot_index(part, "d")]
    valid = s[..., lay.slot_index(part, "valid")] > 0.5
    cut = valid.all(axis=-1) & (np.abs(d[:, -1] - d[:, -2]) <= ATOL)
    tied = cut[:, None] & (np.abs(d - d[:, -1:]) <= ATOL)
    point = [lay.slot_index(part, f) for f in ("valid", "x", "y", "d")]
    other = np.ones(s.shape[-1], dtype=bool)
    other[point] = False
    out[tied] = ~other
    return out


@pytest.mark.parametrize("seed", [3, 11, 20])
def test_the_mirrored_world_observes_the_mirrored_observation(tmp_path, seed):
    """The strong test builds a world and its mirror image (the TIN's vertices ``y -> -y``, robots,
    targets and assets reflected, headings negated) and compares the two envs' observations step by
    step while the mirrored world is driven by the mirrored actions. Tolerance: the mirrored world
    runs the same float operations on negated y values, which are exact, but in other orders (each
    triangle's vertices are re-ordered to stay counter-clockwise, so plane fits, barycentric and
    aspect computations sum in another order): relative differences of a few 1e-16 in the geometry,
    which reach the float32 observation as at most a few float32 ulps (~1e-7 on values in [-1, 1]).
    ``atol=1e-5`` leaves room for their growth over a few steps of motion and is still 10^3 times
    smaller than any real asymmetry (a slot of another robot, another break, a sign). Slots whose
    distances tie exactly (two break segments meeting at the vertex nearest the robot) are ordered by
    index in the env, which the mirrored TIN numbers differently, so slots are compared as sets
    ordered by (distance, then the other fields); and where the last of the K slots ties with the one
    before it, a third break through the same vertex may have been left out in one image and taken in
    the other, so in a row whose slots differ (and only there) those tied slots are compared on the
    point only (valid, x, y, d), not on which segment through it was kept; such rows stay under 5%
    (0, 0 and 12 of 480 robot-steps at seeds 3, 11, 20)."""
    gen = tse.parallel_env(scenario="generated", n_robots=2)
    gen.reset(seed=seed)
    tin = gen.tin
    save_tin(tin, tmp_path / "a.npz")
    save_tin(_mirror_tin(tin), tmp_path / "b.npz")
    env_a = tse.parallel_env(scenario_from_dict(_world_dict(tmp_path / "a.npz", "a"), source="a"))
    env_b = tse.parallel_env(scenario_from_dict(_world_dict(tmp_path / "b.npz", "b"), source="b"))
    rng = np.random.default_rng(seed)
    # targets and assets beside the robots so that every slot kind is seen
    env_a.reset(seed=seed, options={"target_positions": gen.task.targets})
    st = env_a.world_state
    pos, head = st.positions.copy(), st.headings.copy()
    near = pos[rng.choice(len(pos), 2, replace=False)] + rng.uniform(-3, 3, (2, 2))
    flip = np.array([1.0, -1.0])
    opts_a = {"robot_positions": pos, "headings": head, "target_positions": near}
    opts_b = {"robot_positions": pos * flip, "headings": -head, "target_positions": near * flip}
    lay = env_a.layout
    assert lay == env_b.layout and lay.k_assets == 2
    oa = env_a.reset_arrays(seed=seed, options=opts_a)
    ob = env_b.reset_arrays(seed=seed, options=opts_b)
    seen = np.zeros(lay.size, dtype=bool)
    cut_ties = 0
    for step in range(12):
        m = lay.mirror(oa)
        np.testing.assert_allclose(ob[:, :lay.own_size], m[:, :lay.own_size], atol=ATOL,
                                   err_msg=f"own fields, step {step}")
        for part in SLOT_FIELDS:
            if lay.count(part):
                sb, sm = _sorted_slots(lay, ob, part), _sorted_slots(lay, m, part)
                differ = (np.abs(sb - sm) > ATOL).any(axis=(1, 2))  # rows whose slots differ at all
                same = _comparable(lay, sm, part)
                same[~differ] = True  # rows that agree are compared in full
                cut_ties += int(differ.sum())
                np.testing.assert_allclose(np.where(same, sb, 0), np.where(same, sm, 0), atol=ATOL,
                                           err_msg=f"{part} slots, step {step}")
        seen |= np.abs(oa).max(axis=0) > 1e-3
        act = rng.uniform(-1, 1, (env_a.n, 2)).astype(np.float32)
        oa, *_ = env_a.step_arrays(act)
        ob, *_ = env_b.step_arrays(mirror_action(act))
        np.testing.assert_allclose(env_b.world_state.positions, env_a.world_state.positions * flip, atol=1e-6)
    assert cut_ties <= 0.05 * 12 * env_a.n, cut_ties  # rows kept by a tie at the cut-off: the exception
    # the comparison was not vacuous: every part had valid slots, and nonzero y/ny values were compared
    names = np.array(lay.names())
    for part in SLOT_FIELDS:
        for f in ("valid", "y"):
            assert seen[[n.startswith(f"{part}[0].{f}") for n in names]].all(), f"{part}[0].{f} never seen"
    for name in ("own.tilt", "own.uphill[1]", "own.target_dir[1]", "breaks[0].ny"):
        assert seen[list(names).index(name)], name


@pytest.mark.parametrize("scenario", ["cliff_goal", "containment", "flat"])
def test_compiled_observations_equal_the_numpy_reference(scenario, observations_match):
    env = tse.parallel_env(scenario=scenario, n_robots=30)
    env.reset(seed=2)
    rng = np.random.default_rng(1)
    for _ in range(40):
        env.step_arrays(rng.uniform(-1, 1, (30, 2)))
        a = observations_match(env)
        assert np.any(a[:, env.layout.robots] != 0)


def test_mobile_targets_heights_follow_them_step_by_step(observations_match):
    """The encoder keeps static targets' heights per world (observation._target_heights, keyed on
    the targets' positions and triangles): a mobile target's height must be read anew every step
    it moves, and a new reset's targets must not read the last episode's heights. Against the
    numpy reference (which reads height_in every step), on the same env across two resets."""
    import dataclasses

    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(targets=dataclasses.replace(cfg.targets, mobile=True))
    with pytest.warns(UserWarning, match="mobile targets"):
        env = tse.parallel_env(scenario=cfg, n_robots=12)
    rng = np.random.default_rng(3)
    tz_seen = set()
    for seed in (2, 5):
        env.reset(seed=seed)
        for _ in range(15):
            env.step_arrays(rng.uniform(-1, 1, (12, 2)))
            observations_match(env)
            tg = env.world_state.targets
            tz_seen.add(env.world.tin.height_in(tg.positions, tg.tri_idx).tobytes())
    assert len(tz_seen) > 10  # the targets moved (and their heights changed) step by step


def test_small_swarms_are_encoded_on_one_thread_and_large_ones_on_all(monkeypatch):
    """build_observations runs its kernel on one numba thread below OBS_SERIAL_BELOW robots
    (and restores the count after), on every thread from there on; the observations are the same bits."""
    env = tse.parallel_env(scenario="cliff_goal", n_robots=24)
    env.reset_arrays(seed=3)
    w, s, r = env.world, env.world_state, env.sensed()
    seen = []
    kernel = O.fill_observations

    def spy(*a):
        seen.append(numba.get_num_threads())
        return kernel(*a)

    monkeypatch.setattr(O, "fill_observations", spy)
    k = min(2, numba.config.NUMBA_NUM_THREADS)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(k)
        small = O.build_observations(w, s, r, env.target_assignment, env.live_mask, env.layout)
        monkeypatch.setattr(O, "OBS_SERIAL_BELOW", 24)
        large = O.build_observations(w, s, r, env.target_assignment, env.live_mask, env.layout)
        assert seen == [1, k] and numba.get_num_threads() == k
    finally:
        numba.set_num_threads(old)
    assert small.tobytes() == large.tobytes() and np.any(small != 0)


# -- the terrain scan ([observation] k_scan): exact ranges on a hand-built plane, the compiled encoder
# against the numpy reference, its mirror image (a permutation of the beams), the layout's saving and checks
SCAN_R = 60.0
X0, X1, Y0, Y1 = 0.0, 100.0, -50.0, 50.0  # a flat square whose only breaks are its border edges

@pytest.fixture(scope="module")
def square(tmp_path_factory):
    xy = np.array([[X0, Y0], [X1, Y0], [X1, Y1], [X0, Y1], [50.0, 0.0]])
    path = tmp_path_factory.mktemp("square") / "square.npz"
    save_tin(Tin.from_points(np.column_stack([xy, np.full(5, 10.0)])), path)

    def make(k_scan, count=1):
        return tse.parallel_env(scenario=scenario_from_dict({
            "name": "square", "task": "goal", "max_cycles": 5, "terrain": {"source": "tin", "path": str(path)},
            "robots": {"count": count}, "sensor": {"range_m": SCAN_R, "fov_deg": 360.0},
            "targets": {"positions": [[90.0, 0.0]], "arrival_radius_m": 1.0},
            "observation": {"k_scan": k_scan}}, source="square"))
    return make


def _to_border(x, y, ang):
    """Distance from (x, y) along bearing ``ang`` to the square's border (by hand: the nearest of
    the four lines the ray meets ahead)."""
    dx, dy = math.cos(ang), math.sin(ang)
    ts = []
    if dx > 1e-12:
        ts.append((X1 - x) / dx)
    if dx < -1e-12:
        ts.append((X0 - x) / dx)
    if dy > 1e-12:
        ts.append((Y1 - y) / dy)
    if dy < -1e-12:
        ts.append((Y0 - y) / dy)
    return min(ts)


@pytest.mark.parametrize("heading_deg", [0.0, 90.0, -37.0, 180.0])
def test_each_beam_reads_the_range_to_the_border_along_its_bearing(square, heading_deg):
    env = square(8)
    lay = env.layout
    assert lay.k_scan == 8 and lay.size == 59 + 8 and lay.names()[-1] == "scan[7].d"
    x, y, h = 30.0, 20.0, math.radians(heading_deg)
    obs = env.reset_arrays(seed=0, options={"robot_positions": np.array([[x, y]]), "headings": np.array([h])})
    got = obs[0, lay.scan]
    want = [min(_to_border(x, y, h + 2 * math.pi * k / 8), SCAN_R) / SCAN_R for k in range(8)]
    np.testing.assert_allclose(got, want, atol=1e-6)
    # at heading 0: beam 0 east 70 m away (out of range), beam 2 north 30 m, beam 4 west 30 m, beam 6 south 70 m
    if heading_deg == 0.0:
        np.testing.assert_allclose(got[[0, 2, 4, 6]], [1.0, 0.5, 0.5, 1.0], atol=1e-6)


def test_the_mirror_image_permutes_the_beams(square):
    """The square is its own mirror image across y = 0: the robot at (x, -y) heading -h observes the
    mirror of what the robot at (x, y) heading h observes, beam k as beam (K - k) mod K."""
    env = square(12)
    lay = env.layout
    a = env.reset_arrays(seed=0, options={"robot_positions": np.array([[30.0, 20.0]]), "headings": np.array([0.4])})
    b = env.reset_arrays(seed=0, options={"robot_positions": np.array([[30.0, -20.0]]),
                                          "headings": np.array([-0.4])})
    np.testing.assert_allclose(lay.mirror(a)[:, lay.scan], b[:, lay.scan], atol=1e-6)
    np.testing.assert_allclose(lay.mirror(a), b, atol=1e-6)  # every other field too
    assert not np.allclose(a[:, lay.scan], b[:, lay.scan], atol=1e-3)  # the test is not vacuous
    np.testing.assert_array_equal(lay.mirror(lay.mirror(a)), a)
    perm = lay.mirror_permutation()
    s = lay.scan.start
    assert list(perm[s:s + 12]) == [s + (12 - k) % 12 for k in range(12)]
    assert list(perm[:s]) == list(range(s))
    with pytest.raises(ObservationLayoutError, match="k_scan = 12"):
        lay.mirror_signs()
    assert ObsLayout(k_scan=0).mirror_signs().shape == (59,)  # no scan: the sign flip is the whole mirror


@pytest.mark.parametrize("scenario", ["cliff_goal", "generated"])
def test_compiled_scan_equals_the_numpy_reference(scenario, observations_match):
    cfg = load_scenario(scenario)
    cfg = cfg.replace(observation=ObservationSpec(k_scan=16))
    env = tse.parallel_env(scenario=cfg, n_robots=20)
    env.reset(seed=4)
    rng = np.random.default_rng(2)
    hit = False
    for _ in range(25):
        env.step_arrays(rng.uniform(-1, 1, (20, 2)))
        a = observations_match(env)
        live = env.live_mask
        hit |= bool(np.any(a[live][:, env.layout.scan] < 1.0))
    assert hit  # some beam met a break


def test_the_layout_saves_the_scan_and_old_files_still_load():
    old = ObsLayout(k_scan=0).to_dict()
    assert "k_scan" not in old and "scan" not in old["slots"]  # no scan: the dict layouts had before it
    assert ObsLayout.from_dict(old) == ObsLayout(k_scan=0) != ObsLayout()  # the default has the scan now
    assert ObsLayout().k_scan == DEFAULT_K_SCAN == 32 and ObsLayout().size == 59 + 32
    lay = ObsLayout(k_scan=32)
    d = json.loads(json.dumps(lay.to_dict()))
    assert d["k_scan"] == 32 and d["slots"]["scan"] == ["d"] and ObsLayout.from_dict(d) == lay
    with pytest.raises(ObservationLayoutError, match="'size'"):
        ObsLayout.from_dict({**d, "k_scan": 16})
    assert ObsLayout.from_spec(ObservationSpec(k_scan=5)).k_scan == 5


@pytest.mark.parametrize("bad", [-1, 257, 2.5, True])
def test_a_bad_k_scan_is_refused_by_name(bad):
    with pytest.raises(Exception, match="k_scan"):
        ObservationSpec(k_scan=bad)
    if bad != 257:  # the layout checks the type and sign; the scenario table also the upper limit
        with pytest.raises(ObservationLayoutError, match="k_scan"):
            ObsLayout(k_scan=bad)


def test_decoded_scan_hits_are_body_frame_vectors_and_an_absent_robot_has_none(square):
    from tin_swarm_env.policies.base import decode

    env = square(4, count=2)
    lay = env.layout
    obs = env.reset_arrays(seed=0, options={"robot_positions": np.array([[30.0, 20.0], [70.0, 0.0]]),
                                            "headings": np.array([0.0, 0.0])})
    obs[1] = 0.0  # robot 1 no longer in the episode: an all-zero row
    d = decode(obs, lay, SCAN_R)
    # robot 0 heading east: beam 1 north meets the border 30 m away, beam 2 west 30 m; east 70 m and south 70 m miss
    np.testing.assert_array_equal(d.s_hit[0], [False, True, True, False])
    np.testing.assert_allclose(d.s_rel[0, 1:3], [[0.0, 30.0], [-30.0, 0.0]], atol=1e-4)
    assert not d.s_hit[1].any()


# -- the scan's beams (moved from tests/env/test_scan_beams.py) ---------------------------------
# The scan's beams (:func:`~tin_swarm_env.env.observation.scan_beams`): each contact crossed with
# the beams of its wedge only (:func:`~tin_swarm_env.env.observation.beam_span`) gives the same bits
# as every beam crossed with every contact (the plain loop below), compiled and as plain Python, on
# random segments and on the ones that strain the wedge: ends at the robot, segments through it,
# edge-on ones, long and tiny ones, and headings far from 0.


def every_beam(K, ends, danger, x, y, head, R):
    """The scan by every beam against every dangerous segment (the obvious loop)."""
    out = np.empty(K)
    units = ObsLayout(k_scan=K).scan_units()  # the bearings 2 pi k / K as (cos, sin)
    c, s = math.cos(head), math.sin(head)
    for k in range(K):  # the beam's direction: the heading turned by its bearing
        cb, sb = units[k]
        dx, dy = c * cb - s * sb, s * cb + c * sb
        best = R
        for j in range(len(ends)):
            if danger[j] == 0.0:
                continue
            ex, ey = ends[j, 2] - ends[j, 0], ends[j, 3] - ends[j, 1]
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            wx, wy = ends[j, 0] - x, ends[j, 1] - y
            t = (wx * ey - wy * ex) / den
            u = (wx * dy - wy * dx) / den
            if -1e-12 <= u <= 1.0 + 1e-12 and 0.0 <= t < best:
                best = t
        out[k] = best / R
    return out


def _run(kernel, K, ends, danger, x, y, head, R):
    obs = np.full((1, K + 3), -7.0)
    start = np.array([0, len(ends)], dtype=np.int64)
    idx = np.arange(len(ends), dtype=np.int64)
    kernel(obs, 0, 3, K, start, idx, ends, ObsLayout(k_scan=K).scan_units(), danger, np.array([[x, y]]),
           math.cos(head), math.sin(head), R, np.full((K, 3), np.nan))
    return obs[0, 3:]


coord = st.floats(-80.0, 80.0, allow_nan=False)


@st.composite
def segments(draw, x, y):
    """A segment near the robot at (x, y), of one of the shapes that strain the wedge."""
    kind = draw(st.sampled_from(["free", "free", "end_at_robot", "through_robot", "edge_on", "near_end", "tiny",
                                 "long"]))
    a = np.array([draw(coord), draw(coord)])
    b = np.array([draw(coord), draw(coord)])
    p = np.array([x, y])
    if kind == "end_at_robot":
        a = p.copy()
    elif kind == "through_robot":
        b = 2 * p - a
    elif kind == "edge_on":
        b = p + draw(st.floats(1.1, 3.0)) * (a - p)
    elif kind == "near_end":
        a = p + draw(st.floats(-1e-9, 1e-9)) * np.array([1.0, draw(st.floats(-1.0, 1.0))])
    elif kind == "tiny":
        b = a + draw(st.floats(-1e-6, 1e-6))
    elif kind == "long":
        b = a + 1e4 * (b - a)
    return [a[0], a[1], b[0], b[1]]


@settings(max_examples=400, deadline=None)
@given(st.data(), st.sampled_from([1, 2, 3, 4, 5, 8, 16, 32, 33, 64, 256]), coord, coord,
       st.floats(-1e4, 1e4, allow_nan=False), st.integers(0, 12))
def test_the_wedge_scan_equals_every_beam_against_every_segment(data, K, x, y, head, m):
    ends = np.array([data.draw(segments(x, y)) for _ in range(m)], dtype=np.float64).reshape(-1, 4)
    danger = np.array([data.draw(st.sampled_from([1.0, 1.0, 0.0])) for _ in range(m)])
    want = every_beam(K, ends, danger, x, y, head, 60.0)
    np.testing.assert_array_equal(_run(scan_beams.py_func, K, ends, danger, x, y, head, 60.0), want)
    np.testing.assert_array_equal(_run(scan_beams, K, ends, danger, x, y, head, 60.0), want)


def test_the_wedge_scan_on_a_dense_random_field():
    """Many segments around many robots: every beam's range the same bits (and some beams hit)."""
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(200):
        a = rng.uniform(-60, 60, (40, 2))
        ends = np.column_stack([a, a + rng.normal(0, 8, (40, 2))])
        danger = (rng.random(40) < 0.8).astype(np.float64)
        x, y, head = *rng.uniform(-20, 20, 2), rng.uniform(-10, 10)
        for K in (7, 32):
            want = every_beam(K, ends, danger, x, y, head, 60.0)
            np.testing.assert_array_equal(_run(scan_beams, K, ends, danger, x, y, head, 60.0), want)
            hits += int((want < 1.0).sum())
    assert hits > 1000


def test_approx_angle_is_within_its_error():
    ang = np.linspace(-math.pi, math.pi, 200_001)
    for r in (1e-9, 1.0, 1e6):
        got = np.array([approx_angle(r * math.cos(t), r * math.sin(t)) for t in ang[::97]])
        want = np.arctan2(r * np.sin(ang[::97]), r * np.cos(ang[::97]))
        err = np.abs((got - want + np.pi) % (2 * np.pi) - np.pi)
        assert err.max() < ANGLE_ERROR


def test_beam_span_covers_the_wedge_and_no_more_than_it_needs():
    """A segment seen across 0.3 rad at bearing 1 rad from the heading (5.09 .. 6.62 steps of 32): beam
    6 lies in it, beam 5 within SPAN_MARGIN of it, and the span takes no more."""
    step = 2 * math.pi / 32
    h = 0.25
    a = 30 * np.array([math.cos(h + 1.0), math.sin(h + 1.0)])
    b = 30 * np.array([math.cos(h + 1.3), math.sin(h + 1.3)])
    lo, hi = beam_span(a[0], a[1], b[0], b[1], math.cos(h), math.sin(h), 32)
    assert lo <= math.ceil((1.0 - SPAN_MARGIN) / step) == 5 and hi >= math.floor((1.3 + SPAN_MARGIN) / step) == 6
    assert hi - lo + 1 <= 3
    assert beam_span(a[0], a[1], b[0], b[1], math.cos(h), math.sin(h), 32) == \
        beam_span(b[0], b[1], a[0], a[1], math.cos(h), math.sin(h), 32)  # either end first
    assert beam_span(0.0, 0.0, 5.0, 5.0, 1.0, 0.0, 32) == (0, 31)  # an end at the robot: every beam
    assert beam_span(-5.0, 1e-9, 5.0, 0.0, 1.0, 0.0, 32) == (0, 31)  # the robot on the segment: every beam
