"""The geodesic progress reward, distance_to_go_m, and solvability at load."""

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ScenarioError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import RewardWeights, load_scenario, scenario_from_dict


def _pit_asc(path, pit_xy=(60.0, 50.0), pit_r=15.0, depth=20.0):
    """A 120 x 100 m level DEM (2 m cells) with a round pit whose walls are vertical steps."""
    x = np.arange(0.0, 121.0, 2.0)
    y = np.arange(0.0, 101.0, 2.0)
    X, Y = np.meshgrid(x, y)
    z = np.where(np.hypot(X - pit_xy[0], Y - pit_xy[1]) <= pit_r, -depth, 0.0)
    rows = "\n".join(" ".join(f"{v:.1f}" for v in row) for row in z[::-1])  # first row: north
    path.write_text(f"ncols {len(x)}\nnrows {len(y)}\nxllcorner -1\nyllcorner -1\ncellsize 2\n{rows}\n")
    return path


def _pit_toml(tmp_path, target, region):
    _pit_asc(tmp_path / "pit.asc")
    p = tmp_path / "pit.toml"
    p.write_text(f"""task = "goal"
[terrain]
source = "dem"
path = "pit.asc"
method = "delaunay"
[robots]
count = 6
spawn_region = {list(region)}
[targets]
positions = [[100.0, 20.0], {list(target)}]
""")
    return p


def test_target_in_an_enclosed_pit_fails_at_load_naming_file_and_target(tmp_path):
    p = _pit_toml(tmp_path, (60.0, 50.0), (5.0, 5.0, 30.0, 95.0))
    msg = r"pit\.toml \[targets\] positions\[1\] \[60\.0, 50\.0\]: cannot be reached"
    with pytest.raises(ScenarioError, match=msg):
        tse.parallel_env(scenario=str(p))


def test_robots_spawn_only_where_their_target_can_be_reached(tmp_path):
    # target 0 outside the pit, target 1 inside; the spawn region covers both: robots of target 0
    # must start outside the pit, robots of target 1 inside it
    p = _pit_toml(tmp_path, (60.0, 50.0), (40.0, 30.0, 80.0, 70.0))
    env = tse.parallel_env(scenario=str(p), n_robots=16)
    for seed in range(3):
        env.reset_arrays(seed=seed)
        pos = env.world_state.positions
        in_pit = np.hypot(pos[:, 0] - 60, pos[:, 1] - 50) <= 15
        assert np.array_equal(in_pit, env.target_assignment == 1)
        assert np.all(np.isfinite(env.distance_to_go()))


def test_cliff_goal_robots_must_detour_and_apf_brings_the_distance_down():
    env = tse.parallel_env(scenario="cliff_goal", n_robots=8)
    obs, infos = env.reset(seed=0)
    s = env.world_state
    straight = np.hypot(*(s.targets.positions[0] - s.positions).T)
    geo = np.array([infos[a]["distance_to_go_m"] for a in env.possible_agents])
    np.testing.assert_array_equal(geo, env.distance_to_go())
    assert np.all(np.isfinite(geo)) and np.all(geo > straight + 20.0)  # the pass is far north of the line
    pol = APFPolicy(env)
    start, hist = geo.copy(), [geo]
    arrived = np.zeros(env.n, dtype=bool)
    while env.agents:
        obs, rew, term, trunc, infos = env.step(pol.act(obs))
        for a, info in infos.items():
            assert np.isfinite(rew[a])
            assert "distance_to_go_m" in info
            arrived[env.agent_name_mapping[a]] |= info.get("reason") == "arrived"
        hist.append(env.distance_to_go())
    hist = np.array(hist)  # (steps + 1, n)
    assert arrived.sum() >= 6
    end = np.array([hist[np.isfinite(hist[:, i]), i][-1] for i in range(env.n)])
    assert np.all(end[arrived] < start[arrived]) and np.all(end[arrived] <= 13.0)  # 8 m arrival radius, straight
    # on average over 100-step windows the distance to go never grows (APF wobbles step to step
    # and, at the start, spreads the crowd along the cliff edge)
    k = len(hist) // 100
    windows = np.array([hist[j * 100:(j + 1) * 100][:, arrived].mean() for j in range(k)])
    assert k >= 3 and np.all(np.diff(windows) <= 0.0) and windows[-1] < 0.2 * windows[0]


def _zero_weights(**kw):
    z = {k: 0.0 for k in ("arrival", "on_ring_per_step", "fall", "battery_empty", "collision", "energy_per_kj")}
    return RewardWeights(**{**z, **kw})


@pytest.mark.parametrize("progress", ["geodesic", "euclidean"])
def test_reward_is_the_decrease_of_the_distance_to_go(progress):
    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(rewards=_zero_weights(progress=progress, progress_per_m=2.0))
    env = tse.parallel_env(scenario=cfg, n_robots=6)
    env.reset_arrays(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(30):
        d0 = env.distance_to_go()
        live = env.live_mask
        _, rew, *_ = env.step_arrays(rng.uniform(-1, 1, (6, 2)))
        d1 = env.distance_to_go()
        np.testing.assert_allclose(rew[live], (2.0 * (d0 - d1))[live].astype(np.float32), rtol=1e-5, atol=1e-4)
    s = env.world_state
    straight = np.hypot(*(s.targets.positions[0] - s.positions).T)
    if progress == "euclidean":
        np.testing.assert_array_equal(env.distance_to_go(), straight)
    else:
        assert np.all(env.distance_to_go() >= straight - 1e-9)


def test_reward_stays_finite_after_a_fall_onto_impassable_ground():
    env = tse.parallel_env(scenario="cliff_goal", n_robots=2)
    env.reset(seed=0, options={"robot_positions": [[146.0, 100.0], [60.0, 100.0]], "headings": [0.0, 0.0]})
    for _ in range(20):
        obs, rew, term, trunc, infos = env.step({a: np.array([1.0, 0.0], np.float32) for a in env.agents})
        assert all(np.isfinite(v) for v in rew.values())
        if "robot_0" in term and term["robot_0"]:
            assert infos["robot_0"]["reason"] == "fell" and infos["robot_0"]["distance_to_go_m"] == np.inf
            assert rew["robot_0"] == pytest.approx(-100.0, abs=1.0)  # the fall, no inf progress
            break
    else:
        pytest.fail("robot_0 did not fall")


def test_progress_setting_is_checked_with_the_file_named():
    with pytest.raises(ScenarioError, match=r"my\.toml \[rewards\].*RewardWeights\.progress must be 'geodesic' or"):
        scenario_from_dict({"terrain": {"source": "flat"}, "targets": {"positions": [[1.0, 1.0]]},
                            "rewards": {"progress": "manhattan"}}, source="my.toml")
    assert RewardWeights().progress == "geodesic"


def test_fields_are_built_once_per_tin_and_target():
    a = tse.parallel_env(scenario="ramp", n_robots=2)
    b = tse.parallel_env(scenario="ramp", n_robots=2)
    a.reset(seed=0)
    b.reset(seed=1)
    a.reset(seed=2)
    assert a.target_fields[0] is b.target_fields[0]


def test_the_envs_one_pass_distance_to_go_is_reward_distance_to_go_bit_for_bit(tmp_path):
    """The env measures every robot's distance to go with the vector env's pass over its episode's
    FieldPack (both targets' fields at once, :func:`~tin_swarm_env.env.reward.measure`);
    :func:`~tin_swarm_env.env.reward.distance_to_go` (one field at a time) is the spec. Random
    driving round a pit, robots of both targets, live and gone."""
    from tin_swarm_env.env.reward import distance_to_go

    p = _pit_toml(tmp_path, (60.0, 50.0), (40.0, 30.0, 80.0, 70.0))
    env = tse.parallel_env(scenario=str(p), n_robots=16)
    rng = np.random.default_rng(0)
    env.reset_arrays(seed=1)
    assert len(env.target_fields) == 2 and set(env.target_assignment.tolist()) == {0, 1}
    for _ in range(40):
        s = env.world_state
        want = distance_to_go(s, env.target_assignment, env.target_fields)
        assert np.isfinite(want).any()
        np.testing.assert_array_equal(env._measure(s), want)
        env.step_arrays(rng.uniform(-1, 1, (env.n, 2)))
