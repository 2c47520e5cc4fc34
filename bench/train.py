"""Training figures, run by hand (never part of the tests):

    python bench/train.py [--cap-minutes 20] [--eval-every 20000] [--throughput-timesteps 40000]
    python bench/train.py --throughput-timesteps 0 --only scratch --cap-minutes 10   # time to solve only

1. **Time to solve**: wall-clock minutes on this machine until the policy first reaches 90%
   arrival on cliff_goal (8 robots, evaluated every ``--eval-every`` timesteps on the same 3
   held-out seeds from ``EVAL_SEED0``), for PPO from scratch and for BC+DAgger-then-PPO (DAgger with
   beta-mixing 0.5 and stalled robots' samples dropped after 60 steps; the clock starts
   before the imitation's APF rollouts, so they are counted; evaluation time is counted too).
   Each is capped at ``--cap-minutes``; a run that does not get there prints "not solved within".
   The reward is the scenario's: once the geodesic progress reward is the goal task's default
   (``[rewards] progress = "geodesic"``) this measures PPO with it.
2. **Throughput** in the same run: environment steps per second while PPO learns (collection plus
   gradient updates) for 1 and 4 copies of 8 robots, and each time-to-solve run's own average
   (``--throughput-timesteps 0`` skips the separate measurement).

The clock is wall-clock on a possibly shared machine: quote the load average beside the figures.
"""

from __future__ import annotations

import argparse
import csv
import os
import tempfile
import time
from pathlib import Path


def throughput(scenario, n_envs, n_robots, timesteps):
    import torch
    from stable_baselines3 import PPO

    import tin_swarm_env as tse

    torch.set_num_threads(1)  # as apps/train.py: extra torch threads spin-wait against the env
    vec = tse.adapters.make_sb3_vec_env(scenario, n_robots=n_robots, n_envs=n_envs, seed=0)
    model = PPO("MlpPolicy", vec, n_steps=256, batch_size=1024, n_epochs=5, policy_kwargs={"net_arch": [128, 128]},
                seed=0, device="cpu", verbose=0)
    model.learn(total_timesteps=2 * 256 * vec.num_envs)  # warm-up: compilation, first allocations
    t = time.perf_counter()
    model.learn(total_timesteps=timesteps, reset_num_timesteps=False)
    return (model.num_timesteps - 2 * 256 * vec.num_envs) / (time.perf_counter() - t)


def time_to_solve(label, cap_minutes, eval_every, target=0.9, **imitation):
    """Train on cliff_goal until an evaluation reaches ``target`` arrival or ``cap_minutes``
    pass; returns ``(minutes to solve or None, timesteps then, env steps/s of PPO, last row)``."""
    from tin_swarm_env.apps.train import Args, train

    with tempfile.TemporaryDirectory() as tmp:
        args = Args(scenario="cliff_goal", n_robots=8, n_envs=4, n_steps=256, batch_size=1024, n_epochs=5,
                    net_arch="256,256", ent_coef=0.005, gamma=0.995, total_timesteps=50_000_000,
                    max_minutes=cap_minutes, eval_every=eval_every, eval_episodes=3, stop_at_arrival=target,
                    checkpoint_every=10**9, out_dir=str(Path(tmp) / label), progress_bar=False, **imitation)
        t0 = time.perf_counter()
        train(args)
        wall = time.perf_counter() - t0
        with open(Path(tmp) / label / "eval.csv") as fh:
            rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    hit = next((r for r in rows if r["arrived"] >= target), None)
    steps = rows[-1]["timesteps"]
    return (hit["minutes"] if hit else None, hit["timesteps"] if hit else steps, steps / wall, rows[-1])


def main(a):
    if a.throughput_timesteps:
        print("environment steps per second while PPO learns (one step = one robot), cliff_goal, 8 robots per copy")
        res = {c: throughput("cliff_goal", c, 8, a.throughput_timesteps) for c in (1, 4)}
        for c, v in res.items():
            print(f"  {c} copies ({8 * c:3d} sub-envs): {v:8.0f} steps/s")
        print(f"  4 copies / 1 copy: {res[4] / res[1]:.2f}x\n")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores at the start")
    print(f"time to solve cliff_goal (>= 90% arrived on 3 held-out seeds, evaluated every {a.eval_every} "
          f"timesteps; cap {a.cap_minutes:g} min each)")
    runs = [("PPO from scratch", {}),
            ("BC+DAgger then PPO", {"bc_episodes": a.bc_episodes, "dagger_rounds": 2, "dagger_episodes":
                                    max(a.bc_episodes // 2, 1), "dagger_beta": 0.5, "stall_steps": 60})]
    only = {"scratch": runs[:1], "bc": runs[1:], "both": runs}[a.only]
    for label, kw in only:
        mins, steps, sps, last = time_to_solve(label.replace(" ", "_"), a.cap_minutes, a.eval_every, **kw)
        if mins is None:
            print(f"  {label:20s} not solved within {a.cap_minutes:g} min ({steps:.0f} timesteps; last eval "
                  f"arrived {last['arrived']:.0%}, fell {last['fell']:.0%}); {sps:.0f} PPO steps per wall-clock s")
        else:
            print(f"  {label:20s} solved in {mins:.1f} min ({steps:.0f} PPO timesteps); {sps:.0f} env steps/s "
                  "overall")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cap-minutes", type=float, default=20.0)
    p.add_argument("--eval-every", type=int, default=20_000)
    p.add_argument("--bc-episodes", type=int, default=10)
    p.add_argument("--throughput-timesteps", type=int, default=40_000)
    p.add_argument("--only", choices=("both", "scratch", "bc"), default="both")
    main(p.parse_args())
