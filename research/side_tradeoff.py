"""The side preference's trade: the default APF's ``ChartParams.side_cost`` against two of #44's bars at once,
the generated fork family (>= 97% arrived) and jacksboro by 1 800 steps (>= 80%), and the chart's other
constants (``--chart``) against those and a third, the realdem family (>= 90%). Run by hand:

    python research/side_tradeoff.py --jobs 2      # about 20 min on two cores; writes research/side_tradeoff.md
    [--side-costs 0,0.6,0.75] [--fork-sets 0,100,200] [--seeds 50] [--jacksboro-seeds 5] [--out FILE]
    [--side-leave 60]    # every run with ChartParams.side_leave_m = 60 (a robot leaves its side at a dead end)
    [--chart min_cell_m=3]    # every run with these ChartParams (KEY=VALUE, comma-separated)
    [--realdem-sets 0,100]    # the realdem family too (bar: >= 90%), on these held-out sets

    python research/side_tradeoff.py --trace 1000129 --chart min_cell_m=3   # a picture: the tracks of one fork seed

For each ``side_cost`` (every other chart constant at its default): fork, 20 robots on each of ``--seeds``
held-out seeds from ``EVAL_SEED0 + offset`` for each offset of ``--fork-sets`` (the held-out sets of
``bench/apf.py --seed-offset``), its episodes of the family's length (1 000 steps); and jacksboro, its 200
robots on seeds ``0..--jacksboro-seeds - 1``, given 1 800 steps, scored at 900 and at 1 800. Per row: the
share arrived (per set and pooled), the robots fallen, and the seeds that lost the most robots; with
``--realdem-sets``, the ``realdem`` family on those held-out sets the same way (20 robots a seed, its episodes of
the family's length), the third bar the chart's constants trade against. A robot's
side is fixed by its index (:func:`~tin_swarm_env.policies.chart.robot_side`), so the runs are
deterministic and do not depend on ``--jobs``.

    python research/side_tradeoff.py --ideal-seeds 1000112,1000202 --jobs 2   # writes side_tradeoff_ideal.md

runs instead the idealised map-less robot of ``research/sensing_bound.py`` (perfect memory, top speed, no
turning, no other robots, no side preference; every unsafe cell within 60 m through hills, a 1 m raster) on
those fork seeds: how soon a robot that reads only its sensor can bring that seed's robots in.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import shlex
import subprocess
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.chart import ChartParams
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
JACKSBORO_STEPS = (900, 1800)  # jacksboro's episode length and the #44 bar's longer horizon


def _apf_bench():
    mod = sys.modules.get("bench_apf")
    if mod is None:
        spec = importlib.util.spec_from_file_location("bench_apf", ROOT / "bench" / "apf.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules["bench_apf"] = mod
        spec.loader.exec_module(mod)
    return mod


def episode(job) -> tuple:
    """``job``: (terrain, side_cost, seed, robots, max_cycles, side_leave_m[, chart]): ``(job, robots, arrived
    by each step of JACKSBORO_STEPS (fork, realdem: by its episode's end, twice), fell)`` of one APF episode.
    ``robots``/``max_cycles`` None: the scenario's own; ``chart``: more ``ChartParams`` as ``(key, value)``
    pairs."""
    terrain, side_cost, seed, robots, max_cycles, side_leave = job[:6]
    chart = dict(job[6]) if len(job) > 6 else {}
    if terrain == "jacksboro":
        env = tse.parallel_env(scenario="jacksboro", n_robots=robots, max_cycles=max_cycles)
    else:
        env = _apf_bench().generated_family(terrain, robots, max_cycles)
    params = ChartParams(side_cost=side_cost, side_leave_m=side_leave, **chart)
    out = rollout(env, APFPolicy(env, chart=params), seed)
    by = arrived_by(out, JACKSBORO_STEPS) if terrain == "jacksboro" else [out.count(Reason.ARRIVED)] * 2
    return job, out.n_robots, by, out.count(Reason.FELL)


def arrived_by(out, checkpoints) -> list[int]:
    """Robots of ``out`` (an :class:`~tin_swarm_env.training.rollout.Outcome`) arrived by each step of
    ``checkpoints`` (one that arrives on step ``s`` counts by ``s``)."""
    got = out.reasons == Reason.ARRIVED
    return [int(np.sum(got & (out.steps <= s))) for s in checkpoints]


def ideal_row(seed: int, res: float = 1.0) -> str:
    """The idealised map-less robot of ``research/sensing_bound.py`` (``disk`` sensing, a ``res`` m raster)
    on fork seed ``seed``: a Markdown row of its arrival steps (median, max) and how many are in by the
    episode's end."""
    import sensing_bound as BOUND  # research/ is on the path: the script's own folder

    env = BOUND._generated_env("fork")
    env.reset(seed=seed)
    b = env.unwrapped
    steps = np.array([r[0] for r in BOUND.ideal_robots(env, range(b.n), "disk", 0, res)])
    return (f"| {seed} | {np.median(steps):.0f} | {steps.max()} | {int(np.sum(steps <= b.max_cycles))} of {b.n} "
            f"| {b.max_cycles} |")


def trace_figure(seed: int, charts, out, robots=None, cycles=None) -> list[int]:
    """A picture of fork seed ``seed``: one panel per ``charts`` entry (``(label, ChartParams kwargs)``), every
    robot's track over the terrain, red for the robots that prefer the right side, blue the left
    (:func:`~tin_swarm_env.policies.chart.robot_side`), a dot where each started and a cross where each
    that did not arrive ended. Written to ``out`` (PNG); returns each panel's robots arrived."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tin_swarm_env.policies.chart import robot_side

    fig, axes = plt.subplots(1, len(charts), figsize=(6.5 * len(charts), 6.5), squeeze=False)
    got = []
    for ax, (label, kw) in zip(axes[0], charts):
        env = _apf_bench().generated_family("fork", robots, cycles)
        track = []
        o = rollout(env, APFPolicy(env, chart=ChartParams(**kw)), seed,
                    on_step=lambda e, _r: track.append(e.world_state.positions.copy()))
        P = np.array(track)
        t = env.unwrapped.tin
        ax.tripcolor(t.vertices[:, 0], t.vertices[:, 1], t.triangles, t.vertices[:, 2], cmap="terrain",
                     shading="gouraud")
        for i in range(P.shape[1]):
            ax.plot(P[:, i, 0], P[:, i, 1], "-", lw=0.7, color="r" if robot_side(i) > 0 else "b")
        lost = o.reasons != Reason.ARRIVED
        ax.plot(P[0, :, 0], P[0, :, 1], "k.", ms=4)
        ax.plot(P[-1, lost, 0], P[-1, lost, 1], "kx", ms=6)
        got.append(o.count(Reason.ARRIVED))
        ax.set_title(f"fork seed {seed}, {label}: {got[-1]} of {o.n_robots} in")
        ax.set_aspect("equal")
    fig.tight_layout()
    with atomic_path(out) as tmp:
        fig.savefig(tmp, dpi=70, format="png")
    plt.close(fig)
    return got


def jobs_for(side_costs, fork_sets, seeds, jacksboro_seeds, robots=None, cycles=None, side_leave=0.0,
             realdem_sets=(), chart=()) -> list:
    """Every episode of the study (``robots``/``cycles``: override the scenarios' own, for tests;
    ``side_leave``: ``ChartParams.side_leave_m`` of every run; ``realdem_sets``: the realdem family's
    held-out sets, as ``fork_sets``; ``chart``: more ``ChartParams`` of every run, ``(key, value)`` pairs)."""
    chart = tuple(chart)
    out = []
    for sc in side_costs:
        out += [(fam, sc, EVAL_SEED0 + off + s, robots, cycles, side_leave, chart)
                for fam, sets in (("fork", fork_sets), ("realdem", realdem_sets)) for off in sets for s in range(seeds)]
        out += [("jacksboro", sc, s, robots, cycles or JACKSBORO_STEPS[-1], side_leave, chart)
                for s in range(jacksboro_seeds)]
    return out


def _family_cells(rows, family, sets, seeds) -> tuple[str, str, str]:
    """``(arrived per set, pooled, seeds that lost most)`` of ``family``'s episodes among ``rows``."""
    fk = [r for r in rows if r[0][0] == family]
    per_set = []
    for off in sets:
        s = [r for r in fk if EVAL_SEED0 + off <= r[0][2] < EVAL_SEED0 + off + seeds]
        per_set.append(100 * sum(r[2][0] for r in s) / max(sum(r[1] for r in s), 1))
    pooled = 100 * sum(r[2][0] for r in fk) / max(sum(r[1] for r in fk), 1)
    worst = sorted(((r[1] - r[2][0], r[0][2]) for r in fk if r[2][0] < r[1]), reverse=True)[:4]
    return (" / ".join(f"{x:.1f}%" for x in per_set), f"{pooled:.1f}%",
            ", ".join(f"{s} ({n} lost)" for n, s in worst) or "-")


def table(results, side_costs, fork_sets, seeds, realdem_sets=()) -> list[str]:
    """The Markdown rows of ``results`` (:func:`episode`'s tuples); realdem's three columns where
    ``realdem_sets`` are given."""
    def named(sets):
        return ", ".join(f"{EVAL_SEED0 + o}-{EVAL_SEED0 + o + seeds - 1}" for o in sets)

    real = (f" realdem: arrived per set ({named(realdem_sets)}) | realdem, pooled | realdem: seeds that lost most |"
            if realdem_sets else "")
    lines = [f"| side_cost | fork: arrived per set ({named(fork_sets)}) | fork, pooled | fork: seeds that lost most |"
             f"{real} jacksboro: by 900 | by 1 800 (per seed) | robots fell (every run) |",
             "|---:|---|---:|---|" + ("---|---:|---|" if realdem_sets else "") + "---:|---|---:|"]
    for sc in side_costs:
        rows = [r for r in results if r[0][1] == sc]
        cells = list(_family_cells(rows, "fork", fork_sets, seeds))
        if realdem_sets:
            cells += _family_cells(rows, "realdem", realdem_sets, seeds)
        jb = sorted((r for r in rows if r[0][0] == "jacksboro"), key=lambda r: r[0][2])
        n_jb = max(sum(r[1] for r in jb), 1)
        by900 = 100 * sum(r[2][0] for r in jb) / n_jb
        seeds1800 = " / ".join(f"{100 * r[2][1] / r[1]:.1f}" for r in jb)
        fell = sum(r[3] for r in rows)
        lines.append(f"| {sc:g} | {' | '.join(cells)} | {by900:.1f}% | {seeds1800} | {fell} |")
    return lines


def _at_least_1(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def _floats(text: str) -> list[float]:
    try:
        out = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected numbers separated by commas") from None
    if not out or any(not np.isfinite(x) or x < 0 for x in out):
        raise argparse.ArgumentTypeError(f"{text!r}: expected finite numbers >= 0")
    return out


def _offsets(text: str) -> list[int]:
    try:
        out = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected whole numbers separated by commas") from None
    if not out or min(out) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected offsets >= 0")
    return out


def _chart_items(text: str) -> tuple:
    """``--chart``'s ``KEY=VALUE[,KEY=VALUE]``: ``ChartParams`` fields (not ``side_cost``/``side_leave_m``,
    which have their own options) as ``(key, value)`` pairs, checked by building the params."""
    fields = {f.name: f for f in dataclasses.fields(ChartParams)}
    out = []
    for part in text.split(","):
        key, eq, val = part.partition("=")
        key = key.strip()
        if not eq or key not in fields or key in ("side_cost", "side_leave_m"):
            raise argparse.ArgumentTypeError(f"{part!r}: expected KEY=VALUE with KEY a ChartParams field other than "
                                             "side_cost and side_leave_m")
        try:
            v = int(val) if isinstance(fields[key].default, int) else float(val)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{part!r}: {key} expects a number") from None
        out.append((key, v))
    try:
        ChartParams(**dict(out))
    except Exception as exc:  # noqa: BLE001 - ParameterError names the field and the bound
        raise argparse.ArgumentTypeError(str(exc)) from None
    return tuple(out)


def main(argv=None) -> list[str]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--side-costs", type=_floats, default=[0.0, 0.6, 0.75], help="side_cost values, comma-separated")
    p.add_argument("--fork-sets", type=_offsets, default=[0, 100, 200], help="held-out seed offsets for fork")
    p.add_argument("--seeds", type=_at_least_1, default=50, help="fork seeds per set")
    p.add_argument("--jacksboro-seeds", type=_at_least_1, default=5)
    p.add_argument("--jobs", type=_at_least_1, default=1, help="processes (results do not depend on it)")
    p.add_argument("--side-leave", type=float, default=0.0, metavar="M",
                   help="ChartParams.side_leave_m of every run (default 0: a robot keeps its side)")
    p.add_argument("--chart", type=_chart_items, default=(), metavar="KEY=VALUE,...",
                   help="more ChartParams of every run (e.g. min_cell_m=3)")
    p.add_argument("--realdem-sets", type=_offsets, default=[], metavar="O,O,...",
                   help="held-out seed offsets for the realdem family (default: none)")
    p.add_argument("--trace", type=_offsets, default=None, metavar="SEED",
                   help="instead of the study: a picture of this fork seed's tracks, the default chart beside\n"
                        "--chart's (--out then defaults to research/figures/side_tradeoff_SEED.png)")
    p.add_argument("--ideal-seeds", type=_offsets, default=None, metavar="S,S,...",
                   help="instead of the study: the idealised map-less robot on these fork seeds (--out then\n"
                        "defaults to research/side_tradeoff_ideal.md)")
    p.add_argument("--out", default=None, help="default research/side_tradeoff.md")
    args = p.parse_args(argv)
    if args.trace is not None:
        if len(args.trace) != 1 or not args.chart:
            p.error("--trace: expected one fork seed, and --chart to set beside the default chart")
        seed = args.trace[0]
        out = args.out or str(ROOT / "research" / "figures" / f"side_tradeoff_{seed}.png")
        label = ", ".join(f"{k}={v:g}" for k, v in args.chart)
        got = trace_figure(seed, [("default chart", {}), (label, dict(args.chart))], out)
        print(f"{out}: arrived {got[0]} (default chart) and {got[1]} ({label})")
        return [out]
    name = "side_tradeoff_ideal.md" if args.ideal_seeds else "side_tradeoff.md"
    args.out = args.out or str(ROOT / "research" / name)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip() or "?"
    load0, t0 = " / ".join(f"{v:.2f}" for v in os.getloadavg()), time.time()
    if args.ideal_seeds:
        title = "The idealised map-less robot on fork's seeds that APF loses half of"
        with Pool(args.jobs) as pool:
            body = ["| seed | arrival step: median | max | in by the episode's end | episode |",
                    "|---:|---:|---:|---:|---:|", *pool.map(ideal_row, args.ideal_seeds, chunksize=1)]
    else:
        title = ("The chart search's trade: fork against realdem and jacksboro" if args.realdem_sets
                 else "The side preference's trade: fork against jacksboro")
        if args.chart:
            title += ", with " + ", ".join(f"{k} = {v:g}" for k, v in args.chart)
        if not (np.isfinite(args.side_leave) and args.side_leave >= 0):
            p.error(f"--side-leave: expected a finite number >= 0, got {args.side_leave}")
        jobs = jobs_for(args.side_costs, args.fork_sets, args.seeds, args.jacksboro_seeds, side_leave=args.side_leave,
                        realdem_sets=args.realdem_sets, chart=args.chart)
        with Pool(args.jobs) as pool:
            body = table(pool.map(episode, jobs, chunksize=1), args.side_costs, args.fork_sets, args.seeds,
                         args.realdem_sets)
    cmd = shlex.join(["python", "research/side_tradeoff.py", *(sys.argv[1:] if argv is None else argv)])
    lines = [f"Written by `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
             f"{(time.time() - t0) / 60:.0f} min, load average {load0} at the start ({os.cpu_count()} cores, "
             "shared).", "", *body]
    print("\n".join(lines))
    with atomic_path(args.out) as tmp:
        Path(tmp).write_text(f"# {title}\n\n" + "\n".join(lines) + "\n")
    return lines


if __name__ == "__main__":
    main()
