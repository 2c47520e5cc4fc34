"""TorchRL adapter: the vector env as a native torchrl ``EnvBase`` (the way VMAS is).

    from tin_swarm_env.adapters.torchrl import make_torchrl_env
    env = make_torchrl_env("generated", n_envs=256, n_robots=16, seed=0)
    td = env.rollout(100)          # td["next", "robot", "reward"]  (256, 100, 16, 1)

* ``batch_size = [E]`` (the copies), one group ``"robot"`` of shape ``[E, N]`` (one shared policy
  over the ``(E, N, d)`` observations; ``group_map = {"robot": ["robot_0", ...]}``).
* Keys: ``("robot", "observation")`` ``(E, N, d)``, ``("robot", "action")`` ``(E, N, 2)`` in
  [-1, 1], ``("robot", "reward")`` ``(E, N, 1)``, ``("robot", "done" | "terminated" |
  "truncated")`` ``(E, N, 1)``, ``("robot", "mask")`` ``(E, N)`` (False for a robot that has ended:
  zero observation and reward afterwards, its actions ignored, its own ``done`` True),
  ``("robot", "info", "distance_to_go_m" | "reason")`` (m; the :class:`~tin_swarm_env.Reason` code
  of the step it ended, 0 while it runs), and the copy's ``done``/``terminated``/``truncated``
  ``(E, 1)``: True when none of its robots is left (truncated when the copy's ``max_cycles`` ended
  it), so one robot falling does not end the swarm's episode.
* Resets: a copy that ended waits, done, until a reset: ``env.reset(td)`` with ``"_reset"``
  ``(E, 1)`` resets only those copies (torchrl's partial reset, what its collectors do); the seeds
  are the vector env's (``env.vec.copy_seeds``, drawn from per-copy streams seeded by ``seed``).
* Passes ``torchrl.envs.utils.check_env_specs`` (``tests/adapters/test_torchrl.py``).

Needs the ``[torchrl]`` extra (torchrl >= 0.11; tested with torchrl 0.11.1, tensordict 0.11.0,
torch 2.13).
"""

from __future__ import annotations

import numpy as np

from ..errors import require

__all__ = ["make_torchrl_env", "TinSwarmTorchEnv"]  # noqa: F822 (TinSwarmTorchEnv: made on first use)

_CLASS = None


def make_torchrl_env(scenario="cliff_goal", *, n_envs: int = 1, n_robots: int | None = None,
                     seed: int | None = None, device="cpu", **env_kwargs):
    """The native TorchRL env over ``tse.vector_env(scenario, n_envs, n_robots, seed, **env_kwargs)``
    (see the module docstring)."""
    return torch_env_class()(scenario, n_envs=n_envs, n_robots=n_robots, seed=seed, device=device, **env_kwargs)


class _TorchEnvBody:
    """The body of ``TinSwarmTorchEnv``: the vector env as a torchrl ``EnvBase`` with ``batch_size
    [E]`` (module docstring), mixed into ``EnvBase`` by :func:`torch_env_class`."""

    def __init__(self, scenario="cliff_goal", *, n_envs=1, n_robots=None, seed=None, device="cpu", **env_kwargs):
        import torch

        from ..env.vector import VectorEnv

        self.vec = VectorEnv(scenario, n_envs=n_envs, n_robots=n_robots, seed=seed, autoreset=False,
                             **env_kwargs)
        E, N = self.vec.n_envs, self.vec.n_robots
        super().__init__(batch_size=torch.Size([E]), device=device)
        self.n_robots = N
        self.group_map = {"robot": [f"robot_{i}" for i in range(N)]}
        self.max_cycles = int(self.vec._protos[0].max_cycles)
        self.render_mode = None
        self._specs(E, N, self.vec.layout.size, device)
        self._rterm = np.zeros((E, N), dtype=bool)  # sticky per-robot flags until the copy resets
        self._rtrunc = np.zeros((E, N), dtype=bool)
        self._reason = np.zeros((E, N), dtype=np.int64)
        self._started = False

    def _specs(self, E, N, d, device):
        import torch
        from torchrl.data import Bounded, Categorical, Composite, Unbounded

        en = (E, N)
        self.observation_spec = Composite(
            robot=Composite(observation=Bounded(-1.0, 1.0, en + (d,), dtype=torch.float32, device=device),
                            mask=Categorical(2, en, dtype=torch.bool, device=device),
                            info=Composite(distance_to_go_m=Unbounded(en, dtype=torch.float64, device=device),
                                           reason=Unbounded(en, dtype=torch.int64, device=device), shape=en),
                            shape=en),
            shape=(E,), device=device)
        self.action_spec = Composite(
            robot=Composite(action=Bounded(-1.0, 1.0, en + (2,), dtype=torch.float32, device=device), shape=en),
            shape=(E,), device=device)
        self.reward_spec = Composite(
            robot=Composite(reward=Unbounded(en + (1,), dtype=torch.float32, device=device), shape=en),
            shape=(E,), device=device)
        flag = Categorical(2, (E, 1), dtype=torch.bool, device=device)
        rflag = Categorical(2, en + (1,), dtype=torch.bool, device=device)
        self.done_spec = Composite(
            done=flag.clone(), terminated=flag.clone(), truncated=flag.clone(),
            robot=Composite(done=rflag.clone(), terminated=rflag.clone(), truncated=rflag.clone(), shape=en),
            shape=(E,), device=device)

    def _t(self, a, dtype=None):
        """A tensor of its own (never a view of the env's arrays, which the next reset or step changes)."""
        import torch

        return torch.as_tensor(np.array(a, copy=True), device=self.device, dtype=dtype)

    def _td(self, obs, extra: dict):
        import torch
        from tensordict import TensorDict

        v = self.vec
        live = v._live.reshape(v.n_envs, v.n_robots)
        en = live.shape
        info = TensorDict({"distance_to_go_m": self._t(v.distance_to_go()), "reason": self._t(self._reason)},
                          batch_size=en, device=self.device)
        robot = TensorDict({"observation": self._t(obs, torch.float32), "mask": self._t(live), "info": info,
                            "done": self._t(~live[..., None]), "terminated": self._t(self._rterm[..., None]),
                            "truncated": self._t(self._rtrunc[..., None]), **extra}, batch_size=en,
                           device=self.device)
        done = ~live.any(axis=1, keepdims=True)
        trunc = done & self._rtrunc.any(axis=1, keepdims=True)
        return TensorDict({"robot": robot, "done": self._t(done), "terminated": self._t(done & ~trunc),
                           "truncated": self._t(trunc)}, batch_size=self.batch_size, device=self.device)

    def _reset(self, tensordict=None, **kwargs):
        v = self.vec
        mask = None
        if tensordict is not None and "_reset" in tensordict.keys():
            mask = tensordict["_reset"].reshape(v.n_envs).cpu().numpy().astype(bool)
        if not self._started or mask is None:
            self._obs = v.reset()
            self._started = True
            mask = np.ones(v.n_envs, dtype=bool)
        else:
            for c in np.flatnonzero(mask).tolist():
                self._obs[c] = v.reset_copy(c)
        self._rterm[mask] = False
        self._rtrunc[mask] = False
        self._reason[mask] = 0
        return self._td(self._obs, {})

    def _step(self, tensordict):
        import torch

        v = self.vec
        a = tensordict["robot", "action"].detach().cpu().numpy()
        obs, rew, term, trunc, info = v.step(a)
        self._obs = obs
        self._rterm |= term
        self._rtrunc |= trunc
        ended = term | trunc
        self._reason[ended] = info["reasons"][ended]
        return self._td(obs, {"reward": self._t(rew[..., None], torch.float32)})

    def _set_seed(self, seed):
        if seed is not None:
            self.vec._seed_streams(int(seed))
            self._started = False
        return seed



def torch_env_class():
    """The ``TinSwarmTorchEnv`` class (``_TorchEnvBody`` over torchrl's ``EnvBase``), made on first use."""
    global _CLASS
    if _CLASS is None:
        require("torchrl", "torchrl", "The TorchRL adapter")
        from torchrl.envs import EnvBase

        _CLASS = type("TinSwarmTorchEnv", (_TorchEnvBody, EnvBase), {"__doc__": _TorchEnvBody.__doc__})
    return _CLASS


def __getattr__(name):
    if name == "TinSwarmTorchEnv":
        return torch_env_class()
    raise AttributeError(name)
