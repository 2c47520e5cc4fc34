"""Evaluate policies on the same scenarios and seeds: random, APF, GeodesicPolicy (the
map-knowing reference, when installed) and learned policies (pickle-free directories or SB3 .zip).

    tin-swarm eval cliff_goal ramp --seeds 20 --model runs/bc_ppo_cliff_goal_s0/policy
    python agents/evaluate.py --scenarios cliff_goal,ramp,hill,generated --seeds 20 \
        --models "bc+dagger=runs/bc_cliff_goal+ramp_s0/policy,ppo=runs/ppo_cliff_goal_s0/model.zip" --trust-pickle true

Rows: ``policies`` (``random``, ``apf``, ``geodesic``) then every entry of ``models``
(``label=path`` or ``path``; a path is a policy directory, loaded without pickle, or an SB3
``.zip``, which unpickles and so needs ``trust_pickle``). Every model runs on every scenario (held-out
ones included). Columns (:data:`~tin_swarm_env.training.evaluation.METRICS`): arrived, fell, timed out, of which stalled and looping
(:mod:`~tin_swarm_env.training.trajectory`), steps to arrive, contacts per robot, return per robot,
each a mean with a 95% confidence half-width (Student t) over the robot-episodes (``seeds`` x
robots; steps to arrive over the robots that arrived; robots of one episode are not independent,
so the interval is somewhat narrow); the CSV also has the median steps to arrive
(``steps_to_arrive_median``). The rows, their metrics and files are the library's
(:mod:`tin_swarm_env.training.evaluation`); this module is the command.

**Seed split.** Evaluation seeds are ``seed_offset .. seed_offset + seeds - 1``, with
``seed_offset`` at least :data:`~tin_swarm_env.training.evaluation.EVAL_SEED0` by default; training (:mod:`tin_swarm_env.training`) uses
seeds below it. On ``"generated"`` (a new terrain drawn from each reset seed) the evaluation
terrains are therefore never seen in training. Every option is checked before the first episode
(:func:`check_args`). Writes ``out``.md and .csv and a bar plot ``out``.png (default ``out``:
``runs/eval_<scenarios>``), each file whole or not at all, and prints their paths at the end, one
a line (``wrote PATH``); :func:`evaluate` returns the rows with the paths in ``.files``.

**The standard suite** (``suite="standard"``, ``tin-swarm eval --suite standard --model DIR``):
fixed maps, seeds, robots and steps instead of ``scenarios``/``seeds``/``robots``, one leaderboard
row per policy (:mod:`~tin_swarm_env.apps.suite`; the suite's maps: :mod:`~tin_swarm_env.training.suite`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .._atomic import stem_file
from ..errors import ArgumentError
from ..options import check_args as check_fields
from ..options import opt
from ..training.evaluation import (EVAL_SEED0, METRICS, MIRROR_AXIS, EvalRows, bar_figure, bar_plot, ci95,
                                   episode_metrics, evaluation_row, markdown, parse_models, policy_entries, policy_rows,
                                   print_files, write_csv, write_text)

__all__ = ["Args", "METRICS", "EVAL_SEED0", "EvalRows", "evaluate", "check_args", "default_out", "episode_metrics",
           "ci95", "markdown", "bar_figure", "bar_plot", "parse_models", "policy_rows", "policy_entries", "write_text",
           "write_csv", "MIRROR_AXIS", "DEFAULT_SCENARIOS", "SUITE_NAMES"]

DEFAULT_SCENARIOS = "cliff_goal,ramp"

SUITE_NAMES = ("standard",)  # the suites of training/suite.py (SUITES there)

def _suite_name(v: str):
    return None if v in ("", *SUITE_NAMES) else f"choose from {', '.join(SUITE_NAMES)} (or leave it out)"

@dataclass
class Args:
    """``tin-swarm eval`` / ``agents/evaluate.py``: every option, its help and what it accepts."""

    scenarios: str = opt(DEFAULT_SCENARIOS, "built-in scenario names or .toml paths (comma-separated; on the "
                         "command line, space-separated; none with --suite)")
    seeds: int = opt(20, "episodes (seeds) per scenario and policy", lo=1)
    robots: int = opt(0, "robots per episode (0: the scenario's)", lo=0)
    models: str = opt("", "a pickle-free policy directory ([NAME=]path), or an SB3 .zip with --trust-pickle "
                      "(repeatable, or comma-separated)")
    policies: str = opt("random,apf,geodesic", "built-in policies to evaluate as well (random, apf, geodesic: the "
                        "map-knowing reference; comma-separated, empty: none)")
    out: str = opt("", "writes OUT.md, OUT.csv and OUT.png (empty: runs/eval_<scenarios>); with --suite OUT.md, "
                   "OUT.csv and OUT_maps.csv (empty: runs/suite_<suite>[_quick])")
    seed_offset: int = opt(EVAL_SEED0, f"evaluation seeds are SEED_OFFSET .. SEED_OFFSET + SEEDS - 1 (training "
                           f"uses the seeds below EVAL_SEED0 = {EVAL_SEED0}, so the default is held out)", lo=0)
    trust_pickle: bool = opt(False, "allow SB3 .zip models: they are pickles and loading one runs any code it "
                             "holds", flag=True)
    suite: str = opt("", "run a fixed suite instead of SCENARIOS [one of: standard] (its maps, seeds, robots and "
                     "steps: tin_swarm_env/training/suite.py), one leaderboard row per policy", check=_suite_name)
    quick: bool = opt(False, "with --suite: a seconds-long version (one map per split, 1 seed, 3 robots, 60 steps)",
                      flag=True)
    mirror: bool = opt(False, "also play each scenario's north-south mirror image, on the same seeds (its rows: "
                       "'SCENARIO (mirror ns)'; tin_swarm_env/scenario/mirror.py)", flag=True)
    max_cycles: int = opt(0, "steps per episode (0: each scenario's own)", lo=0)
    by_family: bool = opt(False, "play each generated scenario once per family of its terrain (rows "
                          "'SCENARIO: FAMILY'), on the same seeds", flag=True)

    def __post_init__(self):
        check_fields(self)

def default_out(scenarios) -> str:
    """The default output stem of an evaluation: ``runs/eval_<scenario>_<scenario>...``."""
    return str(Path("runs") / ("eval_" + "_".join(Path(s).stem for s in scenarios)))

def check_args(args: Args) -> tuple[list, list, Path]:
    """Everything an evaluation needs, checked before its first episode: returns ``(played,
    entries, out)`` with ``played`` the ``(label, ScenarioConfig)`` of each scenario (then its mirror
    image with ``mirror``) and ``entries`` the rows ``(label, spec, path or None)``. ArgumentError
    names the option (no seeds, no scenario, an unknown policy name, a model that is missing or a
    .zip without trust_pickle, an output that cannot be written); a scenario that does not load
    raises its own error, naming the file and key."""
    from .._atomic import check_outputs, output_stem
    from ..errors import check_range
    from ..scenario import load_scenario, mirror_scenario
    from ..scenario.generators import ALL_FAMILIES, family_weights

    check_range("eval", "seeds", args.seeds, 1, integer=True, exc=ArgumentError)
    check_range("eval", "robots", args.robots, 0, integer=True, exc=ArgumentError)
    check_range("eval", "seed_offset", args.seed_offset, 0, integer=True, exc=ArgumentError)
    scens = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    if not scens:
        raise ArgumentError("eval: give at least one scenario (or --suite standard)")
    if args.quick:
        raise ArgumentError("--quick applies to --suite only")
    configs = [load_scenario(s) for s in scens]  # a missing file or a bad key is refused before any episode
    entries = policy_entries(args, "eval")
    out = output_stem(args.out or default_out(scens))
    if not args.out:
        out.parent.mkdir(parents=True, exist_ok=True)
    check_outputs({f"--out ({ext})": stem_file(out, ext) for ext in (".md", ".csv", ".png")},
                  inputs=[m for _, _, m in entries if m], scenarios=scens)
    if args.by_family and not any(c.terrain.source == "generated" for c in configs):
        raise ArgumentError(f"--by-family: no scenario of {scens} is generated (their [terrain] sources: "
                            f"{sorted({c.terrain.source for c in configs})}); it splits generated terrains by family "
                            "and applies to none of them")
    played = []
    for s, c in zip(scens, configs):
        if args.by_family and c.terrain.source == "generated":
            played += [(f"{s}: {f}", c.with_families((f,)))
                       for f in family_weights(c.terrain.families or ALL_FAMILIES, "families")[0]]
        else:
            played.append((s, c))
    if args.mirror:
        played = [x for s, c in played
                  for x in ((s, c), (f"{s} (mirror {MIRROR_AXIS})", mirror_scenario(c, MIRROR_AXIS)))]
    return played, entries, out


def evaluate(args: Args) -> EvalRows:
    """Every (scenario, row) over ``args.seeds`` seeds; prints a line each, writes the
    Markdown table, the CSV and the bar plot, prints their paths; returns the rows with
    ``.files``. A suite (``args.suite``) is run by :func:`tin_swarm_env.apps.suite.run_suite`
    (``tin-swarm eval --suite`` and ``agents/evaluate.py`` call it)."""
    if args.suite:
        raise ArgumentError(f"--suite {args.suite}: run it with tin_swarm_env.apps.suite.run_suite(args) (evaluate() "
                            "runs SCENARIOS)")
    from ..env import parallel_env
    from ..training.policy_factory import make_policy, policy_scenario

    played, entries, out = check_args(args)
    rows = []
    for scen, cfg in played:
        envs = {}  # one env per observation layout: a policy file runs on the layout it was trained on
        for label, spec, path in entries:
            p_cfg = policy_scenario(cfg, spec if path is None else path, args.trust_pickle)
            key = repr(p_cfg.observation)
            if key not in envs:
                envs[key] = parallel_env(scenario=p_cfg, n_robots=args.robots or None,
                                         max_cycles=args.max_cycles or None)
            env = envs[key]
            pol = make_policy(env, spec if path is None else path, seed=args.seed_offset,
                              trust_pickle=args.trust_pickle)
            row = evaluation_row(env, pol, scen, label, args.seeds, args.seed_offset)
            rows.append(row)
            print(f"{scen:12s} {label:28s} arrived {row['arrived']:.1%} ± {row['arrived_ci95']:.1%}, "
                  f"fell {row['fell']:.1%}, timed out {row['timed_out']:.1%} (stalled {row['stalled']:.1%}, "
                  f"looping {row['looping']:.1%}), return {row['return']:.1f}", flush=True)
    md = markdown(rows)
    files = [write_text(stem_file(out, ".md"), md + "\n"), write_csv(stem_file(out, ".csv"), rows),
             bar_plot(rows, stem_file(out, ".png"))]
    print(md)
    print_files(files)
    return EvalRows(rows, files)
