"""Evaluate policies on the same scenarios and seeds: random, APF and saved models.

    tin-swarm eval cliff_goal ramp --seeds 20 --model runs/ppo_cliff_goal/policy
    tin-swarm eval cliff_goal --model runs/ppo_cliff_goal/model.zip --trust-pickle   # an SB3 .zip (a pickle)
    python agents/evaluate.py --scenarios cliff_goal,ramp --seeds 20 --models runs/ppo_cliff_goal/policy

A model is a pickle-free policy directory (policy.json + weights.npz); an SB3 ``.zip`` is
unpickled, which can run code, so it needs ``trust_pickle``. Every option is checked before the
first episode (:func:`check_args`).

A model is evaluated on every scenario it is given with (``models`` are matched to scenarios by
the scenario recorded in their ``model.json`` when there is one, else used on all). Per
(scenario, policy): arrival rate, fall rate, collisions per robot, battery used, steps to
arrive, episode return per robot, each as a mean over seeds with a 95% confidence interval
(Student t). Writes ``out``.md and .csv and a bar plot ``out``.png (default ``out``:
``runs/eval_<scenarios>``).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..world.state import Reason
from .rollout import Outcome, rollout

__all__ = ["Args", "METRICS", "evaluate", "check_args", "default_out", "episode_metrics", "ci95", "markdown",
           "bar_plot"]

METRICS = [("arrived", "arrival rate", "{:.1%}"), ("fell", "falls", "{:.1%}"),
           ("collisions", "collisions/robot", "{:.2f}"), ("battery_used", "battery used", "{:.1%}"),
           ("steps_to_arrive", "steps to arrive", "{:.0f}"), ("return", "return/robot", "{:.1f}")]


@dataclass
class Args:
    scenarios: str = "cliff_goal,ramp"
    seeds: int = 20
    robots: int = 0  # 0: the scenario's count
    models: str = ""  # comma-separated policy directories (or SB3 .zip files with trust_pickle)
    policies: str = "random,apf"
    out: str = ""  # "": runs/eval_<scenarios>
    seed0: int = 1000  # evaluation seeds are seed0 .. seed0 + seeds - 1 (not the training seeds)
    trust_pickle: bool = False  # allow SB3 .zip models (unpickled: they can run code)


def default_out(scenarios) -> str:
    """The default output stem of an evaluation: ``runs/eval_<scenario>_<scenario>...``."""
    names = [Path(s).stem for s in scenarios]
    return str(Path("runs") / ("eval_" + "_".join(names)))


def check_args(args: Args) -> tuple[list, list, list, Path]:
    """Everything an evaluation needs, checked before its first episode: returns ``(scenarios,
    policies, models, out)``. ArgumentError names the option (no seeds, no scenario, an unknown
    policy name, a model that is missing or a .zip without trust_pickle, an output that cannot
    be written)."""
    from .._atomic import check_outputs
    from ..errors import ArgumentError, check_range
    from .policy_factory import POLICY_NAMES, check_policy_spec

    check_range("eval", "seeds", args.seeds, 1, integer=True, exc=ArgumentError)
    check_range("eval", "robots", args.robots, 0, integer=True, exc=ArgumentError)
    scens = [s for s in args.scenarios.split(",") if s]
    if not scens:
        raise ArgumentError("eval: give at least one scenario")
    pols = [p.strip().lower() for p in args.policies.split(",") if p.strip()]
    bad = [p for p in pols if p not in POLICY_NAMES]
    if bad:
        raise ArgumentError(f"--policies: unknown {bad}; choose from {','.join(POLICY_NAMES)} (models go in --model)")
    models = [m for m in args.models.split(",") if m]
    for m in models:
        check_policy_spec(m, args.trust_pickle, option="--model")
    if not pols and not models:
        raise ArgumentError("eval: nothing to evaluate (no --policies and no --model)")
    out = Path(args.out or default_out(scens))
    if not args.out:
        out.parent.mkdir(parents=True, exist_ok=True)
    check_outputs({f"--out ({ext})": out.with_suffix(ext) for ext in (".md", ".csv", ".png")}, inputs=models)
    return scens, pols, models, out


def episode_metrics(o: Outcome) -> dict:
    """The :data:`METRICS` of one episode (means over its robots)."""
    return {"arrived": o.share(Reason.ARRIVED), "fell": o.share(Reason.FELL), "collisions": o.collisions.mean(),
            "battery_used": 1 - o.battery_left.mean(), "steps_to_arrive": o.steps_to_arrive(),
            "return": o.returns.mean()}


def ci95(x):
    """``(mean, 95% half-width)`` of the non-NaN values of ``x`` (Student t)."""
    from scipy import stats

    x = np.asarray([v for v in x if not np.isnan(v)], dtype=float)
    if len(x) == 0:
        return np.nan, np.nan
    if len(x) == 1:
        return float(x[0]), 0.0
    h = stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))
    return float(x.mean()), float(h)


def model_scenario(path):
    """The scenario a saved model was trained on (its ``model.json``), or None."""
    meta = Path(path).with_name("model.json")
    if meta.exists():
        return json.loads(meta.read_text())["args"]["scenario"]
    return None


def _entries(scen, policies, models):
    out = [(p, p) for p in policies]
    for m in models:
        ms = model_scenario(m)
        if ms is None or ms == scen:
            out.append((f"ppo ({Path(m).parent.name or Path(m).stem})", m))
    return out


def evaluate(args: Args) -> list[dict]:
    """Every (scenario, policy) over ``args.seeds`` seeds; prints a line each, writes the
    Markdown table, the CSV and the bar plot, returns the rows."""
    from ..env import parallel_env
    from .policy_factory import make_policy
    from .run import progress_bar

    scenarios, policies, models, out = check_args(args)
    rows = []
    for scen in scenarios:
        env = parallel_env(scenario=scen, n_robots=args.robots or None)
        for label, spec in _entries(scen, policies, models):
            pol = make_policy(env, spec, seed=args.seed0, trust_pickle=args.trust_pickle)
            bar = progress_bar(args.seeds, f"{scen} {label}")
            eps = []
            for k in range(args.seeds):
                eps.append(episode_metrics(rollout(env, pol, args.seed0 + k)))
                if bar is not None:
                    bar.update(1)
            if bar is not None:
                bar.close()
            row = {"scenario": scen, "policy": label, "seeds": args.seeds, "robots": env.n}
            for key, _, _ in METRICS:
                row[key], row[key + "_ci95"] = ci95([e[key] for e in eps])
            rows.append(row)
            print(f"{scen:12s} {label:28s} arrived {row['arrived']:.1%} ± {row['arrived_ci95']:.1%}, "
                  f"fell {row['fell']:.1%}, return {row['return']:.1f} ± {row['return_ci95']:.1f}")
    md = markdown(rows)
    out.with_suffix(".md").write_text(md + "\n")
    with open(out.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    bar_plot(rows, out.with_suffix(".png"))
    print(md)
    return rows


def markdown(rows) -> str:
    head = "| scenario | policy | " + " | ".join(name for _, name, _ in METRICS) + " |"
    lines = [head, "|---|---|" + "---:|" * len(METRICS)]
    for r in rows:
        cells = []
        for key, _, fmt in METRICS:
            m, h = r[key], r[key + "_ci95"]
            cells.append("–" if np.isnan(m) else f"{fmt.format(m)} ± {fmt.format(h)}")
        lines.append(f"| {r['scenario']} | {r['policy']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + f"\n\n{rows[0]['seeds']} seeds each, mean ± 95% confidence half-width (Student t)."


def bar_plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scen = list(dict.fromkeys(r["scenario"] for r in rows))
    pols = list(dict.fromkeys(r["policy"] for r in rows))
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4), dpi=110)
    for ax, (key, name) in zip(axes, (("arrived", "arrival rate"), ("fell", "falls"), ("return", "return/robot"))):
        w = 0.8 / len(pols)
        for j, p in enumerate(pols):
            vals = [next((r[key] for r in rows if r["scenario"] == s and r["policy"] == p), np.nan) for s in scen]
            errs = [next((r[key + "_ci95"] for r in rows if r["scenario"] == s and r["policy"] == p), 0) for s in scen]
            ax.bar(np.arange(len(scen)) + j * w, vals, w, yerr=errs, capsize=3, label=p)
        ax.set_xticks(np.arange(len(scen)) + 0.4 - w / 2, scen)
        ax.set_title(name)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
