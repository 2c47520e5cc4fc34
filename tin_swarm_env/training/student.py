"""Imitation's rounds, shared by the MLP actor and the recurrent student: behaviour cloning on
episodes the teacher drove, then DAgger rounds in which the learner drives and the teacher labels
(:func:`bc_dagger`); and the student trained by imitation only (``--student gru`` or ``--head
categorical``: :func:`train_student`), exported as a policy file.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

from ..errors import require
from .config import Args, net_arch, scenarios_of
from .scoring import evaluate_policy_file

__all__ = ["fit_set", "bc_dagger", "train_student"]

def fit_set(demos, args: Args, layout):
    """What imitation fits on: ``demos``, and with ``--mirror-samples`` their mirror images too
    (:meth:`~tin_swarm_env.training.imitation.Demos.mirrored`)."""
    return demos + demos.mirrored(layout) if args.mirror_samples else demos

def bc_dagger(args: Args, scen, kw: dict, fit_on, learner, log, student: str = "", t0: float | None = None):
    """Imitation's rounds, for the MLP actor and the GRU student alike: behaviour cloning on
    ``--bc-episodes`` episodes the teacher drove, then ``--dagger-rounds`` rounds in which
    ``learner()`` drives ``--dagger-episodes`` episodes (the teacher drives each robot-step with
    probability ``beta ** (r + 1)``) and the fit is redone on every sample so far.
    ``fit_on(demos, seed) -> mse`` fits the student; ``kw`` goes to
    :func:`~tin_swarm_env.training.imitation.collect`. Returns ``(demos, info)`` (samples, MSEs, the
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

def train_student(args: Args, out: Path, log=print) -> Path:
    """``--student gru`` or ``--head categorical``: BC then DAgger of a GRU (or, ``--student mlp``,
    memoryless) student (:mod:`tin_swarm_env.training.recurrent_imitation`), with ``args`` (teacher, episodes, rounds,
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
    student = GRUStudent(layout.size, args.gru_hidden, net_arch(args.net_arch), signs=signs, seed=args.seed,
                         classes=classes, cell=cell, acting=args.head_acting,
                         feedback=args.feedback, obs_perm=obs_perm)
    kw = {"n_robots": args.bc_robots or None, "max_cycles": args.max_cycles or None, "gamma": args.gamma,
          "stall_steps": args.stall_steps, "shield": args.shield, "teacher": args.teacher, "sequences": True}
    fit = {"epochs": args.bc_epochs, "lr": args.bc_lr}

    def fit_on(demos, seed):
        return fit_sequences(student, fit_set(demos, args, layout).sequences, seed=seed, **fit)

    demos, info = bc_dagger(args, scen, kw, fit_on, lambda: student.policy(layout), log, student=name, t0=t0)
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
