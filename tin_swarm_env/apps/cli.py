"""The ``tin-swarm`` command line.

    tin-swarm run SCENARIO [--robots N] [--policy apf|random|PATH] [--episodes K] [--seed S]
                  [--gif OUT.gif] [--mp4 OUT.mp4] [--fields robot,target,break,height] [--summary OUT.md]
    tin-swarm scenarios
    tin-swarm explore SCENARIO [--png OUT.png] [--robot I|all] [--fields ...] [--steps K] [--cost-to-go]
    tin-swarm train SCENARIO --timesteps N [any field of apps.train.Args: --n-robots 8 ...]
    tin-swarm eval SCENARIO... [--seeds K] [--model PATH]... [--out OUT]
    tin-swarm build-tin DEM -o OUT.tin [--method vip|greedy|delaunay] [--max-vertices N]
                        [--max-error-m E] [--min-significance-m S] [--png OUT.png]

``run`` runs a swarm on a scenario (a built-in name or a TOML path) with the APF baseline (or
random actions, or a saved SB3 model), shows progress, prints a table per episode and writes a
GIF (or, for a ``.png`` path, the last frame) of the first episode. ``build-tin``: ``DEM`` is a
file :func:`~tin_swarm_env.terrain.load_dem` reads, or ``sample:jacksboro`` /
``sample:topobathy``; it prints vertices, triangles, the max and RMS vertical error against
every DEM cell, and the build time.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..errors import ArgumentError, TinSwarmError

__all__ = ["main"]


def _load(spec: str):
    from .. import terrain

    if spec.startswith("sample:"):
        return terrain.sample_dem(spec.split(":", 1)[1])
    return terrain.load_dem(spec)


def _cmd_build_tin(args) -> int:
    from .. import terrain

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


def _fields(spec, default=None):
    """``--fields robot,target`` -> a tuple of APF field names (``default`` when not given)."""
    from ..world.fields import FIELDS

    if spec is None:
        return default
    fields = tuple(f for f in spec.split(",") if f)
    bad = set(fields) - set(FIELDS)
    if bad:
        raise ArgumentError(f"--fields: unknown field(s) {sorted(bad)}; choose from {','.join(FIELDS)}")
    return fields


def _cmd_run(args) -> int:
    from .media import save_gif, save_mp4
    from .run import format_table, run_episodes

    fields = _fields(args.fields)
    if args.episodes < 1:
        raise ArgumentError("--episodes must be >= 1")
    every = max(1, args.frame_every) if (args.gif or args.mp4) else 0
    stats, frames = run_episodes(args.scenario, policy=args.policy, robots=args.robots, episodes=args.episodes,
                                 seed=args.seed, fields=fields, frames_every=every, max_cycles=args.max_cycles,
                                 progress=not args.quiet)
    table = format_table(stats)
    print(f"scenario {args.scenario}, policy {args.policy}" + (f", fields {','.join(fields)}" if fields else ""))
    print(table)
    if args.summary:
        from .._atomic import atomic_path

        with atomic_path(args.summary) as tmp, open(tmp, "w") as fh:
            fh.write(f"# tin-swarm run {args.scenario} ({args.policy})\n\n{table}\n")
        print(f"wrote {args.summary}")
    if args.gif:
        save_gif(frames, args.gif)
        print(f"wrote {args.gif} ({len(frames)} frames)")
    if args.mp4:
        save_mp4(frames, args.mp4)
        print(f"wrote {args.mp4} ({len(frames)} frames)")
    return 0


def _cmd_train(args) -> int:
    from .args import dataclass_from_namespace
    from .train import Args, train

    train(dataclass_from_namespace(Args, args, total_timesteps=args.timesteps))
    return 0


def _cmd_eval(args) -> int:
    from .evaluate import Args, evaluate

    evaluate(Args(scenarios=",".join(args.scenarios), seeds=args.seeds, robots=args.robots,
                  models=",".join(args.model), policies=args.policies, out=args.out))
    return 0


def _cmd_explore(args) -> int:
    import matplotlib

    if args.png:
        matplotlib.use("Agg")
    from ..world.fields import FIELDS
    from .explorer import FieldExplorer

    fields = _fields(args.fields, FIELDS)
    robot = None if args.robot == "all" else int(args.robot)
    ex = FieldExplorer(args.scenario, robot=robot, fields=fields, n_robots=args.robots, seed=args.seed,
                       cost_to_go=args.cost_to_go)
    if robot is not None and not 0 <= robot < ex.env.n:
        raise ArgumentError(f"--robot {robot}: the scenario has robots 0..{ex.env.n - 1}")
    for _ in range(args.steps):
        ex.next_step(draw=False)
    ex.redraw()
    if args.png:
        from .._atomic import atomic_path

        with atomic_path(args.png) as tmp:
            ex.fig.savefig(tmp, format="png")
        print(f"wrote {args.png}")
        ex.close()
    else:
        ex.show()
    return 0


def _cmd_scenarios(args) -> int:
    from ..scenario import list_scenarios

    for name, desc in list_scenarios().items():
        print(f"{name:12s} {desc}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The parser of every subcommand (a flat list of options; see the module docstring)."""
    from .args import add_dataclass_args
    from .train import Args as TrainArgs

    p = argparse.ArgumentParser(prog="tin-swarm", description="Robot swarms on TIN terrain.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a swarm on a scenario and report each episode")
    r.add_argument("scenario", help="built-in scenario name (tin-swarm scenarios) or a .toml path")
    r.add_argument("--robots", type=int, default=None, help="number of robots (default: the scenario's)")
    r.add_argument("--policy", default="apf", help="apf, random, or a saved SB3 model .zip")
    r.add_argument("--episodes", type=int, default=1)
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--fields", default=None, help="APF fields to use, e.g. robot,target,height (default: all)")
    r.add_argument("--gif", default=None, help="write the first episode as a GIF (or its last frame as .png)")
    r.add_argument("--mp4", default=None, help="write the first episode as an MP4 video (the [video] extra)")
    r.add_argument("--frame-every", type=int, default=5, help="steps between GIF/MP4 frames")
    r.add_argument("--max-cycles", type=int, default=None)
    r.add_argument("--summary", default=None, help="also write the table to this Markdown file")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=_cmd_run)
    s = sub.add_parser("scenarios", help="list the built-in scenarios")
    s.set_defaults(func=_cmd_scenarios)
    x = sub.add_parser("explore", help="the field explorer (a window, or --png OUT.png headless)")
    x.add_argument("scenario")
    x.add_argument("--png", default=None, help="draw into this file instead of opening a window")
    x.add_argument("--robot", default="0", help="robot index whose field is shown, or 'all'")
    x.add_argument("--fields", default=None, help="fields switched on, e.g. robot,target,break (default: all)")
    x.add_argument("--robots", type=int, default=None)
    x.add_argument("--steps", type=int, default=0, help="APF steps to take before drawing")
    x.add_argument("--seed", type=int, default=0)
    x.add_argument("--cost-to-go", action="store_true",
                   help="overlay contours of the selected robot's target's cost-to-go (m of drivable path)")
    x.set_defaults(func=_cmd_explore)
    t = sub.add_parser("train", help="train PPO (apps/train.py, = agents/train_sb3.py; needs the [train] extra)")
    t.add_argument("scenario")
    t.add_argument("--timesteps", type=int, default=200_000)
    add_dataclass_args(t, TrainArgs, skip=("scenario", "total_timesteps"))
    t.set_defaults(func=_cmd_train)
    e = sub.add_parser("eval", help="random, APF and saved models on the same scenarios and seeds")
    e.add_argument("scenarios", nargs="+")
    e.add_argument("--seeds", type=int, default=20)
    e.add_argument("--robots", type=int, default=0)
    e.add_argument("--model", action="append", default=[], help="a saved SB3 model (repeatable)")
    e.add_argument("--policies", default="random,apf")
    e.add_argument("--out", default="eval", help="writes OUT.md, OUT.csv and OUT.png")
    e.set_defaults(func=_cmd_eval)
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
