"""Training figures, run by hand (never part of the tests):

    python bench/train.py [--cap-minutes 20] [--eval-every 20000] [--throughput-timesteps 40000]
    python bench/train.py --throughput-timesteps 0 --only scratch --cap-minutes 10   # time to solve only
    python bench/train.py --split [--rollouts 4]   # where PPO's time goes, shipped recipe and variants
    python bench/train.py --quick                  # a smoke run (seconds): the same for the shipped recipe alone,
                                                   # 16-step rollouts, 1 epoch, 1 rollout; prints only

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

3. **Where the time goes** (``--split``, ``--quick``): PPO with the shipped recipe, the arguments
   of ``agents/train_sb3.py`` in ``agents/reproduce_shared_sb3.sh`` (read from the script, so the recipe
   has one home; its imitation stage is not run: this times PPO), timed per phase over
   ``--rollouts`` rollouts after one warm-up rollout: *collection* (``collect_rollouts``: env steps,
   of which the VecEnv's own ``step_wait`` is shown apart, plus the policy's forward passes) in
   robot-steps per second, and *update* (``train``: ``n_epochs`` passes of minibatch SGD over the
   rollout) in rollout samples per second of update. ``--split`` adds variants of the recipe (more
   robots per copy, a smaller network, fewer epochs) and writes the table to
   ``docs/figures/train.md``.

The clock is wall-clock on a possibly shared machine: quote the load average beside the figures.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "agents" / "reproduce_shared_sb3.sh"  # the SB3 recipe (the shipped one is PufferLib's)


def throughput(scenario, n_envs, n_robots, timesteps):
    import torch
    from stable_baselines3 import PPO

    import tin_swarm_env as tse

    torch.set_num_threads(1)  # as training/sb3.py: extra torch threads spin-wait against the env
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
    from tin_swarm_env.training.config import Args
    from tin_swarm_env.training.sb3 import train

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


def shipped_recipe():
    """The :class:`~tin_swarm_env.training.config.Args` of the ``agents/train_sb3.py`` command in
    ``agents/reproduce_shared_sb3.sh`` (continuation lines joined, shell variables at their defaults,
    the redirection dropped)."""
    from tin_swarm_env.apps.args import parse_dataclass
    from tin_swarm_env.training.config import Args
    from tin_swarm_env.training.held_out import recipe_command

    argv = recipe_command(RECIPE.read_text(), "agents/train_sb3.py", where=str(RECIPE))
    return parse_dataclass(Args, argv)


VARIANTS = {"shipped recipe": {},
            "32 robots per copy": {"n_robots": 32, "n_envs": 1},
            "network 64,64": {"net_arch": "64,64"},
            "32 robots, 64,64, 3 epochs": {"n_robots": 32, "n_envs": 1, "net_arch": "64,64", "n_epochs": 3}}


QUICK = {"n_steps": 16, "n_epochs": 1}  # --quick: the shipped recipe's rollouts cut short (a check, not a figure)


def split_throughput(args, rollouts: int) -> dict:
    """Seconds in collection (of which VecEnv.step_wait) and in updates over ``rollouts`` PPO
    rollouts with training arguments ``args``, after one warm-up rollout (compilation, first
    allocations); returns the figures of one table row."""
    import torch

    from tin_swarm_env.adapters import make_sb3_vec_env
    from tin_swarm_env.training.config import scenarios_of
    from tin_swarm_env.training.sb3 import build_model

    torch.set_num_threads(args.torch_threads)
    scen = scenarios_of(args)
    kw = {"max_cycles": args.max_cycles} if args.max_cycles else {}
    vec = make_sb3_vec_env(scen if len(scen) > 1 else scen[0], n_robots=args.n_robots,
                           n_envs=args.n_envs * len(scen), seed=args.seed, shield=args.shield, **kw)
    model = build_model(args, vec, None)
    per_rollout = args.n_steps * vec.num_envs
    model.learn(total_timesteps=per_rollout)  # warm-up
    t = {"collect": 0.0, "step_wait": 0.0, "update": 0.0}

    def timed(key, fn):
        def run(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                t[key] += time.perf_counter() - t0
        return run

    model.collect_rollouts = timed("collect", model.collect_rollouts)
    model.train = timed("update", model.train)
    vec.step_wait = timed("step_wait", vec.step_wait)
    t0 = time.perf_counter()
    model.learn(total_timesteps=rollouts * per_rollout, reset_num_timesteps=False)
    wall = time.perf_counter() - t0
    vec.close()
    samples = rollouts * per_rollout
    return {"sub_envs": vec.num_envs, "samples": samples, "collect_s": t["collect"], "env_s": t["step_wait"],
            "update_s": t["update"], "wall_s": wall, "collect_sps": samples / t["collect"],
            "env_sps": samples / t["step_wait"], "update_sps": samples / t["update"], "overall_sps": samples / wall}


def split_rows(a, argv) -> list[str]:
    recipe = shipped_recipe()
    lines = [_header(argv), "",
             f"PPO only (the recipe's imitation stage is not run), {a.rollouts} rollouts after a warm-up rollout; "
             f"recipe: `{recipe.scenario}`, {recipe.n_robots} robots x {recipe.n_envs} copies per scenario, "
             f"net {recipe.net_arch}, n_steps {recipe.n_steps}, batch {recipe.batch_size}, {recipe.n_epochs} "
             f"epochs, shield {recipe.shield}, torch threads {recipe.torch_threads}. Robot-steps (samples) per "
             "second of each phase; the env's share is `VecEnv.step_wait` within collection.", "",
             "| variant | sub-envs | collection steps/s | env alone steps/s | env share of collection | "
             "update samples/s | collection share of wall | overall steps/s |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for line in lines:
        print(line, flush=True)
    names = ["shipped recipe"] if a.quick else list(VARIANTS)
    for name in names:
        args = dataclasses.replace(recipe, **VARIANTS[name], **(QUICK if a.quick else {}))
        r = split_throughput(args, a.rollouts)
        row = (f"| {name} | {r['sub_envs']} | {r['collect_sps']:.0f} | {r['env_sps']:.0f} | "
               f"{r['env_s'] / r['collect_s']:.0%} | {r['update_sps']:.0f} | {r['collect_s'] / r['wall_s']:.0%} | "
               f"{r['overall_sps']:.0f} |")
        print(row, flush=True)
        lines.append(row)
    lines.append(f"\nload average {_load()} at the end.")
    print(lines[-1].strip())
    return lines


def _header(argv) -> str:
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            check=False).stdout.strip() or "?"
    return (f"Measured with `python bench/train.py {' '.join(argv)}` at commit {commit}, "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {_load()} at the start "
            f"({os.cpu_count()} cores, shared).")


def _load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def main(a):
    if a.quick or a.split:
        lines = split_rows(a, sys.argv[1:])
        out = a.out if a.out is not None else (None if a.quick else str(ROOT / "docs" / "figures" / "train.md"))
        if out:
            Path(out).write_text("\n".join(lines) + "\n")
            print(f"wrote {out}")
        return
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
    p.add_argument("--split", action="store_true",
                   help="only: collection vs update throughput, shipped recipe and variants (docs/figures/train.md)")
    p.add_argument("--quick", action="store_true", help=f"a smoke run (seconds): --split for the shipped recipe alone "
                   f"with {QUICK}, 1 rollout; prints only")
    p.add_argument("--rollouts", type=int, default=None, help="measured rollouts per row (default 4; 1 with --quick)")
    p.add_argument("--out", default=None, help="Markdown file for the --split table (none with --quick)")
    a = p.parse_args()
    a.rollouts = a.rollouts or (1 if a.quick else 4)
    main(a)
