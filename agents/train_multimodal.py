"""The multimodal-head experiment (docs/figures/teacher_multimodal.md): three students imitate the
map-knowing teacher (GeodesicPolicy) by BC + DAgger on the same data recipe, all mirror-equivariant
and shielded, differing only in the head and the memory:

    mlp_mse  an MLP whose output is the action, fitted by mean squared error (the control)
    mlp_cat  the same MLP with a categorical head (policies/heads.py), fitted by likelihood
    gru_cat  a GRU before that head (memory)

    nice -n 19 python agents/train_multimodal.py --out runs/multimodal [--only mlp_cat,gru_cat]

Each writes ``OUT/<name>/policy`` (a pickle-free policy file) and ``OUT/<name>/model.json``
(:func:`tin_swarm_env.apps.train.train_student`). Torch runs on 1 thread.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from tin_swarm_env.apps.train import Args, train_student

COMMON = dict(scenario="generated,generated,cliff_goal,ramp", bc_robots=8, teacher="geodesic", symmetry="mirror",
              shield="safety_cut", bc_episodes=32, dagger_rounds=2, dagger_episodes=16, dagger_beta=0.5,
              stall_steps=60, bc_lr=1e-3, net_arch="128,128", gamma=0.995, total_timesteps=0, eval_every=0,
              seed=0, torch_threads=1, progress_bar=False)
VARIANTS = {
    "mlp_mse": dict(student="mlp", head="mean", bc_epochs=20),
    "mlp_cat": dict(student="mlp", head="categorical", bc_epochs=20),
    "gru_cat": dict(student="gru", head="categorical", bc_epochs=10, gru_hidden=64, net_arch="64"),
}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/multimodal")
    ap.add_argument("--only", default=",".join(VARIANTS), help="comma-separated variants to train")
    a = ap.parse_args(argv)
    for name in [s for s in a.only.split(",") if s]:
        if name not in VARIANTS:
            raise SystemExit(f"--only: unknown variant {name!r}; known: {', '.join(VARIANTS)}")
        t0 = time.perf_counter()
        out = Path(a.out) / name
        out.mkdir(parents=True, exist_ok=True)
        args = Args(**{**COMMON, **VARIANTS[name], "out_dir": str(out)})
        train_student(args, out, log=lambda m, n=name: print(f"[{n}] {m}", flush=True))
        print(f"[{name}] {(time.perf_counter() - t0) / 60:.1f} min", flush=True)


if __name__ == "__main__":
    main()
