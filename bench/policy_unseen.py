"""Learned policy files on terrain shapes the project has not seen: do they fall? The twelve shapes of
``bench/apf_unseen.py`` (built there, each as built and in its north-south mirror image; cliffs and
hillside too steep to drive across the straight way), played by each policy file for ``--seeds``
episodes of ``--robots`` robots, ``--steps`` steps. Writes ``docs/figures/policy_unseen.md``:

    python bench/policy_unseen.py --model shared=agents/models/shared --model ppo_puffer=agents/models/ppo_puffer
    python bench/policy_unseen.py --quick      # a smoke run (seconds): one shape, 1 seed of 4 robots; prints only
    [--seeds 5] [--robots 20] [--steps 1000] [--only u_pocket,spiral,...] [--out FILE]
    --model NAME=DIR#SHIELD                    # the file behind another shield (none, safety_cut, safety_cut_scan)

The question is the issue's "where it cannot find the way it stops on drivable ground": a robot that
fell drove onto ground too steep to hold it; one that timed out stopped or wandered on drivable ground.
APF and the map-knowing reference on the same shapes: ``docs/figures/apf_unseen.md``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.policies.learned import load_policy
from tin_swarm_env.training.policy_factory import policy_scenario
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
QUICK = {"only": ["u_pocket"], "seeds": 1, "robots": 4, "steps": 300}


def _load(name: str):
    """bench/<name>.py as a module (its shapes, load average): one definition of each."""
    mod = sys.modules.get(f"bench_{name}")
    if mod is None:
        spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[f"bench_{name}"] = mod  # dataclasses look their module up there
        spec.loader.exec_module(mod)
    return mod


unseen = _load("apf_unseen")


def play(path: str, cfg, seeds: int) -> dict:
    """Robots arrived, fallen and timed out (stopped or wandering on drivable ground) of the policy
    file ``path`` on scenario ``cfg`` over ``seeds`` episodes (seeds 0 ..)."""
    env = tse.parallel_env(scenario=policy_scenario(cfg, path))  # the policy's own observation layout
    reasons = np.concatenate([rollout(env, load_policy(path, env), s).reasons for s in range(seeds)])
    return {"n": len(reasons), "arrived": int(np.sum(reasons == Reason.ARRIVED)),
            "fell": int(np.sum(reasons == Reason.FELL)), "timed_out": int(np.sum(reasons == Reason.TIMEOUT)),
            "battery": int(np.sum(reasons == Reason.BATTERY))}


def _models(specs: list[str], p, folder) -> list[tuple[str, str]]:
    """``(name, policy dir)`` of each ``NAME=DIR`` or ``NAME=DIR#SHIELD`` (the file behind another
    shield: a copy with its ``"shield"`` replaced, in ``folder``)."""
    from tin_swarm_env.policies.network import SHIELDS

    out = []
    for s in specs:
        name, eq, path = s.partition("=")
        path, _, shield = path.partition("#")
        if not eq or not name or not Path(path, "policy.json").is_file() or (shield and shield not in SHIELDS):
            p.error(f"--model {s!r}: give NAME=DIR or NAME=DIR#SHIELD, DIR a policy directory (policy.json and "
                    f"weights.npz), SHIELD one of {list(SHIELDS)}")
        if shield:
            copy = Path(folder) / f"model_{name}"
            shutil.copytree(path, copy)
            meta = json.loads((copy / "policy.json").read_text())
            meta["shield"] = shield
            (copy / "policy.json").write_text(json.dumps(meta))
            path = str(copy)
        out.append((name, path))
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", action="append", default=[], metavar="NAME=DIR", help="a policy file (repeat)")
    p.add_argument("--seeds", type=unseen.apf._at_least(1), default=5, help="episodes per shape, image and policy")
    p.add_argument("--robots", type=unseen.apf._at_least(1), default=20, help="robots per episode")
    p.add_argument("--steps", type=unseen.apf._at_least(1), default=1000, help="steps per episode")
    p.add_argument("--only", type=lambda s: s.split(","), default=None, help="comma-separated shapes")
    p.add_argument("--quick", action="store_true", help=f"a smoke run ({QUICK}); prints only, unless --out is given")
    p.add_argument("--out", default=None, help="Markdown file (default docs/figures/policy_unseen.md; none with "
                                                "--quick)")
    args = p.parse_args(argv)
    if args.quick:
        args.only = args.only or QUICK["only"]
        for k in ("seeds", "robots", "steps"):
            setattr(args, k, min(getattr(args, k), QUICK[k]))
    shapes = args.only or list(unseen.SHAPES)
    bad = [s for s in shapes if s not in unseen.SHAPES]
    if bad:
        p.error(f"--only: unknown shape(s) {bad}; choose from {','.join(unseen.SHAPES)}")
    out = args.out if args.out is not None else (None if args.quick else
                                                 str(ROOT / "docs" / "figures" / "policy_unseen.md"))
    cmd = shlex.join(["python", "bench/policy_unseen.py", *argv])
    lines = [f"Written by `{cmd}` at commit {unseen._commit()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
             f"load average {unseen.apf._load()} at the start ({os.cpu_count()} cores, shared).", "",
             f"{args.seeds} x {args.robots} robots per shape, image and policy, {args.steps} steps; percentages of "
             "robots. timed out: stopped or wandering on drivable ground at the end (the safe way to fail). The "
             "shapes: `bench/apf_unseen.py`; APF's and the reference's rows: "
             "[APF on unseen shapes](figures.md#apf-on-terrain-shapes-the-project-has-not-seen).", "",
             "| policy | shape | image | arrived % | fell % | timed out % | battery % |",
             "|---|---|---|---:|---:|---:|---:|"]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="policy_unseen_") as folder:
        models = _models(args.model or ["shared=" + os.path.relpath(ROOT / "agents" / "models" / "shared")], p, folder)
        totals = {name: np.zeros(5, dtype=np.int64) for name, _ in models}
        for name, path in models:
            for shape in shapes:
                for image, label in unseen.IMAGES:
                    cfg = unseen.shape_config(shape, folder, image, args.robots, args.steps)
                    r = play(path, cfg, args.seeds)
                    totals[name] += [r["n"], r["arrived"], r["fell"], r["timed_out"], r["battery"]]
                    row = (f"| {name} | {shape} | {label} | {100 * r['arrived'] / r['n']:.1f} | "
                           f"{100 * r['fell'] / r['n']:.1f} | {100 * r['timed_out'] / r['n']:.1f} | "
                           f"{100 * r['battery'] / r['n']:.1f} |")
                    print(row, flush=True)
                    lines.append(row)
    lines += ["", "All shapes and images:", "", "| policy | robots | arrived % | fell % | timed out % | battery % |",
              "|---|---:|---:|---:|---:|---:|"]
    for name, (n, a, f, t, b) in totals.items():
        pct = " | ".join(f"{100 * k / n:.1f}" for k in (a, f, t, b))
        lines.append(f"| {name} | {n} | {pct} |")
    lines.append(f"\n{time.perf_counter() - t0:.0f} s; load average at the end: {unseen.apf._load()}.")
    print("\n".join(lines[-len(totals) - 3:]))
    if out:
        with atomic_path(out) as tmp:  # the whole file or nothing
            Path(tmp).write_text("\n".join(lines) + "\n")
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
