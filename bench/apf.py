"""APF against its references, in one run: arrived / fell / timed out / contacts per robot. By hand:

    python bench/apf.py [--seeds 5] [--robots N] [--jacksboro-seeds 5] [--generated 50] [--only cliff_goal,...]
                        [--horizon]

Policies: the APF baseline with all its fields, the APF without the break field (the thesis's
"poor ending": falls), :class:`~tin_swarm_env.policies.GeodesicPolicy` (knows the map: an upper
bound, not a baseline) and uniform random actions. Terrains: every built-in goal scenario
(``jacksboro`` with its 200 robots and 900 steps), the four canyon terrains of
``tests/canyons.py`` (pass left or right, travelling east or west) and, with ``--generated K``,
seeds 0..K-1 of the ``generated`` scenario (a new terrain per seed; default K = 50, 0 leaves it
out). A terrain whose env cannot be built is reported as a skipped row with the error.
``containment`` has no arrival: its rows give the mean distance to the assigned threat over the
standoff (1.00 = on the ring) and contacts per robot.
Every episode runs through :func:`~tin_swarm_env.apps.rollout.rollout`.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.apps.rollout import rollout
from tin_swarm_env.policies import APFPolicy, GeodesicPolicy, RandomPolicy
from tin_swarm_env.world.state import Reason

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from canyons import VARIANTS, canyon_config  # noqa: E402

POLICIES = {
    "apf": lambda env: APFPolicy(env),
    "apf, no break field": lambda env: APFPolicy(env, fields=("robot", "target", "height")),
    "geodesic (knows the map)": lambda env: GeodesicPolicy(env),
    "random": lambda env: RandomPolicy(env, seed=0),
}
GOAL_SCENARIOS = ("cliff_goal", "ramp", "hill", "flat", "jacksboro")


def _envs(args):
    """(label, env factory, seeds) for every goal-task row."""
    out = []
    for s in GOAL_SCENARIOS:
        n = None if s == "jacksboro" else args.robots
        seeds = range(args.jacksboro_seeds if s == "jacksboro" else args.seeds)
        out.append((s, lambda s=s, n=n: tse.parallel_env(scenario=s, n_robots=n), seeds))
    for side, travel in VARIANTS:
        out.append((f"canyon, pass {side}, going {travel}",
                    lambda a=side, b=travel: tse.parallel_env(scenario=canyon_config(a, b, robots=args.robots or 20)),
                    range(args.seeds)))
    if args.generated:
        out.append((f"generated ({args.generated} seeds)",
                    lambda: tse.parallel_env(scenario="generated", n_robots=args.robots), range(args.generated)))
    return out


def goal_rows(args):
    print("| terrain | policy | arrived | fell | timed out | contacts / robot | s |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for label, make, seeds in _envs(args):
        if args.only and not any(label.startswith(o) for o in args.only):
            continue
        try:
            env = make()
        except Exception as e:  # noqa: BLE001 - report the row as skipped, run the rest
            print(f"| {label} | (skipped: {type(e).__name__}: {e}) | | | | | |")
            continue
        for name, make_pol in POLICIES.items():
            t = time.perf_counter()
            pol = make_pol(env)
            c = {r: 0 for r in (Reason.ARRIVED, Reason.FELL, Reason.TIMEOUT)}
            n = contacts = 0
            for sd in seeds:
                out = rollout(env, pol, sd)
                for r in c:
                    c[r] += out.count(r)
                n += out.n_robots
                contacts += int(out.collisions.sum())
            print(f"| {label} | {name} | {c[Reason.ARRIVED] / n:.1%} | {c[Reason.FELL] / n:.1%} | "
                  f"{c[Reason.TIMEOUT] / n:.1%} | {contacts / n:.2f} | {time.perf_counter() - t:.0f} |", flush=True)


def containment_rows(args):
    print("\ncontainment: mean distance to the assigned threat / standoff (1.00 = on the ring), worst seed "
          "and threat, and contacts per robot")
    print("| policy | distance / standoff (mean) | worst | fell | contacts / robot |")
    print("|---|---:|---:|---:|---:|")
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
        print(f"| {name} | {np.mean(ratios):.2f} | {worst:.2f} | {fell} | {contacts / n:.2f} |", flush=True)


def horizon_rows(args):
    """Why APF times out on jacksboro: for each robot that timed out, the step at which it
    first followed a break plus the steps the shortest drivable path from there to its target
    takes at top speed (GeodesicPolicy's cost-to-go field). Above ``max_cycles``, no policy
    that first walks straight at the target (as APF must, seeing 150 m) could have arrived."""
    env = tse.parallel_env(scenario="jacksboro")
    cfg = env.config
    step_m = cfg.world.robot.max_speed_mps * cfg.world.dt_s
    print("\njacksboro, APF robots that timed out: first break contact + shortest path at top speed (steps)")
    print("| seed | timed out | needed: min | median | max | share within max_cycles |")
    print("|---:|---:|---:|---:|---:|---:|")
    for sd in range(args.jacksboro_seeds):
        pol = APFPolicy(env)
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
            print(f"| {sd} | 0 | | | | |")
            continue
        geo, targets = GeodesicPolicy(env), env.world_state.targets.positions
        need = np.empty(len(late))
        for k in np.unique(env.target_assignment[late]):
            mine = env.target_assignment[late] == k
            need[mine] = first_t[late[mine]] + geo.field(k, targets[k])[0].distance_at(first_xy[late[mine]]) / step_m
        print(f"| {sd} | {len(late)} | {need.min():.0f} | {np.median(need):.0f} | {need.max():.0f} | "
              f"{np.mean(need <= cfg.max_cycles):.0%} |", flush=True)


def longer_rows(args, checkpoints=(900, 1200, 1500, 1800)):
    """Jacksboro's APF given more steps than the scenario's ``max_cycles``: the share of robots
    that arrived by each checkpoint (one episode of ``checkpoints[-1]`` steps per seed). It says
    whether APF's timeouts are robots that are lost or robots that are late."""
    env = tse.parallel_env(scenario="jacksboro", max_cycles=checkpoints[-1])
    print(f"\njacksboro, APF given {checkpoints[-1]} steps: share of robots arrived by step ...")
    print("| seed | " + " | ".join(str(c) for c in checkpoints) + " | fell |")
    print("|---:|" + "---:|" * (len(checkpoints) + 1))
    for sd in range(args.jacksboro_seeds):
        out = rollout(env, APFPolicy(env), sd)
        arrived = out.reasons == Reason.ARRIVED
        shares = [np.mean(arrived & (out.steps <= c)) for c in checkpoints]
        print(f"| {sd} | " + " | ".join(f"{x:.1%}" for x in shares) + f" | {out.share(Reason.FELL):.1%} |", flush=True)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5, help="episodes per row (not jacksboro, not generated)")
    p.add_argument("--robots", type=int, default=None, help="robots per episode (default: the scenario's)")
    p.add_argument("--jacksboro-seeds", type=int, default=5)
    p.add_argument("--generated", type=int, default=50, metavar="K",
                   help="seeds of the 'generated' scenario (0: none)")
    p.add_argument("--only", type=lambda s: s.split(","), default=None,
                   help="comma-separated row prefixes (e.g. jacksboro,canyon,containment)")
    p.add_argument("--horizon", action="store_true",
                   help="also: for jacksboro's timed-out APF robots, first contact + shortest path at top speed; "
                        "and APF on jacksboro given up to 1800 steps")
    args = p.parse_args(argv)
    print(f"{args.seeds} seeds per row ({args.jacksboro_seeds} on jacksboro), robots: "
          f"{args.robots or 'the scenario default'}\n")
    goal_rows(args)
    if not args.only or "containment" in args.only:
        containment_rows(args)
    if args.horizon:
        horizon_rows(args)
        longer_rows(args)


if __name__ == "__main__":
    main()
