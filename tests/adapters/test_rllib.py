"""Ray RLlib: the corrected ParallelPettingZooEnv, ppo_config's shared policy, and one PPO iteration
on this machine."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ray", reason="the rllib extra: pip install 'tin_swarm_env[rllib]'")

from tin_swarm_env.adapters.rllib import ENV_NAME, SHARED_POLICY, ppo_config, rllib_env_creator  # noqa: E402


def test_agents_stay_in_order_and_shrink_render_works_episode_ends_once():
    env = rllib_env_creator({"scenario": "ramp", "n_robots": 3, "max_cycles": 40, "render_mode": "rgb_array"})
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2"]
    obs, infos = env.reset(seed=0)
    assert list(obs) == env.agents == env.possible_agents
    img = env.render()
    assert img.ndim == 3 and img.dtype == np.uint8
    # send robot_0 off the cliff: it leaves `agents`; the rest time out together
    env.par_env.reset(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 100.0], [30.0, 140.0]],
                                       "headings": [0.0, 0.0, 0.0]})
    env.agents = list(env.par_env.agents)
    seen_all = []
    for _ in range(40):
        acts = {a: (np.array([1.0, 0.0], np.float32) if a == "robot_0" else np.zeros(2, np.float32))
                for a in env.agents}
        obs, rew, term, trunc, info = env.step(acts)
        seen_all.append((term["__all__"], trunc["__all__"]))
        assert env.agents == [a for a in env.possible_agents if a in env.agents]
        if term["__all__"] or trunc["__all__"]:
            break
    assert "robot_0" not in env.agents
    assert env.agents == []
    assert seen_all[-1] == (False, True) and not any(t or u for t, u in seen_all[:-1])


def test_ppo_config_maps_every_robot_to_one_shared_policy():
    cfg = ppo_config("ramp", n_robots=3, max_cycles=9, env_runners=2, seed=4).training(lr=1e-3)
    assert cfg.env == ENV_NAME and cfg.env_config == {"scenario": "ramp", "n_robots": 3, "max_cycles": 9}
    assert set(cfg.policies) == {SHARED_POLICY}
    assert {cfg.policy_mapping_fn(f"robot_{i}", None) for i in range(3)} == {SHARED_POLICY}
    assert list(cfg.rl_module_spec.rl_module_specs) == [SHARED_POLICY]
    assert cfg.num_env_runners == 2 and cfg.num_learners == 0 and cfg.seed == 4 and cfg.lr == 1e-3
    assert cfg.is_multi_agent
    # the env it names is the corrected wrapper, with observation spaces per robot
    env = rllib_env_creator(cfg.env_config)
    assert env.observation_spaces["robot_2"].shape == (59,)


def test_one_rllib_ppo_iteration_runs_locally(tmp_path):
    script = Path(__file__).resolve().parents[2] / "agents" / "train_rllib.py"
    r = subprocess.run([sys.executable, str(script), "--scenario", "flat", "--n-robots", "4", "--max-cycles", "50",
                        "--iterations", "1", "--train-batch-size", "400", "--minibatch-size", "100",
                        "--num-epochs", "1", "--num-cpus", "2", "--out-dir", str(tmp_path / "rl")],
                       capture_output=True, text=True, timeout=600, env={**__import__("os").environ,
                                                                         "RAY_ADDRESS": ""})
    assert r.returncode == 0, (r.stdout[-2000:], r.stderr[-3000:])
    assert "iteration 1: env steps" in r.stdout
    # ppo_config's callback counted the steps sampled on this (only) node: all of them
    steps = int(float(r.stdout.split("iteration 1: env steps ")[1].split(",")[0]))
    by_node = r.stdout.split("iteration 1: env steps by Ray node: ")[1].splitlines()[0].split(", ")
    assert len(by_node) == 1 and int(by_node[0].split()[1]) == steps >= 400
    assert (tmp_path / "rl" / "progress.csv").exists()
