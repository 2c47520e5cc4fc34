"""The configuration of a training run: :class:`Args` (every option of ``tin-swarm train`` and
``agents/train_sb3.py``, its help and what it accepts, declared once with
:func:`~tin_swarm_env.options.opt`), the checks across options (:func:`check_args`), the run
directory and what it holds, and the arguments a resumed run continues with.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

from ..errors import ArgumentError
from ..options import check_args as check_fields
from ..options import opt
from ..policies.heads import ACTINGS
from ..policies.learned import SHIELDS
from ..policies.symmetry import SYMMETRIES
from ..scenario.config import MAX_ROBOTS
from .evaluation import EVAL_SEED0
from .imitation import TEACHERS

__all__ = ["Args", "STUDENTS", "check_args", "scenarios_of", "imitating", "run_dir", "net_arch", "resumed",
           "RUN_FILES", "RUN_DIRS", "check_run_outputs", "run_info"]

STUDENTS = ("mlp", "gru")  # --student: what imitation fits (training/imitation.py, training/recurrent_imitation.py)

def net_arch(spec: str) -> list[int]:
    """``"64,64"`` -> ``[64, 64]``: hidden layer widths, each 1..MAX_LAYER_WIDTH (the policy file's limit)."""
    from ..policies.learned import MAX_LAYER_WIDTH, MAX_LAYERS

    parts = [p.strip() for p in str(spec).split(",") if p.strip()]
    if not parts or not all(p.isdigit() and 1 <= int(p) <= MAX_LAYER_WIDTH for p in parts) or len(parts) >= MAX_LAYERS:
        raise ArgumentError(f"--net-arch {spec!r}: give hidden layer widths separated by commas (e.g. 64,64), "
                            f"each 1..{MAX_LAYER_WIDTH}, at most {MAX_LAYERS - 1} layers")
    return [int(p) for p in parts]

def _arch_msg(spec):
    try:
        net_arch(spec)
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
                       "student, imitation only: --timesteps 0; training/recurrent_imitation.py)", choices=STUDENTS)
    head: str = opt("mean", "the action head: mean (MSE fit) or categorical (class actions, likelihood fit, "
                    "imitation only; policies/heads.py)", choices=("mean", "categorical"))
    head_acting: str = opt("mode", "--head categorical: how the file acts: mode, side (the likelier side, then its "
                           "mode) or sample (a seeded per-robot draw); policies/heads.py", choices=ACTINGS)
    feedback: str = opt("none", "--student gru: action feeds the GRU the action it commanded at the previous step "
                        "(policies/recurrent.py), so a sampled side can be kept", choices=("none", "action"))
    gru_hidden: int = opt(64, "--student gru: GRU units (--net-arch: the head after it)", lo=1, hi=1024)
    bc_episodes: int = opt(0, "behaviour cloning: teacher-driven episodes (0: no imitation)", **_NONNEG)
    teacher: str = opt("apf", "imitation's teacher: apf, geodesic (knows the map; the student sees only the "
                       "observation), or apf_student (APF along the student's trajectory: training/apf_teacher.py)",
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

def imitating(args: Args) -> bool:
    return args.bc_episodes > 0

def run_dir(args: Args) -> Path:
    """``args.out_dir``, or ``runs/<algo>_<scenarios>_s<seed>`` (a path's stem for a TOML file)."""
    if args.out_dir:
        return Path(args.out_dir)
    algo = ("rppo" if args.recurrent else "bc_gru" if args.student == "gru" else
            "bc_ppo" if imitating(args) and args.total_timesteps else "bc" if imitating(args) else "ppo")
    return Path("runs") / f"{algo}_{'+'.join(Path(s).stem for s in scenarios_of(args))}_s{args.seed}"

def check_args(args: Args) -> None:
    """Refuse arguments that would train nothing or cannot be combined (naming the option; each
    option's own range is checked by ``Args`` itself)."""
    check_fields(args)  # again: fields may have been changed after construction
    if args.total_timesteps == 0 and not imitating(args):
        raise ArgumentError("--timesteps 0 without imitation would save an untrained model; give a positive "
                            "--timesteps, or --bc-episodes N to train by imitation only")
    if args.dagger_rounds and not imitating(args):
        raise ArgumentError("--dagger-rounds needs --bc-episodes (DAgger starts from a cloned policy)")
    if not 0.0 <= args.dagger_beta < 1.0:
        raise ArgumentError(f"--dagger-beta must be in [0, 1), got {args.dagger_beta}")
    if args.teacher == "geodesic" and args.mirror_samples:
        raise ArgumentError("--mirror-samples cannot be combined with --teacher geodesic: a mirrored label is the "
                            "map-knowing teacher's action on a mirror-image map nobody ran (training/imitation.py); "
                            "use --symmetry mirror (a mirror-equivariant student) instead")
    if args.head == "categorical":
        if not imitating(args) or args.total_timesteps:
            raise ArgumentError("--head categorical learns by imitation only: give --bc-episodes N and --timesteps 0")
        if args.recurrent:
            raise ArgumentError("--head categorical cannot be combined with --recurrent (RecurrentPPO's LSTM)")
    if args.head != "categorical" and args.head_acting != "mode":
        raise ArgumentError(f"--head-acting {args.head_acting} is for --head categorical (a mean head has one action "
                            "per observation)")
    if args.feedback != "none" and args.student != "gru":
        raise ArgumentError(f"--feedback {args.feedback} needs --student gru (a memoryless MLP has no previous step)")
    if args.student == "gru":
        if not imitating(args):
            raise ArgumentError("--student gru learns by imitation: give --bc-episodes N")
        if args.total_timesteps:
            raise ArgumentError("--student gru has no PPO stage: give --timesteps 0 (imitation only)")
        if args.recurrent:
            raise ArgumentError("--student gru cannot be combined with --recurrent (RecurrentPPO's LSTM)")
    if args.recurrent and imitating(args):
        raise ArgumentError("--recurrent cannot be combined with --bc-episodes (imitation fits an MLP actor)")
    if args.batch_size > args.n_steps * args.n_robots * args.n_envs * len(scenarios_of(args)) and args.total_timesteps:
        raise ArgumentError(f"--batch-size {args.batch_size} is more than one rollout holds (--n-steps x robots x "
                            f"copies = {args.n_steps * args.n_robots * args.n_envs * len(scenarios_of(args))})")
    if args.symmetry != "none" and args.recurrent:
        raise ArgumentError("--symmetry mirror is for the MLP policy; RecurrentPPO has no mirror-equivariant "
                            "policy here")

def resumed(args: Args) -> tuple[Args, Path]:
    """For ``--resume DIR``: the run's saved arguments (all of them, each checked: the run continues
    as it was started; ``--trust-pickle`` is the one taken from this command) and ``DIR``.
    CheckpointError naming ``args.json`` and the key when one is unknown, missing or wrong."""
    from ..errors import CheckpointError
    from ..options import option_name
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
            "obs_size": int(layout.size), "layout": layout.to_dict(), "net_arch": net_arch(args.net_arch),
            "policy": "recurrent" if args.recurrent else "mirror" if args.symmetry == "mirror" else "mlp",
            "lstm_hidden": args.lstm_hidden if args.recurrent else 0, "shield": args.shield}
    return json.loads(json.dumps(info))  # as it reads back from state.json (tuples as lists)
