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
  (:mod:`tin_swarm_env.apps.imitation`). ``--dagger-rounds K``: K rounds in which the learner drives
  ``--dagger-episodes`` episodes while the teacher runs alongside on the same observations (APF's per-robot
  memory stays consistent) and labels them; the actor is refitted on everything so far.
  ``--dagger-beta b``: in round r (from 0) the teacher drives each robot-step with probability b**(r+1)
  (DAgger's mixture, so early rounds stay near the teacher's states). ``--stall-steps S``: a robot
  whose distance to go has not improved for S steps contributes no more samples that episode. Then the
  critic is warmed up on the rollouts' discounted returns (``--value-epochs``) and the policy's
  exploration std set to ``--bc-std`` before PPO fine-tuning. ``--mirror-samples``: every fit also
  sees each sample's mirror image (observation and APF's action reflected,
  :meth:`~tin_swarm_env.apps.imitation.Demos.mirrored`), so the clone learns both sides alike
  (refused with ``--teacher geodesic``, whose labels are not mirror-equivariant on the map driven:
  use ``--symmetry mirror``; :mod:`tin_swarm_env.apps.imitation` says why).
  ``--symmetry mirror``: the actor and critic are mirror-equivariant by construction
  (:func:`~tin_swarm_env.adapters.sb3.mirror_policy_class`) in imitation and PPO alike, and the
  exported file says ``"symmetry": "mirror"`` (:mod:`tin_swarm_env.policies.symmetry`).
* ``--student gru``: imitation fits a recurrent student instead (a GRU before the MLP head, BC and
  DAgger on whole episodes per robot, exported as a recurrent policy file with the same
  ``--symmetry``/``--shield``; :mod:`tin_swarm_env.apps.recurrent_imitation`); no PPO after it.
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
* Seeds: training uses seeds below :data:`~tin_swarm_env.apps.evaluate.EVAL_SEED0`: the
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ArgumentError, require
from ..policies.learned import SHIELDS, ShieldedPolicy
from ..scenario.config import MAX_ROBOTS
from .args import check_args as check_fields, opt
from ..policies.heads import ACTINGS
from ..policies.symmetry import SYMMETRIES
from ..world.state import Reason
from .evaluate import EVAL_SEED0
from .imitation import TEACHERS
from .policy_factory import SB3Policy
from .rollout import rollout

__all__ = ["Args", "train", "train_student", "evaluate_model", "evaluate_policy_file", "plot_curve", "scenarios_of",
           "run_dir", "RecurrentSB3Policy"]

STUDENTS = ("mlp", "gru")  # --student: what imitation fits (apps/imitation.py, apps/recurrent_imitation.py)


def _net_arch(spec: str) -> list[int]:
    """``"64,64"`` -> ``[64, 64]``: hidden layer widths, each 1..MAX_LAYER_WIDTH (the policy file's limit)."""
    from ..policies.learned import MAX_LAYER_WIDTH, MAX_LAYERS

    parts = [p.strip() for p in str(spec).split(",") if p.strip()]
    if not parts or not all(p.isdigit() and 1 <= int(p) <= MAX_LAYER_WIDTH for p in parts) or len(parts) >= MAX_LAYERS:
        raise ArgumentError(f"--net-arch {spec!r}: give hidden layer widths separated by commas (e.g. 64,64), "
                            f"each 1..{MAX_LAYER_WIDTH}, at most {MAX_LAYERS - 1} layers")
    return [int(p) for p in parts]


def _arch_msg(spec):
    try:
        _net_arch(spec)
    except ArgumentError as exc:
        return str(exc).split(": ", 1)[1]
    return None


_NONNEG = {"lo": 0}
_POS = {"lo": 1}


@dataclass
class Args:
    """``tin-swarm train`` / ``agents/train_sb3.py``: every option, its help and what it accepts."""

    scenario: str = opt("cliff_goal", "built-in name or TOML path; several, comma-separated: a mix")
    n_robots: int = opt(8, "robots per environment copy (parameter sharing: each is one sub-env)", lo=1,
                        hi=MAX_ROBOTS)
    n_envs: int = opt(2, "environment copies in the VecEnv (per scenario of a mix)", lo=1, hi=1024)
    max_cycles: int = opt(0, "steps per episode (0: the scenario's)", lo=0)
    total_timesteps: int = opt(200_000, "PPO timesteps after imitation (0 only with imitation)", lo=0)
    max_minutes: float = opt(0.0, "stop early after this much wall-clock time (0: no limit)", lo=0)
    seed: int = opt(0, "training seed (copies seed + c; imitation seed * 1000 + k)", lo=0,
                    hi=EVAL_SEED0 // 1000 - 1)
    learning_rate: float = opt(3e-4, "Adam learning rate", lo=0, lo_open=True, hi=1)
    n_steps: int = opt(256, "PPO rollout length per sub-env", **_POS)
    batch_size: int = opt(512, "PPO minibatch size", lo=2)
    n_epochs: int = opt(5, "PPO passes over each rollout", lo=1, hi=1000)
    gamma: float = opt(0.99, "discount factor", lo=0, lo_open=True, hi=1)
    gae_lambda: float = opt(0.95, "GAE lambda", lo=0, hi=1)
    ent_coef: float = opt(0.0, "entropy bonus coefficient", lo=0)
    clip_range: float = opt(0.2, "PPO clip range", lo=0, lo_open=True, hi=10)
    net_arch: str = opt("64,64", "hidden layer widths of actor and critic, comma-separated", check=_arch_msg)
    recurrent: bool = opt(False, "sb3-contrib RecurrentPPO (MlpLstmPolicy); no imitation")
    lstm_hidden: int = opt(256, "--recurrent: LSTM units (RecurrentPPO's default)", lo=1, hi=4096)
    student: str = opt("mlp", "imitation's student: mlp (the SB3 actor, PPO may follow) or gru (a recurrent "
                       "student, imitation only: --timesteps 0; apps/recurrent_imitation.py)", choices=STUDENTS)
    head: str = opt("mean", "the action head: mean (MSE fit) or categorical (class actions, likelihood fit, "
                    "imitation only; policies/heads.py)", choices=("mean", "categorical"))
    head_acting: str = opt("mode", "--head categorical: how the file acts: mode, side (the likelier side, then its "
                           "mode) or sample (a seeded per-robot draw); policies/heads.py", choices=ACTINGS)
    feedback: str = opt("none", "--student gru: action feeds the GRU the action it commanded at the previous step "
                        "(policies/recurrent.py), so a sampled side can be kept", choices=("none", "action"))
    gru_hidden: int = opt(64, "--student gru: GRU units (--net-arch: the head after it)", lo=1, hi=1024)
    bc_episodes: int = opt(0, "behaviour cloning: teacher-driven episodes (0: no imitation)", **_NONNEG)
    teacher: str = opt("apf", "imitation's teacher: apf, geodesic (knows the map; the student sees only the "
                       "observation), or apf_student (APF along the student's trajectory: apps/apf_teacher.py)",
                       choices=TEACHERS)
    dagger_rounds: int = opt(0, "DAgger rounds after BC (the learner drives, the teacher labels)", **_NONNEG)
    dagger_episodes: int = opt(0, "episodes per DAgger round (0: as many as --bc-episodes)", **_NONNEG)
    dagger_beta: float = opt(0.0, "round r (from 0): the teacher drives each robot-step with probability beta**(r+1)",
                             lo=0, hi=1, hi_open=True)
    stall_steps: int = opt(0, "imitation keeps no samples of a robot stuck this many steps (0: keep all)", **_NONNEG)
    bc_robots: int = opt(0, "robots per imitation episode (0: the scenario's count)", lo=0, hi=MAX_ROBOTS)
    bc_epochs: int = opt(30, "passes over the imitation data per fit", **_POS)
    bc_lr: float = opt(1e-3, "imitation learning rate", lo=0, lo_open=True, hi=1)
    bc_batch_size: int = opt(4096, "imitation minibatch size", **_POS)
    bc_std: float = opt(0.3, "the Gaussian std PPO starts from after imitation", lo=0, lo_open=True, hi=10)
    mirror_samples: bool = opt(False, "imitation fits on every sample and its mirror image (both sides alike)")
    symmetry: str = opt("none", "mirror: a mirror-equivariant actor and critic (exported with symmetry mirror)",
                        choices=SYMMETRIES)
    value_epochs: int = opt(10, "critic warm-up epochs on the imitation rollouts' returns (0: none)", **_NONNEG)
    eval_every: int = opt(20_000, "timesteps between evaluations (0: none)", **_NONNEG)
    eval_episodes: int = opt(3, "episodes per scenario in each evaluation", **_POS)
    stop_at_arrival: float = opt(0.0, "stop once an evaluation reaches this arrival share (0: never)", lo=0, hi=1)
    checkpoint_every: int = opt(50_000, "timesteps between checkpoints (what --resume continues from)", **_POS)
    out_dir: str = opt("", "run directory (empty: runs/<algo>_<scenarios>_s<seed>)")
    progress_bar: bool = opt(True, "show a progress bar (needs rich and tqdm)")
    shield: str = opt("none", "safety_cut: learn and act through the policy-file shield (exported with it)",
                      choices=SHIELDS)
    torch_threads: int = opt(1, "torch threads; more than 1 on a busy 2-core machine makes PPO ~10x slower",
                             lo=1, hi=256)
    resume: str = opt("", "continue the killed run in this directory from its last checkpoint, with the "
                          "arguments it was started with (the other options are not used)")
    trust_pickle: bool = opt(False, "--resume: allow a checkpoint written by an older version, whose model is an SB3 "
                             "model.zip (a pickle: loading it runs any code it holds)", flag=True)

    def __post_init__(self):
        check_fields(self)


def scenarios_of(args: Args) -> list[str]:
    """The scenario names/paths of ``args.scenario`` (comma-separated)."""
    out = [s.strip() for s in args.scenario.split(",") if s.strip()]
    if not out:
        raise ArgumentError("--scenario: give at least one scenario name or path")
    return out


def _imitating(args: Args) -> bool:
    return args.bc_episodes > 0


def run_dir(args: Args) -> Path:
    """``args.out_dir``, or ``runs/<algo>_<scenarios>_s<seed>`` (a path's stem for a TOML file)."""
    if args.out_dir:
        return Path(args.out_dir)
    algo = ("rppo" if args.recurrent else "bc_gru" if args.student == "gru" else
            "bc_ppo" if _imitating(args) and args.total_timesteps else "bc" if _imitating(args) else "ppo")
    return Path("runs") / f"{algo}_{'+'.join(Path(s).stem for s in scenarios_of(args))}_s{args.seed}"


def check_args(args: Args) -> None:
    """Refuse arguments that would train nothing or cannot be combined (naming the option; each
    option's own range is checked by ``Args`` itself)."""
    check_fields(args)  # again: fields may have been changed after construction
    if args.total_timesteps == 0 and not _imitating(args):
        raise ArgumentError("--timesteps 0 without imitation would save an untrained model; give a positive "
                            "--timesteps, or --bc-episodes N to train by imitation only")
    if args.dagger_rounds and not _imitating(args):
        raise ArgumentError("--dagger-rounds needs --bc-episodes (DAgger starts from a cloned policy)")
    if not 0.0 <= args.dagger_beta < 1.0:
        raise ArgumentError(f"--dagger-beta must be in [0, 1), got {args.dagger_beta}")
    if args.teacher == "geodesic" and args.mirror_samples:
        raise ArgumentError("--mirror-samples cannot be combined with --teacher geodesic: a mirrored label is the "
                            "map-knowing teacher's action on a mirror-image map nobody ran (apps/imitation.py); "
                            "use --symmetry mirror (a mirror-equivariant student) instead")
    if args.head == "categorical":
        if not _imitating(args) or args.total_timesteps:
            raise ArgumentError("--head categorical learns by imitation only: give --bc-episodes N and --timesteps 0")
        if args.recurrent:
            raise ArgumentError("--head categorical cannot be combined with --recurrent (RecurrentPPO's LSTM)")
    if args.head != "categorical" and args.head_acting != "mode":
        raise ArgumentError(f"--head-acting {args.head_acting} is for --head categorical (a mean head has one action "
                            "per observation)")
    if args.feedback != "none" and args.student != "gru":
        raise ArgumentError(f"--feedback {args.feedback} needs --student gru (a memoryless MLP has no previous step)")
    if args.student == "gru":
        if not _imitating(args):
            raise ArgumentError("--student gru learns by imitation: give --bc-episodes N")
        if args.total_timesteps:
            raise ArgumentError("--student gru has no PPO stage: give --timesteps 0 (imitation only)")
        if args.recurrent:
            raise ArgumentError("--student gru cannot be combined with --recurrent (RecurrentPPO's LSTM)")
    if args.recurrent and _imitating(args):
        raise ArgumentError("--recurrent cannot be combined with --bc-episodes (imitation fits an MLP actor)")
    if args.batch_size > args.n_steps * args.n_robots * args.n_envs * len(scenarios_of(args)) and args.total_timesteps:
        raise ArgumentError(f"--batch-size {args.batch_size} is more than one rollout holds (--n-steps x robots x "
                            f"copies = {args.n_steps * args.n_robots * args.n_envs * len(scenarios_of(args))})")
    if args.symmetry != "none" and args.recurrent:
        raise ArgumentError("--symmetry mirror is for the MLP policy; RecurrentPPO has no mirror-equivariant "
                            "policy here")


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
        return ShieldedPolicy(pol, env) if args.shield != "none" else pol

    return _evaluate(policy_of, args, episodes, seed)


def evaluate_policy_file(policy_of, args: Args, episodes: int, seed: int = EVAL_SEED0) -> dict:
    """:func:`evaluate_model` of a policy ``policy_of(env)`` (a policy file, which applies its own
    shield) as ``{"return", "arrived", "fell"}``."""
    ret, arr, fell = _evaluate(policy_of, args, episodes, seed)
    return {"return": ret, "arrived": arr, "fell": fell}


def _eval_row(model, args, rows, t0, timesteps, logger=None) -> dict:
    ret, arr, fell = evaluate_model(model, args, args.eval_episodes)
    row = {"timesteps": timesteps, "minutes": (time.perf_counter() - t0) / 60, "return": ret, "arrived": arr,
           "fell": fell}
    rows.append(row)
    if logger is not None:
        for k in ("return", "arrived", "fell"):
            logger.record(f"eval/{k}", row[k])
    return row


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
                row = _eval_row(self.model, args, rows, t0, self.num_timesteps, self.logger)
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
    arch = _net_arch(args.net_arch)
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


def fit_set(demos, args: Args, layout):
    """What imitation fits on: ``demos``, and with ``--mirror-samples`` their mirror images too
    (:meth:`~tin_swarm_env.apps.imitation.Demos.mirrored`)."""
    return demos + demos.mirrored(layout) if args.mirror_samples else demos


def _bc_dagger(args: Args, scen, kw: dict, fit_on, learner, log, student: str = "", t0: float | None = None):
    """Imitation's rounds, for the MLP actor and the GRU student alike: behaviour cloning on
    ``--bc-episodes`` episodes the teacher drove, then ``--dagger-rounds`` rounds in which
    ``learner()`` drives ``--dagger-episodes`` episodes (the teacher drives each robot-step with
    probability ``beta ** (r + 1)``) and the fit is redone on every sample so far.
    ``fit_on(demos, seed) -> mse`` fits the student; ``kw`` goes to
    :func:`~tin_swarm_env.apps.imitation.collect`. Returns ``(demos, info)`` (samples, MSEs, the
    driving policies' arrival per round)."""
    from .imitation import collect

    who = args.teacher.upper() if args.teacher == "apf" else args.teacher
    what = f"the {student}" if student else "the learner"
    took = (lambda: f" ({(time.perf_counter() - t0) / 60:.1f} min)") if t0 is not None else (lambda: "")
    loss = "cross-entropy" if args.head == "categorical" else "MSE" if student else "actor MSE"
    base = args.seed * 1000
    demos = collect(scen, args.bc_episodes, base, **kw)
    mse = fit_on(demos, args.seed)
    info = {"bc_samples": len(demos), "teacher": args.teacher, "teacher_arrived": demos.arrived,
            "rounds": [{"mse": mse}]}
    log(f"BC{f' ({student})' if student else ''}: {len(demos)} samples from {demos.episodes} {who} episodes ({who} "
        f"arrived {demos.arrived:.0%}, fell {demos.fell:.0%}); {loss} {mse:.4f}{took()}")
    n_dag = args.dagger_episodes or args.bc_episodes
    for r in range(args.dagger_rounds):
        beta = args.dagger_beta ** (r + 1) if args.dagger_beta > 0 else 0.0
        new = collect(scen, n_dag, base + args.bc_episodes + r * n_dag, learner=learner(), beta=beta, **kw)
        demos = demos + new
        mse = fit_on(demos, args.seed + r + 1)
        info["rounds"].append({"learner_arrived": new.arrived, "learner_fell": new.fell, "mse": mse})
        log(f"DAgger round {r + 1} (beta {beta:.2f}): {what} drove {n_dag} episodes (arrived "
            f"{new.arrived:.0%}, fell {new.fell:.0%}); {len(demos)} samples; {loss} {mse:.4f}{took()}")
    return demos, info


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

    demos, info = _bc_dagger(args, scen, kw, fit_on, lambda: TorchActor(model.policy), log)
    if args.value_epochs:
        fs = fit_set(demos, args, layout)
        info["value_mse"] = fit_value(model.policy, fs.obs, fs.returns, epochs=args.value_epochs,
                                      batch_size=args.bc_batch_size, lr=args.bc_lr, seed=args.seed)
        log(f"value warm-up on {len(demos)} returns: MSE {info['value_mse']:.3f}")
    return info


def train_student(args: Args, out: Path, log=print) -> Path:
    """``--student gru`` or ``--head categorical``: BC then DAgger of a GRU (or, ``--student mlp``,
    memoryless) student (:mod:`tin_swarm_env.apps.recurrent_imitation`), with ``args`` (teacher, episodes, rounds,
    beta, stall steps, robots, epochs, learning rate, ``--gru-hidden`` units, ``--net-arch`` as
    the head's widths, ``--symmetry``, ``--mirror-samples``, ``--shield``); writes ``out/policy``
    (the student's policy file: recurrent for ``--student gru``, an MLP file for ``--student mlp``) and ``out/model.json`` (arguments, per-round figures and, with
    ``--eval-every`` > 0, the file's evaluation on the held-out seeds). Returns ``out/policy``."""
    from .._atomic import atomic_path
    from ..env import parallel_env
    from ..policies.learned import load_policy
    from .recurrent_imitation import GRUStudent, fit_sequences

    torch = require("torch", "train", "The recurrent student")
    torch.set_num_threads(args.torch_threads)
    t0 = time.perf_counter()
    out = Path(out)
    scen = scenarios_of(args)
    layout = parallel_env(scenario=scen[0], n_robots=args.bc_robots or args.n_robots).layout
    from ..policies.symmetry import mirror_map

    obs_perm, signs = mirror_map(layout) if args.symmetry == "mirror" else (None, None)
    from ..policies.heads import categorical_classes

    classes = categorical_classes() if args.head == "categorical" else None
    cell = "gru" if args.student == "gru" else None
    name = f"{'GRU' if cell else 'MLP'} student{' (categorical)' if classes is not None else ''}"
    student = GRUStudent(layout.size, args.gru_hidden, _net_arch(args.net_arch), signs=signs, seed=args.seed,
                         classes=classes, cell=cell, acting=args.head_acting,
                         feedback=args.feedback, obs_perm=obs_perm)
    kw = {"n_robots": args.bc_robots or None, "max_cycles": args.max_cycles or None, "gamma": args.gamma,
          "stall_steps": args.stall_steps, "shield": args.shield, "teacher": args.teacher, "sequences": True}
    fit = {"epochs": args.bc_epochs, "lr": args.bc_lr}

    def fit_on(demos, seed):
        return fit_sequences(student, fit_set(demos, args, layout).sequences, seed=seed, **fit)

    demos, info = _bc_dagger(args, scen, kw, fit_on, lambda: student.policy(layout), log, student=name, t0=t0)
    info = {"student": args.student, "head": args.head, **info}
    path = student.export(out / "policy", layout, scenario=args.scenario, shield=args.shield,
                          extra={"imitation": info, "args": dataclasses.asdict(args),
                                 "algorithm": f"BC+DAgger ({name})", "torch": torch.__version__})
    meta = {"args": dataclasses.asdict(args), "imitation": info, "minutes": (time.perf_counter() - t0) / 60}
    if args.eval_every:
        meta["final_eval"] = evaluate_policy_file(lambda env: load_policy(path, env), args, args.eval_episodes)
        log(f"the {name}'s file: arrived {meta['final_eval']['arrived']:.0%}, fell "
            f"{meta['final_eval']['fell']:.0%}")
    with atomic_path(out / "model.json") as tmp:
        Path(tmp).write_text(json.dumps(meta, indent=2))
    log(f"exported the policy {path} in {meta['minutes']:.1f} min (load_policy / --model {path})")
    return path


def _resumed(args: Args) -> tuple[Args, Path]:
    """For ``--resume DIR``: the run's saved arguments (all of them, each checked: the run continues
    as it was started; ``--trust-pickle`` is the one taken from this command) and ``DIR``.
    CheckpointError naming ``args.json`` and the key when one is unknown, missing or wrong."""
    from ..errors import CheckpointError
    from .args import option_name
    from .checkpoint import ARGS_FILE, read_args

    run = Path(args.resume)
    saved = read_args(run)
    p = run / ARGS_FILE
    known = {f.name for f in dataclasses.fields(Args)}
    for k in sorted(set(saved) - known):
        raise CheckpointError(f"{p}: key {k!r}: found an unknown argument, expected only the options of "
                              "tin-swarm train")
    for k in sorted(known - set(saved) - {"trust_pickle"}):
        raise CheckpointError(f"{p}: key {k!r}: found nothing (missing), expected the run's {option_name(k)}")
    for k in ("out_dir", "resume"):
        if not isinstance(saved[k], str):
            raise CheckpointError(f"{p}: key {k!r}: found {type(saved[k]).__name__}, expected a string")
    if saved["resume"]:
        raise CheckpointError(f"{p}: key 'resume': found {saved['resume']!r}, expected \"\" (a run's own arguments)")
    try:
        new = Args(**{**saved, "out_dir": str(run), "resume": "", "trust_pickle": args.trust_pickle})
        check_args(new)
    except ArgumentError as exc:
        raise CheckpointError(f"{p}: {exc}") from None
    return new, run


RUN_FILES = ("model.zip", "model.json", "eval.csv", "curve.png", "args.json")  # what a run directory holds
RUN_DIRS = ("policy", "policy_imitation", "checkpoints", "tb")


def check_run_outputs(args: Args, out: Path) -> None:
    """The run directory ``out`` (made if missing) and what train writes into it, checked against
    every file the run reads (its scenarios and the terrain files they name) before any work:
    :func:`~tin_swarm_env._atomic.check_outputs`."""
    from .._atomic import check_outputs

    if out.exists() and not out.is_dir():
        raise ArgumentError(f"--out-dir {out}: is a file; give a directory")
    out.mkdir(parents=True, exist_ok=True)
    check_outputs({f"--out-dir ({n})": out / n for n in RUN_FILES},
                  dirs={f"--out-dir ({n}/)": out / n for n in RUN_DIRS}, scenarios=scenarios_of(args))


def run_info(args: Args, layout, n_copies: int) -> dict:
    """What a checkpoint's network was built for (its ``state.json`` ``run``; a resume compares
    it key by key): scenario, robots, environment copies, observation layout, network."""
    info = {"scenario": args.scenario, "n_robots": args.n_robots, "n_copies": n_copies,
            "obs_size": int(layout.size), "layout": layout.to_dict(), "net_arch": _net_arch(args.net_arch),
            "policy": "recurrent" if args.recurrent else "mirror" if args.symmetry == "mirror" else "mlp",
            "lstm_hidden": args.lstm_hidden if args.recurrent else 0, "shield": args.shield}
    return json.loads(json.dumps(info))  # as it reads back from state.json (tuples as lists)


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
        args, resume_run = _resumed(args)
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
        imitation = imitate(model, args, layout=vec.envs[0].layout) if _imitating(args) else None
        if imitation is not None and args.total_timesteps:  # the imitation stage alone, before PPO changes it
            from ..adapters.sb3 import export_sb3_policy

            export_sb3_policy(model, out / "policy_imitation", vec, scenario=args.scenario, shield=args.shield,
                              extra={"imitation": imitation, "args": dataclasses.asdict(args), "stage": "imitation"})
        if imitation is not None and args.eval_every:
            row = _eval_row(model, args, rows, t0, 0)
            print(f"after imitation: arrived {row['arrived']:.0%}, fell {row['fell']:.0%} ({row['minutes']:.1f} min)")
        if imitation is not None:
            write_checkpoint(out, model, vec, extra(rows, args.eval_every if rows else 0))
    solved = bool(rows) and args.stop_at_arrival and rows[-1]["arrived"] >= args.stop_at_arrival
    remaining = args.total_timesteps - model.num_timesteps
    if remaining > 0 and not solved:
        model.learn(total_timesteps=remaining, callback=_callbacks(args, out, rows, t0, vec, extra, next_eval),
                    progress_bar=args.progress_bar and _has("rich", "tqdm"), reset_num_timesteps=ckpt is None)
    if not rows or rows[-1]["timesteps"] != model.num_timesteps:
        _eval_row(model, args, rows, t0, model.num_timesteps)
    _save(model, args, out, rows, t0, vec, imitation)
    vec.close()
    return out / "model.zip"


def _save(model, args: Args, out: Path, rows: list, t0: float, vec, imitation) -> None:
    """``model.zip``, ``policy/`` (pickle-free; recurrent for a recurrent model), ``model.json``,
    ``eval.csv``, ``curve.png``; prints where."""
    from .. import __version__
    from ..scenario import load_scenario

    from .._atomic import atomic_path

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
