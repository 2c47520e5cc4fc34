"""PPO (Stable-Baselines3) on a tin_swarm scenario, one shared policy for all robots.

    tin-swarm train cliff_goal --timesteps 200000
    python agents/train_sb3.py --scenario cliff_goal --total-timesteps 200000   # the same

Read top to bottom: arguments, environment, evaluation, training, saving. Writes into
``out_dir``: ``model.zip`` (final), ``model.json`` (the scenario file's text and these
arguments), ``checkpoints/``, ``eval.csv`` (periodic evaluation), ``curve.png`` (the training
curve) and TensorBoard logs when tensorboard is installed. Needs the ``[train]`` extra.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import require
from ..world.state import Reason
from .policy_factory import SB3Policy
from .rollout import rollout

__all__ = ["Args", "train", "evaluate_model", "plot_curve"]


@dataclass
class Args:
    scenario: str = "cliff_goal"  # built-in name or TOML path
    n_robots: int = 8  # robots per environment copy (parameter sharing: each is one sub-env)
    n_envs: int = 2  # environment copies in the VecEnv
    max_cycles: int = 0  # 0: the scenario's
    total_timesteps: int = 200_000
    max_minutes: float = 0.0  # stop early after this much wall-clock time (0: no limit)
    seed: int = 0
    learning_rate: float = 3e-4
    n_steps: int = 256  # per sub-env per rollout
    batch_size: int = 512
    n_epochs: int = 5
    gamma: float = 0.99
    gae_lambda: float = 0.95
    ent_coef: float = 0.0
    clip_range: float = 0.2
    net_arch: str = "64,64"
    eval_every: int = 20_000  # timesteps between evaluations (0: none)
    eval_episodes: int = 3
    checkpoint_every: int = 50_000
    out_dir: str = "runs/ppo"
    progress_bar: bool = True
    torch_threads: int = 2


def evaluate_model(model, args: Args, episodes: int, seed: int) -> tuple[float, float, float]:
    """``(mean per-robot return, arrival share, fall share)`` of the deterministic policy over
    ``episodes`` episodes (seeds ``seed``, ``seed + 1``...)."""
    from ..env import parallel_env

    env = parallel_env(scenario=args.scenario, n_robots=args.n_robots, max_cycles=args.max_cycles or None)
    outs = [rollout(env, SB3Policy(model), seed + ep) for ep in range(episodes)]
    return (float(np.mean([o.returns.mean() for o in outs])), float(np.mean([o.share(Reason.ARRIVED) for o in outs])),
            float(np.mean([o.share(Reason.FELL) for o in outs])))


def _callbacks(args: Args, out: Path, rows: list, t0: float, num_envs: int):
    """Periodic evaluation (appending to ``rows``), the wall-clock limit and checkpoints."""
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback

    class EvalAndClock(BaseCallback):
        def __init__(self):
            super().__init__()
            self.next_eval = 0

        def _on_step(self) -> bool:
            if args.eval_every and self.num_timesteps >= self.next_eval:
                ret, arr, fell = evaluate_model(self.model, args, args.eval_episodes, seed=10_000)
                rows.append({"timesteps": self.num_timesteps, "minutes": (time.perf_counter() - t0) / 60,
                             "return": ret, "arrived": arr, "fell": fell})
                self.logger.record("eval/return", ret)
                self.logger.record("eval/arrived", arr)
                self.logger.record("eval/fell", fell)
                self.next_eval += args.eval_every
            return not (args.max_minutes and time.perf_counter() - t0 > 60 * args.max_minutes)

    return CallbackList([EvalAndClock(), CheckpointCallback(
        max(args.checkpoint_every // num_envs, 1), str(out / "checkpoints"), name_prefix="ppo")])


def _model(args: Args, vec, tb):
    from stable_baselines3 import PPO

    arch = [int(x) for x in args.net_arch.split(",") if x]
    return PPO("MlpPolicy", vec, learning_rate=args.learning_rate, n_steps=args.n_steps,
               batch_size=args.batch_size, n_epochs=args.n_epochs, gamma=args.gamma, gae_lambda=args.gae_lambda,
               ent_coef=args.ent_coef, clip_range=args.clip_range, policy_kwargs={"net_arch": arch},
               seed=args.seed, device="cpu", tensorboard_log=tb, verbose=0)


def _has(*modules) -> bool:
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in modules)


def train(args: Args) -> Path:
    """Train, evaluate, save (see the module docstring); returns the path of ``model.zip``."""
    torch = require("torch", "train", "Training with Stable-Baselines3")
    require("stable_baselines3", "train", "Training with Stable-Baselines3")
    from .. import __version__
    from ..adapters import make_sb3_vec_env
    from ..scenario import load_scenario

    torch.set_num_threads(args.torch_threads)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # every robot of every copy is one SB3 sub-environment
    kw = {"max_cycles": args.max_cycles} if args.max_cycles else {}
    vec = make_sb3_vec_env(args.scenario, n_robots=args.n_robots, n_envs=args.n_envs, seed=args.seed, **kw)
    rows, t0 = [], time.perf_counter()
    model = _model(args, vec, str(out / "tb") if _has("tensorboard") else None)
    model.learn(total_timesteps=args.total_timesteps, callback=_callbacks(args, out, rows, t0, vec.num_envs),
                progress_bar=args.progress_bar and _has("rich", "tqdm"))
    ret, arr, fell = evaluate_model(model, args, args.eval_episodes, seed=10_000)
    rows.append({"timesteps": model.num_timesteps, "minutes": (time.perf_counter() - t0) / 60,
                 "return": ret, "arrived": arr, "fell": fell})
    # save: the model, the scenario and arguments, the curve
    model.save(out / "model.zip")
    cfg = load_scenario(args.scenario)
    scen_text = Path(cfg.source).read_text() if Path(cfg.source).exists() else ""
    meta = {"args": dataclasses.asdict(args), "scenario_file": cfg.source, "scenario_toml": scen_text,
            "timesteps": int(model.num_timesteps), "minutes": (time.perf_counter() - t0) / 60,
            "final_eval": rows[-1], "tin_swarm_env": __version__}
    (out / "model.json").write_text(json.dumps(meta, indent=2))
    with open(out / "eval.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot_curve(rows, out / "curve.png", title=f"PPO on {args.scenario}")
    print(f"trained {model.num_timesteps} timesteps in {meta['minutes']:.1f} min; final eval: return "
          f"{ret:.1f}, arrived {arr:.0%}, fell {fell:.0%}; saved {out / 'model.zip'}")
    vec.close()
    return out / "model.zip"


def plot_curve(rows, path, title=""):
    """Evaluation return (left axis) and arrival/fall shares (right axis) against timesteps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ts = [r["timesteps"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=110)
    ax.plot(ts, [r["return"] for r in rows], "o-", label="return per robot")
    ax.set_xlabel("timesteps")
    ax.set_ylabel("evaluation return per robot")
    ax2 = ax.twinx()
    ax2.plot(ts, [r["arrived"] for r in rows], "s--", color="tab:green", label="arrived")
    ax2.plot(ts, [r["fell"] for r in rows], "x:", color="tab:red", label="fell")
    ax2.set_ylim(0, 1)
    ax2.set_ylabel("share of robots")
    fig.legend(loc="lower right", fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
