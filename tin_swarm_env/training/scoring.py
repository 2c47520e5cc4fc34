"""A model or policy file scored while it trains: the deterministic policy over held-out seeds
(from :data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`) of every scenario of the run, as
``(return per robot, arrival share, fall share)``; the rows of ``eval.csv``.
"""

from __future__ import annotations

import time

import numpy as np

from ..policies.learned import ShieldedPolicy
from ..world.state import Reason
from .config import Args, scenarios_of
from .evaluation import EVAL_SEED0
from .policy_factory import SB3Policy
from .rollout import rollout

__all__ = ["RecurrentSB3Policy", "evaluate_model", "evaluate_policy_file", "eval_row"]

class RecurrentSB3Policy:
    """A recurrent SB3 model (RecurrentPPO) as a deterministic policy with ``reset()``: the
    LSTM state is carried between steps and cleared at each episode start."""

    def __init__(self, model):
        self.model = model
        self.reset()

    def reset(self):
        self.state, self.start = None, True

    def act_batch(self, obs):
        starts = np.full(len(obs), self.start)
        a, self.state = self.model.predict(obs, state=self.state, episode_start=starts, deterministic=True)
        self.start = False
        return np.asarray(a, dtype=np.float32)

def _evaluate(policy_of, args: Args, episodes: int, seed: int):
    from ..env import parallel_env

    outs = []
    for scen in scenarios_of(args):
        env = parallel_env(scenario=scen, n_robots=args.n_robots, max_cycles=args.max_cycles or None)
        pol = policy_of(env)
        outs += [rollout(env, pol, seed + ep) for ep in range(episodes)]
    return (float(np.mean([o.returns.mean() for o in outs])), float(np.mean([o.share(Reason.ARRIVED) for o in outs])),
            float(np.mean([o.share(Reason.FELL) for o in outs])))

def evaluate_model(model, args: Args, episodes: int, seed: int = EVAL_SEED0) -> tuple[float, float, float]:
    """``(mean per-robot return, arrival share, fall share)`` of the deterministic policy over
    ``episodes`` episodes per scenario of ``args`` (seeds ``seed``, ``seed + 1``...)."""

    def policy_of(env):
        pol = RecurrentSB3Policy(model) if args.recurrent else SB3Policy(model)
        return ShieldedPolicy(pol, env, args.shield) if args.shield != "none" else pol

    return _evaluate(policy_of, args, episodes, seed)

def evaluate_policy_file(policy_of, args: Args, episodes: int, seed: int = EVAL_SEED0) -> dict:
    """:func:`evaluate_model` of a policy ``policy_of(env)`` (a policy file, which applies its own
    shield) as ``{"return", "arrived", "fell"}``."""
    ret, arr, fell = _evaluate(policy_of, args, episodes, seed)
    return {"return": ret, "arrived": arr, "fell": fell}

def eval_row(model, args, rows, t0, timesteps, logger=None) -> dict:
    """:func:`evaluate_model` on ``args.eval_episodes`` episodes as a row (timesteps, minutes since
    ``t0``, return, arrived, fell) appended to ``rows`` (and recorded by an SB3 ``logger``)."""
    ret, arr, fell = evaluate_model(model, args, args.eval_episodes)
    row = {"timesteps": timesteps, "minutes": (time.perf_counter() - t0) / 60, "return": ret, "arrived": arr,
           "fell": fell}
    rows.append(row)
    if logger is not None:
        for k in ("return", "arrived", "fell"):
            logger.record(f"eval/{k}", row[k])
    return row
