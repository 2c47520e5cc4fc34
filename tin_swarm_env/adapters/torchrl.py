"""TorchRL adapter: ``tin_swarm_v0`` as torchrl's ``PettingZooWrapper`` with the flags a swarm whose
robots end one by one needs.

    from tin_swarm_env.adapters.torchrl import make_torchrl_env
    env = make_torchrl_env("cliff_goal", n_robots=8, max_cycles=300, seed=0)
    td = env.rollout(100)          # td["next", "robot", "reward"]  (100, 8, 1)

which is exactly::

    PettingZooWrapper(env=tse.parallel_env(scenario="cliff_goal", n_robots=8, max_cycles=300),
                      use_mask=True, done_on_any=False, seed=0)

* ``done_on_any=False``: the tensordict's root ``done`` is the AND over robots, so one robot
  falling does not end (and, in a collector, reset) the swarm's episode. torchrl's default for a
  parallel env, ``done_on_any=True``, resets the whole swarm at the first fall.
* ``use_mask=True``: a robot that ended stays in the tensordicts with ``("robot", "mask")`` False,
  an all-zero observation, reward 0 and its own ``done`` True; its actions are ignored. Without it
  torchrl raises "Dead agents found" at the first robot that ends.
* Grouping: torchrl's default group map puts every ``robot_<i>`` in one group ``"robot"`` (one
  shared policy over the ``(n_robots, d)`` observation). The env is parallel, so the wrapper
  steps it with its parallel API.
* Infos: torchrl writes every info value into a tensor, so the env is wrapped to give numbers only:
  ``td[..., "robot", "info", "distance_to_go_m"]`` (m, ``inf`` when unreachable) and
  ``td[..., "robot", "info", "reason"]``, the :class:`~tin_swarm_env.Reason` code (0 while the
  robot runs; ``Reason(code).label`` is the env's string).

Needs the ``[torchrl]`` extra (torchrl >= 0.11; tested with torchrl 0.11.1, tensordict 0.11.0,
torch 2.13).
"""

from __future__ import annotations

from ..errors import require

__all__ = ["make_torchrl_env", "TORCHRL_FLAGS"]

TORCHRL_FLAGS = {"use_mask": True, "done_on_any": False}
"""The ``PettingZooWrapper`` flags this adapter sets (see the module docstring)."""


def make_torchrl_env(scenario: str = "cliff_goal", *, seed: int | None = None, device="cpu",
                     return_state: bool = False, **env_kwargs):
    """A torchrl ``PettingZooWrapper`` around ``tse.parallel_env(scenario=scenario, **env_kwargs)``
    with ``use_mask=True, done_on_any=False``. ``seed`` seeds the first reset (torchrl's
    convention; later resets continue the env's generator); ``return_state=True`` adds the env's
    global ``state()`` as ``td["state"]``."""
    require("torchrl", "torchrl", "The TorchRL adapter")
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper

    from ..env import parallel_env

    env = _numeric_infos(parallel_env(scenario=scenario, **env_kwargs))
    return PettingZooWrapper(env=env, seed=seed, device=device, return_state=return_state, **TORCHRL_FLAGS)


def _numeric_infos(env):
    """``env`` with every agent's info as ``{"distance_to_go_m": float, "reason": int}`` (the
    :class:`~tin_swarm_env.Reason` code), the same keys at reset and at every step."""
    from pettingzoo.utils.wrappers import BaseParallelWrapper

    from ..world.state import Reason

    codes = {r.label: int(r) for r in Reason}

    def numeric(infos):
        return {a: {"distance_to_go_m": float(i.get("distance_to_go_m", float("inf"))),
                    "reason": codes.get(i.get("reason", ""), 0)} for a, i in infos.items()}

    class NumericInfos(BaseParallelWrapper):
        def reset(self, seed=None, options=None):
            obs, infos = self.env.reset(seed=seed, options=options)
            return obs, numeric(infos)

        def step(self, actions):
            obs, rew, term, trunc, infos = self.env.step(actions)
            return obs, rew, term, trunc, numeric(infos)

        def state(self):
            return self.env.state()

    return NumericInfos(env)
