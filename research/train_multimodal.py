"""The multimodal-head experiment (research/teacher_multimodal.md): three students imitate the
map-knowing teacher (GeodesicPolicy) by BC + DAgger on the same data recipe, all mirror-equivariant
and shielded, differing only in the head and the memory:

    mlp_mse  an MLP whose output is the action, fitted by mean squared error (the control)
    mlp_cat  the same MLP with a categorical head (policies/heads.py), fitted by likelihood
    gru_cat  a GRU before that head (memory)

    nice -n 19 python research/train_multimodal.py --out runs/multimodal [--only mlp_cat,gru_cat]

The second run (``--recipe student``, variants ``*0`` and ``gru_fb``): DAgger with the student driving
every step (beta 0 after BC), no stall filter (the stuck states stay, labelled by the teacher), 4
rounds of 12 episodes, every file acting by a seeded draw ("sample") while it collects:

    mlp_cat0  mlp_cat on that recipe
    gru_cat0  gru_cat on that recipe
    gru_fb    gru_cat0 with the previous commanded action fed to the GRU (``--feedback action``)

    nice -n 19 python research/train_multimodal.py --recipe student --out runs/multimodal2

The third run (``--recipe apf``): the student recipe with APF as the teacher along the student's own
trajectory (``teacher="apf_student"``: tin_swarm_env/training/apf_teacher.py), so that the labels follow the
side the student took instead of the map's side:

    gru_apf        gru_fb taught by apf_student
    mlp_apf        mlp_cat0 taught by apf_student (no memory: the control for the GRU)
    gru_apf_plain  gru_fb taught by plain APF, whose odometry reads its own label and whose side never
                   follows the student (the control for the teacher)

    nice -n 19 python research/train_multimodal.py --recipe apf --out runs/multimodal3

The fourth run (``--recipe apf_chunk``): the third run's recipe, every fit now in pieces of 64 steps with
the state carried (truncated backpropagation, ``fit_sequences``' default ``chunk``: the whole-episode fits
of the first three runs underfit, research/diag_fit.py), 12 epochs per fit for both students:

    gru_apf4  gru_apf (GRU 64, previous action fed back) on this recipe
    mlp_apf4  mlp_apf (no memory) on this recipe

    nice -n 19 python research/train_multimodal.py --recipe apf_chunk --out runs/multimodal4

The fifth run (``--recipe apf_aux``): the fourth run's recipe, the GRU also fitted to APF's side
(``BugMemory.side``, recorded in each sequence's ``aux``) through a side read-out of its state, weighted
:data:`AUX_WEIGHTS` (``recurrent_imitation.AUX_WEIGHT`` per variant; the read-out is not in the file):

    gru_aux6  gru_apf4 with the side read-out
    gru_ctl6  gru_apf4 again (no read-out), the control trained in the same run with the same APF

    nice -n 19 python research/train_multimodal.py --recipe apf_aux --out runs/multimodal6

The first three recipes were fitted on whole episodes (``chunk`` 0, the default then): this script sets
:data:`~tin_swarm_env.training.recurrent_imitation.CHUNK` per recipe (:data:`CHUNKS`), so they run as they did.

Each writes ``OUT/<name>/policy`` (a pickle-free policy file) and ``OUT/<name>/model.json``
(:func:`tin_swarm_env.training.student.train_student`). Torch runs on 1 thread.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from tin_swarm_env.training import recurrent_imitation
from tin_swarm_env.training.config import Args
from tin_swarm_env.training.student import train_student

TRAIN = "agents/scenarios/train_generated.toml"  # the training families only (tests/training/test_held_out.py)
COMMON = dict(scenario=f"{TRAIN},{TRAIN},cliff_goal,ramp", bc_robots=8, teacher="geodesic", symmetry="mirror",
              shield="safety_cut", bc_episodes=32, dagger_rounds=2, dagger_episodes=16, dagger_beta=0.5,
              stall_steps=60, bc_lr=1e-3, net_arch="128,128", gamma=0.995, total_timesteps=0, eval_every=0,
              seed=0, torch_threads=1, progress_bar=False)
STUDENT_DRIVES = dict(dagger_rounds=4, dagger_episodes=12, dagger_beta=0.0, stall_steps=0, head_acting="sample")
RECIPES = {"mixed": (COMMON, ("mlp_mse", "mlp_cat", "gru_cat")),
           "student": ({**COMMON, **STUDENT_DRIVES}, ("gru_fb", "gru_cat0", "mlp_cat0")),
           "apf": ({**COMMON, **STUDENT_DRIVES, "teacher": "apf_student"}, ("gru_apf", "mlp_apf", "gru_apf_plain")),
           "apf_chunk": ({**COMMON, **STUDENT_DRIVES, "teacher": "apf_student"}, ("gru_apf4", "mlp_apf4")),
           "apf_aux": ({**COMMON, **STUDENT_DRIVES, "teacher": "apf_student"}, ("gru_aux6", "gru_ctl6"))}
CHUNKS = {"mixed": 0, "student": 0, "apf": 0, "apf_chunk": 64, "apf_aux": 64}  # fit_sequences' piece length
AUX_WEIGHTS = {"gru_aux6": 1.0}  # the side read-out's weight in the loss per variant (others: 0, no read-out)
VARIANTS = {
    "mlp_mse": dict(student="mlp", head="mean", bc_epochs=20),
    "mlp_cat": dict(student="mlp", head="categorical", bc_epochs=20),
    "gru_cat": dict(student="gru", head="categorical", bc_epochs=10, gru_hidden=64, net_arch="64"),
}
VARIANTS.update(mlp_cat0=VARIANTS["mlp_cat"], gru_cat0=VARIANTS["gru_cat"],
                gru_fb={**VARIANTS["gru_cat"], "feedback": "action"})
VARIANTS.update(gru_apf=VARIANTS["gru_fb"], mlp_apf=VARIANTS["mlp_cat"],
                gru_apf_plain={**VARIANTS["gru_fb"], "teacher": "apf"})
VARIANTS.update(gru_apf4={**VARIANTS["gru_fb"], "bc_epochs": 12}, mlp_apf4={**VARIANTS["mlp_cat"], "bc_epochs": 12})
VARIANTS.update(gru_aux6=VARIANTS["gru_apf4"], gru_ctl6=VARIANTS["gru_apf4"])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/multimodal")
    ap.add_argument("--recipe", default="mixed", choices=sorted(RECIPES))
    ap.add_argument("--only", default="", help="comma-separated variants to train (default: the recipe's)")
    a = ap.parse_args(argv)
    common, names = RECIPES[a.recipe]
    recurrent_imitation.CHUNK = CHUNKS[a.recipe]
    for name in [s for s in (a.only or ",".join(names)).split(",") if s]:
        if name not in names:
            raise SystemExit(f"--only: unknown variant {name!r} for --recipe {a.recipe}; known: {', '.join(names)}")
        t0 = time.perf_counter()
        out = Path(a.out) / name
        out.mkdir(parents=True, exist_ok=True)
        args = Args(**{**common, **VARIANTS[name], "out_dir": str(out)})
        recurrent_imitation.AUX_WEIGHT = AUX_WEIGHTS.get(name, 0.0)
        (out / "variant.json").write_text(json.dumps({"recipe": a.recipe, "chunk": recurrent_imitation.CHUNK,
                                                      "aux_weight": recurrent_imitation.AUX_WEIGHT}) + "\n")
        train_student(args, out, log=lambda m, n=name: print(f"[{n}] {m}", flush=True))
        print(f"[{name}] {(time.perf_counter() - t0) / 60:.1f} min", flush=True)


if __name__ == "__main__":
    main()
