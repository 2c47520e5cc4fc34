"""tin_swarm_v0: PettingZoo conformance, determinism, spaces, and tests of meaning."""

import inspect
import math
import warnings

import numpy as np
import pettingzoo
import pytest
from pettingzoo.test import api_test, max_cycles_test, parallel_api_test, parallel_seed_test, render_test, seed_test
from pettingzoo.test.state_test import state_test
from pettingzoo.utils.conversions import parallel_to_aec

import tin_swarm_env as tse
from tin_swarm_env import tin_swarm_v0
from tin_swarm_env.scenario import scenario_from_dict

SMALL = {"scenario": "cliff_goal", "n_robots": 6}


def make(**kw):
    return tse.parallel_env(**{**SMALL, **kw})


def test_parallel_api_test():
    parallel_api_test(make(max_cycles=60), num_cycles=80)


def test_aec_api_test():
    api_test(parallel_to_aec(make(max_cycles=40)), num_cycles=60)
    api_test(tin_swarm_v0.env(**SMALL, max_cycles=40), num_cycles=60)


def test_seed_tests():
    seed_test(lambda: tin_swarm_v0.env(**SMALL, max_cycles=50), num_cycles=50)
    parallel_seed_test(lambda: make(max_cycles=50), num_cycles=50)


def test_max_cycles_test():
    max_cycles_test(tin_swarm_v0)


def test_render_test():
    render_test(lambda render_mode=None: tin_swarm_v0.env(**SMALL, render_mode=render_mode))


def test_state_test():
    state_test(tin_swarm_v0.env(**SMALL), make(), num_cycles=10)


@pytest.mark.skipif(not hasattr(pettingzoo, "register"), reason="pettingzoo < 1.27 has no environment registry")
def test_registered_with_pettingzoo():
    env = pettingzoo.make("parallel", "tin_swarm/TinSwarm-v0", n_robots=3, max_cycles=5)
    obs, _ = env.reset(seed=1)
    assert env.agents == ["robot_0", "robot_1", "robot_2"]
    aec = pettingzoo.make("aec", "tin_swarm/TinSwarm-v0", n_robots=3)
    aec.reset(seed=1)
    assert aec.agent_selection == "robot_0"


@pytest.mark.parametrize("scenario", sorted(tse.scenario.list_scenarios()))
def test_random_rollout_observations_lie_in_their_space(scenario):
    env = tse.parallel_env(scenario=scenario, n_robots=8, max_cycles=200)
    space = env.observation_space("robot_0")
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    seen = []
    steps = 0
    while env.agents:
        assert all(space.contains(o) for o in obs.values()), scenario
        assert env.state_space.contains(env.state())
        seen.append(np.stack(list(obs.values())))
        obs, *_ = env.step({a: rng.uniform(-1.5, 1.5, 2).astype(np.float32) for a in env.agents})
        steps += 1
    assert steps <= 200
    assert env.observation_space("robot_3") is space and env.action_space("robot_0") is env.action_space("robot_1")
    allobs = np.concatenate(seen)
    assert np.abs(allobs).max() <= 1.0 and np.any(allobs != 0)


def test_multi_step_determinism_bit_identical():
    def run():
        env = tse.parallel_env(scenario="hill", n_robots=12, max_cycles=100)
        obs, _ = env.reset(seed=123)
        rng = np.random.default_rng(5)
        out = [np.stack([obs[a] for a in env.possible_agents])]
        rews = []
        for _ in range(100):
            if not env.agents:
                break
            acts = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.possible_agents if a in env.agents}
            obs, r, *_ = env.step(acts)
            out.append(np.stack([obs.get(a, np.zeros(env.layout.size, np.float32)) for a in env.possible_agents]))
            rews.append([r.get(a, 0.0) for a in env.possible_agents])
        return np.stack(out), np.array(rews)

    (o1, r1), (o2, r2) = run(), run()
    assert o1.tobytes() == o2.tobytes() and r1.tobytes() == r2.tobytes()
    assert len(o1) == 101


def test_fresh_arrays_every_step():
    env = make()
    obs, _ = env.reset(seed=0)
    first = obs["robot_0"]
    obs2, *_ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert not np.shares_memory(first, obs2["robot_0"])


def test_bad_actions_are_named():
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_2 is not finite"):
        env.step({"robot_2": np.array([np.nan, 0.0])})
    with pytest.raises(ValueError, match="unknown agent 'robot_99'"):
        env.step({"robot_99": np.zeros(2)})
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        env.step({"robot_0": np.zeros(3)})
    # missing agents stand still; out-of-range actions are clipped
    p0 = env.world_state.positions.copy()
    env.step({"robot_0": np.array([5.0, 0.0], np.float32)})
    moved = np.hypot(*(env.world_state.positions - p0).T)
    assert moved[1:].max() == 0.0
    assert moved[0] <= env.config.world.robot.max_speed_mps * env.config.world.dt_s + 1e-9
    with pytest.warns(UserWarning, match="ignoring unknown reset option"):
        env.reset(options={"robots": 1})
    with pytest.raises(ValueError, match="unknown scenario"):
        tse.parallel_env(scenario="nowhere")


def test_truncation_and_dead_agents_leave_the_step_after():
    env = make(max_cycles=3)
    env.reset(seed=0)
    for k in range(3):
        obs, r, term, trunc, info = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert all(trunc.values()) and not any(term.values())
    assert all(i["reason"] == "max_cycles" for i in info.values())
    assert env.agents == []
    # max_cycles is read at step time
    env = make(max_cycles=3)
    env.reset(seed=0)
    env.max_cycles = 5
    for _ in range(4):
        _, _, _, trunc, _ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
        assert not any(trunc.values())


def toward(env, xy_goal):
    """Body-frame action (unit, clipped) driving each live robot toward a world point."""
    s = env.world_state
    acts = {}
    for a in env.agents:
        i = env.agent_name_mapping[a]
        d = np.asarray(xy_goal, float) - s.positions[i]
        d /= np.linalg.norm(d)
        c, sn = math.cos(s.headings[i]), math.sin(s.headings[i])
        acts[a] = np.array([c * d[0] + sn * d[1], -sn * d[0] + c * d[1]], np.float32)
    return acts


def ramp_env(**kw):
    d = {"name": "ramp_test", "task": "goal", "max_cycles": 200,
         "terrain": {"source": "procedural", "recipe": "ramp", "method": "greedy", "max_error_m": 0.25},
         "robots": {"count": 1}, "targets": {"positions": [[270.0, 100.0]]}}
    return tse.parallel_env(scenario=scenario_from_dict(d, "ramp_test"), **kw)


def test_driving_off_the_cliff_terminates_with_reason_fell():
    env = ramp_env()
    env.reset(seed=0, options={"robot_positions": [[200.0, 100.0]], "headings": [0.0]})
    for _ in range(40):
        obs, r, term, trunc, info = env.step(toward(env, (270.0, 100.0)))
        if term.get("robot_0"):
            break
    assert term["robot_0"] and info["robot_0"]["reason"] == "fell"
    assert r["robot_0"] <= env.config.rewards.fall + 1.0
    assert env.agents == []


def test_break_slots_next_to_a_cliff_point_to_the_safe_side():
    env = ramp_env()
    heading = 0.7
    obs, _ = env.reset(seed=0, options={"robot_positions": [[215.0, 100.0]], "headings": [heading]})
    b = env.layout.slots(obs["robot_0"], "breaks")
    R = env.config.world.sensor.range_m
    valid = b[:, 0] == 1
    assert valid.any()
    # the nearest break: the cliff top at x = 220, 5 m east
    k = int(np.argmin(np.where(valid, b[:, 6], np.inf)))
    c, s = math.cos(heading), math.sin(heading)
    px, py = b[k, 1] * R, b[k, 2] * R
    world_pt = np.array([c * px - s * py, s * px + c * py])
    world_n = np.array([c * b[k, 3] - s * b[k, 4], s * b[k, 3] + c * b[k, 4]])
    np.testing.assert_allclose(world_pt[0], 5.0, atol=0.6)
    np.testing.assert_allclose(world_n, [-1.0, 0.0], atol=0.05)  # back onto the plateau
    assert b[k, 5] > 0.5  # the ground falls away (a 15 m drop -> 15 / 25)
    assert b[k, 7] == 1.0  # a dangerous break (cliff edge)


def ridge_env(ridge_m):
    d = {"name": "ridge_test", "task": "containment", "max_cycles": 50,
         "terrain": {"source": "procedural", "recipe": "ridge", "method": "greedy", "max_error_m": 0.1,
                     "params": {"ridge_m": ridge_m}},
         "robots": {"count": 2, "max_slope_deg": 40.0, "max_climb_deg": 45.0},
         "sensor": {"range_m": 100.0, "fov_deg": 360.0}}
    return tse.parallel_env(scenario=scenario_from_dict(d, "ridge_test"))


@pytest.mark.parametrize("ridge_m,visible", [(10.0, False), (0.2, True)])
def test_robot_behind_a_ridge_is_not_in_the_visible_robot_slots(ridge_m, visible):
    env = ridge_env(ridge_m)
    obs, _ = env.reset(seed=0, options={"robot_positions": [[60.0, 50.0], [140.0, 50.0]], "headings": [0.0, 0.0]})
    slots = env.layout.slots(obs["robot_0"], "robots")
    assert bool(slots[0, 0]) is visible
    if visible:
        np.testing.assert_allclose(slots[0, 1:], [0.8, 0.0, 0.8], atol=1e-6)


def test_arrival_terminates_with_reason_arrived():
    env = tse.parallel_env(scenario="flat", n_robots=1, max_cycles=100)
    goal = env.config.targets.positions[0]
    env.reset(seed=0, options={"robot_positions": [[goal[0] - 10.0, goal[1]]], "headings": [0.0]})
    for _ in range(20):
        _, r, term, _, info = env.step(toward(env, goal))
        if term.get("robot_0"):
            break
    assert info["robot_0"]["reason"] == "arrived" and r["robot_0"] > env.config.rewards.arrival


def test_arriving_and_running_dry_in_one_step_is_an_arrival_a_fall_beats_both():
    """compute_rewards by hand: robot 0 arrives and empties its battery (ARRIVED, +arrival, no
    battery penalty), robot 1 only empties it (BATTERY), robot 2 arrives but fell (FELL)."""
    from types import SimpleNamespace

    from tin_swarm_env.env.reward import compute_rewards

    cfg = tse.parallel_env(scenario="flat", n_robots=1).config
    w = cfg.rewards
    tg = np.array([[0.0, 0.0]])
    state = SimpleNamespace(n_robots=3, positions=np.array([[1.0, 0.0], [500.0, 0.0], [0.0, 1.0]]),
                            targets=SimpleNamespace(positions=tg))
    ev = SimpleNamespace(energy_j=np.zeros(3), collisions=np.zeros(3), fell=np.array([False, False, True]),
                         emptied=np.array([True, True, False]))
    d = np.full(3, 10.0)
    r, term, why = compute_rewards(cfg, d, d, state, ev, np.zeros(3, dtype=np.int64), np.ones(3, dtype=bool))
    assert why.tolist() == [tse.Reason.ARRIVED, tse.Reason.BATTERY, tse.Reason.FELL] and term.all()
    np.testing.assert_allclose(r, np.float32([w.arrival, w.battery_empty, w.fall]), rtol=1e-6)


def test_state_keeps_its_space_when_a_reset_changes_the_target_count():
    two = tse.parallel_env(scenario="flat", n_robots=3)  # two targets, two slots
    two.reset(seed=0, options={"target_positions": [two.config.targets.positions[0]]})
    st = two.state()
    assert two.state_space.contains(st) and np.all(st[-2:] == 0) and np.any(st[-4:-2] != 0)  # the empty slot is 0
    env = make()  # cliff_goal: one target, one slot
    assert env.state_space.shape == (6 * 6 + 2,)
    with pytest.raises(tse.TinSwarmError, match="empty list.*goal task"):  # a goal episode without a target
        env.reset(seed=0, options={"target_positions": np.zeros((0, 2))})
    g = env.config.targets.positions[0]
    env.reset(seed=0, options={"target_positions": [g, g]})
    with pytest.raises(tse.TinSwarmError, match="2 targets .* state_space holds 1"):
        env.state()


def test_batched_path_matches_the_dict_api():
    a, b = make(), make()
    oa, _ = a.reset(seed=9)
    ob = b.reset_arrays(seed=9)
    np.testing.assert_array_equal(np.stack([oa[x] for x in a.possible_agents]), ob)
    rng = np.random.default_rng(0)
    for _ in range(30):
        acts = rng.uniform(-1, 1, (a.n, 2)).astype(np.float32)
        da = {x: acts[i] for i, x in enumerate(a.possible_agents) if x in a.agents}
        oa, ra, ta, tra, _ = a.step(da)
        ob, rb, tb, trb, _ = b.step_arrays(acts)
        for x, o in oa.items():
            i = a.agent_name_mapping[x]
            np.testing.assert_array_equal(o, ob[i])
            assert ra[x] == rb[i] and ta[x] == tb[i] and tra[x] == trb[i]


def test_rgb_array_shows_robots_and_human_mode_returns_none():
    env = make(render_mode="rgb_array", sensor_cones=True)
    env.reset(seed=0)
    img = env.render()
    assert img.shape[2] == 3 and img.dtype == np.uint8
    assert (img == [255, 140, 0]).all(axis=2).sum() >= 6 * 20  # six orange robot discs
    assert np.any(img != img[0, 0])
    env.close()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        h = make(render_mode="human")
        h.reset(seed=0)
        assert h.render() is None
        h.close()


def test_pickle_round_trip():
    import pickle

    env = make()
    env2 = pickle.loads(pickle.dumps(env))
    o1, _ = env.reset(seed=4)
    o2, _ = env2.reset(seed=4)
    np.testing.assert_array_equal(o1["robot_0"], o2["robot_0"])


def test_parallel_env_has_the_constructor_s_typed_signature():
    from tin_swarm_env.env.tin_swarm import TinSwarmEnv, parallel_env

    want = dict(inspect.signature(TinSwarmEnv.__init__).parameters)
    want.pop("self")
    got = dict(inspect.signature(parallel_env).parameters)
    assert list(got) == list(want)
    for k in want:
        assert (got[k].default, got[k].annotation, got[k].kind) == (want[k].default, want[k].annotation,
                                                                     want[k].kind), k


def test_human_render_without_a_display_warns(monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = tse.parallel_env(scenario="flat", n_robots=2, render_mode="human", render_width=64)
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="no display"):
        env.render()
    env.close()
