"""The ``tin-swarm`` command line.

    tin-swarm run SCENARIO [--robots N] [--policy apf|random|DIR|MODEL.zip] [--trust-pickle] [--episodes K]
                  [--seed S] [--gif OUT.gif] [--mp4 OUT.mp4] [--fields robot,target,break,height] [--summary OUT.md]
    tin-swarm scenarios [--copy NAME DEST [--force]]
    tin-swarm explore SCENARIO [--png OUT.png] [--robot I|all] [--fields ...] [--steps K] [--cost-to-go]
    tin-swarm train SCENARIO --timesteps N [any field of apps.train.Args: --n-robots 8 ...]
    tin-swarm eval SCENARIO... [--seeds K] [--model DIR]... [--trust-pickle] [--out OUT]
    tin-swarm eval --suite standard [--model [NAME=]DIR]... [--quick] [--out OUT]
    tin-swarm build-tin DEM -o OUT.tin [--method vip|greedy|delaunay] [--max-vertices N]
                        [--max-error-m E] [--min-significance-m S] [--png OUT.png]

``run`` runs a swarm on a scenario (a built-in name or a TOML path) with the APF baseline (or
random actions, or a saved policy), shows progress, prints a table per episode and writes a
GIF (or, for a ``.png`` path, the last frame) of the first episode, frame by frame as it runs.
``build-tin``: ``DEM`` is a file :func:`~tin_swarm_env.terrain.load_dem` reads, or
``sample:jacksboro`` / ``sample:topobathy``; it prints vertices, triangles, the max and RMS
vertical error against every DEM cell, and the build time.

Bad input never ends in a traceback: every option and output path is checked before the work
starts, and any error (a :class:`~tin_swarm_env.errors.TinSwarmError`, an ``OSError`` such as a
full or read-only disk) is one line on stderr with exit status 2 (1 for an unexpected error);
Ctrl-C prints "interrupted" and exits with 130. ``--debug`` (or ``TIN_SWARM_DEBUG=1``) re-raises
instead, with the traceback. Policies: ``apf``/``random`` (any case) or a pickle-free policy
directory; an SB3 ``.zip`` is a pickle (loading it can run code) and needs ``--trust-pickle``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from .._atomic import check_outputs
from ..errors import ArgumentError, TinSwarmError

__all__ = ["main"]


def _load(spec: str):
    from .. import terrain

    if spec.startswith("sample:"):
        return terrain.sample_dem(spec.split(":", 1)[1])
    return terrain.load_dem(spec)


def _cmd_build_tin(args) -> int:
    from .. import terrain

    check_outputs({"-o/--output": args.output, "--png": args.png},
                  inputs=() if args.dem.startswith("sample:") else (args.dem,))
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
    if args.max_slope_deg is not None:
        kw["max_slope_deg"] = args.max_slope_deg
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
    from .._atomic import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def _fields(spec, default=None):
    """``--fields robot,target`` -> a tuple of APF field names (``default`` when not given; an
    empty list is an error, not "all")."""
    from ..world.fields import FIELDS

    if spec is None:
        return default
    fields = tuple(f.strip() for f in spec.split(",") if f.strip())
    if not fields:
        raise ArgumentError(f"--fields {spec!r}: no field named; choose from {','.join(FIELDS)} (leave the option "
                            "out for all of them)")
    bad = set(fields) - set(FIELDS)
    if bad:
        raise ArgumentError(f"--fields: unknown field(s) {sorted(bad)}; choose from {','.join(FIELDS)}")
    return fields


def _scenario_inputs(scenario: str) -> tuple:
    """The scenario argument as an input path when it is a file (outputs must not overwrite it)."""
    return (scenario,) if os.path.isfile(scenario) else ()


def _cmd_run(args) -> int:
    from contextlib import ExitStack

    from .media import FrameWriter
    from .policy_factory import check_policy_spec
    from .run import format_table, run_episodes

    fields = _fields(args.fields)
    check_policy_spec(args.policy, args.trust_pickle)
    if args.mp4 and not args.mp4.lower().endswith(".mp4"):
        raise ArgumentError(f"--mp4 {args.mp4}: the file name must end in .mp4")
    check_outputs({"--summary": args.summary, "--gif": args.gif, "--mp4": args.mp4},
                  inputs=(*_scenario_inputs(args.scenario), args.policy))
    if args.gif or args.mp4:
        from ..scenario.config import load_scenario
        from .media import check_animation

        cfg = load_scenario(args.scenario)
        check_animation(args.robots or cfg.robots.count, args.max_cycles or cfg.max_cycles, args.frame_every,
                        "--gif" if args.gif else "--mp4")
    with ExitStack() as stack:  # frames go to disk as they are drawn; .part files removed on any error
        writers = [stack.enter_context(FrameWriter(p)) for p in (args.gif, args.mp4) if p]
        every = args.frame_every if writers else 0

        def on_frame(frame):
            for w in writers:
                w.add(frame)

        stats, _ = run_episodes(args.scenario, policy=args.policy, robots=args.robots, episodes=args.episodes,
                                seed=args.seed, fields=fields, frames_every=every, max_cycles=args.max_cycles,
                                progress=not args.quiet, render_width=args.render_width, on_frame=on_frame,
                                trust_pickle=args.trust_pickle)
        table = format_table(stats)
        print(f"scenario {args.scenario}, policy {args.policy}" + (f", fields {','.join(fields)}" if fields else ""))
        print(table)
        if args.summary:
            from .._atomic import atomic_path

            with atomic_path(args.summary) as tmp, open(tmp, "w") as fh:
                fh.write(f"# tin-swarm run {args.scenario} ({args.policy})\n\n{table}\n")
            print(f"wrote {args.summary}")
    for w in writers:
        print(f"wrote {w.path} ({w.n_frames} frames)")
    return 0


def _cmd_train(args) -> int:
    from .args import dataclass_from_namespace
    from .train import Args, train

    a = dataclass_from_namespace(Args, args)
    if a.resume:
        from .checkpoint import read_args

        saved = read_args(Path(a.resume)).get("scenario")
        if saved != a.scenario:
            raise ArgumentError(f"--resume {a.resume}: that run trained on {saved!r}, not {a.scenario!r}")
    train(a)
    return 0


def _cmd_eval(args) -> int:
    from .args import dataclass_from_namespace
    from .evaluate import Args, evaluate
    from .suite import run_suite

    a = dataclass_from_namespace(Args, args, scenarios=",".join(args.scenarios), models=",".join(args.models))
    (run_suite if a.suite else evaluate)(a)
    return 0


def _robot_arg(s: str):
    """``--robot``: a robot index >= 0 or ``all`` (-> None)."""
    if s.strip().lower() == "all":
        return None
    try:
        i = int(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a robot index or 'all', got {s!r}") from None
    if i < 0:
        raise argparse.ArgumentTypeError(f"a robot index is >= 0, got {i}")
    return i


def _cmd_explore(args) -> int:
    import matplotlib

    from ..scenario.config import load_scenario
    from ..world.fields import FIELDS

    fields = _fields(args.fields, FIELDS)
    robot = args.robot
    n = args.robots or load_scenario(args.scenario).robots.count
    if robot is not None and robot >= n:
        raise ArgumentError(f"--robot {robot}: the scenario has robots 0..{n - 1}")
    check_outputs({"--png": args.png}, inputs=_scenario_inputs(args.scenario))
    if args.png:
        matplotlib.use("Agg")
    from .explorer import FieldExplorer

    ex = FieldExplorer(args.scenario, robot=robot, fields=fields, n_robots=args.robots, seed=args.seed,
                       cost_to_go=args.cost_to_go)
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
    from ..scenario.config import list_scenarios, scenario_file

    if args.copy:
        name, dest = args.copy
        src = scenario_file(name)
        if os.path.isdir(dest):
            dest = os.path.join(dest, src.name)
        if os.path.exists(dest) and not args.force:
            raise ArgumentError(f"--copy: {dest} exists; pass --force to overwrite it")
        check_outputs({"--copy DEST": dest})
        from .._atomic import atomic_path

        with atomic_path(dest) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(src.read_bytes())
        print(f"wrote {dest} (the built-in scenario {name!r}; edit it and run: tin-swarm run {dest})")
        return 0
    for name, desc in list_scenarios().items():
        print(f"{name:12s} {desc}")
    return 0


def _int_in(lo: int, hi: int | None = None):
    """An argparse type: an integer ``lo <= v`` (``<= hi`` when given); the message names the bound."""
    def conv(s: str) -> int:
        try:
            v = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {s!r}") from None
        if v < lo or (hi is not None and v > hi):
            raise argparse.ArgumentTypeError(f"must be >= {lo}" + (f" and <= {hi}" if hi is not None else "")
                                             + f", got {v}")
        return v
    conv.__name__ = "integer"
    return conv


_POS, _NONNEG = _int_in(1), _int_in(0)


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with every option's default shown (``(default: ...)``), None defaults left out."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == []:
            return action.help
        return super()._get_help_string(action)


def _add_run(sub) -> None:
    from ..env.tin_swarm import DEFAULT_RENDER_WIDTH_PX, RENDER_WIDTH_PX

    r = sub.add_parser("run", help="run a swarm on a scenario and report each episode", formatter_class=_Formatter,
                       description="Run a policy on a scenario; a table per episode, optionally a GIF/MP4.")
    r.add_argument("scenario", help="built-in scenario name (tin-swarm scenarios) or a .toml path")
    r.add_argument("--robots", type=_POS, default=None, help="number of robots (default: the scenario's)")
    r.add_argument("--policy", default="apf", help="apf, random, geodesic (the map-knowing reference; any case), "
                   "a pickle-free policy directory, or an SB3 .zip with --trust-pickle")
    r.add_argument("--trust-pickle", action="store_true",
                   help="allow --policy MODEL.zip: SB3 files are pickles and loading one runs any code it holds")
    r.add_argument("--episodes", type=_POS, default=1, help="episodes to run (seeds SEED, SEED+1, ...)")
    r.add_argument("--seed", type=_NONNEG, default=0, help="seed of the first episode")
    r.add_argument("--fields", default=None, help="APF fields to use, e.g. robot,target,height (default: all)")
    r.add_argument("--gif", default=None, help="write the first episode as a GIF (or its last frame as .png)")
    r.add_argument("--mp4", default=None, help="write the first episode as an MP4 video (the [video] extra)")
    r.add_argument("--frame-every", type=_POS, default=5, help="steps between GIF/MP4 frames")
    r.add_argument("--render-width", type=_int_in(*RENDER_WIDTH_PX), default=DEFAULT_RENDER_WIDTH_PX,
                   help="width of GIF/MP4 frames in pixels")
    r.add_argument("--max-cycles", type=_POS, default=None, help="steps per episode (default: the scenario's)")
    r.add_argument("--summary", default=None, help="also write the table to this Markdown file")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=_cmd_run)


def _add_explore_and_scenarios(sub) -> None:
    s = sub.add_parser("scenarios", help="list the built-in scenarios, or copy one to start from",
                       formatter_class=_Formatter)
    s.add_argument("--copy", nargs=2, metavar=("NAME", "DEST"), default=None,
                   help="write the built-in scenario NAME to the file (or into the directory) DEST")
    s.add_argument("--force", action="store_true", help="with --copy: overwrite DEST if it exists")
    s.set_defaults(func=_cmd_scenarios)
    x = sub.add_parser("explore", help="the field explorer (a window, or --png OUT.png headless)",
                       formatter_class=_Formatter)
    x.add_argument("scenario", help="built-in scenario name or a .toml path")
    x.add_argument("--png", default=None, help="draw into this file instead of opening a window")
    x.add_argument("--robot", type=_robot_arg, default="0", help="robot index whose field is shown, or 'all'")
    x.add_argument("--fields", default=None, help="fields switched on, e.g. robot,target,break (default: all)")
    x.add_argument("--robots", type=_POS, default=None, help="number of robots (default: the scenario's)")
    x.add_argument("--steps", type=_NONNEG, default=0, help="APF steps to take before drawing")
    x.add_argument("--seed", type=_NONNEG, default=0, help="reset seed")
    x.add_argument("--cost-to-go", action="store_true",
                   help="overlay contours of the selected robot's target's cost-to-go (m of drivable path)")
    x.set_defaults(func=_cmd_explore)


def _add_train_eval_build(sub) -> None:
    from .args import add_dataclass_args
    from .evaluate import Args as EvalArgs
    from .train import Args as TrainArgs
    from ..terrain.build import METHODS

    t = sub.add_parser("train", help="train PPO (apps/train.py, = agents/train_sb3.py; needs the [train] extra)",
                       formatter_class=_Formatter)
    add_dataclass_args(t, TrainArgs, positional=("scenario",), rename={"total_timesteps": "timesteps"})
    t.set_defaults(func=_cmd_train)
    e = sub.add_parser("eval", help="random, APF and saved policies on the same scenarios and seeds",
                       formatter_class=_Formatter)
    add_dataclass_args(e, EvalArgs, positional=("scenarios",), rename={"models": "model"},
                       cli={"scenarios": {"nargs": "*"}, "models": {"action": "append", "metavar": "MODEL"}})
    e.set_defaults(func=_cmd_eval)
    b = sub.add_parser("build-tin", help="reduce a DEM to a TIN and write it (.tin or .npz)",
                       formatter_class=_Formatter)
    b.add_argument("dem", help="DEM file (.xyz/.txt/.asc/.npy/.npz/.tif) or sample:jacksboro")
    b.add_argument("-o", "--output", required=True, help="output .tin (thesis text) or .npz")
    b.add_argument("--method", choices=list(METHODS), default=None,
                   help="reduction (default: greedy with --max-error-m, else vip; delaunay for point clouds; robot "
                        "needs --max-slope-deg)")
    b.add_argument("--max-vertices", type=_POS, default=None, help="vertex budget (vip default: 5000)")
    b.add_argument("--max-error-m", type=float, default=None, help="greedy: largest vertical error kept (m)")
    b.add_argument("--min-significance-m", type=float, default=None, help="vip: drop points less significant")
    b.add_argument("--max-slope-deg", type=float, default=None,
                   help="robot: the robots' steepest drivable slope, whose class the TIN keeps (deg)")
    b.add_argument("--png", default=None, help="also draw the TIN coloured by slope")
    b.set_defaults(func=_cmd_build_tin)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every subcommand (a flat list of options; see the module docstring)."""
    from .. import __version__

    p = argparse.ArgumentParser(prog="tin-swarm", description="Robot swarms on TIN terrain.",
                                formatter_class=_Formatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    p.add_argument("--debug", action="store_true",
                   help="show the traceback of an error instead of one line (also: TIN_SWARM_DEBUG=1)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_run(sub)
    _add_explore_and_scenarios(sub)
    _add_train_eval_build(sub)
    return p


def main(argv=None) -> int:
    """Parse ``argv`` and run the subcommand; returns the exit status (0 ok, 2 bad input or an
    OSError, 1 an unexpected error, 130 Ctrl-C), printing one line on stderr for any error."""
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:
        print("tin-swarm: interrupted", file=sys.stderr)
        return 130
    debug = args.debug or os.environ.get("TIN_SWARM_DEBUG", "") not in ("", "0")
    try:
        return args.func(args)
    except KeyboardInterrupt:
        if debug:
            raise
        print("tin-swarm: interrupted", file=sys.stderr)
        return 130
    except (TinSwarmError, ValueError, OSError) as exc:
        if debug:
            raise
        print(f"tin-swarm: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug or a library's own error: still one line (the traceback with --debug)
        if debug:
            raise
        print(f"tin-swarm: error: {type(exc).__name__}: {_one_line(exc)} (rerun with --debug for the traceback)",
              file=sys.stderr)
        return 1


def _one_line(exc: BaseException) -> str:
    """The exception's message on one line (an OSError names its file)."""
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        msg = f"{exc.filename}: {exc.strerror}"
    else:
        msg = str(exc) or type(exc).__name__
    return " ".join(msg.split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
