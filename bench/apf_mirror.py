"""APF on the generated families and their mirror images: the same held-out seeds played as built,
reflected east-west and reflected north-south (the terrain's ``mirror`` key,
:mod:`tin_swarm_env.scenario.mirror`), so a rule that prefers one side shows as a gap between rows.
Writes ``docs/figures/apf_mirror.md``:

    python bench/apf_mirror.py [--seeds 20] [--search bug,chart] [--k-scan 32] [--jobs 1] [--out FILE]
    python bench/apf_mirror.py --quick     # a smoke run (seconds): canyon, 1 seed of 4 robots, 100 steps; prints only

Each row: ``--seeds`` held-out seeds from ``EVAL_SEED0`` x the scenario's 20 robots, one
:func:`~tin_swarm_env.training.rollout.rollout` each (``max_cycles`` of the ``generated`` scenario);
stalled and looping as in :mod:`tin_swarm_env.training.trajectory`; one row per boundary search
(``APFPolicy(search=...)``) of ``--search``; ``--k-scan N`` gives the observation the terrain scan's
``N`` beams (``[observation] k_scan``); ``--jobs J`` runs the rows in J processes (the figures do not
depend on it; a row's seconds do, with the load).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import tin_swarm_env as tse
from tin_swarm_env import Reason
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout

ROOT = Path(__file__).resolve().parents[1]
FAMILIES = ("canyon", "mesa", "fork", "trap")
MIRRORS = (("", "as built"), ("ew", "east-west"), ("ns", "north-south"))


SEARCHES = ("bug", "chart")
QUICK = {"families": ("canyon",), "seeds": 1, "robots": 4, "max_cycles": 100}


def row(family: str, mirror: str, seeds: int, search: str = "chart", k_scan: int | None = None,
        robots: int | None = None, max_cycles: int | None = None) -> tuple[float, ...]:
    cfg = load_scenario("generated")
    cfg = cfg.replace(terrain=dataclasses.replace(cfg.terrain, families=(family,), mirror=mirror),
                      observation=dataclasses.replace(cfg.observation,
                                                      k_scan=cfg.observation.k_scan if k_scan is None else k_scan))
    env = tse.parallel_env(scenario=cfg, n_robots=robots, max_cycles=max_cycles)
    t = time.perf_counter()
    outs = [rollout(env, APFPolicy(env, search=search), sd) for sd in range(EVAL_SEED0, EVAL_SEED0 + seeds)]
    n = sum(o.n_robots for o in outs)
    return (sum(o.count(Reason.ARRIVED) for o in outs) / n, sum(o.count(Reason.FELL) for o in outs) / n,
            sum(int(o.stalled.sum()) for o in outs) / n, sum(int(o.looping.sum()) for o in outs) / n,
            time.perf_counter() - t)


def _row(job):
    return row(*job)


def _rows(jobs: list, n: int):
    """:func:`row` of every job, in order, in ``n`` processes (in this one for ``n = 1``)."""
    if n <= 1:
        yield from map(_row, jobs)
        return
    import multiprocessing

    with multiprocessing.get_context("fork").Pool(n) as pool:
        yield from pool.imap(_row, jobs, chunksize=1)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=20, help="held-out seeds per row (default 20)")
    p.add_argument("--search", type=lambda v: v.split(","), default=list(SEARCHES),
                   help="boundary searches, comma-separated (default bug,chart)")
    p.add_argument("--k-scan", type=int, default=None,
                   help="the observation's terrain scan beams (default: the default layout's, 32; 0: none)")
    p.add_argument("--jobs", type=int, default=1, help="processes, one row each at a time (default 1)")
    p.add_argument("--out", default=None, help="Markdown file (default docs/figures/apf_mirror.md; none with --quick)")
    p.add_argument("--quick", action="store_true", help=f"a smoke run (seconds): {QUICK}; prints only")
    a = p.parse_args(argv)
    families, robots, max_cycles = FAMILIES, None, None
    if a.quick:
        families, a.seeds, robots, max_cycles = QUICK["families"], 1, QUICK["robots"], QUICK["max_cycles"]
    if a.out is None and not a.quick:
        a.out = str(ROOT / "docs" / "figures" / "apf_mirror.md")
    if a.jobs < 1:
        p.error(f"--jobs must be >= 1, got {a.jobs}")
    if a.k_scan is not None and a.k_scan < 0:
        p.error(f"--k-scan must be >= 0, got {a.k_scan}")
    bad = [x for x in a.search if x not in SEARCHES]
    if bad:
        p.error(f"--search: unknown {bad}; choose from {','.join(SEARCHES)}")
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip() or "?"
    load = " / ".join(f"{x:.2f}" for x in os.getloadavg())
    cmd = shlex.join(["python", "bench/apf_mirror.py", *argv])  # quoted: the line can be run as it stands
    lines = [f"Measured with `{cmd}`" +
             f" at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {load} at "
             f"the start ({os.cpu_count()} cores).", "",
             f"APF, {a.seeds} held-out seeds x 20 robots per row, the same seeds as built and mirrored"
             + (f"; the observation with a {a.k_scan}-beam terrain scan." if a.k_scan else
                "; the default observation (its 32-beam terrain scan)." if a.k_scan is None else
                "; no terrain scan."), "",
             "| family | search | terrain | arrived | fell | stalled | looping | s |",
             "|---|---|---|---:|---:|---:|---:|---:|"]
    jobs = [(fam, mir, a.seeds, search, a.k_scan, robots, max_cycles)
            for fam in families for search in a.search for mir, _ in MIRRORS]
    for (fam, mir, _, search, *_), (ar, fe, st, lo, s) in zip(jobs, _rows(jobs, a.jobs)):
        lines.append(f"| {fam} | {search} | {dict(MIRRORS)[mir]} | {ar:.1%} | {fe:.1%} | {st:.1%} | {lo:.1%} "
                     f"| {s:.0f} |")
        print(lines[-1], flush=True)
    if not a.out:
        return 0
    out = Path(a.out)
    part = out.with_name(f".{out.name}.part")
    part.write_text("\n".join(lines) + "\n")
    os.replace(part, out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
