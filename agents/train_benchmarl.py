"""MAPPO with BenchMARL on a tin_swarm scenario, to a wall-clock budget, exported to a pickle-free policy file.

    python agents/train_benchmarl.py --scenario generated --max-minutes 30 --out-dir runs/mappo_benchmarl

One group ``"robot"`` with one shared actor (``share_policy_params``) and a shared centralised critic
(MAPPO; ``--algorithm ippo`` for independent critics), both BenchMARL's ``MlpConfig`` (``--hidden``
units, tanh). The task is one :class:`~tin_swarm_env.adapters.benchmarl.TinSwarmTask`: one scenario
per experiment (BenchMARL's tasks hold one environment), so the shipped policy's training mix
(generated, cliff_goal, ramp) is not expressible here; ``generated`` (a new seeded terrain at every
reset, seeds far below the evaluation seeds) is the default. Training stops after the iteration that
would pass ``--max-minutes`` (or at ``--max-frames``); no wandb or other logger is needed: the
per-iteration progress goes to stdout and ``progress.csv``.

Then the actor's deterministic action (``tanh`` of the Gaussian's mean, as BenchMARL evaluates) is
written to ``OUT_DIR/policy`` (``policy.json`` + ``weights.npz``, :mod:`tin_swarm_env.policies.export`)
and checked: the numpy policy's actions against the torch actor's on observations of real episodes.
``--symmetry mirror``: the actor and the critic are
:class:`~tin_swarm_env.adapters.benchmarl.MirrorMlp` (mirror-equivariant by construction), the actor a
plain Gaussian (``use_tanh_normal=False``; the world clips the command), and the file says
``"symmetry": "mirror"``. Evaluate it with ``tin-swarm eval --policies OUT_DIR/policy`` (or
``agents/evaluate.py``). Needs the ``[benchmarl]`` extra.
"""

from __future__ import annotations

import csv
import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

os.environ.setdefault("TQDM_DISABLE", "1")  # BenchMARL's progress bar; one line per iteration is printed instead
from benchmarl.experiment.callback import Callback  # noqa: E402

from tin_swarm_env import Reason  # noqa: E402
from tin_swarm_env.apps.args import opt, parse_dataclass  # noqa: E402
from tin_swarm_env.policies.network import SHIELDS  # noqa: E402


@dataclass
class Args:
    scenario: str = opt("agents/scenarios/train_generated.toml", "built-in scenario (a TinSwarmTask member) or a "
                        "scenario TOML file (default: the training families only)")
    n_robots: int = opt(8, "robots per environment (one BenchMARL group)", lo=1)
    max_cycles: int = opt(0, "steps per episode (0: the scenario's)", lo=0)
    algorithm: str = opt("mappo", "mappo (centralised critic) or ippo (one critic input per robot)",
                         choices=("mappo", "ippo"))
    hidden: str = opt("256,256", "hidden layer sizes of the actor and the critic (tanh)")
    max_minutes: float = opt(30.0, "wall-clock budget: stop after the iteration that would pass it", lo=0, lo_open=True)
    max_frames: int = opt(50_000_000, "environment steps (frames) at most", lo=1)
    frames_per_batch: int = opt(4000, "environment steps collected per iteration", lo=1)
    n_envs: int = opt(4, "environments stepped one after another in the collector", lo=1)
    minibatch_size: int = opt(400, "environment steps per PPO minibatch (each holds every robot)", lo=1)
    minibatch_iters: int = opt(30, "PPO minibatches per iteration", lo=1)
    lr: float = opt(3e-4, "Adam learning rate", lo=0, lo_open=True)
    gamma: float = opt(0.99, "discount", lo=0, hi=1)
    lmbda: float = opt(0.95, "GAE lambda", lo=0, hi=1)
    entropy_coef: float = opt(0.0, "entropy bonus", lo=0)
    seed: int = opt(0, "seed (torch and the first env reset; training seeds stay far below EVAL_SEED0)", lo=0,
                    hi=999_999)
    torch_threads: int = opt(0, "torch threads (0: torch's default)", lo=0)
    snapshot_minutes: float = opt(5.0, "write the actor to OUT_DIR/snapshots/mMMM.M/policy every this many "
                                  "minutes (its learning curve)", lo=0, lo_open=True)
    symmetry: str = opt("none", "mirror: the actor and critic mirror-equivariant by construction (MirrorMlp; the "
                        "actor a plain Gaussian whose command the world clips)", choices=("none", "mirror"))
    shield: str = opt("safety_cut", "the exported file acts behind this shield (the actor trains without it)",
                      choices=SHIELDS)
    out_dir: str = opt("runs/mappo_benchmarl", "run directory: progress.csv, run.json, actor.pt (torch), policy/")


class TimeUp(KeyboardInterrupt):
    """Raised by :class:`Budget` to end ``Experiment.run()``: BenchMARL closes the experiment
    cleanly on a KeyboardInterrupt (its collector and envs) and re-raises it to us."""


class Snapshot:
    """Writes the actor to ``OUT_DIR/snapshots/mMMM.M/policy`` (unchecked: the final export is
    checked), a point of the learning curve. Plain data, as BenchMARL pickles its callbacks."""

    def __init__(self, args: Args):
        self.out, self.scenario, self.shield = Path(args.out_dir), args.scenario, args.shield
        self.n_robots = args.n_robots

    def __call__(self, experiment, minutes: float) -> None:
        import tin_swarm_env as tse
        from tin_swarm_env.adapters.benchmarl import actor_mean_layers, actor_symmetry
        from tin_swarm_env.policies.export import export_actor as write

        layers, activation, squash = actor_mean_layers(experiment, "robot")
        d = self.out / "snapshots" / f"m{minutes:05.1f}"
        d.mkdir(parents=True, exist_ok=True)
        layout = tse.parallel_env(scenario=self.scenario, n_robots=self.n_robots).unwrapped.layout
        write(d / "policy", layers, activation, squash=squash, layout=layout, scenario=self.scenario,
              extra={"minutes": round(minutes, 2)}, shield=self.shield, symmetry=actor_symmetry(experiment))


class Budget(Callback):
    """Prints one progress line per iteration and stops the run (:class:`TimeUp` after a training
    step) once another iteration would pass ``seconds``."""

    def __init__(self, seconds: float, rows: list, snapshot=None, snapshot_s: float = float("inf")):
        super().__init__()
        self.seconds, self.rows = seconds, rows
        self.t0 = self.last = time.perf_counter()
        self.frames, self.row = 0, {}
        self.snapshot, self.snapshot_s, self.next_snap = snapshot, snapshot_s, snapshot_s

    def on_batch_collected(self, batch):
        live = batch["robot", "mask"]  # robots still running before the step
        reason = batch["next", "robot", "info", "reason"]  # Reason code after it (0: still running)
        ended = reason[live & (reason != 0)]
        self.frames += batch.numel()
        self.row = {"frames": self.frames,
                    "reward_per_robot_step": float(batch["next", "robot", "reward"][live].mean()),
                    "robot_episodes_ended": int(ended.numel()),
                    **{f"{r.label}_share": float((ended == int(r)).sum()) / max(ended.numel(), 1)
                       for r in (Reason.ARRIVED, Reason.FELL, Reason.BATTERY, Reason.TIMEOUT)}}

    def on_train_end(self, training_td, group):
        now = time.perf_counter()
        row = {**self.row, "seconds": round(now - self.t0, 1),
               "loss_objective": float(training_td["loss_objective"].mean())}
        self.rows.append(row)
        print(f"iter {len(self.rows)}: frames {row['frames']}, reward/robot-step {row['reward_per_robot_step']:.4f},"
              f" robot episodes ended {row['robot_episodes_ended']} (arrived {row['arrived_share']:.2f}, fell "
              f"{row['fell_share']:.2f}, timed out {row['max_cycles_share']:.2f}), {row['seconds']:.0f} s", flush=True)
        if self.snapshot is not None and now - self.t0 >= self.next_snap:  # the learning curve's points
            self.snapshot(self.experiment, (now - self.t0) / 60)
            self.next_snap += self.snapshot_s
        if now - self.t0 + (now - self.last) > self.seconds:
            raise TimeUp()
        self.last = now


def build_experiment(args: Args, callbacks=()):
    from benchmarl.algorithms import IppoConfig, MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.benchmarl import TinSwarmTask, mirror_mlp_config

    env_kw = {"n_robots": args.n_robots, **({"max_cycles": args.max_cycles} if args.max_cycles else {})}
    member = args.scenario.upper() if args.scenario.upper() in TinSwarmTask.__members__ else "GENERATED"
    if member != args.scenario.upper():
        env_kw["scenario"] = args.scenario  # a TOML path
    task = TinSwarmTask[member].get_task(config=env_kw)
    algo = (MappoConfig if args.algorithm == "mappo" else IppoConfig).get_from_yaml()
    algo.lmbda, algo.entropy_coef = args.lmbda, args.entropy_coef
    model = MlpConfig.get_from_yaml()
    model.num_cells = [int(h) for h in args.hidden.split(",")]
    critic = model
    if args.symmetry == "mirror":
        layout = tse.parallel_env(scenario=args.scenario, n_robots=args.n_robots).unwrapped.layout
        model, critic = mirror_mlp_config(layout, model), mirror_mlp_config(layout, model)
        algo.use_tanh_normal = False  # the mean is averaged before any squash, as the policy file does
    cfg = ExperimentConfig.get_from_yaml()
    cfg.max_n_frames, cfg.max_n_iters = args.max_frames, None
    cfg.on_policy_collected_frames_per_batch, cfg.on_policy_n_envs_per_worker = args.frames_per_batch, args.n_envs
    cfg.on_policy_minibatch_size, cfg.on_policy_n_minibatch_iters = args.minibatch_size, args.minibatch_iters
    cfg.lr, cfg.gamma = args.lr, args.gamma
    cfg.evaluation, cfg.render = False, False  # evaluated afterwards on held-out seeds (tin-swarm eval)
    cfg.loggers, cfg.create_json, cfg.checkpoint_at_end = [], False, False  # no wandb: progress to stdout/csv
    cfg.save_folder = str(Path(args.out_dir).resolve())
    return Experiment(task=task, algorithm_config=algo, model_config=model, critic_model_config=critic,
                      seed=args.seed, config=cfg, callbacks=list(callbacks))


def main(args: Args):
    import benchmarl
    import torch

    import tin_swarm_env as tse
    from tin_swarm_env.adapters.benchmarl import export_actor
    from tin_swarm_env.policies.export import real_observations

    if args.torch_threads:
        torch.set_num_threads(args.torch_threads)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows: list = []
    budget = Budget(60 * args.max_minutes, rows, Snapshot(args), 60 * args.snapshot_minutes)
    experiment = build_experiment(args, [budget])
    t0 = time.perf_counter()
    try:
        experiment.run()
    except TimeUp:
        print(f"stopped at the {args.max_minutes:g}-minute budget")
    minutes = (time.perf_counter() - t0) / 60
    if rows:
        with open(out / "progress.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    torch.save(experiment.group_policies["robot"].state_dict(), out / "actor.pt")  # torch's own copy, for reruns
    env_kw = {"n_robots": args.n_robots, **({"max_cycles": args.max_cycles} if args.max_cycles else {})}
    env = tse.parallel_env(scenario=args.scenario, **env_kw)
    obs = real_observations(env, seeds=(args.seed + 100, args.seed + 101))
    extra = {"algorithm": args.algorithm, "frames": rows[-1]["frames"] if rows else 0, "iterations": len(rows),
             "minutes": round(minutes, 2), "args": asdict(args), "benchmarl": benchmarl.__version__,
             "torch": torch.__version__, "tin_swarm_env": tse.__version__}
    gap = export_actor(experiment, out / "policy", env, obs=obs, scenario=args.scenario, extra=extra,
                       shield=args.shield)
    (out / "run.json").write_text(json.dumps({**extra, "export_max_action_gap": gap}, indent=1) + "\n")
    print(f"exported {out / 'policy'}: numpy vs torch actions differ by at most {gap:.2e} on {len(obs)} "
          f"observations; {len(rows)} iterations, {extra['frames']} frames, {minutes:.1f} min")
    return rows


if __name__ == "__main__":
    main(parse_dataclass(Args, description=__doc__.splitlines()[0]))
