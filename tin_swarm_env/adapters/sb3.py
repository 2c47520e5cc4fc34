"""Stable-Baselines3 adapter: every robot of every environment copy is one sub-environment of
one SB3 ``VecEnv`` (parameter sharing), stepped through the vector env
(:func:`tin_swarm_env.vector_env`): one call per step for all copies, the safety shield applied
to all copies at once.

Contract (what SB3 expects of a ``VecEnv``, and how robots map onto it):

* ``num_envs = n_envs * n_robots``; sub-environment ``c * n_robots + i`` is robot ``i`` of copy
  ``c``. Observations ``(num_envs, d)`` float32, rewards float32, dones bool.
* A robot's episode ends when it is terminated (arrived, fell, battery: ``done`` with
  ``info["TimeLimit.truncated"] = False``) or when its copy reaches ``max_cycles``
  (``done`` with ``TimeLimit.truncated = True``); ``info["terminal_observation"]`` holds its last
  observation and ``info["episode"] = {"r", "l"}`` its return and length (SB3's ep_rew_mean).
* One robot-episode, one ``done``: a sub-environment reports ``done`` exactly once per
  robot-episode, at the step the robot ends, so ``VecMonitor`` counts, and ``evaluate_policy``'s
  ``n_eval_episodes`` means, robot-episodes (``n_eval_episodes = k * num_envs`` evaluates each
  robot slot ``k`` times).
* The frozen stretch: a robot that ended before its copy's episode is over is frozen from the
  next step until its copy resets: it observes zeros, gets reward 0, its actions are ignored, and
  it reports no ``done``. At the copy reset its slot simply continues with the new episode's
  observation (no ``done``, empty info). For SB3 the frozen stretch is therefore a zero-reward
  lead-in to the slot's *next* episode, not an episode of its own. What it costs: (a) the
  frozen steps are in every rollout batch (they carry no policy-gradient signal in expectation,
  as actions change nothing, but add variance, and the value net learns the all-zero
  observation as "waiting for the next episode"); (b) lengths counted by the caller
  (``VecMonitor``'s ``l``, ``evaluate_policy``'s episode lengths) include the frozen stretch
  before that episode, while returns are exact (frozen rewards are 0). This adapter's own
  ``info["episode"]["l"]`` counts live steps only (``VecMonitor`` overwrites it).
* A copy resets automatically when none of its robots is live; the observations returned for
  its robots at that step are the new episode's.
* Seeding: ``seed(s)`` (or the constructor's ``seed``) restarts, at the next reset, each copy's
  seed stream (:func:`~tin_swarm_env.env.vector.copy_seed_stream`: copy ``c``'s episodes are
  reset with seeds drawn from ``np.random.default_rng([s, c])``); the vector env's
  ``copy_seeds`` (``self.vec.copy_seeds``) are the seeds of the running episodes, so two adapters
  with the same seed and actions produce the same rollouts, and each copy's episode is the
  parallel env's ``reset_arrays(seed=copy_seeds[c])``. ``envs[c]`` is a
  :class:`~tin_swarm_env.env.vector.CopyView` of copy ``c`` (its ``config``, ``layout``,
  ``steps``, ``live_mask``, ``rng_state``, ``reset_arrays(seed, options)``). ``render_mode`` is
  not supported (render a copy through ``parallel_env`` with its seed).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, require
from ..world.state import Reason

__all__ = ["TinSwarmVecEnv", "make_sb3_vec_env", "export_sb3_policy", "mirror_policy_class"]  # noqa: F822 (lazy)


def _vecenv_base():
    return require("stable_baselines3", "train", "The SB3 adapter").common.vec_env.base_vec_env.VecEnv


def make_sb3_vec_env(scenario="cliff_goal", n_robots=None, n_envs=1, seed=0, shield="none", **env_kwargs):
    """An SB3 ``VecEnv`` of ``n_envs`` copies of ``tin_swarm_v0`` (see the module docstring);
    ``env_kwargs`` (``max_cycles``, ``render_mode``...) pass through to each copy. ``scenario``
    may be a list (a mix): copy ``c`` runs ``scenario[c % len(scenario)]``; the copies must then
    share the robot count (pass ``n_robots``) and the observation size. ``shield="safety_cut"``:
    the actions pass through the policy-file shield (:mod:`tin_swarm_env.policies.learned`) of
    their copy before the env steps, so the policy learns in the shielded environment it will
    be deployed in (PPO keeps the unshielded action as the one taken: the shield is part of the
    environment)."""
    cls = vec_class()
    return cls(scenario=scenario, n_robots=n_robots, n_envs=n_envs, seed=seed, shield=shield, **env_kwargs)


_CLASS = None


class _VecEnvBody:
    """The body of ``TinSwarmVecEnv`` (the module docstring), mixed into SB3's ``VecEnv`` by
    :func:`vec_class` (it can only derive from ``VecEnv`` once SB3 is imported)."""

    def __init__(self, scenario="cliff_goal", n_robots=None, n_envs=1, seed=0, shield="none", **env_kwargs):
        from ..env.checks import ENV_ARGS, check_env_kwargs, check_seed
        from ..env.vector import VectorEnv
        from ..errors import check_range
        from ..policies.base import make_shield
        from ..policies.learned import SHIELDS

        check_range("make_sb3_vec_env", "n_envs", n_envs, 1, integer=True, exc=ArgumentError)
        check_seed(seed, "make_sb3_vec_env")
        check_env_kwargs(env_kwargs, "make_sb3_vec_env", tuple(a for a in ENV_ARGS if a not in ("scenario",
                                                                                              "n_robots")))
        if isinstance(scenario, (list, tuple)) and not scenario:
            raise ArgumentError("make_sb3_vec_env: scenario is an empty list; give a name, a path or a list of them")
        if shield not in SHIELDS:
            raise ArgumentError(f"shield must be one of {list(SHIELDS)}, got {shield!r}")
        mix = [scenario] if isinstance(scenario, str) or not hasattr(scenario, "__len__") else list(scenario)
        env_kwargs = {k: v for k, v in env_kwargs.items() if not (k == "render_mode" and v is None)}
        self.vec = VectorEnv(mix, n_envs=n_envs, n_robots=n_robots, seed=seed, **env_kwargs)
        self.envs = self.vec.copies()  # one view per copy (config, layout, steps, live_mask, reset_arrays)
        self.n_robots = self.vec.n_robots
        self.n_copies = n_envs
        self.shield = shield
        # one shield serves every copy of the mix (SafetyShield's docstring)
        self._shield = make_shield(shield, self.vec._protos[0])
        super().__init__(n_envs * self.n_robots, self.vec.single_observation_space, self.vec.single_action_space)
        self.render_mode = None
        self._seed = seed
        self._actions = None
        self._obs = None
        self._ep_ret = np.zeros(self.num_envs)
        self._ep_len = np.zeros(self.num_envs, dtype=np.int64)

    # -- VecEnv interface ----------------------------------------------------------------
    def seed(self, seed=None):
        """The next :meth:`reset` restarts the copies' seed streams from ``seed``
        (:func:`~tin_swarm_env.env.vector.copy_seed_stream`); None: they continue."""
        self._seed = seed
        return [seed] * self.n_copies

    def reset(self):
        obs = self.vec.reset(seed=self._seed).reshape(self.num_envs, -1)
        self._seed = None
        self._ep_ret[:] = 0
        self._ep_len[:] = 0
        self._obs = obs
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs.copy()

    def step_async(self, actions):
        from ..env.checks import float_array

        self._actions = float_array(np.reshape(actions, (self.num_envs, -1)) if np.size(actions) == 2 * self.num_envs
                                    else actions, "step_async(actions)", (self.num_envs, 2), finite=False)

    def _shielded(self, act):
        return act if self._shield is None else self._shield(act, self._obs)

    def step_wait(self):
        E, N = self.n_copies, self.n_robots
        live_before = self.vec._live.copy()
        act = self._shielded(self._actions)
        o, r, term, trunc, info = self.vec.step(np.reshape(act, (E, N, 2)))
        obs = o.reshape(self.num_envs, -1)
        rewards = np.where(live_before, r.reshape(-1), np.float32(0.0)).astype(np.float32)
        term, trunc = term.reshape(-1), trunc.reshape(-1)
        ended = term | trunc
        self._ep_ret += rewards
        self._ep_len += live_before
        infos = [{} for _ in range(self.num_envs)]
        final = np.repeat(info["_final"], N)
        last = np.where(final[:, None], info["final_obs"].reshape(self.num_envs, -1), obs)
        reasons = info["reasons"].reshape(-1)
        for j in np.flatnonzero(ended).tolist():
            infos[j] = {"terminal_observation": last[j].copy(), "TimeLimit.truncated": bool(trunc[j]),
                        "episode": {"r": float(self._ep_ret[j]), "l": int(self._ep_len[j])},
                        "reason": Reason(int(reasons[j])).label}
        self._ep_ret[ended] = 0
        self._ep_len[ended] = 0
        obs = np.where((ended & ~final)[:, None], np.float32(0.0), obs)  # frozen until the copy resets
        self._obs = obs
        return obs.copy(), rewards, ended, infos

    def close(self):
        self.vec.close()

    def get_images(self):
        return [None for _ in self.envs]

    def render(self, mode=None):
        return None

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.envs[self._copy(i)], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name, value, indices=None):
        for c in {self._copy(i) for i in self._get_indices(indices)}:
            setattr(self.envs[c], attr_name, value)

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        """Call the method once per copy (its robots' sub-environments share it) and give each index its
        copy's result; a copy reset this way (``reset_arrays``) continues from its new observations."""
        got = {}
        for i in self._get_indices(indices):
            c = self._copy(i)
            if c not in got:
                got[c] = getattr(self.envs[c], method_name)(*method_args, **method_kwargs)
                if method_name == "reset_arrays":
                    rows = slice(c * self.n_robots, (c + 1) * self.n_robots)
                    self._obs[rows] = got[c]
                    self._ep_ret[rows] = 0
                    self._ep_len[rows] = 0
        return [got[self._copy(i)] for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False for _ in self._get_indices(indices)]

    def _copy(self, i):
        return int(i) // self.n_robots



def vec_class():
    """The ``TinSwarmVecEnv`` class (``_VecEnvBody`` over SB3's ``VecEnv``), made on first use."""
    global _CLASS
    if _CLASS is None:
        _CLASS = type("TinSwarmVecEnv", (_VecEnvBody, _vecenv_base()), {"__doc__": __doc__})
    return _CLASS


_TORCH_ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu", "ELU": "elu", "LeakyReLU": "leaky_relu", "Identity": "identity"}


def export_sb3_policy(model, path, env_or_layout, scenario: str | None = None, extra: dict | None = None,
                      shield: str = "none", symmetry: str = "none"):
    """Write the actor of an SB3 PPO/A2C ``MlpPolicy`` as a pickle-free policy directory
    (:func:`tin_swarm_env.policies.save_policy`): the Linear layers of
    ``policy.mlp_extractor.policy_net`` and ``policy.action_net``, the activation from
    ``policy_kwargs["activation_fn"]`` (default Tanh), the deterministic action (the Gaussian's
    mean, clipped to [-1, 1]). A recurrent actor (sb3-contrib's RecurrentPPO ``MlpLstmPolicy``,
    one LSTM layer) is written as a recurrent policy file
    (:mod:`tin_swarm_env.policies.recurrent`): ``policy.lstm_actor``'s weights, then the same
    head. ``env_or_layout``: the env (or this module's VecEnv) it was trained on
    (its layout and scenario name are recorded) or an ``ObsLayout``; ``shield`` is written into the
    file (``"safety_cut"``: the actor was trained to act through it), and ``symmetry``
    (``"mirror"``: the file acts as the mirror-averaged network). Returns the path."""
    require("torch", "train", "Exporting an SB3 policy")
    from ..policies.learned import save_policy

    pol = model.policy
    where = f"model {type(model).__name__}.policy"
    layers, activation = _actor_head(pol, where)
    if hasattr(pol, "mirror_mean_value"):  # trained equivariant: the file must average the same way
        if symmetry != "none" and symmetry != "mirror":
            raise ArgumentError(f"{where} is mirror-equivariant; it exports with symmetry 'mirror', not {symmetry!r}")
        symmetry = "mirror"
    cell = _lstm_cell(pol.lstm_actor, where) if hasattr(pol, "lstm_actor") else None
    src = env_or_layout.envs[0] if hasattr(env_or_layout, "envs") else env_or_layout  # our VecEnv: a copy
    layout = getattr(src, "layout", src)
    if hasattr(pol, "mirror_mean_value"):  # the file mirrors with the layout's map: the model must have used it
        from ..policies.symmetry import check_mirror_map

        check_mirror_map(layout, pol.mirror_perm, pol.mirror_signs, where)
    if scenario is None:
        cfg = getattr(src, "config", None)
        scenario = getattr(cfg, "name", "") if cfg is not None else ""
    meta = {"algorithm": type(model).__name__, "num_timesteps": int(getattr(model, "num_timesteps", 0))}
    try:
        import stable_baselines3
        import torch

        meta.update(stable_baselines3=stable_baselines3.__version__, torch=torch.__version__)
    except ImportError:  # pragma: no cover
        pass
    meta.update(extra or {})
    return save_policy(path, layers, activation, layout=layout, scenario=scenario, extra=meta, shield=shield,
                       symmetry=symmetry, cell=cell)


def _actor_head(pol, where: str):
    """``([(W, b), ...], activation)`` of an SB3 actor: ``mlp_extractor.policy_net`` then
    ``action_net``; refuses anything the policy file cannot express, naming the part."""
    for attr in ("mlp_extractor", "action_net"):
        if not hasattr(pol, attr):
            raise ArgumentError(f"{where} has no {attr}: only SB3 MlpPolicy actors (PPO, A2C) can be exported")
    fx = getattr(pol, "pi_features_extractor", getattr(pol, "features_extractor", None))
    if fx is not None and type(fx).__name__ != "FlattenExtractor":
        raise ArgumentError(f"{where}: features extractor {type(fx).__name__} is not exportable "
                            "(FlattenExtractor only)")
    if getattr(pol, "squash_output", False) or type(pol.action_dist).__name__ != "DiagGaussianDistribution":
        raise ArgumentError(f"{where}: only an unsquashed diagonal Gaussian actor can be exported")
    layers, acts = [], set()
    for m in list(pol.mlp_extractor.policy_net) + [pol.action_net]:
        name = type(m).__name__
        if name == "Linear":
            layers.append((m.weight.detach().cpu().double().numpy(), m.bias.detach().cpu().double().numpy()))
        elif name in _TORCH_ACTIVATIONS:
            acts.add(_TORCH_ACTIVATIONS[name])
        else:
            raise ArgumentError(f"{where}: layer {name} of the actor is not exportable")
    if len(acts) > 1:
        raise ArgumentError(f"{where}: mixed activations {sorted(acts)} are not exportable")
    act_fn = pol.activation_fn.__name__ if hasattr(pol, "activation_fn") else "Tanh"
    return layers, (acts.pop() if acts else _TORCH_ACTIVATIONS.get(act_fn, "tanh"))


def _lstm_cell(lstm, where: str):
    """``("lstm", {cell_W_ih, cell_W_hh, cell_b_ih, cell_b_hh})`` of a one-layer torch ``nn.LSTM``."""
    if (type(lstm).__name__ != "LSTM" or lstm.num_layers != 1 or lstm.bidirectional
            or getattr(lstm, "proj_size", 0)):
        raise ArgumentError(f"{where}.lstm_actor: only a one-layer, one-directional LSTM without projection is "
                            f"exportable (got {lstm})")

    def get(name):
        t = getattr(lstm, name, None)
        return t.detach().cpu().double().numpy() if t is not None else np.zeros(4 * lstm.hidden_size)

    return "lstm", {"cell_W_ih": get("weight_ih_l0"), "cell_W_hh": get("weight_hh_l0"),
                    "cell_b_ih": get("bias_ih_l0"), "cell_b_hh": get("bias_hh_l0")}


_MIRROR = None


def mirror_policy_class():
    """``MirrorActorCriticPolicy``: SB3's ``ActorCriticPolicy`` (MlpPolicy) made mirror-equivariant
    by construction, for PPO/A2C with ``policy_kwargs={"mirror_signs": signs.tolist(), "mirror_perm":
    perm.tolist()}`` (``perm, signs = mirror_map(layout)``,
    :func:`~tin_swarm_env.policies.symmetry.mirror_map`; ``mirror_perm`` may be left out when the layout
    has no scan beams; ``apps/train.py --symmetry mirror``). Every evaluation runs the networks on the observations
    and their mirror images in one batch: the Gaussian's mean is ``(g(o) + M g(M o)) / 2`` (``g``
    the actor network, ``M`` :func:`~tin_swarm_env.env.observation.mirror_action` on the output)
    and the value ``(v(o) + v(M o)) / 2``; the state-independent std is the same for both sides
    (a sign flip does not change a variance), so ``pi(M a | M o) = pi(a | o)`` for every sample
    PPO draws, and its deterministic action, clipped, is what a policy file with
    ``"symmetry": "mirror"`` and the same weights computes (:func:`export_sb3_policy` writes it so)."""
    global _MIRROR
    if _MIRROR is not None:
        return _MIRROR
    policies = require("stable_baselines3", "train", "The mirror-equivariant SB3 policy").common.policies
    import torch as th

    from ..env.observation import ACTION_PARITY

    class MirrorActorCriticPolicy(policies.ActorCriticPolicy):
        def __init__(self, *args, mirror_signs=None, mirror_perm=None, **kwargs):
            super().__init__(*args, **kwargs)
            d = int(np.prod(self.observation_space.shape))
            if mirror_signs is None or len(mirror_signs) != d:
                raise ArgumentError(f"MirrorActorCriticPolicy needs mirror_signs of length {d} "
                                    "(mirror_map(layout)[1]), got "
                                    f"{None if mirror_signs is None else len(mirror_signs)}")
            if type(self.action_dist).__name__ != "DiagGaussianDistribution":
                raise ArgumentError("MirrorActorCriticPolicy: only a diagonal Gaussian actor (no gSDE)")
            if mirror_perm is not None and sorted(int(j) for j in mirror_perm) != list(range(d)):
                raise ArgumentError(f"MirrorActorCriticPolicy: mirror_perm must be a permutation of 0..{d - 1} "
                                    "(mirror_map(layout)[0])")
            self.mirror_signs = [float(x) for x in mirror_signs]
            self.mirror_perm = list(range(d)) if mirror_perm is None else [int(j) for j in mirror_perm]
            self.register_buffer("_signs", th.as_tensor(self.mirror_signs, dtype=th.float32))
            self.register_buffer("_perm", th.as_tensor(self.mirror_perm, dtype=th.long))
            self.register_buffer("_parity", th.as_tensor(ACTION_PARITY, dtype=th.float32))

        def _get_constructor_parameters(self):
            return {**super()._get_constructor_parameters(), "mirror_signs": self.mirror_signs,
                    "mirror_perm": self.mirror_perm}

        def mirror_mean_value(self, obs):
            """``(mean (n, 2), value (n, 1))``, both averaged with the mirror image."""
            obs = obs.float()
            n = obs.shape[0]
            features = self.extract_features(th.cat([obs, obs[:, self._perm] * self._signs]))
            if self.share_features_extractor:
                latent_pi, latent_vf = self.mlp_extractor(features)
            else:
                latent_pi = self.mlp_extractor.forward_actor(features[0])
                latent_vf = self.mlp_extractor.forward_critic(features[1])
            mean, value = self.action_net(latent_pi), self.value_net(latent_vf)
            return (mean[:n] + mean[n:] * self._parity) / 2, (value[:n] + value[n:]) / 2

        def _dist(self, mean):
            return self.action_dist.proba_distribution(mean, self.log_std)

        def forward(self, obs, deterministic=False):
            mean, values = self.mirror_mean_value(obs)
            dist = self._dist(mean)
            actions = dist.get_actions(deterministic=deterministic)
            log_prob = dist.log_prob(actions)
            return actions.reshape((-1, *self.action_space.shape)), values, log_prob

        def evaluate_actions(self, obs, actions):
            mean, values = self.mirror_mean_value(obs)
            dist = self._dist(mean)
            return values, dist.log_prob(actions), dist.entropy()

        def get_distribution(self, obs):
            return self._dist(self.mirror_mean_value(obs)[0])

        def predict_values(self, obs):
            return self.mirror_mean_value(obs)[1]

    MirrorActorCriticPolicy.__qualname__ = "MirrorActorCriticPolicy"
    _MIRROR = MirrorActorCriticPolicy
    return MirrorActorCriticPolicy


def __getattr__(name):
    if name == "TinSwarmVecEnv":
        return vec_class()
    raise AttributeError(name)
