"""What the students of research/train_multimodal.py do where the map-knowing teacher turns
(research/teacher_multimodal.md, "Where it fails"): the teacher (GeodesicPolicy) labels every live
robot-step, on held-out generated seeds, in two regimes:

* ``teacher`` drives: the states imitation trained on (the teacher's own trajectories);
* ``student`` drives: the states the student visits on its own (the numpy policy file, through its shield).

At the steps where the teacher turns (``|vy| > 0.5`` in its label) it prints the student's mean ``|vy|``
(the action before the shield), and for a categorical head the probability it gives the ``+y``
classes, the ``-y`` classes, straight on (``vy = 0``), and the side the teacher took; then the share of
such steps, and how often a robot's commanded side (sign of ``vy``, ignoring zeros) flips, per 100 steps.

    python research/diag_multimodal.py --scenario runs/eval_multimodal/cfg/gen_canyon.toml \\
        --models mlp_mse=runs/multimodal/mlp_mse/policy,gru_cat=runs/multimodal/gru_cat/policy

``--teacher apf_student`` labels with APF along the driven trajectory instead (tin_swarm_env/training/apf_teacher.py:
it is told each step's executed command); the last column then counts the steps at which it took the
student's side, per 100 robot-steps (the geodesic teacher: 0). The two columns before it count, the same way as
the student's side flips, the side of the teacher's label (sign of its ``vy``; for a categorical student the
label snapped to its head's nearest class, as the student only ever commands a class; the raw label's sign
changes far more often: research/teacher_multimodal.md, fifth run) and, for APF, the side its memory follows
(``BugMemory.side``, :func:`~tin_swarm_env.training.imitation.teacher_side`): with the teacher driving, APF's own
side flips per 100 steps beside the student's.
"""

from __future__ import annotations

import argparse

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.policies import load_policy
from tin_swarm_env.policies.heads import nearest_class, softmax
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.imitation import TEACHERS, make_teacher, teacher_side


def side_flips(side, last, live) -> tuple[int, np.ndarray]:
    """One step of the side-flip count: ``side`` ``(n,)`` this step's sides (-1, 0, +1), ``last`` each row's
    last non-zero side (0: none yet), ``live`` the rows that count. Returns the live rows whose side is
    non-zero and differs from a non-zero last side, and the updated ``last`` (a 0 keeps the last side)."""
    k = int(((side != 0) & (last != 0) & (side != last) & live).sum())
    return k, np.where(side != 0, side, last)


def run(env, pol, driver: str, seeds, steps: int, teacher: str = "geodesic") -> dict:
    teach = make_teacher(teacher, env)
    adopted = 0
    rows = []
    flips, live_steps = 0, 0
    t_flips, m_flips = 0, 0  # the teacher's label side and its memory's side (BugMemory.side), the same count
    for seed in seeds:
        obs = env.reset_arrays(seed=seed)
        pol.reset()
        teach.reset()
        last, last_t, last_m = np.zeros(env.n), np.zeros(env.n), np.zeros(env.n)
        for _ in range(steps):
            live = env.live_mask.copy()
            lab = teach.act_batch(obs)
            lab_c = lab if pol.head is None else pol.head.actions[nearest_class(lab, pol.head.actions)]
            k, last_t = side_flips(np.sign(lab_c[:, 1]), last_t, live)
            t_flips += k
            ms = teacher_side(teach, env.n)
            if ms is not None:
                k, last_m = side_flips(ms, last_m, live)
                m_flips += k
            if pol.head is not None:
                z = pol.logits(obs)
                z = z[0] if isinstance(z, tuple) else z
                p = softmax(z)
                vy = pol.head.actions[:, 1]
                a = pol.head.act(z).astype(np.float32)
                if hasattr(pol, "remember"):  # a file with feedback reads what it commanded (policies/recurrent.py)
                    pol.remember(a)
                mass = np.stack([p[:, vy > 0].sum(1), p[:, vy < 0].sum(1), p[:, vy == 0].sum(1)], 1)
            else:
                a = pol.net_batch(obs)
                mass = np.full((env.n, 3), np.nan)
            k, last = side_flips(np.sign(a[:, 1]), last, live)
            flips += k
            live_steps += int(live.sum())
            rows.append(np.column_stack([lab[:, 1], a[:, 1], mass])[live])
            act = lab if driver == "teacher" else (pol.shield_cut(a, obs) if pol.shield_cut is not None else a)
            if hasattr(teach, "driven"):  # APF along the driven trajectory: told what moved the robots
                adopted += int(teach.driven(act)[live].sum())
            obs, *_ = env.step_arrays(act)
            if not env.live_mask.any():
                break
    r = np.concatenate(rows)
    turn = np.abs(r[:, 0]) > 0.5
    t = r[turn]
    own = np.where(t[:, 0] > 0, t[:, 2], t[:, 3])
    return {"turning share": turn.mean(), "|vy| teacher": np.abs(t[:, 0]).mean(),
            "|vy| student": np.abs(t[:, 1]).mean(), "P(+y)": t[:, 2].mean(), "P(-y)": t[:, 3].mean(),
            "P(straight)": t[:, 4].mean(), "P(teacher's side)": own.mean(),
            "side flips /100 steps": 100 * flips / max(live_steps, 1),
            "teacher label side flips /100": 100 * t_flips / max(live_steps, 1),
            "teacher memory side flips /100": 100 * m_flips / max(live_steps, 1),
            "sides taken /100 steps": 100 * adopted / max(live_steps, 1), "robot-steps": len(r)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", required=True)
    ap.add_argument("--models", required=True, help="NAME=DIR,...")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--robots", type=int, default=20)
    ap.add_argument("--teacher", default="geodesic", choices=TEACHERS)
    a = ap.parse_args(argv)
    env = tse.parallel_env(scenario=a.scenario, n_robots=a.robots)
    seeds = range(EVAL_SEED0, EVAL_SEED0 + a.seeds)
    keys = None
    for spec in a.models.split(","):
        name, path = spec.split("=", 1)
        pol = load_policy(path, env)
        for driver in ("teacher", "student"):
            out = run(env, pol, driver, seeds, a.steps, a.teacher)
            if keys is None:
                keys = list(out)
                print("| student | driver | " + " | ".join(keys) + " |")
                print("|---|---|" + "---:|" * len(keys))
            print(f"| {name} | {driver} | " + " | ".join(f"{out[k]:.0f}" if k == "robot-steps" else f"{out[k]:.2f}"
                                                      for k in keys) + " |", flush=True)


if __name__ == "__main__":
    main()
