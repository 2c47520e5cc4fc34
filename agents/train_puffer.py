"""PPO with PufferLib (``pufferlib.pufferl.PuffeRL``) on the vector env, to a wall-clock budget.

    python agents/train_puffer.py --scenario generated --n-envs 256 --n-robots 16 --max-minutes 30

Every robot of every copy is one PufferLib agent of one native ``PufferEnv``
(:mod:`tin_swarm_env.adapters.puffer`: ``n_envs * n_robots`` agents stepped by one call). The
policy is PufferLib's ``models.Default`` (one hidden layer of ``--hidden`` units, GELU, a Gaussian
head), trained by PuffeRL's PPO; each epoch prints the steps per second, the mean reward and the
shares of the robots that ended (arrived, fell, battery, timed out), and ``progress.csv`` keeps them.
The torch weights go to ``OUT_DIR/model.pt`` (a state dict). Needs the ``[puffer]`` extra
(``pufferlib-core``).
"""

from __future__ import annotations

import csv
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tin_swarm_env.apps.args import opt, parse_dataclass


@dataclass
class Args:
    scenario: str = opt("generated", "scenario name or TOML file")
    n_envs: int = opt(64, "copies of the swarm stepped by one call", lo=1)
    n_robots: int = opt(16, "robots per copy", lo=1)
    max_cycles: int = opt(0, "steps per episode (0: the scenario's)", lo=0)
    hidden: int = opt(64, "hidden units of PufferLib's Default policy", lo=1)
    horizon: int = opt(64, "steps collected per agent per epoch (PuffeRL's bptt_horizon)", lo=2)
    minibatch_size: int = opt(8192, "samples per PPO minibatch", lo=1)
    update_epochs: int = opt(2, "PPO passes over each batch", lo=1)
    lr: float = opt(3e-4, "Adam learning rate", lo=0, lo_open=True)
    gamma: float = opt(0.99, "discount", lo=0, hi=1)
    max_minutes: float = opt(30.0, "wall-clock budget", lo=0, lo_open=True)
    max_steps: int = opt(10**9, "agent steps at most", lo=1)
    seed: int = opt(0, "seed of the copies' seed streams and of torch", lo=0)
    torch_threads: int = opt(1, "torch threads (1: the env gets the other core)", lo=1)
    out_dir: str = opt("runs/ppo_puffer", "run directory: progress.csv, model.pt")


def config(args: Args, total_agents: int) -> dict:
    """PuffeRL's configuration (its ``default.ini`` keys), with the recipe's numbers."""
    batch = total_agents * args.horizon
    mb = min(args.minibatch_size, batch) // args.horizon * args.horizon
    return {"seed": args.seed, "torch_deterministic": True, "device": "cpu", "cpu_offload": False, "compile": False,
            "compile_mode": "default", "compile_fullgraph": False, "precision": "float32", "use_rnn": False,
            "batch_size": batch, "bptt_horizon": args.horizon, "minibatch_size": mb, "max_minibatch_size": mb,
            "update_epochs": args.update_epochs, "total_timesteps": args.max_steps, "optimizer": "adam",
            "learning_rate": args.lr, "adam_beta1": 0.9, "adam_beta2": 0.999, "adam_eps": 1e-8, "anneal_lr": False,
            "gamma": args.gamma, "gae_lambda": 0.95, "clip_coef": 0.2, "vf_coef": 0.5, "vf_clip_coef": 0.2,
            "ent_coef": 0.0, "max_grad_norm": 0.5, "prio_alpha": 0.0, "prio_beta0": 1.0, "vtrace_c_clip": 1.0,
            "vtrace_rho_clip": 1.0, "checkpoint_interval": 10**9, "data_dir": "/tmp/puffer_unused", "env": "tin_swarm"}


def main(argv=None) -> Path:
    args = parse_dataclass(Args, argv, description=__doc__.splitlines()[0])
    import torch

    from tin_swarm_env.adapters.puffer import make_puffer_env, use_cpu_advantage

    use_cpu_advantage()  # PufferLib's compiled advantage kernel needs CUDA torch: the same kernel in torch
    from pufferlib import models, pufferl

    torch.set_num_threads(args.torch_threads)
    torch.manual_seed(args.seed)
    kw = {"max_cycles": args.max_cycles} if args.max_cycles else {}
    env = make_puffer_env(args.scenario, n_envs=args.n_envs, n_robots=args.n_robots, seed=args.seed, **kw)
    policy = models.Default(env, hidden_size=args.hidden)
    pufferl.PuffeRL.print_dashboard = lambda *a, **k: None  # one line per epoch instead of the full-screen dashboard
    trainer = pufferl.PuffeRL(config(args, env.num_agents), env, policy)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows, t0 = [], time.perf_counter()
    while trainer.global_step < args.max_steps and time.perf_counter() - t0 < 60 * args.max_minutes:
        stats = trainer.evaluate()
        ended = defaultdict(list)
        for k, v in stats.items():
            ended[k].extend(v if isinstance(v, list) else [v])
        stats.clear()
        trainer.train()
        minutes = (time.perf_counter() - t0) / 60
        row = {"minutes": round(minutes, 3), "agent_steps": int(trainer.global_step),
               "steps_per_s": round(trainer.global_step / (60 * minutes), 1),
               **{k: round(float(np.mean(v)), 4) for k, v in ended.items() if v}}
        rows.append(row)
        print(row, flush=True)
    trainer.utilization.stop()  # PuffeRL's monitor thread (not a daemon: the process would not exit)
    torch.save(policy.state_dict(), out / "model.pt")
    keys = sorted({k for r in rows for k in r})
    with open(out / "progress.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    env.close()
    return out


if __name__ == "__main__":
    main()
