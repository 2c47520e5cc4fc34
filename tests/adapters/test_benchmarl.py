"""BenchMARL: the TinSwarmTask enum builds environments with the swarm's masking flags, and one tiny
MAPPO experiment runs on it."""

import pytest

pytest.importorskip("benchmarl", reason="benchmarl not installed: pip install 'tin_swarm_env[benchmarl]'")

from tin_swarm_env.adapters.benchmarl import TinSwarmTask  # noqa: E402
from tin_swarm_env.scenario import list_scenarios  # noqa: E402


@pytest.fixture(autouse=True)
def _no_distribution_checks():
    """torchrl's TanhNormal cannot be validated (its ``support`` calls a constraint instance).
    Importing torchrl turns torch's default distribution checks off; importing ``pufferlib.pufferl``
    turns them back on, so a PufferLib test earlier in the same process broke these. Each test
    here runs with them off, as BenchMARL does, and puts the setting back."""
    from torch.distributions import Distribution

    before = Distribution._validate_args
    Distribution.set_default_validate_args(False)
    yield
    Distribution.set_default_validate_args(before)


def test_one_member_per_builtin_scenario_and_specs():
    assert sorted(m.name.lower() for m in TinSwarmTask) == sorted(list_scenarios())
    task = TinSwarmTask.RAMP.get_task(config={"n_robots": 3, "max_cycles": 7})
    env = task.get_env_fun(num_envs=4, continuous_actions=True, seed=0, device="cpu")()
    assert tuple(env.batch_size) == (4,) and env.vec.n_envs == 4  # vectorized: BenchMARL's copies in one env
    assert task._env_kwargs() == {"scenario": "ramp", "n_robots": 3, "max_cycles": 7}
    assert task.max_steps(env) == 7 and task.has_render(env) is False
    assert task.group_map(env) == {"robot": ["robot_0", "robot_1", "robot_2"]}
    assert env.full_observation_spec["robot", "observation"].shape == (4, 3, 91)
    assert task.observation_spec(env)["robot", "observation"].shape == (3, 91)
    assert task.action_spec(env)["robot", "action"].shape == (3, 2)
    info = task.info_spec(env)  # numbers only: the distance to go and the Reason code
    assert set(info["robot", "info"].keys()) == {"distance_to_go_m", "reason"}
    assert task.state_spec(env) is None and task.action_mask_spec(env) is None
    with pytest.raises(ValueError, match="continuous"):
        task.get_env_fun(num_envs=1, continuous_actions=False, seed=0, device="cpu")


def test_a_tiny_mappo_experiment_runs(tmp_path):
    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    cfg = ExperimentConfig.get_from_yaml()
    cfg.max_n_frames = 120
    cfg.on_policy_collected_frames_per_batch = 60
    cfg.on_policy_n_envs_per_worker = 3  # one vectorized env of 3 copies
    cfg.on_policy_n_minibatch_iters = 1
    cfg.on_policy_minibatch_size = 30
    cfg.evaluation = False
    cfg.render = False
    cfg.loggers = []
    cfg.create_json = False
    cfg.save_folder = str(tmp_path)
    task = TinSwarmTask.FLAT.get_task(config={"n_robots": 2, "max_cycles": 20})
    exp = Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=MlpConfig.get_from_yaml(),
                     critic_model_config=MlpConfig.get_from_yaml(), seed=0, config=cfg)
    before = [p.detach().clone() for p in exp.policy.parameters()]
    exp.run()
    assert exp.n_iters_performed == 2 and exp.total_frames == 120
    assert any(not (a == b.detach()).all() for a, b in zip(before, exp.policy.parameters()))  # it trained


def _tiny_experiment(tmp_path, share=True, scenario="RAMP", mirror=False):
    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.benchmarl import mirror_mlp_config

    cfg = ExperimentConfig.get_from_yaml()
    cfg.max_n_frames, cfg.on_policy_collected_frames_per_batch, cfg.on_policy_n_envs_per_worker = 60, 60, 1
    cfg.evaluation, cfg.render, cfg.loggers, cfg.create_json = False, False, [], False
    cfg.save_folder, cfg.share_policy_params = str(tmp_path), share
    algo = MappoConfig.get_from_yaml()
    model = MlpConfig.get_from_yaml()
    model.num_cells = [16, 16]
    critic = model
    if mirror:
        layout = tse.parallel_env(scenario=scenario.lower(), n_robots=3).unwrapped.layout
        model, critic = mirror_mlp_config(layout, model), mirror_mlp_config(layout, model)
        algo.use_tanh_normal = False
    task = TinSwarmTask[scenario].get_task(config={"n_robots": 3, "max_cycles": 40})
    return Experiment(task=task, algorithm_config=algo, model_config=model,
                      critic_model_config=critic, seed=0, config=cfg)


def test_a_mirror_mlp_actor_and_critic_are_equivariant_and_export_exactly(tmp_path):
    import json

    import numpy as np
    import torch
    from tensordict import TensorDict

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.benchmarl import actor_symmetry, deterministic_actions, export_actor
    from tin_swarm_env.policies.export import real_observations
    from tin_swarm_env.policies.learned import load_policy
    from tin_swarm_env.policies.symmetry import mirror_map

    exp = _tiny_experiment(tmp_path, mirror=True)
    assert actor_symmetry(exp) == "mirror" and actor_symmetry(_tiny_experiment(tmp_path)) == "none"
    env = tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=40)
    perm, signs = mirror_map(env.unwrapped.layout)
    mlp = next(m for m in exp.group_policies["robot"].modules() if type(m).__name__ == "MultiAgentMLP")
    with torch.no_grad():  # large enough that the clip and the mirror's sign both matter
        mlp.params["4", "weight"].mul_(20.0)
    rng = np.random.default_rng(0)
    obs = np.concatenate([real_observations(env, seeds=(0,), steps=30, every=3), rng.normal(size=(30, len(perm)))])
    act = deterministic_actions(exp)
    a, am = act(obs.astype(np.float32)), act((obs[:, perm] * signs).astype(np.float32))
    assert np.abs(a[:, 1]).max() > 0.1  # not the trivial vy = 0
    np.testing.assert_allclose(am, a * [1.0, -1.0], atol=1e-6)  # the actor: mirrored observation, mirrored action
    critic = exp.algorithm.get_critic("robot")  # the critic (MAPPO's, on the swarm): the same value mirrored
    x = torch.as_tensor(obs[:30].reshape(10, 3, -1), dtype=torch.float32)
    values = [critic(TensorDict({("robot", "observation"): o}, batch_size=[10]))[critic.out_keys[0]]
              for o in (x, x[..., torch.as_tensor(perm)] * torch.as_tensor(signs, dtype=torch.float32))]
    assert values[0].abs().max() > 0 and torch.allclose(values[0], values[1], atol=1e-6)
    gap = export_actor(exp, tmp_path / "policy", env, obs=obs, scenario="ramp")
    assert gap < 1e-5 and json.loads((tmp_path / "policy" / "policy.json").read_text())["symmetry"] == "mirror"
    file = load_policy(tmp_path / "policy", env)
    np.testing.assert_array_equal(file.act_batch(obs[:, perm] * signs), file.act_batch(obs) * [1.0, -1.0])


def test_export_gives_the_torch_actors_deterministic_actions(tmp_path):
    import json

    import numpy as np
    import torch

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.benchmarl import actor_mean_layers, deterministic_actions, export_actor
    from tin_swarm_env.policies.export import real_observations
    from tin_swarm_env.policies.learned import load_policy

    exp = _tiny_experiment(tmp_path)
    mlp = next(m for m in exp.group_policies["robot"].modules() if type(m).__name__ == "MultiAgentMLP")
    with torch.no_grad():  # an untrained actor's means are small: scale the last layer so tanh saturates too
        mlp.params["4", "weight"].mul_(50.0)
    layers, activation, squash = actor_mean_layers(exp)
    assert [W.shape for W, _ in layers] == [(16, 91), (16, 16), (2, 16)] and (activation, squash) == ("tanh", "tanh")
    env = tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=40)
    obs = real_observations(env, seeds=(0, 1), steps=30, every=3)
    torch_act = deterministic_actions(exp)(obs.astype(np.float32))
    assert torch_act.shape == (len(obs), 2) and (np.abs(torch_act) > 0.99).any() and (np.abs(torch_act) < 0.9).any()
    # the deterministic action is tanh of the Gaussian's mean (the first half of the MLP's output)
    mean = np.tanh(np.tanh(obs @ layers[0][0].T + layers[0][1]) @ layers[1][0].T + layers[1][1]) @ layers[2][0].T
    np.testing.assert_allclose(torch_act, np.tanh(mean + layers[2][1]), atol=1e-5)
    gap = export_actor(exp, tmp_path / "policy", env, obs=obs, scenario="ramp", extra={"note": "untrained"})
    assert gap < 1e-5
    np.testing.assert_allclose(load_policy(tmp_path / "policy", env).act_batch(obs), torch_act, atol=1e-5)
    meta = json.loads((tmp_path / "policy" / "policy.json").read_text())
    assert meta["training"]["library"] == "benchmarl" and meta["training"]["note"] == "untrained"
    # deployed behind the safety shield: the file says so, and the check cuts torch's actions alike
    from tin_swarm_env.policies.base import SafetyShield

    gap = export_actor(exp, tmp_path / "shielded", env, obs=obs, scenario="ramp", shield="safety_cut")
    assert gap < 1e-5 and json.loads((tmp_path / "shielded" / "policy.json").read_text())["shield"] == "safety_cut"
    np.testing.assert_allclose(load_policy(tmp_path / "shielded", env).act_batch(obs),
                               SafetyShield(env)(torch_act.astype(np.float64), obs), atol=1e-5)


def test_export_refuses_one_network_per_robot(tmp_path):
    from tin_swarm_env.adapters.benchmarl import actor_mean_layers
    from tin_swarm_env.errors import ArgumentError

    with pytest.raises(ArgumentError, match="one MLP per robot"):
        actor_mean_layers(_tiny_experiment(tmp_path, share=False))
