"""The package root is lazy, registration happens on PettingZoo's import, one Reason enum,
one episode loop (rollout), the env's read-only views, and no second copy of a setting."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env import Reason
from tin_swarm_env.apps.rollout import rollout

ROOT = Path(__file__).resolve().parents[2]


def run_py(code):
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout


def test_terrain_loads_no_pettingzoo_gymnasium_or_env():
    out = run_py("import sys, tin_swarm_env.terrain\n"
                 "print(sorted(m for m in ('pettingzoo', 'gymnasium', 'tin_swarm_env.env') if m in sys.modules))")
    assert out.strip() == "[]"


def test_env_subpackage_is_not_shadowed_and_registration_waits_for_pettingzoo():
    out = run_py("import sys\nimport tin_swarm_env as tse\n"
                 "assert 'pettingzoo' not in sys.modules\n"
                 "import pettingzoo\nimport tin_swarm_env.env.reward\n"
                 "e = pettingzoo.make('parallel', 'tin_swarm/TinSwarm-v0', n_robots=2, max_cycles=3)\n"
                 "a = pettingzoo.make('aec', 'tin_swarm/TinSwarm-v0', n_robots=2)\n"
                 "print(type(tse.env).__name__, type(e).__name__, callable(tse.tin_swarm_v0.env), tse.Reason(4).label)")
    assert out.split() == ["module", "TinSwarmEnv", "True", "max_cycles"]
    assert tse.parallel_env is tse.tin_swarm_v0.parallel_env and tse.TinSwarmEnv is tse.env.TinSwarmEnv
    assert tse.env.Reason is Reason and tse.adapters and tse.policies and tse.terrain


def test_on_import_runs_callbacks_once_after_the_module_executed(tmp_path, monkeypatch):
    from tin_swarm_env._registration import _on_import

    (tmp_path / "tse_probe_mod.py").write_text("VALUE = 41\nVALUE += 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    seen = []
    _on_import("tse_probe_mod", lambda m: seen.append(m.VALUE))
    assert seen == []
    import tse_probe_mod  # noqa: F401

    assert seen == [42]
    _on_import("tse_probe_mod", lambda m: seen.append(-m.VALUE))  # already imported: at once
    assert seen == [42, -42]
    from tin_swarm_env._registration import _PostImportFinder

    assert not any(isinstance(f, _PostImportFinder) for f in sys.meta_path)  # steps aside when done


def test_reason_codes_and_labels():
    assert [int(r) for r in Reason] == [0, 1, 2, 3, 4]
    assert [r.label for r in Reason][1:] == ["arrived", "fell", "battery", "max_cycles"]
    import tin_swarm_env.world as world
    import tin_swarm_env.world.state as state

    for alias in ("ACTIVE", "DONE", "FELL", "EMPTY", "STATUS_NAMES"):  # robot status is a Reason code, no aliases
        assert not hasattr(world, alias) and not hasattr(state, alias), alias


def test_no_raw_reason_numbers_and_no_env_internals_outside_env():
    bad = []
    for d in ("tin_swarm_env", "agents", "bench"):
        for p in (ROOT / d).rglob("*.py"):
            text = p.read_text()
            if re.search(r"reasons == [0-9]", text):
                bad.append(f"{p}: reasons == <number>")
            if "tin_swarm_env/env/" not in p.as_posix() and re.search(
                    r"env\.(wstate|live|readings|target_idx)\b", text):
                bad.append(f"{p}: env internals")
    assert bad == []


class Standstill:
    def __init__(self):
        self.resets = 0

    def reset(self):
        self.resets += 1

    def act_batch(self, obs):
        return np.zeros((len(obs), 2), np.float32)


def test_rollout_of_a_standstill_times_every_robot_out():
    env = tse.parallel_env(scenario="flat", n_robots=4, max_cycles=7)
    pol = Standstill()
    o = rollout(env, pol, seed=3)
    assert pol.resets == 1
    assert o.n_steps == 7 and np.all(o.steps == 7)
    assert np.all(o.reasons == Reason.TIMEOUT)
    assert o.counts() == {"arrived": 0, "fell": 0, "battery": 0, "max_cycles": 4}
    assert np.all(o.battery_left < 1) and np.all(o.battery_left > 0.99)  # idle and sensing drain a little
    np.testing.assert_allclose(o.returns, -(2.0 + 3.0) * 0.5 * 7 / 1000)  # energy_per_kj = -1, 5 W for 3.5 s


def test_rollout_agrees_with_the_dict_api_infos():
    env = tse.parallel_env(scenario="ramp", n_robots=6)
    pol = tse.policies.APFPolicy(env)
    o = rollout(env, pol, seed=1)
    obs, _ = env.reset(seed=1)
    pol.reset()  # the policy keeps per-robot memory: reset it with the env (as rollout does)
    got, ret = {}, dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        obs, rew, _, _, infos = env.step(pol.act(obs))
        for a, r in rew.items():
            ret[a] += r
        got.update({a: (i["reason"], env.steps) for a, i in infos.items() if "reason" in i})
    assert [got[a][0] for a in env.possible_agents] == [Reason(int(r)).label for r in o.reasons]
    assert [got[a][1] for a in env.possible_agents] == o.steps.tolist()
    np.testing.assert_allclose([ret[a] for a in env.possible_agents], o.returns, rtol=1e-5)


def test_env_views_are_copies_and_read_only():
    env = tse.parallel_env(scenario="flat", n_robots=3, max_cycles=5)
    env.reset(seed=0)
    m = env.live_mask
    m[:] = False
    assert env.live_mask.all()
    t = env.target_assignment
    env.target_assignment[:] = 9
    np.testing.assert_array_equal(env.target_assignment, t)
    assert env.tin is env.world.tin and env.world_state.n_robots == 3 and env.sensed() is not None
    for name in ("world", "tin", "world_state", "live_mask", "target_assignment", "steps"):
        with pytest.raises(AttributeError):
            setattr(env, name, None)


def test_reset_options_go_through_the_generator_and_are_checked():
    from tin_swarm_env.errors import PlacementError

    env = tse.parallel_env(scenario="ramp", n_robots=2)
    env.reset(seed=0, options={"robot_positions": [[20.0, 100.0], [30.0, 120.0]], "headings": [0.0, 1.0],
                               "target_positions": [[270.0, 120.0], [270.0, 60.0], [40.0, 40.0]]})
    s = env.world_state
    np.testing.assert_array_equal(s.positions, [[20.0, 100.0], [30.0, 120.0]])
    assert len(s.targets) == 3 and env.target_assignment.tolist() == [0, 1]
    with pytest.raises(PlacementError, match=r"robot 1 at \[221.0, 120.0\] lies on a too-steep"):
        env.reset(options={"robot_positions": [[20.0, 100.0], [221.0, 120.0]]})
    with pytest.raises(PlacementError, match=r"target 0 at \[-5.0, 0.0\] lies outside"):
        env.reset(options={"target_positions": [[-5.0, 0.0]]})


def test_each_setting_has_one_default():
    import inspect

    from tin_swarm_env.terrain import Tin
    from tin_swarm_env.terrain.breaks import find_breaks
    from tin_swarm_env.world import RobotParams, WorldParams

    for fn in (Tin.breaks, find_breaks):
        sig = inspect.signature(fn).parameters
        assert sig["max_slope_deg"].default == RobotParams().max_slope_deg == WorldParams().robot.max_slope_deg
        assert sig["break_angle_deg"].default == WorldParams().break_angle_deg
    for p in ("tin_swarm_env/terrain/tin.py", "tin_swarm_env/terrain/breaks.py", "tin_swarm_env/world/params.py"):
        src = (ROOT / p).read_text()
        assert not re.search(r"(max_slope_deg|break_angle_deg)(: float[^=\n]*)? = [0-9]", src), p  # no literal default
