"""``tin-swarm eval --suite standard``: the standard evaluation suite (its maps, seeds and
leaderboard: :mod:`tin_swarm_env.training.suite`) checked, run with every policy given, printed and
written (OUT.md, OUT.csv, OUT_maps.csv), each file whole or not at all.

    tin-swarm eval --suite standard --model shared=agents/models/shared [--model NAME=DIR ...]
    tin-swarm eval --suite standard --quick             # seconds: the first map of each split, 1 seed
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import ArgumentError
from ..training.evaluation import EvalRows, policy_entries, print_files, write_csv, write_text
from ..training.suite import (
    BUDGET_S,
    MIRROR_AXIS,
    PLAYED,
    QUICK,
    SUITES,
    header_line,
    leaderboard_markdown,
    maps_markdown,
    outputs,
    pct,
    play_policy,
    scenario_path,
)
from .evaluate import DEFAULT_SCENARIOS, SUITE_NAMES, Args

__all__ = ["check_suite", "run_suite"]

assert tuple(SUITES) == SUITE_NAMES, "apps/evaluate.py SUITE_NAMES must list the suites of training/suite.py"

def _default(name: str):
    f = Args.__dataclass_fields__[name]
    return f.default

def check_suite(args: Args):
    """Everything a suite run needs, before its first episode: ``(splits, entries, out)`` with
    ``entries`` the rows ``(label, spec, path or None)``; ArgumentError names the option that does
    not apply to a suite (scenarios, ``--seeds``, ``--robots``, ``--seed-offset``: the suite fixes them),
    a bad model or output, or a scenario file the suite reads that is missing."""
    from .._atomic import check_outputs, output_stem

    if args.suite not in SUITES:
        raise ArgumentError(f"--suite {args.suite!r}: choose from {', '.join(SUITES)}")
    if args.scenarios not in ("", DEFAULT_SCENARIOS):
        raise ArgumentError(f"--suite {args.suite}: plays its own maps (tin_swarm_env/training/suite.py); give no "
                            f"scenarios (got {args.scenarios!r})")
    for name in ("seeds", "robots", "seed_offset", "max_cycles", "mirror", "by_family"):
        if getattr(args, name) != _default(name):
            raise ArgumentError(f"--{name.replace('_', '-')}: does not apply to --suite (its seeds, robots and steps "
                                "are fixed: tin_swarm_env/training/suite.py)")
    splits = SUITES[args.suite]
    if args.quick:
        splits = tuple(dataclasses.replace(s, maps=(dataclasses.replace(s.maps[0], **QUICK),)) for s in splits)
    for s in splits:
        for m in s.maps:
            scenario_path(m)
    entries = policy_entries(args, "eval --suite")
    out = output_stem(args.out or Path("runs") / f"suite_{args.suite}{'_quick' if args.quick else ''}")
    if not args.out:
        out.parent.mkdir(parents=True, exist_ok=True)
    check_outputs({f"--out ({what})": p for what, p in outputs(out).items()},
                  inputs=[m for _, _, m in entries if m],
                  scenarios=[scenario_path(m) for s in splits for m in s.maps])
    return splits, entries, out

def run_suite(args: Args, command: str | None = None) -> EvalRows:
    """Play the suite ``args.suite`` (``--quick``: its small version) with every policy of
    ``args``; prints a line per policy as it finishes, then the leaderboard and the paths written
    (OUT.md: header line, leaderboard, splits, per-map table; OUT.csv: the leaderboard;
    OUT_maps.csv: per map). Returns the leaderboard rows with ``.files``. ``command`` is the
    header's command (default: this process's)."""
    splits, entries, out = check_suite(args)
    header = header_line(command)
    rows, maps = [], []
    for label, spec, path in entries:
        row, per_map = play_policy(label, spec, path, splits, args.trust_pickle)
        rows.append(row)
        maps += per_map
        print(f"{label}: arrived {pct(row['arrived'])} %, fell {pct(row['fell'])} %, {row['seconds']:.0f} s",
              flush=True)
    board = leaderboard_markdown(rows, splits)
    over = [f"{r['policy']} took {r['seconds']:.0f} s" for r in rows if r["seconds"] > BUDGET_S]
    if over:
        board += f"\n\nOver the budget of {BUDGET_S:.0f} s for one policy: {', '.join(over)}."
    quick = " (--quick: one map per split, 1 seed, 3 robots, 60 steps; not a measurement)" if args.quick else ""
    eps = sum(m.seeds for s in splits for m in s.maps) * len(PLAYED)
    md = (f"{header}\n\nThe {args.suite} suite{quick}, {eps} episodes per policy (splits: the docstring of "
          "`tin_swarm_env/training/suite.py`, which also says how the figures are averaged): percentages of robots; s: "
          f"seconds for the policy's whole suite.\n\n{board}\n\nPer map (mirror `{MIRROR_AXIS}`: the north-south "
          f"mirror image):\n\n{maps_markdown(maps)}\n")
    o = outputs(out)
    files = [write_text(o["md"], md), write_csv(o["csv"], rows), write_csv(o["maps csv"], maps)]
    print(board)
    print_files(files)
    return EvalRows(rows, files)
