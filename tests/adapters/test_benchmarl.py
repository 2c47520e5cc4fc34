"""BenchMARL: the TinSwarmTask enum builds environments with the swarm's masking flags, and one tiny
MAPPO experiment runs on it."""

import pytest

pytest.importorskip("benchmarl", reason="benchmarl not installed: pip install 'tin_swarm_env[benchmarl]'")

from tin_swarm_env.adapters.benchmarl import TinSwarmTask  # noqa: E402
from tin_swarm_env.scenario import list_scenarios  # noqa: E402


def test_one_member_per_builtin_scenario_and_specs():
    assert sorted(m.name.lower() for m in TinSwarmTask) == sorted(list_scenarios())
    task = TinSwarmTask.RAMP.get_task(config={"n_robots": 3, "max_cycles": 7})
    env = task.get_env_fun(num_envs=1, continuous_actions=True, seed=0, device="cpu")()
    assert env.done_on_any is False and env.use_mask is True
    assert task._env_kwargs() == {"scenario": "ramp", "n_robots": 3, "max_cycles": 7}
    assert task.max_steps(env) == 7 and task.has_render(env) is False
    assert task.group_map(env) == {"robot": ["robot_0", "robot_1", "robot_2"]}
    assert task.observation_spec(env)["robot", "observation"].shape == (3, 59)
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
    cfg.on_policy_n_envs_per_worker = 1
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
