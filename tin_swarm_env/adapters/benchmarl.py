"""BenchMARL task: the built-in scenarios as a BenchMARL ``Task`` enum over :func:`make_torchrl_env`,
a vectorized env (``batch_size [num_envs]``: BenchMARL's ``n_envs_per_worker`` copies stepped by one
call, as its VMAS tasks are).

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig
    from tin_swarm_env.adapters.benchmarl import TinSwarmTask

    task = TinSwarmTask.CLIFF_GOAL.get_task(config={"n_robots": 8, "max_cycles": 300})
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=MlpConfig.get_from_yaml(),
               critic_model_config=MlpConfig.get_from_yaml(), seed=0, config=ExperimentConfig.get_from_yaml()).run()

``config`` holds :func:`tin_swarm_env.vector_env`'s keyword arguments (``n_robots``,
``max_cycles``...; ``scenario`` may name a TOML path instead of the member's built-in scenario);
``get_task()`` with no config uses the scenario's defaults (there are no BenchMARL yaml files for
this task). Every robot is in one group ``"robot"``; continuous actions only. The specs BenchMARL
builds its models from are the env's unbatched ones (one copy). Robots that ended
stay in the batch masked out (``("robot", "mask")`` False, zero observation and reward, ``done``
True): BenchMARL's algorithms do not read the mask, so those steps are terminal zero-reward
samples for the critic, as in BenchMARL's own PettingZoo tasks with ``done_on_any=False``.

:func:`export_actor` writes an experiment's trained actor (its deterministic action,
``tanh`` of the Gaussian's mean) as a pickle-free policy file
(:mod:`tin_swarm_env.policies.export`) and checks it against the torch actor;
``agents/train_benchmarl.py`` trains MAPPO and exports it.

Needs the ``[benchmarl]`` extra (benchmarl 1.5.2, which pins torchrl < 0.12).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, require

require("benchmarl", "benchmarl", "The BenchMARL task")

from benchmarl.environments.common import Task, TaskClass  # noqa: E402
from torchrl.data import Composite  # noqa: E402

from .torchrl import make_torchrl_env  # noqa: E402

__all__ = ["TinSwarmTask", "TinSwarmTaskClass", "actor_mean_layers", "deterministic_actions", "export_actor"]


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
        scenario = kwargs.pop("scenario")
        return lambda: make_torchrl_env(scenario, n_envs=num_envs, seed=seed, device=device, **kwargs)

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
        spec = env.full_observation_spec_unbatched.clone()
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
            return Composite({"state": env.full_observation_spec_unbatched["state"].clone()})
        return None

    def action_spec(self, env) -> Composite:
        return env.full_action_spec_unbatched

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


# -- export ---------------------------------------------------------------------------------

_ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu", "ELU": "elu", "LeakyReLU": "leaky_relu"}


def actor_mean_layers(experiment, group: str = "robot") -> tuple[list, str, str]:
    """``(layers, activation, squash)`` of ``experiment``'s actor for ``group``: the ``(W, b)``
    numpy pairs of its MLP (BenchMARL ``Mlp`` over torchrl's ``MultiAgentMLP`` with shared
    parameters), the last layer cut to the rows of the Gaussian's mean (``NormalParamExtractor``
    splits the output in ``loc, scale`` halves), the hidden activation's name in the policy-file
    format, and ``"tanh"`` for a ``TanhNormal`` actor (``"clip"`` otherwise). Refuses what the file
    format cannot hold exactly (per-robot parameters, a normalisation layer, another activation)."""
    import torch
    from torchrl.modules import TanhNormal

    actor = experiment.group_policies[group]
    mlps = [m for m in actor.modules() if type(m).__name__ == "MultiAgentMLP"]
    if len(mlps) != 1:
        raise ArgumentError(f"group {group!r}: expected one MultiAgentMLP in the actor (BenchMARL's MlpConfig), "
                            f"found {len(mlps)}")
    mlp = mlps[0]
    if not mlp.share_params:
        raise ArgumentError("the actor has one MLP per robot (share_policy_params=False); a policy file holds "
                            "one network for all robots")
    net = mlp._empty_net
    kinds = [type(m).__name__ for m in net]
    linear = [i for i, m in enumerate(net) if isinstance(m, torch.nn.Linear)]
    acts = {kinds[i] for i in range(len(kinds)) if i not in linear}
    if len(acts) != 1 or next(iter(acts)) not in _ACTIVATIONS or kinds[-1] != "Linear" or \
            len(kinds) != 2 * len(linear) - 1:
        raise ArgumentError(f"the actor's MLP {kinds} is not Linear layers with one activation of "
                            f"{sorted(_ACTIVATIONS)} between them")
    params = mlp.params
    layers = [(params[str(i), "weight"].detach().cpu().double().numpy().copy(),
               params[str(i), "bias"].detach().cpu().double().numpy().copy()) for i in linear]
    W, b = layers[-1]
    half = W.shape[0] // 2
    layers[-1] = (W[:half], b[:half])
    dist = getattr(actor, "distribution_class", None)
    if dist is None:
        dist = next((getattr(m, "distribution_class") for m in actor.modules() if hasattr(m, "distribution_class")),
                    None)
    return layers, _ACTIVATIONS[next(iter(acts))], "tanh" if dist is TanhNormal else "clip"


def deterministic_actions(experiment, group: str = "robot"):
    """``f(obs (n, d) float32) -> (n, 2)``: the torch actor's deterministic actions
    (``ExplorationType.DETERMINISTIC``, as BenchMARL evaluates), one robot per row."""
    import torch
    from tensordict import TensorDict
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    actor = experiment.group_policies[group]
    n_agents = len(experiment.group_map[group])

    def act(obs):
        x = torch.as_tensor(obs, dtype=torch.float32)
        n = x.shape[0]
        pad = -n % n_agents  # the actor takes whole swarms: (envs, n_agents, d); the padding rows are dropped
        x = torch.cat([x, x.new_zeros(pad, x.shape[1])]).reshape(-1, n_agents, x.shape[1])
        td = TensorDict({(group, "observation"): x}, batch_size=[x.shape[0]])
        with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
            return actor(td)[group, "action"].reshape(-1, 2)[:n].double().numpy()

    return act


def export_actor(experiment, path, env, *, obs, scenario: str, extra: dict | None = None,
                 group: str = "robot", tol: float = 1e-5, shield: str = "none") -> float:
    """Write ``experiment``'s actor as the policy directory ``path`` for ``env`` (a tin_swarm
    env, whose observation layout the file records), then check the file's actions against the
    torch actor's deterministic actions on ``obs (n, d)``; returns the largest difference and
    raises if it exceeds ``tol``. ``shield="safety_cut"``: the file acts behind the safety shield
    (deployed behind it: the actor trained without), and the check filters torch's actions too."""
    from ..policies.base import make_shield, unwrap_env
    from ..policies.export import export_actor as write, max_action_gap

    layers, activation, squash = actor_mean_layers(experiment, group)
    write(path, layers, activation, squash=squash, layout=unwrap_env(env).layout, scenario=scenario,
          extra={"library": "benchmarl", **(extra or {})}, shield=shield)
    torch_actions = deterministic_actions(experiment, group)
    if shield != "none":
        cut, plain = make_shield(shield, env), torch_actions

        def torch_actions(o):
            return cut(np.asarray(plain(o), dtype=np.float64), o)
    gap = max_action_gap(path, env, torch_actions, obs)
    if not gap <= tol:
        raise ArgumentError(f"{path}: the exported policy's actions differ from the torch actor's by {gap:.3g} "
                            f"(> {tol:g}) on {len(obs)} observations")
    return gap
