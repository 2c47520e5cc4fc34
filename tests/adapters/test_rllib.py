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
    assert env.observation_spaces["robot_2"].shape == (91,)


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
    # the RLModule was exported and checked against itself (export_module raises on a gap)
    assert "exported" in r.stdout and "numpy vs RLModule actions differ by at most" in r.stdout
    import tin_swarm_env as tse
    from tin_swarm_env.policies.learned import load_policy

    pol = load_policy(tmp_path / "rl" / "policy", tse.parallel_env(scenario="flat", n_robots=4))
    assert pol.training["library"] == "rllib" and pol.training["iterations"] == 1


def _tiny_module(**model_config):
    import torch
    from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    import tin_swarm_env as tse

    env = tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=40)
    torch.manual_seed(0)
    spec = RLModuleSpec(module_class=DefaultPPOTorchRLModule, observation_space=env.observation_space("robot_0"),
                        action_space=env.action_space("robot_0"), model_config={"fcnet_hiddens": [16, 16],
                                                                                 **model_config})
    return spec.build(), env


@pytest.mark.parametrize("vf_share_layers", [True, False])
def test_export_gives_the_modules_deterministic_actions(tmp_path, vf_share_layers):
    import torch

    from tin_swarm_env.adapters.rllib import deterministic_actions, export_module, module_mean_layers
    from tin_swarm_env.policies.export import real_observations
    from tin_swarm_env.policies.learned import load_policy

    module, env = _tiny_module(vf_share_layers=vf_share_layers)
    with torch.no_grad():  # an untrained module's means are small: scale the head so the clip matters too
        module.pi.net.mlp[0].weight.mul_(10.0)
    layers, activation = module_mean_layers(module)
    assert [W.shape for W, _ in layers] == [(16, 91), (16, 16), (2, 16)] and activation == "tanh"
    obs = real_observations(env, seeds=(0, 1), steps=30, every=3)
    act = deterministic_actions(module, env.action_space("robot_0"))(obs.astype(np.float32))
    assert (np.abs(act) == 1.0).any() and (np.abs(act) < 0.9).any()  # clipped and inner actions
    # the deterministic action is the Gaussian's mean (the first half of pi's output), clipped to [-1, 1]
    h = np.tanh(np.tanh(obs @ layers[0][0].T + layers[0][1]) @ layers[1][0].T + layers[1][1])
    np.testing.assert_allclose(act, np.clip(h @ layers[2][0].T + layers[2][1], -1, 1), atol=1e-5)
    gap = export_module(module, tmp_path / "policy", env, obs=obs, scenario="ramp")
    assert gap < 1e-5
    np.testing.assert_allclose(load_policy(tmp_path / "policy", env).act_batch(obs), act, atol=1e-5)


def test_export_refuses_a_head_with_another_activation(tmp_path):
    from tin_swarm_env.adapters.rllib import module_mean_layers
    from tin_swarm_env.errors import ArgumentError

    module, _ = _tiny_module(head_fcnet_hiddens=[8], head_fcnet_activation="relu")
    with pytest.raises(ArgumentError, match="one activation"):
        module_mean_layers(module)
    module, _ = _tiny_module(head_fcnet_hiddens=[8], head_fcnet_activation="tanh")
    assert [W.shape for W, _ in module_mean_layers(module)[0]] == [(16, 91), (16, 16), (8, 16), (2, 8)]
