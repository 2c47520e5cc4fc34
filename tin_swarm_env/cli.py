"""The ``tin-swarm`` command line.

    tin-swarm build-tin DEM -o OUT.tin [--method vip|greedy|delaunay] [--max-vertices N]
                        [--max-error-m E] [--min-significance-m S] [--png OUT.png]

``DEM`` is a file :func:`~tin_swarm_env.terrain.load_dem` reads, or ``sample:jacksboro`` /
``sample:topobathy``. Prints vertices, triangles, the max and RMS vertical error against every
DEM cell, and the build time.
"""

from __future__ import annotations

import argparse
import sys
import time

from .errors import TinSwarmError

__all__ = ["main"]


def _load(spec: str):
    from . import terrain

    if spec.startswith("sample:"):
        return terrain.sample_dem(spec.split(":", 1)[1])
    return terrain.load_dem(spec)


def _cmd_build_tin(args) -> int:
    from . import terrain

    dem = _load(args.dem)
    method = args.method
    if method is None:
        method = "greedy" if args.max_error_m is not None else None
    kw = {}
    if args.max_vertices is not None:
        kw["max_vertices"] = args.max_vertices
    if args.max_error_m is not None:
        kw["max_error_m"] = args.max_error_m
    if args.min_significance_m is not None:
        kw["min_significance_m"] = args.min_significance_m
    if method in (None, "vip") and not kw and isinstance(dem, terrain.Dem):
        kw["max_vertices"] = 5000
    t0 = time.perf_counter()
    tin = terrain.build_tin(dem, method=method, **kw)
    dt = time.perf_counter() - t0
    terrain.save_tin(tin, args.output)
    print(f"source     {dem!r}")
    print(f"method     {method or ('delaunay' if isinstance(dem, terrain.PointCloud) else 'vip')}")
    print(f"vertices   {tin.n_vertices}")
    print(f"triangles  {tin.n_triangles}")
    if isinstance(dem, terrain.Dem):
        st, err = terrain.vertical_error(tin, dem)
        print(f"max error  {st.max_m:.2f} m")
        print(f"rms error  {st.rms_m:.2f} m   (over {st.n_cells} DEM cells)")
    print(f"build time {dt:.3f} s")
    print(f"wrote      {args.output}")
    if args.png:
        _plot_tin(tin, args.png)
        print(f"picture    {args.png}")
    return 0


def _plot_tin(tin, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    tri = Triangulation(tin.vertices[:, 0], tin.vertices[:, 1], tin.triangles)
    fig, ax = plt.subplots(figsize=(8, 7), dpi=110)
    pc = ax.tripcolor(tri, facecolors=tin.slope_deg, cmap="viridis")
    ax.triplot(tri, lw=0.15, color="k", alpha=0.4)
    fig.colorbar(pc, ax=ax, label="slope (deg)")
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(f"{tin.n_vertices} vertices, {tin.n_triangles} triangles")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="tin-swarm", description="Robot swarms on TIN terrain.")
    sub = p.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build-tin", help="reduce a DEM to a TIN and write it (.tin or .npz)")
    b.add_argument("dem", help="DEM file (.xyz/.txt/.asc/.npy/.npz/.tif) or sample:jacksboro")
    b.add_argument("-o", "--output", required=True, help="output .tin (thesis text) or .npz")
    b.add_argument("--method", choices=["vip", "greedy", "delaunay"], default=None)
    b.add_argument("--max-vertices", type=int, default=None)
    b.add_argument("--max-error-m", type=float, default=None)
    b.add_argument("--min-significance-m", type=float, default=None)
    b.add_argument("--png", default=None, help="also draw the TIN coloured by slope")
    b.set_defaults(func=_cmd_build_tin)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (TinSwarmError, ValueError, FileNotFoundError) as exc:
        print(f"tin-swarm: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
