"""Across the package: the root is lazy and registration waits for PettingZoo's import, no raw
Reason numbers or env internals outside env/, the env's read-only views, reset options, and no
second copy of a setting."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env import Reason

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


@pytest.mark.parametrize("given, expect", [
    ({}, ("1000", None)),
    ({"GOMP_SPINCOUNT": "5"}, ("5", None)),
    ({"OMP_WAIT_POLICY": "PASSIVE"}, (None, "PASSIVE")),
])
def test_importing_sets_a_short_openmp_spin_unless_the_user_chose(given, expect):
    """The package sets GOMP_SPINCOUNT=1000 (numba's OpenMP threads spin briefly, then sleep; the reason
    is in tin_swarm_env/__init__.py) only where neither GOMP_SPINCOUNT nor OMP_WAIT_POLICY is set."""
    env = {k: v for k, v in os.environ.items() if k not in ("GOMP_SPINCOUNT", "OMP_WAIT_POLICY")} | given
    r = subprocess.run([sys.executable, "-c", "import os, tin_swarm_env\n"
                        "print(os.environ.get('GOMP_SPINCOUNT'), os.environ.get('OMP_WAIT_POLICY'))"],
                       capture_output=True, text=True, timeout=120, cwd=ROOT, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == [str(e) for e in expect]
