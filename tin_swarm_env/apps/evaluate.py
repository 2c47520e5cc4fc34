"""Evaluate policies on the same scenarios and seeds: random, APF, GeodesicPolicy (the
map-knowing reference, when installed) and learned policies (pickle-free directories or SB3 .zip).

    tin-swarm eval cliff_goal ramp --seeds 20 --model runs/bc_ppo_cliff_goal_s0/policy
    python agents/evaluate.py --scenarios cliff_goal,ramp,hill,generated --seeds 20 \
        --models "bc+dagger=runs/bc_cliff_goal+ramp_s0/policy,ppo=runs/ppo_cliff_goal_s0/model.zip" --trust-pickle true

Rows: ``policies`` (``random``, ``apf``, ``geodesic``) then every entry of ``models``
(``label=path`` or ``path``; a path is a policy directory, loaded without pickle, or an SB3
``.zip``, which unpickles and so needs ``trust_pickle``). Every model runs on every scenario (held-out
ones included). Columns (:data:`METRICS`): arrived, fell, timed out, of which stalled and looping
(:mod:`~tin_swarm_env.apps.trajectory`), steps to arrive, contacts per robot, return per robot,
each a mean with a 95% confidence half-width (Student t) over the robot-episodes (``seeds`` x
robots; steps to arrive over the robots that arrived; robots of one episode are not independent,
so the interval is somewhat narrow); the CSV also has the median steps to arrive
(``steps_to_arrive_median``).

**Seed split.** Evaluation seeds are ``seed_offset .. seed_offset + seeds - 1``, with
``seed_offset`` at least :data:`EVAL_SEED0` by default; training (``apps/train.py``) uses
seeds below it. On ``"generated"`` (a new terrain drawn from each reset seed) the evaluation
terrains are therefore never seen in training. Every option is checked before the first episode
(:func:`check_args`). Writes ``out``.md and .csv and a bar plot ``out``.png (default ``out``:
``runs/eval_<scenarios>``), each file whole or not at all, and prints their paths at the end, one
a line (``wrote PATH``); :func:`evaluate` returns the rows with the paths in ``.files``.

**The standard suite** (``suite="standard"``, ``tin-swarm eval --suite standard --model DIR``):
fixed maps, seeds, robots and steps instead of ``scenarios``/``seeds``/``robots``, one leaderboard
row per policy (:mod:`~tin_swarm_env.apps.suite`).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ArgumentError
from ..world.state import Reason
from .args import check_args as check_fields
from .args import opt
from .rollout import Outcome, rollout

__all__ = ["Args", "METRICS", "EVAL_SEED0", "EvalRows", "evaluate", "check_args", "default_out", "episode_metrics",
           "ci95", "markdown", "bar_figure", "bar_plot", "parse_models", "policy_rows", "policy_entries", "write_text"]

EVAL_SEED0 = 1_000_000  # evaluation seeds start here; training seeds stay below
MIRROR_AXIS = "ns"  # the mirror image played by --mirror and the standard suite (scenario/mirror.py axes)

METRICS = [("arrived", "arrived", "{:.1%}"), ("fell", "fell", "{:.1%}"), ("timed_out", "timed out", "{:.1%}"),
           ("stalled", "stalled", "{:.1%}"), ("looping", "looping", "{:.1%}"),
           ("steps_to_arrive", "steps to arrive", "{:.0f}"), ("contacts", "contacts/robot", "{:.2f}"),
           ("return", "return/robot", "{:.1f}")]


DEFAULT_SCENARIOS = "cliff_goal,ramp"
SUITE_NAMES = ("standard",)  # the suites of apps/suite.py (SUITES there)


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
                     "steps: tin_swarm_env/apps/suite.py), one leaderboard row per policy", check=_suite_name)
    quick: bool = opt(False, "with --suite: a seconds-long version (one map per split, 1 seed, 3 robots, 60 steps)",
                      flag=True)
    mirror: bool = opt(False, "also play each scenario's north-south mirror image, on the same seeds (its rows: "
                       "'SCENARIO (mirror ns)'; tin_swarm_env/scenario/mirror.py)", flag=True)
    max_cycles: int = opt(0, "steps per episode (0: each scenario's own)", lo=0)
    by_family: bool = opt(False, "play each generated scenario once per family of its terrain (rows "
                          "'SCENARIO: FAMILY'), on the same seeds", flag=True)

    def __post_init__(self):
        check_fields(self)


def episode_metrics(o: Outcome) -> dict:
    """Per-robot values of one episode: ``{key: (n,) array}`` for the :data:`METRICS` (steps to
    arrive NaN for the robots that did not arrive)."""
    arrived = o.reasons == Reason.ARRIVED
    return {"arrived": arrived.astype(float), "fell": (o.reasons == Reason.FELL).astype(float),
            "timed_out": (o.reasons == Reason.TIMEOUT).astype(float),
            "stalled": o.stalled.astype(float), "looping": o.looping.astype(float),
            "steps_to_arrive": np.where(arrived, o.steps, np.nan), "contacts": o.collisions.astype(float),
            "return": np.asarray(o.returns, dtype=float)}


def ci95(x):
    """``(mean, 95% half-width)`` of the non-NaN values of ``x`` (Student t)."""
    from scipy import stats

    x = np.asarray(x, dtype=float).ravel()
    x = x[~np.isnan(x)]
    if len(x) == 0:
        return np.nan, np.nan
    if len(x) == 1:
        return float(x[0]), 0.0
    h = stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))
    return float(x.mean()), float(h)


def parse_models(spec: str) -> list[tuple[str, str]]:
    """``"a=path1,path2"`` -> ``[("a", "path1"), ("<name>", "path2")]``; an unlabelled path is
    named after its run directory (``runs/x/policy`` -> ``x``, ``runs/x/model.zip`` -> ``x (zip)``)."""
    out = []
    for item in [m.strip() for m in spec.split(",") if m.strip()]:
        label, _, path = item.rpartition("=")
        if not label:
            p = Path(path)
            run = p.parent.name if p.name in ("policy", "model.zip", "policy.json") else p.stem
            label = (run or p.name) + (" (zip)" if p.suffix == ".zip" else "")
        out.append((label, path))
    return out


def policy_rows(names: str) -> list[str]:
    """The built-in rows of ``names`` (comma-separated, any case): ``random``, ``apf``, ``apf-chart``,
    ``geodesic`` (:data:`~tin_swarm_env.apps.policy_factory.POLICY_NAMES`)."""
    from .policy_factory import POLICY_NAMES

    rows = [p.strip().lower() for p in names.split(",") if p.strip()]
    bad = [p for p in rows if p not in POLICY_NAMES]
    if bad:
        raise ArgumentError(f"--policies: unknown {bad}; choose from {','.join(POLICY_NAMES)} (models go in --model)")
    return rows


def default_out(scenarios) -> str:
    """The default output stem of an evaluation: ``runs/eval_<scenario>_<scenario>...``."""
    return str(Path("runs") / ("eval_" + "_".join(Path(s).stem for s in scenarios)))


def policy_entries(args: Args, where: str = "eval") -> list[tuple[str, str, str | None]]:
    """The rows to evaluate, checked: ``(label, spec, path or None)`` for each built-in policy of
    ``args.policies`` then each ``args.models`` entry (its file checked, a .zip only with
    ``trust_pickle``). ArgumentError when there is none or two rows share a label."""
    from .policy_factory import check_policy_spec

    entries = [(p, p, None) for p in policy_rows(args.policies)]
    for label, path in parse_models(args.models):
        check_policy_spec(path, args.trust_pickle, option="--model")
        entries.append((label, label, path))
    if not entries:
        raise ArgumentError(f"{where}: nothing to evaluate (no --policies and no --model)")
    labels = [e[0] for e in entries]
    if len(set(labels)) != len(labels):
        raise ArgumentError(f"--model: two rows named {sorted({x for x in labels if labels.count(x) > 1})}; "
                            "label them NAME=DIR")
    return entries


def check_args(args: Args) -> tuple[list, list, Path]:
    """Everything an evaluation needs, checked before its first episode: returns ``(played,
    entries, out)`` with ``played`` the ``(label, ScenarioConfig)`` of each scenario (then its mirror
    image with ``mirror``) and ``entries`` the rows ``(label, spec, path or None)``. ArgumentError
    names the option (no seeds, no scenario, an unknown policy name, a model that is missing or a
    .zip without trust_pickle, an output that cannot be written); a scenario that does not load
    raises its own error, naming the file and key."""
    from .._atomic import check_outputs
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
    out = Path(args.out or default_out(scens))
    if not args.out:
        out.parent.mkdir(parents=True, exist_ok=True)
    check_outputs({f"--out ({ext})": out.with_suffix(ext) for ext in (".md", ".csv", ".png")},
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


class EvalRows(list):
    """The rows of an evaluation (a list of dicts), with ``files``: the paths it wrote."""

    files: list[Path]

    def __init__(self, rows=(), files=()):
        super().__init__(rows)
        self.files = [Path(f) for f in files]


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` whole or not at all (:func:`~tin_swarm_env._atomic.atomic_path`)."""
    from .._atomic import atomic_path

    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        fh.write(text)
    return Path(path)


def write_csv(path, rows: list[dict]) -> Path:
    """The rows as CSV (the first row's keys as the header), whole or not at all."""
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    return write_text(path, buf.getvalue())


def print_files(files) -> None:
    """``wrote PATH``, one line per file written."""
    for f in files:
        print(f"wrote {f}", flush=True)


def evaluate(args: Args) -> EvalRows:
    """Every (scenario, row) over ``args.seeds`` seeds; prints a line each, writes the
    Markdown table, the CSV and the bar plot, prints their paths; returns the rows with
    ``.files``. A suite (``args.suite``) is run by :func:`tin_swarm_env.apps.suite.run_suite`
    (``tin-swarm eval --suite`` and ``agents/evaluate.py`` call it)."""
    if args.suite:
        raise ArgumentError(f"--suite {args.suite}: run it with tin_swarm_env.apps.suite.run_suite(args) (evaluate() "
                            "runs SCENARIOS)")
    from ..env import parallel_env
    from .policy_factory import make_policy
    from .run import progress_bar

    played, entries, out = check_args(args)
    rows = []
    for scen, cfg in played:
        env = parallel_env(scenario=cfg, n_robots=args.robots or None, max_cycles=args.max_cycles or None)
        for label, spec, path in entries:
            pol = make_policy(env, spec if path is None else path, seed=args.seed_offset,
                              trust_pickle=args.trust_pickle)
            bar = progress_bar(args.seeds, f"{scen} {label}")
            eps = []
            for k in range(args.seeds):
                eps.append(episode_metrics(rollout(env, pol, args.seed_offset + k)))
                if bar is not None:
                    bar.update(1)
            if bar is not None:
                bar.close()
            row = {"scenario": scen, "policy": label, "seeds": args.seeds, "robots": env.n,
                   "seed_offset": args.seed_offset, "max_cycles": env.max_cycles}
            for key, _, _ in METRICS:
                row[key], row[key + "_ci95"] = ci95(np.concatenate([e[key] for e in eps]))
            steps = np.concatenate([e["steps_to_arrive"] for e in eps])
            row["steps_to_arrive_median"] = float(np.nanmedian(steps)) if np.isfinite(steps).any() else np.nan
            rows.append(row)
            print(f"{scen:12s} {label:28s} arrived {row['arrived']:.1%} ± {row['arrived_ci95']:.1%}, "
                  f"fell {row['fell']:.1%}, timed out {row['timed_out']:.1%} (stalled {row['stalled']:.1%}, "
                  f"looping {row['looping']:.1%}), return {row['return']:.1f}", flush=True)
    md = markdown(rows)
    files = [write_text(out.with_suffix(".md"), md + "\n"), write_csv(out.with_suffix(".csv"), rows),
             bar_plot(rows, out.with_suffix(".png"))]
    print(md)
    print_files(files)
    return EvalRows(rows, files)


def markdown(rows) -> str:
    head = "| scenario | policy | " + " | ".join(name for _, name, _ in METRICS) + " |"
    lines = [head, "|---|---|" + "---:|" * len(METRICS)]
    for r in rows:
        cells = []
        for key, _, fmt in METRICS:
            m, h = r[key], r[key + "_ci95"]
            cells.append("–" if np.isnan(m) else f"{fmt.format(m)} ± {fmt.format(h)}")
        lines.append(f"| {r['scenario']} | {r['policy']} | " + " | ".join(cells) + " |")
    r0 = rows[0]
    seeds = f"{r0['seeds']} seed{'s' if r0['seeds'] != 1 else ''}"
    return "\n".join(lines) + (f"\n\n{seeds} each (from {r0['seed_offset']}), mean ± 95% confidence "
                               "half-width (Student t) over robot-episodes.")


_PANELS = (("arrived", "arrival rate", True), ("fell", "falls", True), ("return", "return/robot", False))


def bar_figure(rows):
    """The bar plot of :func:`bar_plot` as a matplotlib Figure: arrival rate, falls (both on a
    0-100 % axis, each bar labelled with its value) and return per robot, one group of bars per
    scenario, one colour per policy, the legend beside the panels (outside every axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import PercentFormatter

    scen = list(dict.fromkeys(r["scenario"] for r in rows))
    pols = list(dict.fromkeys(r["policy"] for r in rows))
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), dpi=110, layout="constrained")
    w = 0.8 / len(pols)
    for ax, (key, name, rate) in zip(axes, _PANELS):
        span = []
        for j, p in enumerate(pols):
            got = [next((r for r in rows if r["scenario"] == s and r["policy"] == p), None) for s in scen]
            vals = np.array([np.nan if r is None else r[key] for r in got], dtype=float)
            errs = np.array([0.0 if r is None or np.isnan(r[key + "_ci95"]) else r[key + "_ci95"] for r in got])
            bars = ax.bar(np.arange(len(scen)) + j * w, vals, w, yerr=errs, capsize=3, label=p, color=f"C{j % 10}")
            if rate:
                ax.bar_label(bars, labels=["" if np.isnan(v) else f"{v:.0%}" for v in vals], fontsize=6, padding=1)
            span += [v for v in (vals - errs).tolist() + (vals + errs).tolist() if np.isfinite(v)]
        if rate:  # a share: always the whole 0-100 % (all zeros included)
            ax.set_ylim(0.0, 1.12)
            ax.set_yticks(np.linspace(0, 1, 6))
            ax.yaxis.set_major_formatter(PercentFormatter(1.0, decimals=0))
        elif not span or max(span) == min(span):  # no spread: a fixed range round the value, not +-4 % of it
            c = span[0] if span else 0.0
            ax.set_ylim(min(c, 0.0) - 1.0, max(c, 0.0) + 1.0)
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.set_xticks(np.arange(len(scen)) + 0.4 - w / 2, scen, rotation=20 if len(scen) > 3 else 0, ha="right"
                      if len(scen) > 3 else "center", fontsize=8)
        ax.set_title(name)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right upper", fontsize=8, title="policy", title_fontsize=8)
    return fig


def bar_plot(rows, path) -> Path:
    """Write :func:`bar_figure` to ``path`` (PNG), whole or not at all; returns the path."""
    import matplotlib.pyplot as plt

    from .._atomic import atomic_path

    fig = bar_figure(rows)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
    return Path(path)
