"""The cost-to-go of cliff_goal's target as a picture. Run by hand:

    python bench/cost_to_go_figure.py [--scenario cliff_goal] [--out bench/figures/cost_to_go_cliff_goal.png]
    python bench/cost_to_go_figure.py --quick    # a smoke run (seconds): a 10 m grid, to a temporary file

Draws ``distance_at`` of the scenario's first target (the field the geodesic reward uses: shortest
drivable path over triangles no steeper than the robots' ``max_slope_deg``) on a 2 m grid as a
heatmap with 25 m contours, too-steep triangles hatched grey, the spawn region and the target;
and prints, for robots spawned from seed 0, the geodesic and straight-line distances.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import tin_swarm_env as tse


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="cliff_goal")
    ap.add_argument("--out", default=None)
    ap.add_argument("--quick", action="store_true", help="a smoke run (seconds): the picture drawn on a 10 m grid "
                    "into a temporary directory")
    a = ap.parse_args()
    if a.quick:
        with tempfile.TemporaryDirectory() as tmp:
            draw(a.scenario, Path(tmp) / "cost_to_go.png", cell_m=10.0)
    else:
        draw(a.scenario, Path(a.out or f"bench/figures/cost_to_go_{a.scenario}.png"))


def draw(scenario: str, out: Path, cell_m: float = 2.0):
    """The picture of ``scenario``'s cost-to-go, its field sampled every ``cell_m``, to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    env = tse.parallel_env(scenario=scenario)
    env.reset(seed=0)
    tin, field = env.tin, env.target_fields[0]
    x0, y0, x1, y1 = tin.bounds
    X, Y = np.meshgrid(np.arange(x0, x1, cell_m), np.arange(y0, y1, cell_m))
    D = field.distance_at(np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape)
    fig, ax = plt.subplots(figsize=(8, 6), constrained_layout=True)
    im = ax.pcolormesh(X, Y, np.where(np.isfinite(D), D, np.nan), cmap="viridis_r", shading="auto")
    levels = np.arange(0, np.nanmax(np.where(np.isfinite(D), D, np.nan)) + 25, 25)
    ax.contour(X, Y, np.where(np.isfinite(D), D, np.nan), levels=levels, colors="white", linewidths=0.6)
    v = tin.vertices
    steep = env.world.steep
    ax.tripcolor(v[:, 0], v[:, 1], tin.triangles[steep], facecolors=np.ones(steep.sum()), cmap="Greys", vmin=0,
                 vmax=2, alpha=0.8)
    if env.config.robots.spawn_region is not None:
        sx0, sy0, sx1, sy1 = env.config.robots.spawn_region
        ax.add_patch(Rectangle((sx0, sy0), sx1 - sx0, sy1 - sy0, fill=False, ec="blue", lw=2, label="spawn region"))
    p = env.world_state.positions
    ax.plot(*p.T, "o", ms=3, mfc="white", mec="black", label="robots (seed 0)")
    ax.plot(*field.goal_xy, "*", ms=18, mfc="red", mec="black", label="target")
    ax.set_aspect("equal")
    ax.set_title(f"{scenario}: cost-to-go of the target (m, 25 m contours); grey: too steep "
                 f"(> {env.config.world.robot.max_slope_deg:.0f} deg)", fontsize=10)
    ax.legend(loc="lower left", fontsize=8)
    fig.colorbar(im, ax=ax, shrink=0.8, label="shortest drivable path to the target, m")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    straight = np.hypot(*(field.goal_xy - p).T)
    geo = env.distance_to_go()
    print(f"wrote {out}")
    print(f"robots of seed 0: geodesic {geo.min():.0f}-{geo.max():.0f} m, straight line "
          f"{straight.min():.0f}-{straight.max():.0f} m, ratio {np.median(geo / straight):.2f} (median)")


if __name__ == "__main__":
    main()
