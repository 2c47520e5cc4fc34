"""Cost-to-go benchmark (terrain/cost_to_go.py). Run by hand:

    nice -n 10 python bench/cost_to_go.py [--sizes 2500,10000,40000] [--queries 1000000] [--repeat 5]
                                          [--reset-repeats 20]
    python bench/cost_to_go.py --quick    # a smoke run (seconds): tiny sizes, one repeat

On jacksboro greedy TINs (max_vertices per size, about 2 triangles per vertex: 5k/20k/80k
triangles; passable = slope <= 30 deg, goal near the centre) prints per TIN: triangles, nodes,
accepted windows, build time of the default (window propagation) and of the plain Steiner
graph, query throughput for 1e6 random points with known triangles and with point location,
and the accuracy on a flat copy of the same TIN (where the exact answer is the straight-line
distance). Times are medians over ``--repeat`` runs, as CPU time of this process (``cpu``: what
the code costs, robust on a shared machine) and wall time (``wall``: inflated when other
processes share the cores). Then, in the same run, the time per ``reset`` of the ``generated``
scenario on a 200 x 200 grid (generation, meshing, world, cost-to-go, and ``env.reset_arrays``
as a whole; ``bench/generated.py``'s ``reset_times``; ``--reset-repeats 0`` skips it). Targets:
build 20k triangles <= 50 ms, query >= 1e6 points/s, <= 200 ms per reset.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from generated import reset_times  # bench/ is sys.path[0] when run as a script

import tin_swarm_env as tse
from tin_swarm_env.terrain import Tin, cost_to_go


def median_of(fn, repeat):
    """``(result, median wall s, median CPU s)`` over ``repeat`` calls."""
    wall, cpu = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return out, float(np.median(wall)), float(np.median(cpu))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2500,10000,40000")
    ap.add_argument("--queries", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--reset-repeats", type=int, default=20)
    ap.add_argument("--quick", action="store_true", help="a smoke run (seconds): one 500-vertex TIN, 10 000 queries, "
                    "one repeat, one reset")
    a = ap.parse_args(argv)
    if a.quick:
        a.sizes, a.queries, a.repeat, a.reset_repeats = "500", 10_000, 1, 1
    dem = tse.terrain.sample_dem("jacksboro")
    rng = np.random.default_rng(0)
    cost_to_go(tse.terrain.build_tin(dem, method="greedy", max_vertices=200), (0.0, 0.0))  # compile/load kernels
    print(f"{'triangles':>9} {'nodes':>7} {'windows':>8} {'build ms cpu/wall':>18} {'plain ms cpu':>12} "
          f"{'query/s known tri cpu/wall':>27} {'query/s + locate cpu':>21} {'flat max err %':>15} "
          f"{'plain flat p99 %':>17}")
    for mv in (int(s) for s in a.sizes.split(",")):
        tin = tse.terrain.build_tin(dem, method="greedy", max_vertices=mv)
        passable = tin.slope_deg <= 30.0
        lo, hi = np.array(tin.bounds[:2]), np.array(tin.bounds[2:])
        goal = (lo + hi) / 2
        args = (tin, goal, passable)
        ctg, b_wall, b_cpu = median_of(lambda args=args: cost_to_go(*args), a.repeat)
        _, _, p_cpu = median_of(lambda args=args: cost_to_go(*args, any_angle=False), a.repeat)
        q = rng.uniform(lo, hi, (a.queries, 2))
        tri = tin.locate(q)
        _, k_wall, k_cpu = median_of(lambda c=ctg, q=q, t=tri: c.distance_at(q, t), a.repeat)
        _, _, l_cpu = median_of(lambda c=ctg, q=q: c.distance_at(q), a.repeat)
        flat = Tin(np.column_stack([tin.vertices[:, :2], np.zeros(tin.n_vertices)]), tin.triangles)
        qs = q[:20000]
        far = np.hypot(*(qs - goal).T) > 100.0
        exact = np.hypot(*(qs - goal).T)[far]
        err = cost_to_go(flat, goal).distance_at(qs)[far] / exact - 1
        err_plain = cost_to_go(flat, goal, any_angle=False).distance_at(qs)[far] / exact - 1
        n = len(q)
        print(f"{tin.n_triangles:9d} {len(ctg.node_distance):7d} {len(ctg._wroot):8d} "
              f"{b_cpu * 1e3:8.1f}/{b_wall * 1e3:<9.1f} {p_cpu * 1e3:12.1f} "
              f"{n / k_cpu:13.3g}/{n / k_wall:<13.3g} {n / l_cpu:21.3g} {100 * err.max():15.2g} "
              f"{100 * np.percentile(err_plain, 99):17.2g}")
    if a.reset_repeats:
        print()
        reset_times(a.reset_repeats)


if __name__ == "__main__":
    main()
