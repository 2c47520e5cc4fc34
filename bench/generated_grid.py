"""Generated terrains: a picture of two per family and the generation + meshing time per reset. Run by hand:

    python bench/generated_grid.py [--out bench/figures/generated_grid.png] [--repeats 30]
    python bench/generated_grid.py --quick    # a smoke run (seconds): the figure to a temporary file, 1 seed

Draws two tasks of every family (``ALL_FAMILIES``, seeds 0, 1, ...) as greedy TINs
(``max_error_m=0.5``) coloured by slope (traversable green-yellow, above the robots' 30 deg red),
with the spawn region, the target, each pass or ramp's centre line (black) and each dead end
(red, entry to far end). Then times, per family,
``generate`` plus ``build_tin(dem, method="greedy", max_error_m=0.5)`` on a 200 x 200 grid (398 m
at 2 m cells) against the issue's target of 200 ms per reset.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from tin_swarm_env.scenario.generators import ALL_FAMILIES, generate
from tin_swarm_env.terrain import build_tin

MAX_SLOPE_DEG = 30.0
TARGET_MS = 200.0
GRID_200 = {"size_m": [398.0, 398.0], "cell_m": [2.0, 2.0]}  # 200 x 200 cells


def draw(out: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Rectangle

    cmap = ListedColormap(["#1a9850", "#91cf60", "#d9ef8b", "#fee08b", "#fc8d59", "#d73027", "#7f0000"])
    norm = BoundaryNorm([0, 5, 10, 15, 22.5, 30, 60, 90], cmap.N)
    fams = [fam for fam in ALL_FAMILIES for _ in range(2)]
    fig, axes = plt.subplots(2, len(ALL_FAMILIES), figsize=(4 * len(ALL_FAMILIES), 8.6), constrained_layout=True)
    axes = axes.T  # column per family
    for seed, (fam, ax) in enumerate(zip(fams, axes.ravel(), strict=True)):
        task = generate(np.random.default_rng(seed), families=(fam,), max_slope_deg=MAX_SLOPE_DEG)
        tin = build_tin(task.dem, method="greedy", max_error_m=0.5)
        v = tin.vertices
        pc = ax.tripcolor(v[:, 0], v[:, 1], tin.triangles, facecolors=tin.slope_deg, cmap=cmap, norm=norm)
        x0, y0, x1, y1 = task.spawn_region
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="blue", lw=2))
        ax.plot(*task.targets.T, "*", ms=16, mfc="white", mec="black")
        for (a, b) in task.passes:
            ax.annotate("", xy=b, xytext=a, arrowprops={"arrowstyle": "->", "color": "black", "lw": 1.5})
        for (a, b) in task.dead_ends:  # entry -> far end
            ax.annotate("", xy=b, xytext=a, arrowprops={"arrowstyle": "->", "color": "red", "lw": 1.5})
        p = task.params
        extra = f", spawn on {p['spawn_on']}" if "spawn_on" in p else ""
        ax.set_title(f"seed {seed}: {fam}, detour {task.detour_side}{extra}\n"
                     f"{p['size_m']:.0f} m, cell {p['cell_m']:.1f} m, {len(tin.triangles)} triangles", fontsize=10)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.colorbar(pc, ax=axes, shrink=0.7, label="slope, deg (robots' limit 30)")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    print(f"wrote {out}")


def timing(repeats: int):
    print(f"\ngenerate + build_tin(greedy, max_error_m=0.5) on a 200 x 200 grid, {repeats} seeds per family")
    print("| family | generate ms (median) | meshing ms (median) | total ms (median / max) | target / median |")
    print("|---|---:|---:|---:|---:|")
    for fam in ALL_FAMILIES:
        gen, mesh = [], []
        for seed in range(repeats):
            t0 = time.perf_counter()
            task = generate(np.random.default_rng(seed), families=(fam,), ranges={fam: GRID_200})
            t1 = time.perf_counter()
            build_tin(task.dem, method="greedy", max_error_m=0.5)
            gen.append(t1 - t0)
            mesh.append(time.perf_counter() - t1)
        assert task.dem.shape == (200, 200)
        g, m = np.array(gen) * 1e3, np.array(mesh) * 1e3
        tot = g + m
        print(f"| {fam} | {np.median(g):.1f} | {np.median(m):.1f} | {np.median(tot):.1f} / {tot.max():.1f} | "
              f"{TARGET_MS / np.median(tot):.1f}x |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("figures") / "generated_grid.png")
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--no-figure", action="store_true")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run (seconds): the figure drawn into a temporary directory, 1 seed per family")
    a = ap.parse_args()
    if a.quick:
        with tempfile.TemporaryDirectory() as tmp:
            draw(Path(tmp) / "generated_grid.png")
        timing(1)
    else:
        if not a.no_figure:
            draw(a.out)
        timing(a.repeats)
