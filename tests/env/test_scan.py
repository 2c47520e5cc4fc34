"""The observation's terrain scan (``[observation] k_scan``): exact ranges on a hand-built plane,
the compiled encoder against the numpy reference, its mirror image (a permutation of the beams),
and the layout's saving and checks."""

import json
import math

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout, build_observations
from tin_swarm_env.env.reference import build_observations_reference
from tin_swarm_env.errors import ObservationLayoutError
from tin_swarm_env.scenario import ObservationSpec, load_scenario, scenario_from_dict
from tin_swarm_env.terrain import Tin, save_tin

R = 60.0
X0, X1, Y0, Y1 = 0.0, 100.0, -50.0, 50.0  # a flat square whose only breaks are its border edges


@pytest.fixture(scope="module")
def square(tmp_path_factory):
    xy = np.array([[X0, Y0], [X1, Y0], [X1, Y1], [X0, Y1], [50.0, 0.0]])
    path = tmp_path_factory.mktemp("square") / "square.npz"
    save_tin(Tin.from_points(np.column_stack([xy, np.full(5, 10.0)])), path)

    def make(k_scan, count=1):
        return tse.parallel_env(scenario=scenario_from_dict({
            "name": "square", "task": "goal", "max_cycles": 5, "terrain": {"source": "tin", "path": str(path)},
            "robots": {"count": count}, "sensor": {"range_m": R, "fov_deg": 360.0},
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
    want = [min(_to_border(x, y, h + 2 * math.pi * k / 8), R) / R for k in range(8)]
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
    assert ObsLayout().mirror_signs().shape == (59,)  # no scan: the sign flip is the whole mirror


@pytest.mark.parametrize("scenario", ["cliff_goal", "generated"])
def test_compiled_scan_equals_the_numpy_reference(scenario):
    cfg = load_scenario(scenario)
    cfg = cfg.replace(observation=ObservationSpec(k_scan=16))
    env = tse.parallel_env(scenario=cfg, n_robots=20)
    env.reset(seed=4)
    rng = np.random.default_rng(2)
    hit = False
    for _ in range(25):
        env.step_arrays(rng.uniform(-1, 1, (20, 2)))
        args = (env.world, env.world_state, env.sensed(), env.target_assignment, env.live_mask, env.layout)
        a, b = build_observations(*args), build_observations_reference(*args)
        np.testing.assert_allclose(a, b, atol=2e-7)
        live = env.live_mask
        hit |= bool(np.any(a[live][:, env.layout.scan] < 1.0))
    assert hit  # some beam met a break


def test_the_layout_saves_the_scan_and_old_files_still_load():
    old = ObsLayout().to_dict()
    assert "k_scan" not in old and "scan" not in old["slots"]  # no scan: the dict layouts had before it
    assert ObsLayout.from_dict(old) == ObsLayout()
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
