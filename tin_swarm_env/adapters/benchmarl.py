"""BenchMARL task: the built-in scenarios as a BenchMARL ``Task`` enum over :func:`make_torchrl_env`.

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig
    from tin_swarm_env.adapters.benchmarl import TinSwarmTask

    task = TinSwarmTask.CLIFF_GOAL.get_task(config={"n_robots": 8, "max_cycles": 300})
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=MlpConfig.get_from_yaml(),
               critic_model_config=MlpConfig.get_from_yaml(), seed=0, config=ExperimentConfig.get_from_yaml()).run()

``config`` holds :func:`tin_swarm_env.parallel_env`'s keyword arguments (``n_robots``,
``max_cycles``...; ``scenario`` may name a TOML path instead of the member's built-in scenario);
``get_task()`` with no config uses the scenario's defaults (there are no BenchMARL yaml files for
this task). Every robot is in one group ``"robot"``; continuous actions only. Robots that ended
stay in the batch masked out (``("robot", "mask")`` False, zero observation and reward, ``done``
True): BenchMARL's algorithms do not read the mask, so those steps are terminal zero-reward
samples for the critic, as in BenchMARL's own PettingZoo tasks with ``done_on_any=False``.

Needs the ``[benchmarl]`` extra (benchmarl 1.5.2, which pins torchrl < 0.12).
"""

from __future__ import annotations

from ..errors import ArgumentError, require

require("benchmarl", "benchmarl", "The BenchMARL task")

from benchmarl.environments.common import Task, TaskClass  # noqa: E402
from torchrl.data import Composite  # noqa: E402

from .torchrl import make_torchrl_env  # noqa: E402

__all__ = ["TinSwarmTask", "TinSwarmTaskClass"]


class TinSwarmTaskClass(TaskClass):
    """BenchMARL's view of one tin_swarm scenario (see the module docstring)."""

    def _env_kwargs(self) -> dict:
        kwargs = dict(self.config)
        kwargs.setdefault("scenario", self.name.lower())
        return kwargs

    def get_env_fun(self, num_envs, continuous_actions, seed, device):
        if not continuous_actions:
            raise ArgumentError("continuous_actions must be True: tin_swarm tasks have continuous actions only"
                                " (Box [-1, 1]^2)")
        kwargs = self._env_kwargs()
        return lambda: make_torchrl_env(seed=seed, device=device, **kwargs)

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def max_steps(self, env) -> int:
        return int(env.max_cycles)  # torchrl and PettingZoo wrappers forward public attributes

    def has_render(self, env) -> bool:
        return env.render_mode == "rgb_array"

    def group_map(self, env):
        return env.group_map

    def _observation_part(self, env, key) -> Composite | None:
        spec = env.observation_spec.clone()
        for group in self.group_map(env):
            for k in list(spec[group].keys()):
                if k != key:
                    del spec[group][k]
            if spec[group].is_empty():
                del spec[group]
        if "state" in spec.keys():
            del spec["state"]
        return None if spec.is_empty() else spec

    def observation_spec(self, env) -> Composite:
        return self._observation_part(env, "observation")

    def info_spec(self, env) -> Composite | None:
        return self._observation_part(env, "info")

    def state_spec(self, env) -> Composite | None:
        if "state" in env.observation_spec.keys():
            return Composite({"state": env.observation_spec["state"].clone()})
        return None

    def action_spec(self, env) -> Composite:
        return env.full_action_spec

    def action_mask_spec(self, env) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "tin_swarm"


class TinSwarmTask(Task):
    """One member per built-in scenario; ``TinSwarmTask.RAMP.get_task(config={...})``."""

    CLIFF_GOAL = None
    CONTAINMENT = None
    FLAT = None
    GENERATED = None
    HILL = None
    JACKSBORO = None
    RAMP = None

    @staticmethod
    def associated_class():
        return TinSwarmTaskClass

    def get_task(self, config: dict | None = None) -> TinSwarmTaskClass:
        return TinSwarmTaskClass(name=self.name, config=dict(config or {}))
