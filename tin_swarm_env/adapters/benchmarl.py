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

:func:`mirror_mlp_config` makes BenchMARL's ``MlpConfig`` mirror-equivariant by construction
(:class:`MirrorMlp`): the actor's Gaussian mean is ``(g(o) + M g(M o)) / 2`` and the critic's value
``(v(o) + v(M o)) / 2`` (``M`` the reflection of every robot's observation,
:func:`~tin_swarm_env.policies.symmetry.mirror_map`), as PufferLib's and SB3's mirror networks; the
actor must then act through a plain Gaussian (``use_tanh_normal=False``: the world clips the
command), so the exported file is the same network with ``"symmetry": "mirror"``.

Needs the ``[benchmarl]`` extra (benchmarl 1.5.2, which pins torchrl < 0.12).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, require

require("benchmarl", "benchmarl", "The BenchMARL task")

from benchmarl.environments.common import Task, TaskClass  # noqa: E402
from dataclasses import asdict, dataclass  # noqa: E402
from typing import Sequence  # noqa: E402

from benchmarl.models.mlp import Mlp, MlpConfig  # noqa: E402
from torchrl.data import Composite  # noqa: E402

from .torchrl import make_torchrl_env  # noqa: E402

__all__ = ["TinSwarmTask", "TinSwarmTaskClass", "MirrorMlp", "MirrorMlpConfig", "mirror_mlp_config",
           "actor_symmetry", "actor_mean_layers", "deterministic_actions", "export_actor"]


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


# -- mirror symmetry ------------------------------------------------------------------------


class MirrorMlp(Mlp):
    """BenchMARL's ``Mlp`` averaged with its mirror image: ``(f(o) + P f(M o)) / 2``, ``M o`` each
    robot's observation reflected (``o[..., perm] * signs``), ``P`` the output's parity: for the
    actor (its output the Gaussian's ``loc, scale`` halves) ``vy`` of the mean negated and the scale
    kept; for a critic every output kept (the value is invariant). One set of weights ``f``."""

    def __init__(self, mirror_perm: Sequence[int], mirror_signs: Sequence[float], **kwargs):
        import torch

        from ..env.observation import ACTION_PARITY

        super().__init__(**kwargs)
        if len(mirror_perm) != self.input_features or len(mirror_signs) != self.input_features:
            raise ArgumentError(f"MirrorMlp: the mirror map has {len(mirror_perm)} entries, the model's input "
                                f"{self.input_features} features (in_keys {self.in_keys}): the input must be the "
                                "observation alone")
        parity = torch.ones(self.output_features)
        if not self.is_critic:
            if self.output_features != 2 * len(ACTION_PARITY):
                raise ArgumentError(f"MirrorMlp: the actor has {self.output_features} outputs; a Gaussian's "
                                    f"loc and scale over the {len(ACTION_PARITY)} action components are "
                                    f"{2 * len(ACTION_PARITY)}")
            parity[:len(ACTION_PARITY)] = torch.as_tensor(ACTION_PARITY)
        self.register_buffer("_perm", torch.as_tensor(list(mirror_perm), dtype=torch.long, device=self.device))
        self.register_buffer("_signs", torch.as_tensor(list(mirror_signs), dtype=torch.float32, device=self.device))
        self.register_buffer("_parity", parity.to(self.device))

    def _net(self, x):
        if self.input_has_agent_dim:
            res = self.mlp.forward(x)
            return res if self.output_has_agent_dim else res[..., 0, :]
        if not self.share_params:
            import torch

            return torch.stack([net(x) for net in self.mlp], dim=-2)
        return self.mlp[0](x)

    def _forward(self, tensordict):
        import torch

        x = torch.cat([torch.flatten(tensordict.get(k), start_dim=-self.num_feature_dims) for k in self.in_keys],
                      dim=-1)
        res = (self._net(x) + self._net(x[..., self._perm] * self._signs) * self._parity) / 2
        tensordict.set(self.out_key, res)
        return tensordict


@dataclass
class MirrorMlpConfig(MlpConfig):
    """:class:`MirrorMlp`'s config: ``MlpConfig``'s fields and the reflection (:func:`mirror_mlp_config`)."""

    mirror_perm: Sequence[int] = ()
    mirror_signs: Sequence[float] = ()

    @staticmethod
    def associated_class():
        return MirrorMlp


def mirror_mlp_config(layout, base: MlpConfig | None = None) -> MirrorMlpConfig:
    """``base`` (default: BenchMARL's ``MlpConfig.get_from_yaml()``) as a :class:`MirrorMlpConfig` for the
    observation ``layout`` (an :class:`~tin_swarm_env.env.observation.ObsLayout`)."""
    from ..policies.symmetry import mirror_map

    perm, signs = mirror_map(layout)
    fields = asdict(base if base is not None else MlpConfig.get_from_yaml())
    return MirrorMlpConfig(**fields, mirror_perm=[int(i) for i in perm], mirror_signs=[float(v) for v in signs])


# -- export ---------------------------------------------------------------------------------

_ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu", "ELU": "elu", "LeakyReLU": "leaky_relu"}


def actor_symmetry(experiment, group: str = "robot") -> str:
    """``"mirror"`` if ``experiment``'s actor for ``group`` is a :class:`MirrorMlp`, else ``"none"``."""
    return "mirror" if any(isinstance(m, MirrorMlp) for m in experiment.group_policies[group].modules()) else "none"


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
    (``ExplorationType.DETERMINISTIC``, as BenchMARL evaluates), one robot per row, clipped to the
    action box as the world clips a command (a ``TanhNormal``'s are inside it already)."""
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
            a = actor(td)[group, "action"].reshape(-1, 2)[:n].double().numpy()
        return np.clip(a, -1.0, 1.0)  # a plain Gaussian's mean can leave the box; the world clips the command

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
    symmetry = actor_symmetry(experiment, group)
    if symmetry == "mirror" and squash != "clip":
        raise ArgumentError("a MirrorMlp actor averages the Gaussian's mean before its squash; a TanhNormal "
                            "actor's file would squash first: train it with use_tanh_normal=False")
    write(path, layers, activation, squash=squash, layout=unwrap_env(env).layout, scenario=scenario,
          extra={"library": "benchmarl", **(extra or {})}, shield=shield, symmetry=symmetry)
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
