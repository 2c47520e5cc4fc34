"""Cost-to-go benchmark (terrain/cost_to_go.py). Run by hand:

    python bench/cost_to_go.py [--sizes 2500,10000,40000] [--queries 1000000]

On jacksboro greedy TINs (max_vertices per size, about 2 triangles per vertex; passable =
slope <= 30 deg, goal near the centre) prints per TIN: triangles, nodes, build time (best of 3)
for the default any-angle method and the plain Steiner graph, query throughput for 1e6 random
points with known triangles and with point location, and the accuracy on a flat copy of the
same TIN (where the exact answer is the straight-line distance). Targets (issue 10): build
20k triangles <= 50 ms, query >= 1e6 points/s.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.terrain import Tin, cost_to_go


def best_of(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2500,10000,40000")
    ap.add_argument("--queries", type=int, default=1_000_000)
    a = ap.parse_args(argv)
    dem = tse.terrain.sample_dem("jacksboro")
    rng = np.random.default_rng(0)
    print(f"{'triangles':>9} {'nodes':>7} {'build ms':>9} {'plain ms':>9} {'query/s known tri':>18} "
          f"{'query/s + locate':>17} {'flat max err %':>15} {'plain flat p99 %':>17}")
    for mv in (int(s) for s in a.sizes.split(",")):
        tin = tse.terrain.build_tin(dem, method="greedy", max_vertices=mv)
        passable = tin.slope_deg <= 30.0
        lo, hi = np.array(tin.bounds[:2]), np.array(tin.bounds[2:])
        goal = (lo + hi) / 2
        ctg, t_build = best_of(lambda: cost_to_go(tin, goal, passable))
        _, t_plain = best_of(lambda: cost_to_go(tin, goal, passable, any_angle=False))
        q = rng.uniform(lo, hi, (a.queries, 2))
        tri = tin.locate(q)
        _, t_known = best_of(lambda: ctg.distance_at(q, tri))
        _, t_loc = best_of(lambda: ctg.distance_at(q))
        flat = Tin(np.column_stack([tin.vertices[:, :2], np.zeros(tin.n_vertices)]), tin.triangles)
        qs = q[:20000]
        far = np.hypot(*(qs - goal).T) > 100.0
        exact = np.hypot(*(qs - goal).T)[far]
        err = cost_to_go(flat, goal).distance_at(qs)[far] / exact - 1
        err_plain = cost_to_go(flat, goal, any_angle=False).distance_at(qs)[far] / exact - 1
        print(f"{tin.n_triangles:9d} {len(ctg.node_distance):7d} {t_build * 1e3:9.1f} {t_plain * 1e3:9.1f} "
              f"{len(q) / t_known:18.3g} {len(q) / t_loc:17.3g} {100 * err.max():15.2g} "
              f"{100 * np.percentile(err_plain, 99):17.2g}")


if __name__ == "__main__":
    main()
