"""APF against its references, in one run: arrived / fell / timed out, and of the timed out the
stalled and looping robots (:mod:`tin_swarm_env.training.trajectory`), contacts per robot. By hand:

    python bench/apf.py                # the full run; writes the tables to docs/figures/apf.md
    python bench/apf.py --quick        # a smoke run (seconds): cliff_goal and one generated family, 1 seed of
                                       # 4 robots, 150-step generated episodes; prints only
    python bench/apf.py --horizon      # also: steps to arrive, APF against GeodesicPolicy, per terrain,
                                       # and jacksboro's horizon analysis
    [--seeds 5] [--robots N] [--jacksboro-seeds 5] [--generated 50] [--only cliff_goal,...] [--out FILE]
    [--jobs 2] [--seed-offset 100] [--max-cycles 3000]   # another held-out set, a longer episode
    [--k-scan 0]                       # every row's observation with that many scan beams (default: as it is, 32)

Policies: the APF baseline with all its fields (its default search, the chart search, on the default
observation with the terrain scan), APF with the bug search (the default before: a weaker baseline), the
APF without the break field (the thesis's "poor ending": falls), :class:`~tin_swarm_env.policies.GeodesicPolicy` (knows the map: an upper
bound, not a baseline) and uniform random actions. Terrains: every built-in goal scenario
(``jacksboro`` with its 200 robots and 900 steps), the DEM-file scenarios ``scenarios/canyon_left.toml``,
``canyon_right.toml`` and ``valley.toml``, the four canyon terrains of
``tests/helpers/canyons.py`` (pass left or right, travelling east or west) and, with ``--generated K``
(default 50, 0 leaves them out), one row per generated family (:data:`ALL_FAMILIES`, then ``realdem``) over K
held-out seeds (``EVAL_SEED0`` on, never used in training), APF and GeodesicPolicy only. A
terrain whose env cannot be built is reported as a skipped row with the error.
``containment`` has no arrival: its rows give the mean distance to the assigned threat over the
standoff (1.00 = on the ring) and contacts per robot.
Every episode runs through :func:`~tin_swarm_env.training.rollout.rollout`. After the table: the APF
robots that timed out saying their target is unreachable, and how many of them the map reaches
(false verdicts).
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

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.policies import APFPolicy, GeodesicPolicy, RandomPolicy
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.generators import ALL_FAMILIES, REAL_FAMILIES
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "helpers"))
from canyons import VARIANTS, canyon_config  # noqa: E402

POLICIES = {
    "apf": lambda env: APFPolicy(env),  # the default: the chart search
    "apf, bug search": lambda env: APFPolicy(env, search="bug"),  # the default before the chart search
    "apf, no break field": lambda env: APFPolicy(env, fields=("robot", "target", "height")),
    "geodesic (knows the map)": lambda env: GeodesicPolicy(env),
    "random": lambda env: RandomPolicy(env, seed=0),
}
GENERATED_POLICIES = ("apf", "apf, bug search", "geodesic (knows the map)")  # the generated rows: the baseline
# with either boundary search, and the bound
GOAL_SCENARIOS = ("cliff_goal", "ramp", "hill", "flat", "jacksboro")
FILE_SCENARIOS = ("canyon_left", "canyon_right", "valley")  # scenarios/<name>.toml, the thesis's DEM-file maps
SEARCHES = ("bug", "chart")  # APFPolicy's boundary searches (policies/bug.py, policies/chart.py)
QUICK = {"seeds": 1, "generated": 1, "jacksboro_seeds": 1, "robots": 4, "max_cycles": 150}  # upper bounds
QUICK_ROWS = ["cliff_goal", "generated: canyon"]  # --quick's rows unless --only names others


@dataclasses.dataclass
class Row:
    """One terrain: its label, an env factory, the seeds and the policies it runs."""

    label: str
    make: object
    seeds: range
    policies: tuple = tuple(POLICIES)


def generated_family(family: str, robots: int | None, max_cycles: int | None = None, k_scan: int | None = None):
    """The built-in ``generated`` scenario restricted to one family (``max_cycles``: its episode
    length, default the scenario's; ``k_scan``: see :func:`scanned`)."""
    cfg = load_scenario("generated")
    cfg = cfg.with_families((family,))
    return tse.parallel_env(scenario=scanned(cfg, k_scan), n_robots=robots, max_cycles=max_cycles)


def scanned(cfg, k_scan: int | None):
    """``cfg`` (a scenario name, file or config) with ``[observation] k_scan`` set (None: as it is, the
    default layout's 32 beams; 0: no scan)."""
    cfg = cfg if not isinstance(cfg, str) else load_scenario(cfg)
    return cfg if k_scan is None else cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=k_scan))


def _rows(args) -> list[Row]:
    out = []
    for s in GOAL_SCENARIOS:
        n = None if s == "jacksboro" else args.robots
        seeds = range(args.jacksboro_seeds if s == "jacksboro" else args.seeds)
        out.append(Row(s, lambda s=s, n=n: tse.parallel_env(scenario=scanned(s, args.k_scan), n_robots=n), seeds))
    for s in FILE_SCENARIOS:
        path = str(ROOT / "scenarios" / f"{s}.toml")
        out.append(Row(f"{s}.toml", lambda path=path: tse.parallel_env(scenario=scanned(path, args.k_scan),
                                                                        n_robots=args.robots),
                       range(args.seeds)))
    for side, travel in VARIANTS:
        def make(a=side, b=travel):
            return tse.parallel_env(scenario=scanned(canyon_config(a, b, robots=args.robots or 20), args.k_scan))

        out.append(Row(f"canyon, pass {side}, going {travel}", make, range(args.seeds)))
    for fam in ALL_FAMILIES + REAL_FAMILIES if args.generated else ():
        s0 = EVAL_SEED0 + args.seed_offset
        out.append(Row(f"generated: {fam}",
                       lambda f=fam: generated_family(f, args.robots, args.max_cycles, args.k_scan),
                       range(s0, s0 + args.generated), GENERATED_POLICIES))
    return [r for r in out if not args.only or any(r.label.startswith(o) for o in args.only)]


_ROWS: list = []  # the rows of this run, set before the worker processes fork (rows hold lambdas)
_WORKER_ENVS: dict = {}  # label -> env, one per process (built on its first episode of the row)


def _episode(job):
    """One episode ``(row index, policy name, seed) -> Outcome`` with a fresh policy, so the result
    does not depend on which process ran it or in which order."""
    k, name, seed = job
    row = _ROWS[k]
    env = _WORKER_ENVS.get(row.label)
    if env is None:
        env = _WORKER_ENVS[row.label] = row.make()
    pol = POLICIES[name](env)
    out = rollout(env, pol, seed)
    out.verdicts = _verdicts(env, pol, out)
    return out


def _verdicts(env, pol, out) -> tuple[int, int]:
    """``(said, false)``: robots that timed out with the policy saying their target is unreachable
    (``pol.unreachable``, APFPolicy's flag; (0, 0) for a policy without one), and of those the ones
    the map reaches from where they stand (the episode's cost-to-go field of their target is finite
    there: a false verdict)."""
    flag = getattr(pol, "unreachable", None)
    if flag is None:
        return 0, 0
    said_mask = np.zeros(out.n_robots, dtype=bool)  # the memory holds the rows it has seen (none: empty)
    flag = np.asarray(flag, dtype=bool)[: out.n_robots]
    said_mask[: len(flag)] = flag
    said = np.flatnonzero(said_mask & (out.reasons == Reason.TIMEOUT))
    fields, tgt, pos = env.target_fields, env.target_assignment, env.world_state.positions
    false = sum(int(np.isfinite(fields[tgt[i]].distance_at(pos[i][None])[0])) for i in said if tgt[i] >= 0)
    return len(said), false


def goal_rows(args, emit) -> dict:
    """Every goal row; returns ``{(label, policy): [Outcome, ...]}`` (one per seed, same order).
    With ``args.jobs > 1`` the episodes of a row run in that many processes (forked)."""
    emit("| terrain | policy | seeds x robots | arrived | fell | timed out | stalled | looping | contacts / robot "
         "| s |")
    emit("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    results = {}
    _ROWS[:] = _rows(args)
    pool = None
    if args.jobs > 1:
        import multiprocessing

        pool = multiprocessing.get_context("fork").Pool(args.jobs)
    try:
        for k, row in enumerate(_ROWS):
            try:
                env = _WORKER_ENVS[row.label] = row.make()
            except Exception as e:  # noqa: BLE001 - report the row as skipped, run the rest
                emit(f"| {row.label} | (skipped: {type(e).__name__}: {e}) | | | | | | | | |")
                continue
            for name in row.policies:
                t = time.perf_counter()
                jobs = [(k, name, sd) for sd in row.seeds]
                outs = pool.map(_episode, jobs, chunksize=1) if pool else [_episode(j) for j in jobs]
                results[(row.label, name)] = outs
                n = sum(o.n_robots for o in outs)
                share = {k: sum(o.shares()[k] * o.n_robots for o in outs) / n
                         for k in ("arrived", "fell", "timed_out", "stalled", "looping")}
                contacts = sum(int(o.collisions.sum()) for o in outs) / n
                emit(f"| {row.label} | {name} | {len(outs)} x {env.n} | {share['arrived']:.1%} | "
                     f"{share['fell']:.1%} | {share['timed_out']:.1%} | {share['stalled']:.1%} | "
                     f"{share['looping']:.1%} | {contacts:.2f} | {time.perf_counter() - t:.0f} |")
            _WORKER_ENVS.pop(row.label, None)
    finally:
        if pool is not None:
            pool.close()
            pool.join()
    return results


def verdict_rows(results, emit):
    """Per terrain, APF robots that timed out saying their target is unreachable, and how many of
    those the map reaches from where they stand (false verdicts; :func:`_verdicts`)."""
    emit("\nAPF robots that timed out saying their target is unreachable (APFPolicy.unreachable), and of those "
         "the ones the map reaches from where they stand (a false verdict); rows with none left out")
    emit("| terrain | robots | said unreachable | of them reachable (false) |")
    emit("|---|---:|---:|---:|")
    for (label, name), outs in results.items():
        said = sum(getattr(o, "verdicts", (0, 0))[0] for o in outs)
        if name != "apf" or not said:
            continue
        n = sum(o.n_robots for o in outs)
        false = sum(o.verdicts[1] for o in outs)
        emit(f"| {label} | {n} | {said} ({said / n:.1%}) | {false} ({false / n:.1%}) |")


def steps_rows(results, emit):
    """Per terrain, APF's steps to arrive against GeodesicPolicy's, robot by robot: the same seed
    puts every robot at the same spawn point under both policies, so the pairs compare like with
    like. Over the robots that arrived under both: median steps of each and the median of the
    per-robot ratio APF / geodesic; and the share that arrived under geodesic but not APF."""
    emit("\nsteps to arrive, APF against GeodesicPolicy (robots that arrived under both; same seeds, same spawns)")
    emit("| terrain | both arrived | APF steps (median) | geodesic steps (median) | APF / geodesic (median) "
         "| geodesic only |")
    emit("|---|---:|---:|---:|---:|---:|")
    for label in dict.fromkeys(k[0] for k in results):
        a, g = results.get((label, "apf")), results.get((label, "geodesic (knows the map)"))
        if not a or not g:
            continue
        sa = np.concatenate([np.where(o.reasons == Reason.ARRIVED, o.steps, -1) for o in a])
        sg = np.concatenate([np.where(o.reasons == Reason.ARRIVED, o.steps, -1) for o in g])
        both = (sa > 0) & (sg > 0)
        only = np.mean((sg > 0) & (sa <= 0))
        if not both.any():
            emit(f"| {label} | 0 | | | | {only:.1%} |")
            continue
        emit(f"| {label} | {both.sum()} | {np.median(sa[both]):.0f} | {np.median(sg[both]):.0f} | "
             f"{np.median(sa[both] / sg[both]):.2f} | {only:.1%} |")


def containment_rows(args, emit=print):
    emit("\ncontainment: mean distance to the assigned threat / standoff (1.00 = on the ring), worst seed "
         "and threat, and contacts per robot")
    emit("| policy | distance / standoff (mean) | worst | fell | contacts / robot |")
    emit("|---|---:|---:|---:|---:|")
    env = tse.parallel_env(scenario="containment", n_robots=args.robots)
    so = env.config.targets.standoff_m
    for name, make_pol in POLICIES.items():
        pol = make_pol(env)
        ratios, fell, contacts, n = [], 0, 0, 0
        for sd in range(args.seeds):
            out = rollout(env, pol, sd)
            s = env.world_state
            for k, T in enumerate(s.targets.positions):
                mine = (env.target_assignment == k) & (out.reasons != Reason.FELL)
                v = s.positions[mine] - T
                ratios.append(np.hypot(v[:, 0], v[:, 1]).mean() / so)
            fell += out.count(Reason.FELL)
            contacts += int(out.collisions.sum())
            n += out.n_robots
        worst = max(ratios, key=lambda r: abs(r - 1))
        emit(f"| {name} | {np.mean(ratios):.2f} | {worst:.2f} | {fell} | {contacts / n:.2f} |")


def horizon_rows(args, emit=print):
    """Why APF (the bug search) times out on jacksboro: for each robot that timed out, the step at which it
    first followed a break plus the steps the shortest drivable path from there to its target
    takes at top speed (GeodesicPolicy's cost-to-go field). Above ``max_cycles``, no policy
    that first walks straight at the target (as APF must, seeing 150 m) could have arrived."""
    env = tse.parallel_env(scenario=scanned("jacksboro", args.k_scan))
    cfg = env.config
    step_m = cfg.world.robot.max_speed_mps * cfg.world.dt_s
    emit("\njacksboro, APF robots that timed out: first break contact + shortest path at top speed (steps)")
    emit("| seed | timed out | needed: min | median | max | share within max_cycles |")
    emit("|---:|---:|---:|---:|---:|---:|")
    for sd in range(args.jacksboro_seeds):
        pol = APFPolicy(env, search="bug")  # the bug search records when it first followed a break
        first_t = np.full(env.n, -1)
        first_xy = np.zeros((env.n, 2))
        clock = [0]

        def on_step(e, reasons, pol=pol, first_t=first_t, first_xy=first_xy, clock=clock):
            clock[0] += 1
            side = np.zeros(e.n, dtype=np.int8)
            side[: len(pol.memory.side)] = pol.memory.side[: e.n]
            new = (side != 0) & (first_t < 0)
            first_t[new] = clock[0]
            first_xy[new] = e.world_state.positions[new]

        out = rollout(env, pol, sd, on_step=on_step)
        late = np.nonzero((out.reasons == Reason.TIMEOUT) & (first_t >= 0))[0]
        if not len(late):
            emit(f"| {sd} | 0 | | | | |")
            continue
        geo, targets = GeodesicPolicy(env), env.world_state.targets.positions
        need = np.empty(len(late))
        for k in np.unique(env.target_assignment[late]):
            mine = env.target_assignment[late] == k
            need[mine] = first_t[late[mine]] + geo.field(k, targets[k])[0].distance_at(first_xy[late[mine]]) / step_m
        emit(f"| {sd} | {len(late)} | {need.min():.0f} | {np.median(need):.0f} | {need.max():.0f} | "
             f"{np.mean(need <= cfg.max_cycles):.0%} |")


def longer_rows(args, emit=print, checkpoints=(900, 1200, 1500, 1800)):
    """Jacksboro's APF (either boundary search) given more steps than the scenario's ``max_cycles``:
    the share of robots that arrived by each checkpoint (one episode of ``checkpoints[-1]`` steps per
    seed and search). It says whether APF's timeouts are robots that are lost or robots that are late."""
    env = tse.parallel_env(scenario=scanned("jacksboro", args.k_scan), max_cycles=checkpoints[-1])
    emit(f"\njacksboro, APF given {checkpoints[-1]} steps: share of robots arrived by step ...")
    emit("| seed | search | " + " | ".join(str(c) for c in checkpoints) + " | fell |")
    emit("|---:|---|" + "---:|" * (len(checkpoints) + 1))
    for sd in range(args.jacksboro_seeds):
        for search in SEARCHES:
            out = rollout(env, APFPolicy(env, search=search), sd)
            arrived = out.reasons == Reason.ARRIVED
            shares = [np.mean(arrived & (out.steps <= c)) for c in checkpoints]
            emit(f"| {sd} | {search} | " + " | ".join(f"{x:.1%}" for x in shares)
                 + f" | {out.share(Reason.FELL):.1%} |")


def _header(argv) -> str:
    """The command, commit, date and load average the tables came from (one line)."""
    try:
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=False).stdout.strip() or "?"
    except OSError:
        commit = "?"
    cmd = shlex.join(["python", "bench/apf.py", *argv])  # quoted: the line can be run as it stands
    return (f"Measured with `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"load average {_load()} at the start ({os.cpu_count()} cores, shared).")


def _load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def _at_least(lo: int):
    """An argparse type: an integer ``>= lo`` (argparse names the option in its error)."""
    def parse(text: str) -> int:
        v = int(text)
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {v}")
        return v
    return parse


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5, help="episodes per row (not jacksboro, not generated)")
    p.add_argument("--robots", type=int, default=None, help="robots per episode (default: the scenario's)")
    p.add_argument("--jacksboro-seeds", type=int, default=5)
    p.add_argument("--generated", type=int, default=50, metavar="K",
                   help="held-out seeds per generated family (0: no generated rows)")
    p.add_argument("--seed-offset", type=_at_least(0), default=0, metavar="J",
                   help="the generated rows' seeds start at EVAL_SEED0 + J (another held-out set: e.g. 100)")
    p.add_argument("--max-cycles", type=_at_least(1), default=None, metavar="N",
                   help="the generated rows' episode length (default the scenario's, 1000)")
    p.add_argument("--only", type=lambda s: s.split(","), default=None,
                   help="comma-separated row prefixes (e.g. jacksboro,canyon,generated: fork,containment)")
    p.add_argument("--k-scan", type=_at_least(0), default=None, metavar="N",
                   help="every row's scenario with [observation] k_scan = N: the terrain scan's beams (default: as "
                        "it is, the default layout's; 0: no scan, the layout before the scan was the default)")
    p.add_argument("--horizon", action="store_true",
                   help="also: APF's steps to arrive against GeodesicPolicy's per terrain; for jacksboro's "
                        "timed-out APF robots, first contact + shortest path at top speed; and APF on jacksboro "
                        "given up to 1800 steps")
    p.add_argument("--jobs", type=int, default=1,
                   help="processes for the goal rows' episodes (results do not depend on it; wall time does)")
    p.add_argument("--quick", action="store_true",
                   help=f"a smoke run ({QUICK}); prints only, unless --out is given")
    p.add_argument("--out", default=None,
                   help="Markdown file for the tables (default docs/figures/apf.md; none with --quick)")
    args = p.parse_args(argv)
    if args.quick:
        for k, v in QUICK.items():
            setattr(args, k, v if getattr(args, k) is None else min(getattr(args, k), v))
        args.only = args.only or QUICK_ROWS
    out = args.out if args.out is not None else (None if args.quick else str(ROOT / "docs" / "figures" / "apf.md"))
    lines = [_header(argv), ""]

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    length = f"{args.max_cycles}-step episodes" if args.max_cycles else "episodes of the scenario's length"
    emit(f"{args.seeds} seeds per row ({args.jacksboro_seeds} on jacksboro, {args.generated} held-out seeds from "
         f"{EVAL_SEED0 + args.seed_offset} per generated family, {length} there), "
         f"robots: {args.robots or 'the scenario default'}; stalled and "
         "looping robots are among the timed out (tin_swarm_env/training/trajectory.py); s: seconds per row.\n")
    results = goal_rows(args, emit)
    verdict_rows(results, emit)
    if args.horizon:
        steps_rows(results, emit)
    if not args.only or "containment" in args.only:
        containment_rows(args, emit)
    if args.horizon and (not args.only or any(o.startswith("jacksboro") for o in args.only)):
        horizon_rows(args, emit)
        longer_rows(args, emit)
    emit(f"\nLoad average at the end: {_load()}.")
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out) as tmp:  # the whole file or nothing
            Path(tmp).write_text("\n".join(lines) + "\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
