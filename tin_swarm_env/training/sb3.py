"""PPO (Stable-Baselines3) on tin_swarm scenarios, one shared policy for all robots, with an
optional warm start by imitation of a teacher (behaviour cloning, then DAgger).

    tin-swarm train cliff_goal --timesteps 200000
    python agents/train_sb3.py --scenario cliff_goal --total-timesteps 200000   # the same
    python agents/train_sb3.py --scenario cliff_goal,ramp --n-robots 8 --bc-episodes 10 --dagger-rounds 2 \
        --total-timesteps 0                                                      # imitation only

Read top to bottom: arguments, environment, imitation, evaluation, training, saving.

* ``--scenario``: a built-in name, a TOML path, or several separated by commas (a mix: the
  VecEnv holds ``n_envs`` copies of each; imitation episodes cycle over them). ``"generated"``
  (a new seeded terrain at every reset) is just another name.
* ``--bc-episodes N``: N episodes driven by the teacher (``--teacher apf``, the default:
  :class:`~tin_swarm_env.policies.APFPolicy`; ``--teacher geodesic``: the map-knowing
  :class:`~tin_swarm_env.policies.GeodesicPolicy`, a privileged teacher whose student sees only
  the observation), every live robot-step labelled with its action; the actor's mean is fitted by MSE
  (:mod:`tin_swarm_env.training.imitation`). ``--dagger-rounds K``: K rounds in which the learner drives
  ``--dagger-episodes`` episodes while the teacher runs alongside on the same observations (APF's per-robot
  memory stays consistent) and labels them; the actor is refitted on everything so far.
  ``--dagger-beta b``: in round r (from 0) the teacher drives each robot-step with probability b**(r+1)
  (DAgger's mixture, so early rounds stay near the teacher's states). ``--stall-steps S``: a robot
  whose distance to go has not improved for S steps contributes no more samples that episode. Then the
  critic is warmed up on the rollouts' discounted returns (``--value-epochs``) and the policy's
  exploration std set to ``--bc-std`` before PPO fine-tuning. ``--mirror-samples``: every fit also
  sees each sample's mirror image (observation and APF's action reflected,
  :meth:`~tin_swarm_env.training.imitation.Demos.mirrored`), so the clone learns both sides alike
  (refused with ``--teacher geodesic``, whose labels are not mirror-equivariant on the map driven:
  use ``--symmetry mirror``; :mod:`tin_swarm_env.training.imitation` says why).
  ``--symmetry mirror``: the actor and critic are mirror-equivariant by construction
  (:func:`~tin_swarm_env.adapters.sb3.mirror_policy_class`) in imitation and PPO alike, and the
  exported file says ``"symmetry": "mirror"`` (:mod:`tin_swarm_env.policies.symmetry`).
* ``--student gru``: imitation fits a recurrent student instead (a GRU before the MLP head, BC and
  DAgger on whole episodes per robot, exported as a recurrent policy file with the same
  ``--symmetry``/``--shield``; :mod:`tin_swarm_env.training.recurrent_imitation`); no PPO after it.
  ``--feedback action``: the GRU also reads the action it commanded at the previous step (the file's
  ``"network.feedback"``, :mod:`tin_swarm_env.policies.recurrent`).
* ``--head categorical``: the student's action head is a categorical over class actions (16
  headings x 2 speeds and stop) fitted by likelihood, not a mean fitted by MSE
  (:mod:`tin_swarm_env.policies.heads`); imitation only, with ``--student gru`` or, for
  ``--student mlp``, the same sequence fit without a cell (an MLP policy file); ``--head-acting``
  says how the file acts (the mode, or a seeded per-robot draw).
* ``--total-timesteps`` of PPO afterwards; 0 is refused without imitation (it would save an
  untrained model). ``--recurrent``: sb3-contrib's RecurrentPPO (MlpLstmPolicy, ``--lstm-hidden`` units,
  then ``--net-arch``); no imitation for it (imitation fits an MLP actor); it is exported as a
  recurrent policy file (:mod:`tin_swarm_env.policies.recurrent`: memory per robot, numpy forward
  pass).
* Seeds: training uses seeds below :data:`~tin_swarm_env.training.evaluate.EVAL_SEED0`: the
  VecEnv's copies ``seed + c``, imitation episodes ``seed * 1000 + k``; evaluation (here and in
  ``tin-swarm eval``) starts there, so on ``"generated"`` it is on terrains never trained on.

Writes into ``out_dir`` (default ``runs/<algo>_<scenarios>_s<seed>``): ``model.zip`` (SB3, a
pickle: load only your own), ``policy/`` (the pickle-free policy directory, ``load_policy``; with imitation and PPO also
``policy_imitation/``, the policy before PPO),
``model.json`` (scenario files' text and these arguments), ``checkpoints/``, ``eval.csv``
(periodic evaluation), ``curve.png`` and TensorBoard logs when tensorboard is installed. Needs the
``[train]`` extra (and sb3-contrib for ``--recurrent``).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from pathlib import Path

from ..errors import require
from .config import Args, check_args, check_run_outputs, imitating, net_arch, resumed, run_dir, run_info, scenarios_of
from .evaluation import EVAL_SEED0
from .scoring import eval_row
from .student import bc_dagger, fit_set, train_student

__all__ = ["train", "build_model", "imitate", "plot_curve"]

def _callbacks(args: Args, out: Path, rows: list, t0: float, vec, ckpt_extra, next_eval: int | None = None):
    """Periodic evaluation (appending to ``rows``), the wall-clock limit, the arrival target and
    checkpoints every ``checkpoint_every`` timesteps (:func:`~.checkpoint.write_checkpoint`)."""
    from stable_baselines3.common.callbacks import BaseCallback

    from .checkpoint import write_checkpoint

    class EvalClockCheckpoint(BaseCallback):
        def __init__(self):
            super().__init__()
            self.next_eval = next_eval if next_eval is not None else (args.eval_every if rows else 0)
            self.next_ckpt = None

        def _on_step(self) -> bool:
            if self.next_ckpt is None:
                self.next_ckpt = (self.num_timesteps // args.checkpoint_every + 1) * args.checkpoint_every
            if args.eval_every and self.num_timesteps >= self.next_eval:
                row = eval_row(self.model, args, rows, t0, self.num_timesteps, self.logger)
                self.next_eval += args.eval_every
                if args.stop_at_arrival and row["arrived"] >= args.stop_at_arrival:
                    return False
            if self.num_timesteps >= self.next_ckpt:
                write_checkpoint(out, self.model, vec, ckpt_extra(rows, self.next_eval))
                self.next_ckpt += args.checkpoint_every
            return not (args.max_minutes and time.perf_counter() - t0 > 60 * args.max_minutes)

    return EvalClockCheckpoint()

def _model_class(args: Args):
    if args.recurrent:
        return require("sb3_contrib", "train", "--recurrent (RecurrentPPO from sb3-contrib)").RecurrentPPO
    from stable_baselines3 import PPO

    return PPO

def build_model(args: Args, vec, tb):
    arch = net_arch(args.net_arch)
    kw = dict(learning_rate=args.learning_rate, n_steps=args.n_steps, batch_size=args.batch_size,
              n_epochs=args.n_epochs, gamma=args.gamma, gae_lambda=args.gae_lambda, ent_coef=args.ent_coef,
              clip_range=args.clip_range, policy_kwargs={"net_arch": arch}, seed=args.seed, device="cpu",
              tensorboard_log=tb, verbose=0)
    if args.recurrent:
        RecurrentPPO = require("sb3_contrib", "train", "--recurrent (RecurrentPPO from sb3-contrib)").RecurrentPPO
        kw["policy_kwargs"]["lstm_hidden_size"] = args.lstm_hidden
        return RecurrentPPO("MlpLstmPolicy", vec, **kw)
    from stable_baselines3 import PPO

    if args.symmetry == "mirror":
        from ..adapters.sb3 import mirror_policy_class
        from ..policies.symmetry import mirror_map

        perm, signs = mirror_map(vec.envs[0].layout)
        kw["policy_kwargs"]["mirror_signs"] = signs.tolist()
        kw["policy_kwargs"]["mirror_perm"] = perm.tolist()
        return PPO(mirror_policy_class(), vec, **kw)
    return PPO("MlpPolicy", vec, **kw)

def _has(*modules) -> bool:
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in modules)

def imitate(model, args: Args, log=print, layout=None) -> dict:
    """Behaviour cloning then DAgger into ``model.policy`` (see the module docstring), then the
    critic warm-up and the exploration std. Returns a summary (samples, MSEs, the driving
    policies' arrival per round). ``layout``: the observation layout (for ``--mirror-samples``;
    default: the first scenario's)."""
    from .imitation import TorchActor, fit_actor, fit_value

    if args.mirror_samples and layout is None:
        from ..env import parallel_env

        layout = parallel_env(scenario=scenarios_of(args)[0], n_robots=args.bc_robots or args.n_robots).layout

    scen, n_rob = scenarios_of(args), args.bc_robots or None
    kw = {"n_robots": n_rob, "max_cycles": args.max_cycles or None, "gamma": args.gamma,
          "stall_steps": args.stall_steps, "shield": args.shield, "teacher": args.teacher}
    fit = {"epochs": args.bc_epochs, "batch_size": args.bc_batch_size, "lr": args.bc_lr, "std": args.bc_std}

    def fit_on(demos, seed):
        fs = fit_set(demos, args, layout)
        return fit_actor(model.policy, fs.obs, fs.actions, seed=seed, **fit)

    demos, info = bc_dagger(args, scen, kw, fit_on, lambda: TorchActor(model.policy), log)
    if args.value_epochs:
        fs = fit_set(demos, args, layout)
        info["value_mse"] = fit_value(model.policy, fs.obs, fs.returns, epochs=args.value_epochs,
                                      batch_size=args.bc_batch_size, lr=args.bc_lr, seed=args.seed)
        log(f"value warm-up on {len(demos)} returns: MSE {info['value_mse']:.3f}")
    return info

def _read_checkpoints(args: Args, run: Path, trust_pickle: bool) -> list:
    """Every checkpoint of ``run``, read and checked against this run (its layout from the first
    scenario, its copies ``n_envs`` per scenario) before anything is built: :mod:`.checkpoint`."""
    from ..env import parallel_env
    from .checkpoint import read_checkpoints

    scen = scenarios_of(args)
    layout = parallel_env(scenario=scen[0], n_robots=args.n_robots).layout
    n_copies = args.n_envs * len(scen)
    return read_checkpoints(run, n_copies=n_copies, run_info=run_info(args, layout, n_copies),
                            trust_pickle=trust_pickle)

def _resume_model(args: Args, cks: list, vec, tb):
    """``(model, checkpoint)`` continuing from the last of the checked checkpoints ``cks``, each of
    them also checked against the network built (:mod:`.checkpoint`); ``(None, None)`` when none."""
    from .checkpoint import LEGACY_MODEL, check_against_model, restore, restore_rng

    if not cks:
        return None, None
    last = cks[-1]
    if last.legacy:  # an older version's SB3 pickle, allowed by --trust-pickle
        model = _model_class(args).load(last.path / LEGACY_MODEL, env=vec, device="cpu", tensorboard_log=tb)
        restore_rng(last.path, last.state, vec, last.torch_rng)
        return model, last
    model = build_model(args, vec, tb)
    for ck in cks:
        check_against_model(ck, model)
    restore(last, model, vec)
    return model, last

def train(args: Args) -> Path:
    """Imitate (optional), train, evaluate, save and export (see the module docstring); returns
    the path of ``model.zip`` (the pickle-free policy is its sibling ``policy/``; with ``--student
    gru`` the recurrent ``policy/`` itself, :func:`train_student`). With
    ``args.resume`` a killed run continues from its last checkpoint (:mod:`.checkpoint`)."""
    resume_run, trust_pickle = None, args.trust_pickle
    if args.resume:
        args, resume_run = resumed(args)
    check_args(args)
    if args.student == "gru" or args.head == "categorical":
        out = run_dir(args)
        check_run_outputs(args, out)
        return train_student(args, out)
    torch = require("torch", "train", "Training with Stable-Baselines3")
    from .checkpoint import ARGS_FILE, remove_unfinished, write_args, write_checkpoint

    out = run_dir(args)
    scen = scenarios_of(args)
    check_run_outputs(args, out)
    cks = _read_checkpoints(args, resume_run, trust_pickle) if resume_run is not None else None
    require("stable_baselines3", "train", "Training with Stable-Baselines3")
    from ..adapters import make_sb3_vec_env

    torch.set_num_threads(args.torch_threads)
    # every robot of every copy is one SB3 sub-environment; a mix holds n_envs copies of each scenario
    kw = {"max_cycles": args.max_cycles} if args.max_cycles else {}
    vec = make_sb3_vec_env(scen if len(scen) > 1 else scen[0], n_robots=args.n_robots,
                           n_envs=args.n_envs * len(scen), seed=args.seed, shield=args.shield, **kw)
    rows, t0 = [], time.perf_counter()
    tb = str(out / "tb") if _has("tensorboard") else None
    info = run_info(args, vec.envs[0].layout, len(vec.envs))

    def extra(rows_now, next_eval):
        return {"eval_rows": rows_now, "minutes": (time.perf_counter() - t0) / 60, "next_eval": next_eval,
                "imitation": imitation, "run": info}

    next_eval, model, ckpt = None, None, None
    if resume_run is not None:
        try:  # every checkpoint read and checked before anything is written
            model, ckpt = _resume_model(args, cks, vec, tb)
        except BaseException:
            vec.close()
            raise
        remove_unfinished(out)
    out.mkdir(parents=True, exist_ok=True)
    if not (out / ARGS_FILE).exists() or resume_run is None:
        write_args(out, {k: v for k, v in dataclasses.asdict(args).items() if k != "trust_pickle"})
    if ckpt is not None:
        path, state = ckpt.path, ckpt.state
        rows, imitation, next_eval = list(state["eval_rows"]), state["imitation"], state["next_eval"]
        t0 -= 60 * state["minutes"]
        print(f"resuming {out} from {path.name}: {model.num_timesteps} of {args.total_timesteps} timesteps done")
    else:
        model = build_model(args, vec, tb)
        imitation = imitate(model, args, layout=vec.envs[0].layout) if imitating(args) else None
        if imitation is not None and args.total_timesteps:  # the imitation stage alone, before PPO changes it
            from ..adapters.sb3 import export_sb3_policy

            export_sb3_policy(model, out / "policy_imitation", vec, scenario=args.scenario, shield=args.shield,
                              extra={"imitation": imitation, "args": dataclasses.asdict(args), "stage": "imitation"})
        if imitation is not None and args.eval_every:
            row = eval_row(model, args, rows, t0, 0)
            print(f"after imitation: arrived {row['arrived']:.0%}, fell {row['fell']:.0%} ({row['minutes']:.1f} min)")
        if imitation is not None:
            write_checkpoint(out, model, vec, extra(rows, args.eval_every if rows else 0))
    solved = bool(rows) and args.stop_at_arrival and rows[-1]["arrived"] >= args.stop_at_arrival
    remaining = args.total_timesteps - model.num_timesteps
    if remaining > 0 and not solved:
        model.learn(total_timesteps=remaining, callback=_callbacks(args, out, rows, t0, vec, extra, next_eval),
                    progress_bar=args.progress_bar and _has("rich", "tqdm"), reset_num_timesteps=ckpt is None)
    if not rows or rows[-1]["timesteps"] != model.num_timesteps:
        eval_row(model, args, rows, t0, model.num_timesteps)
    _save(model, args, out, rows, t0, vec, imitation)
    vec.close()
    return out / "model.zip"

def _save(model, args: Args, out: Path, rows: list, t0: float, vec, imitation) -> None:
    """``model.zip``, ``policy/`` (pickle-free; recurrent for a recurrent model), ``model.json``,
    ``eval.csv``, ``curve.png``; prints where."""
    from .. import __version__
    from .._atomic import atomic_path
    from ..scenario import load_scenario

    with atomic_path(out / "model.zip") as tmp:
        model.save(tmp)
    files = {}
    for s in scenarios_of(args):
        try:
            cfg = load_scenario(s)
            files[s] = {"file": cfg.source, "toml": Path(cfg.source).read_text() if Path(cfg.source).exists() else ""}
        except Exception:  # noqa: BLE001 (a scenario the env builds that has no file: recorded by name)
            files[s] = {"file": "", "toml": ""}
    first = files[scenarios_of(args)[0]]
    meta = {"args": dataclasses.asdict(args), "scenario_file": first["file"], "scenario_toml": first["toml"],
            "scenarios": files, "timesteps": int(model.num_timesteps), "minutes": (time.perf_counter() - t0) / 60,
            "imitation": imitation, "final_eval": rows[-1], "eval_seed0": EVAL_SEED0, "tin_swarm_env": __version__}
    with atomic_path(out / "model.json") as tmp:
        Path(tmp).write_text(json.dumps(meta, indent=2))
    with atomic_path(out / "eval.csv") as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot_curve(rows, out / "curve.png", title=f"{run_dir(args).name if not args.out_dir else 'PPO'} on "
                                               f"{args.scenario}")
    r = rows[-1]
    print(f"trained {model.num_timesteps} timesteps in {meta['minutes']:.1f} min; final eval: return "
          f"{r['return']:.1f}, arrived {r['arrived']:.0%}, fell {r['fell']:.0%}; saved {out / 'model.zip'}")
    from ..adapters.sb3 import export_sb3_policy

    export_sb3_policy(model, out / "policy", vec, scenario=args.scenario, shield=args.shield,
                      extra={"imitation": imitation, "args": dataclasses.asdict(args)})
    print(f"exported the pickle-free policy {out / 'policy'} (load_policy / --model {out / 'policy'})")

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
    from .._atomic import atomic_path

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
