"""PPO with Ray RLlib on a tin_swarm scenario: one shared policy (RLModule) for all robots.

    python agents/train_rllib.py --scenario cliff_goal --iterations 50

Runs on this machine by default. On a Ray cluster: start the head node with ``ray start
--head``, join each other node with ``ray start --address=HEAD_IP:6379``, then run the same
command on the head with ``RAY_ADDRESS=auto`` (or ``HEAD_IP:6379``) and ``--env-runners`` set to
the number of sampling workers the cluster can hold; every node needs this package installed
(``pip install -e '.[rllib]'``). Needs the ``[rllib]`` extra (ray 2.60, which pins gymnasium
1.2.2). Writes a checkpoint to ``--out-dir`` and the per-iteration returns to ``progress.csv``.
"""

from __future__ import annotations

import csv
import os
import time
from dataclasses import dataclass
from pathlib import Path

from tin_swarm_env.apps.args import parse_dataclass


@dataclass
class Args:
    scenario: str = "cliff_goal"
    n_robots: int = 8
    max_cycles: int = 0  # 0: the scenario's
    iterations: int = 20
    env_runners: int = 0  # 0: sample in the driver process (one machine)
    train_batch_size: int = 4000
    minibatch_size: int = 500
    num_epochs: int = 5
    lr: float = 3e-4
    gamma: float = 0.99
    seed: int = 0
    num_cpus: int = 0  # for a local Ray instance (0: all); ignored with RAY_ADDRESS
    out_dir: str = "runs/rllib"


def build_config(args: Args):
    from tin_swarm_env.adapters.rllib import ppo_config

    env_kwargs = {"n_robots": args.n_robots}
    if args.max_cycles:
        env_kwargs["max_cycles"] = args.max_cycles
    return (ppo_config(args.scenario, env_runners=args.env_runners, seed=args.seed, **env_kwargs)
            .training(train_batch_size_per_learner=args.train_batch_size, minibatch_size=args.minibatch_size,
                      num_epochs=args.num_epochs, lr=args.lr, gamma=args.gamma))


def main(args: Args):
    import ray

    from tin_swarm_env.adapters.rllib import NODE_METRIC

    address = os.environ.get("RAY_ADDRESS")
    if address:
        ray.init(address=address)  # an existing cluster
        for node in ray.nodes():
            if node["Alive"]:
                print(f"Ray node {node['NodeID'][:12]} at {node['NodeManagerAddress']}: "
                      f"{node['Resources'].get('CPU', 0):g} CPU", flush=True)
    else:
        ray.init(num_cpus=args.num_cpus or None, include_dashboard=False, log_to_driver=False)
    algo = build_config(args).build_algo()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    t0 = time.perf_counter()
    for it in range(1, args.iterations + 1):
        r = algo.train()
        er = r.get("env_runners", {})
        row = {"iteration": it, "env_steps": r.get("num_env_steps_sampled_lifetime", 0),
               "episode_return_mean": er.get("episode_return_mean", float("nan")),
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"iteration {it}: env steps {row['env_steps']}, episode return (all robots) "
              f"{row['episode_return_mean']:.1f}, {row['seconds']:.0f} s", flush=True)
        by_node = er.get(NODE_METRIC, {})
        print(f"iteration {it}: env steps by Ray node: "
              + ", ".join(f"{node[:12]} {int(steps)}" for node, steps in sorted(by_node.items())), flush=True)
    ckpt = algo.save(str(out.resolve() / "checkpoint"))
    with open(out / "progress.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"saved {getattr(ckpt, 'checkpoint', ckpt)}")
    algo.stop()
    ray.shutdown()
    return rows


if __name__ == "__main__":
    main(parse_dataclass(Args, description=__doc__.splitlines()[0]))
