"""PPO with Ray RLlib on a tin_swarm scenario: one shared policy (RLModule) for all robots, exported to a policy file.

    python agents/train_rllib.py --scenario generated --max-minutes 30 --out-dir runs/ppo_rllib

Trains until ``--iterations`` or the iteration that would pass ``--max-minutes`` (wall clock), then
writes the RLModule's deterministic action (the Gaussian's mean, clipped to the action box as RLlib's
``normalize_actions`` does on ``[-1, 1]``) to ``OUT_DIR/policy`` (``policy.json`` + ``weights.npz``,
:mod:`tin_swarm_env.policies.export`) and checks the numpy policy's actions against the module's on
observations of real episodes; evaluate it with ``tin-swarm eval --policies OUT_DIR/policy``. The
defaults are RLlib's PPO settings scaled to one machine (4000 env steps per iteration sampled in
the driver, RLlib's default 256-256 tanh network with the value function sharing the encoder).

Runs on this machine by default. On a Ray cluster: start the head node with ``ray start
--head``, join each other node with ``ray start --address=HEAD_IP:6379``, then run the same
command on the head with ``RAY_ADDRESS=auto`` (or ``HEAD_IP:6379``) and ``--env-runners`` set to
the number of sampling workers the cluster can hold; every node needs this package installed
(``pip install -e '.[rllib]'``). Needs the ``[rllib]`` extra (ray 2.60, which pins gymnasium
1.2.2). Writes a checkpoint to ``--out-dir`` and the per-iteration returns to ``progress.csv``.
"""

from __future__ import annotations

import csv
import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from tin_swarm_env.apps.args import opt, parse_dataclass


@dataclass
class Args:
    scenario: str = opt("cliff_goal", "built-in scenario or scenario TOML file")
    n_robots: int = opt(8, "robots per environment (all mapped to the one shared policy)", lo=1)
    max_cycles: int = opt(0, "steps per episode (0: the scenario's)", lo=0)
    iterations: int = opt(1000, "PPO iterations (algo.train() calls) at most", lo=1)
    max_minutes: float = opt(30.0, "wall-clock budget: stop after the iteration that would pass it", lo=0,
                             lo_open=True)
    env_runners: int = opt(0, "sampling workers (0: sample in the driver process, one machine)", lo=0)
    train_batch_size: int = opt(4000, "env steps per iteration (train_batch_size_per_learner)", lo=1)
    minibatch_size: int = opt(500, "SGD minibatch size", lo=1)
    num_epochs: int = opt(5, "passes over each train batch", lo=1)
    lr: float = opt(3e-4, "Adam learning rate", lo=0, lo_open=True)
    gamma: float = opt(0.99, "discount", lo=0, hi=1)
    seed: int = opt(0, "seed (training seeds stay far below EVAL_SEED0)", lo=0, hi=999_999)
    torch_threads: int = opt(0, "torch threads of the driver, where the learner runs (0: torch's default)", lo=0)
    num_cpus: int = opt(0, "CPUs of a local Ray instance (0: all); ignored with RAY_ADDRESS", lo=0)
    out_dir: str = opt("runs/rllib", "run directory: checkpoint/, progress.csv, run.json, policy/")


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
    import torch

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
    if args.torch_threads:
        torch.set_num_threads(args.torch_threads)
    algo = build_config(args).build_algo()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    t0 = last = time.perf_counter()
    for it in range(1, args.iterations + 1):
        r = algo.train()
        er = r.get("env_runners", {})
        row = {"iteration": it, "env_steps": int(r.get("num_env_steps_sampled_lifetime", 0)),
               "episode_return_mean": er.get("episode_return_mean", float("nan")),
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"iteration {it}: env steps {row['env_steps']}, episode return (all robots) "
              f"{row['episode_return_mean']:.1f}, {row['seconds']:.0f} s", flush=True)
        by_node = er.get(NODE_METRIC, {})
        print(f"iteration {it}: env steps by Ray node: "
              + ", ".join(f"{node[:12]} {int(steps)}" for node, steps in sorted(by_node.items())), flush=True)
        now = time.perf_counter()
        if now - t0 + (now - last) > 60 * args.max_minutes and it < args.iterations:
            print(f"stopped at the {args.max_minutes:g}-minute budget", flush=True)
            break
        last = now
    ckpt = algo.save(str(out.resolve() / "checkpoint"))
    with open(out / "progress.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"saved {getattr(ckpt, 'checkpoint', ckpt)}")
    export(algo, args, rows, out)
    algo.stop()
    ray.shutdown()
    return rows


def export(algo, args: Args, rows: list, out: Path) -> float:
    """Write the shared RLModule to ``out/policy`` and check it (see the module docstring)."""
    import ray
    import torch

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.rllib import SHARED_POLICY, export_module
    from tin_swarm_env.policies.export import real_observations

    env_kwargs = {"n_robots": args.n_robots, **({"max_cycles": args.max_cycles} if args.max_cycles else {})}
    env = tse.parallel_env(scenario=args.scenario, **env_kwargs)
    obs = real_observations(env, seeds=(args.seed + 100, args.seed + 101))
    extra = {"algorithm": "ppo", "env_steps": rows[-1]["env_steps"], "iterations": len(rows),
             "minutes": round(rows[-1]["seconds"] / 60, 2), "args": asdict(args), "ray": ray.__version__,
             "torch": torch.__version__, "tin_swarm_env": tse.__version__}
    gap = export_module(algo.get_module(SHARED_POLICY), out / "policy", env, obs=obs, scenario=args.scenario,
                        extra=extra)
    (out / "run.json").write_text(json.dumps({**extra, "export_max_action_gap": gap}, indent=1) + "\n")
    print(f"exported {out / 'policy'}: numpy vs RLModule actions differ by at most {gap:.2e} on {len(obs)} "
          f"observations; {len(rows)} iterations, {extra['env_steps']} env steps, {extra['minutes']:.1f} min")
    return gap


if __name__ == "__main__":
    main(parse_dataclass(Args, description=__doc__.splitlines()[0]))
