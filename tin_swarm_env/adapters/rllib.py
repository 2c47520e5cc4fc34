"""Ray RLlib adapter: a corrected ``ParallelPettingZooEnv`` for tin_swarm_v0.

RLlib's own ``ParallelPettingZooEnv`` (ray 2.60) freezes ``agents`` at construction in set
order (so it never shrinks as robots die, and its order changes from run to run), passes an
argument to ``render()`` that PettingZoo's ``render`` does not take, and ends an episode only
when *all* robots reported in a step are terminated (or all truncated), which misses a last step
where one robot arrives while the others hit the time limit. This subclass keeps ``agents`` in
``possible_agents`` order and in step with the environment, renders, and ends the episode
exactly when no robot is left.

:func:`ppo_config` is the PPO set-up for it: the env registered under ``ENV_NAME``, one policy
(``"shared"``) mapped to every robot. Without ``.multi_agent(...)`` RLlib builds one module for the
whole ``Dict`` observation space and fails with a cryptic Dict-encoder error.

    from tin_swarm_env.adapters.rllib import ppo_config
    algo = ppo_config("cliff_goal", n_robots=8).training(lr=3e-4).build_algo()
    algo.train()

:func:`export_module` writes the shared RLModule's deterministic action (the Gaussian's mean,
clipped to the action box as RLlib's ``normalize_actions`` unsquashing does on ``[-1, 1]``) as a
pickle-free policy file (:mod:`tin_swarm_env.policies.export`) and checks it against the module;
``agents/train_rllib.py --export`` does it after training.
"""

from __future__ import annotations

from ..errors import ArgumentError, require

__all__ = ["RLlibTinSwarmEnv", "rllib_env_creator", "ppo_config",  # noqa: F822 (lazy, see __getattr__)
           "ENV_NAME", "SHARED_POLICY", "NODE_METRIC", "module_mean_layers", "deterministic_actions",
           "export_module"]

ENV_NAME = "tin_swarm_v0"
SHARED_POLICY = "shared"
NODE_METRIC = "env_steps_by_node"
"""``result["env_runners"][NODE_METRIC]``: ``{ray node id: env steps sampled there this iteration}``."""

_CLASS = None


def _cls():
    global _CLASS
    if _CLASS is not None:
        return _CLASS
    require("ray.rllib", "rllib", "The RLlib adapter")
    import gymnasium as gym
    from ray.rllib.env.multi_agent_env import MultiAgentEnv
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from ..env import parallel_env

    class RLlibTinSwarmEnv(ParallelPettingZooEnv):
        """``RLlibTinSwarmEnv(config)``: ``config`` holds :func:`tin_swarm_env.parallel_env`'s
        keyword arguments (``scenario``, ``n_robots``, ``max_cycles``, ``render_mode``...)."""

        def __init__(self, config=None):
            MultiAgentEnv.__init__(self)
            from ..env.checks import check_env_kwargs

            if config is not None and not isinstance(config, dict):
                raise ArgumentError(f"RLlib env config must be a dict of parallel_env's arguments, got "
                                    f"{type(config).__name__}")
            check_env_kwargs(dict(config or {}), "RLlib env config")
            self.par_env = parallel_env(**dict(config or {}))
            self.possible_agents = list(self.par_env.possible_agents)
            self.agents = list(self.possible_agents)
            self._agent_ids = set(self.possible_agents)
            self.render_mode = self.par_env.render_mode
            obs_sp = self.par_env.observation_space(self.possible_agents[0])
            act_sp = self.par_env.action_space(self.possible_agents[0])
            self.observation_spaces = {a: obs_sp for a in self.possible_agents}
            self.action_spaces = {a: act_sp for a in self.possible_agents}
            self.observation_space = gym.spaces.Dict(self.observation_spaces)
            self.action_space = gym.spaces.Dict(self.action_spaces)

        def reset(self, *, seed=None, options=None):
            obs, infos = self.par_env.reset(seed=seed, options=options)
            self.agents = list(self.par_env.agents)
            return obs, infos or {}

        def step(self, action_dict):
            obs, rew, term, trunc, infos = self.par_env.step(action_dict)
            self.agents = list(self.par_env.agents)
            over = not self.agents
            term["__all__"] = over and all(term.values())
            trunc["__all__"] = over and not term["__all__"]
            return obs, rew, term, trunc, infos

        def render(self):
            return self.par_env.render()

    _CLASS = RLlibTinSwarmEnv
    return RLlibTinSwarmEnv


def rllib_env_creator(config):
    """For ``ray.tune.registry.register_env(ENV_NAME, rllib_env_creator)``."""
    return _cls()(config)


def ppo_config(scenario: str = "cliff_goal", *, env_runners: int = 0, seed: int | None = None,
               **env_kwargs):
    """A ``PPOConfig`` (new API stack, ray 2.60) for ``tse.parallel_env(scenario=scenario,
    **env_kwargs)``: the env registered as ``ENV_NAME``, ``.multi_agent`` with the one policy
    ``SHARED_POLICY`` mapped to every robot (one ``RLModuleSpec`` in a ``MultiRLModuleSpec``),
    ``env_runners`` sampling workers (0: sample in the driver), one local learner, and an
    ``on_sample_end`` callback that counts env steps per Ray node (``NODE_METRIC``). Chain
    ``.training(...)``, ``.env_runners(...)`` etc. on the result as usual."""
    require("ray.rllib", "rllib", "The RLlib adapter")
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    register_env(ENV_NAME, rllib_env_creator)
    env_config = {"scenario": scenario, **env_kwargs}
    return (PPOConfig()
            .environment(ENV_NAME, env_config=env_config)
            .multi_agent(policies={SHARED_POLICY}, policy_mapping_fn=_to_shared_policy)
            .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={SHARED_POLICY: RLModuleSpec()}))
            .env_runners(num_env_runners=env_runners)
            .learners(num_learners=0)
            .callbacks(on_sample_end=_count_steps_by_node)
            .debugging(seed=seed))


def _to_shared_policy(agent_id, *args, **kwargs):
    return SHARED_POLICY


def _count_steps_by_node(*, env_runner=None, metrics_logger=None, samples=(), **kwargs):
    """Log the env steps this env runner just sampled under its Ray node's id (summed over runners)."""
    import ray

    if metrics_logger is not None:
        node = ray.get_runtime_context().get_node_id()
        metrics_logger.log_value((NODE_METRIC, node), sum(len(e) for e in samples), reduce="sum")


# -- export ---------------------------------------------------------------------------------

_ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu", "ELU": "elu", "LeakyReLU": "leaky_relu"}


def module_mean_layers(module) -> tuple[list, str]:
    """``(layers, activation)`` of a PPO RLModule's mean action network (RLlib's default
    ``DefaultPPOTorchRLModule``): the ``(W, b)`` numpy pairs of its actor encoder (the shared one
    with ``vf_share_layers``) then its ``pi`` head, the head's last layer cut to the Gaussian's mean
    (``TorchDiagGaussian`` reads ``loc, log_std`` halves; with ``free_log_std`` it outputs the mean
    alone), and the activation's name in the policy-file format. Refuses what the file format
    cannot hold exactly (layer norms, two different activations, a non-MLP encoder)."""
    import torch

    enc = module.encoder
    actor = getattr(enc, "actor_encoder", None) or getattr(enc, "encoder", None)
    if actor is None or not hasattr(module, "pi"):
        raise ArgumentError(f"{type(module).__name__}: not an actor-critic MLP RLModule (no encoder / pi head)")
    seq = [m for part in (actor, module.pi) for m in part.modules() if not list(m.children())]
    kinds = [type(m).__name__ for m in seq]
    acts = {k for k in kinds if k != "Linear"}
    ok = (kinds and kinds[-1] == "Linear" and len(acts) <= 1 and acts <= set(_ACTIVATIONS)
          and all((k == "Linear") == (i % 2 == 0) for i, k in enumerate(kinds)))
    if not ok:
        raise ArgumentError(f"the RLModule's actor {kinds} is not Linear layers with one activation of "
                            f"{sorted(_ACTIVATIONS)} between them (set head_fcnet_activation to the same "
                            "activation as fcnet_activation, no layer norm)")
    layers = [(m.weight.detach().cpu().double().numpy().copy(), m.bias.detach().cpu().double().numpy().copy())
              for m in seq if isinstance(m, torch.nn.Linear)]
    W, b = layers[-1]
    if W.shape[0] == 4:  # loc, log_std
        layers[-1] = (W[:2], b[:2])
    elif W.shape[0] != 2:
        raise ArgumentError(f"the pi head has {W.shape[0]} outputs; a Gaussian over 2 actions has 4 (or 2 with "
                            "free_log_std)")
    return layers, _ACTIVATIONS[next(iter(acts))] if acts else "identity"


def deterministic_actions(module, action_space):
    """``f(obs (n, d) float32) -> (n, 2)``: the module's deterministic actions as an env runner
    sends them: ``forward_inference``, the inference distribution's deterministic sample, then
    RLlib's ``unsquash_action`` to ``action_space`` (``normalize_actions=True``, its default)."""
    import numpy as np
    import torch
    from ray.rllib.core.columns import Columns
    from ray.rllib.utils.spaces.space_utils import unsquash_action

    def act(obs):
        with torch.no_grad():
            out = module.forward_inference({Columns.OBS: torch.as_tensor(obs, dtype=torch.float32)})
            dist = module.get_inference_action_dist_cls().from_logits(out[Columns.ACTION_DIST_INPUTS])
            a = dist.to_deterministic().sample().double().numpy()
        return np.stack([unsquash_action(row, action_space) for row in a])

    return act


def export_module(module, path, env, *, obs, scenario: str, extra: dict | None = None, tol: float = 1e-5) -> float:
    """Write ``module``'s mean action network as the policy directory ``path`` for ``env`` (a
    tin_swarm env), then check the file's actions against :func:`deterministic_actions` on
    ``obs (n, d)``; returns the largest difference and raises if it exceeds ``tol``."""
    from ..policies.base import unwrap_env
    from ..policies.export import export_actor as write, max_action_gap

    layers, activation = module_mean_layers(module)
    write(path, layers, activation, squash="clip", layout=unwrap_env(env).layout, scenario=scenario,
          extra={"library": "rllib", **(extra or {})})
    space = env.action_space(env.possible_agents[0])
    gap = max_action_gap(path, env, deterministic_actions(module, space), obs)
    if not gap <= tol:
        raise ArgumentError(f"{path}: the exported policy's actions differ from the RLModule's by {gap:.3g} "
                            f"(> {tol:g}) on {len(obs)} observations")
    return gap


def __getattr__(name):
    if name == "RLlibTinSwarmEnv":
        return _cls()
    raise AttributeError(name)
