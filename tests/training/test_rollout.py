"""The one episode loop (training/rollout.py): a standstill times every robot out with the exact idle
drain, and the outcome agrees with the dict API's infos and rewards."""

from __future__ import annotations

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env import Reason
from tin_swarm_env.training.rollout import rollout


class Standstill:
    def __init__(self):
        self.resets = 0

    def reset(self):
        self.resets += 1

    def act_batch(self, obs):
        return np.zeros((len(obs), 2), np.float32)


def test_rollout_of_a_standstill_times_every_robot_out():
    env = tse.parallel_env(scenario="flat", n_robots=4, max_cycles=7)
    pol = Standstill()
    o = rollout(env, pol, seed=3)
    assert pol.resets == 1
    assert o.n_steps == 7 and np.all(o.steps == 7)
    assert np.all(o.reasons == Reason.TIMEOUT)
    assert o.counts() == {"arrived": 0, "fell": 0, "battery": 0, "max_cycles": 4}
    assert np.all(o.battery_left < 1) and np.all(o.battery_left > 0.99)  # idle and sensing drain a little
    np.testing.assert_allclose(o.returns, -(2.0 + 3.0) * 0.5 * 7 / 1000)  # energy_per_kj = -1, 5 W for 3.5 s


def test_rollout_agrees_with_the_dict_api_infos():
    env = tse.parallel_env(scenario="ramp", n_robots=6)
    pol = tse.policies.APFPolicy(env)
    o = rollout(env, pol, seed=1)
    obs, _ = env.reset(seed=1)
    pol.reset()  # the policy keeps per-robot memory: reset it with the env (as rollout does)
    got, ret = {}, dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        obs, rew, _, _, infos = env.step(pol.act(obs))
        for a, r in rew.items():
            ret[a] += r
        got.update({a: (i["reason"], env.steps) for a, i in infos.items() if "reason" in i})
    assert [got[a][0] for a in env.possible_agents] == [Reason(int(r)).label for r in o.reasons]
    assert [got[a][1] for a in env.possible_agents] == o.steps.tolist()
    np.testing.assert_allclose([ret[a] for a in env.possible_agents], o.returns, rtol=1e-5)


def test_summary_counts_every_ending_and_the_median_arrival_step():
    from tin_swarm_env.training.rollout import Outcome

    z = np.zeros(6)
    o = Outcome(seed=0, reasons=np.array([1, 1, 1, 2, 3, 4], np.int8), steps=np.array([10, 30, 20, 5, 9, 50]),
                returns=z, collisions=np.zeros(6, np.int64), battery_left=z, n_steps=50, seconds=0.0,
                stalled=np.array([0, 0, 0, 0, 0, 1], bool))
    assert str(o) == o.summary() == ("6 robots in 50 steps: 3 arrived, 1 fell, 1 battery-empty, 1 timed out "
                                     "(1 stalled, 0 looping); median 20 steps to arrive")
    none = Outcome(seed=0, reasons=np.full(2, 4, np.int8), steps=np.full(2, 7), returns=z[:2],
                   collisions=np.zeros(2, np.int64), battery_left=z[:2], n_steps=7, seconds=0.0)
    assert none.summary() == "2 robots in 7 steps: 0 arrived, 0 fell, 0 battery-empty, 2 timed out (0 stalled, 0 looping)"
