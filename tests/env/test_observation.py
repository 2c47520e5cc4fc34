"""ObsLayout is the observation's one description: offsets, names, scales, decoders, saving."""

import json

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import DZ_SCALE_M, SLOT_FIELDS, ObsLayout
from tin_swarm_env.errors import ObservationLayoutError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import ObservationSpec, load_scenario
from tin_swarm_env.world.fields import HEIGHT_SCALE_M


def test_field_names_offsets_and_size_agree():
    lay = ObsLayout(k_robots=2, k_targets=1, k_breaks=5)
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
