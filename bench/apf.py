"""The APF baseline over 20 seeds on the thesis scenarios. Run by hand:

    python bench/apf.py [--seeds 20] [--robots 20]

For ``ramp`` and ``cliff_goal``: arrivals, falls, battery deaths and time-outs, with all four
fields, without the break field (the thesis's "poor ending" vs "better ending", figures 5.3
and 5.5), and for random actions; then ``containment``: mean distance to the assigned threat
against the standoff, and how evenly robots spread around each ring.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.apps.rollout import rollout
from tin_swarm_env.apps.run import run_episodes

CONFIGS = [("apf, all fields", "apf", None), ("apf, no break field", "apf", ("robot", "target", "height")),
           ("random", "random", None)]


def main(seeds: int, robots: int):
    print(f"{seeds} seeds x {robots} robots per scenario\n")
    print("| scenario | policy | arrived | fell | battery | timed out | steps (mean) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for scen in ("ramp", "cliff_goal"):
        for label, pol, fields in CONFIGS:
            t = time.perf_counter()
            st, _ = run_episodes(scen, policy=pol, robots=robots, episodes=seeds, seed=0, fields=fields,
                                 progress=False)
            n = sum(s.robots for s in st)
            a, f = sum(s.arrived for s in st), sum(s.fell for s in st)
            b, to = sum(s.battery_dead for s in st), sum(s.timed_out for s in st)
            print(f"| {scen} | {label} | {a / n:.1%} ({a}) | {f / n:.1%} ({f}) | {b} | {to} | "
                  f"{np.mean([s.steps for s in st]):.0f} |  <!-- {time.perf_counter() - t:.0f} s -->")
    print("\ncontainment (standoff ring): per seed and threat, mean distance / standoff, mean resultant "
          "length of the robots' bearings (0 = evenly spread, 1 = bunched) and the largest gap")
    worst_d, worst_r, worst_gap = 0.0, 0.0, 0.0
    for sd in range(seeds):
        env = tse.parallel_env(scenario="containment")
        rollout(env, tse.policies.APFPolicy(env), sd)
        s, so = env.world_state, env.config.targets.standoff_m
        for k, T in enumerate(s.targets.positions):
            v = s.positions[env.target_assignment == k] - T
            ang = np.arctan2(v[:, 1], v[:, 0])
            worst_d = max(worst_d, abs(np.hypot(v[:, 0], v[:, 1]).mean() / so - 1))
            worst_r = max(worst_r, np.hypot(np.cos(ang).mean(), np.sin(ang).mean()))
            worst_gap = max(worst_gap, np.degrees(np.diff(np.sort(np.r_[ang, ang.min() + 2 * np.pi])).max()))
    print(f"worst over {seeds} seeds x 3 threats: mean distance off the standoff by {worst_d:.1%}, "
          f"resultant {worst_r:.2f}, largest gap {worst_gap:.0f} deg")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--robots", type=int, default=20)
    a = p.parse_args()
    main(a.seeds, a.robots)
