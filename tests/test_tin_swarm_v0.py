"""The versioned entry point (tin_swarm_v0.py): the same env classes and constructors as env/, so
``tin_swarm_v0.parallel_env()`` and ``tin_swarm_v0.env()`` give the PettingZoo parallel and AEC envs."""

from __future__ import annotations

from pettingzoo import AECEnv, ParallelEnv

from tin_swarm_env import tin_swarm_v0
from tin_swarm_env.env import tin_swarm


def test_the_versioned_module_exports_the_env_module_s_objects():
    assert tin_swarm_v0.__all__ == ["TinSwarmEnv", "env", "parallel_env", "raw_env"]
    for name in tin_swarm_v0.__all__:
        assert getattr(tin_swarm_v0, name) is getattr(tin_swarm, name), name


def test_parallel_env_and_env_make_the_two_apis():
    p = tin_swarm_v0.parallel_env(scenario="flat", n_robots=2, max_cycles=3)
    assert isinstance(p, ParallelEnv) and isinstance(p, tin_swarm_v0.TinSwarmEnv)
    obs, _ = p.reset(seed=0)
    assert sorted(obs) == sorted(p.possible_agents) and len(obs) == 2
    a = tin_swarm_v0.env(scenario="flat", n_robots=2, max_cycles=3)
    assert isinstance(a, AECEnv)
    a.reset(seed=0)
    assert a.agent_selection in a.possible_agents
