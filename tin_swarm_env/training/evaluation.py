"""Evaluation rows: the seeds evaluation starts from (:data:`EVAL_SEED0`; training seeds stay
below it), the per-robot metrics of an episode (:data:`METRICS`, :func:`episode_metrics`) and their
95 % intervals (:func:`ci95`), the rows to evaluate (built-in policies by name and policy files,
:func:`policy_entries`), and the rows written as Markdown, CSV and a bar plot, each file whole or
not at all. ``tin-swarm eval`` (:mod:`tin_swarm_env.apps.evaluate`) and the standard suite
(:mod:`tin_swarm_env.training.suite`) are built on it.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import ArgumentError
from ..world.state import Reason
from .rollout import Outcome, rollout

__all__ = ["EVAL_SEED0", "MIRROR_AXIS", "METRICS", "episode_metrics", "ci95", "parse_models", "policy_rows",
           "policy_entries", "EvalRows", "write_text", "write_csv", "print_files", "evaluation_row", "markdown",
           "bar_figure", "bar_plot", "progress_bar"]

EVAL_SEED0 = 1_000_000  # evaluation seeds start here; training seeds stay below

MIRROR_AXIS = "ns"  # the mirror image played by --mirror and the standard suite (scenario/mirror.py axes)

METRICS = [("arrived", "arrived", "{:.1%}"), ("fell", "fell", "{:.1%}"), ("timed_out", "timed out", "{:.1%}"),
           ("stalled", "stalled", "{:.1%}"), ("looping", "looping", "{:.1%}"),
           ("steps_to_arrive", "steps to arrive", "{:.0f}"), ("contacts", "contacts/robot", "{:.2f}"),
           ("return", "return/robot", "{:.1f}")]

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
    ``geodesic`` (:data:`~tin_swarm_env.training.policy_factory.POLICY_NAMES`)."""
    from .policy_factory import POLICY_NAMES

    rows = [p.strip().lower() for p in names.split(",") if p.strip()]
    bad = [p for p in rows if p not in POLICY_NAMES]
    if bad:
        raise ArgumentError(f"--policies: unknown {bad}; choose from {','.join(POLICY_NAMES)} (models go in --model)")
    return rows

def policy_entries(args, where: str = "eval") -> list[tuple[str, str, str | None]]:
    """The rows to evaluate, checked: ``(label, spec, path or None)`` for each built-in policy of
    ``args.policies`` (an ``Args`` of ``tin-swarm eval``) then each ``args.models`` entry (its file checked, a .zip only with
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


def evaluation_row(env, pol, scen: str, label: str, seeds: int, seed_offset: int, progress: bool = True) -> dict:
    """One row of an evaluation: ``pol`` on ``env`` over the seeds ``seed_offset .. seed_offset +
    seeds - 1``, each metric of :data:`METRICS` as a mean and its 95 % half-width (``<key>_ci95``)
    over the robot-episodes, and the median steps to arrive."""
    bar = progress_bar(seeds, f"{scen} {label}", progress)
    eps = []
    for k in range(seeds):
        eps.append(episode_metrics(rollout(env, pol, seed_offset + k)))
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    row = {"scenario": scen, "policy": label, "seeds": seeds, "robots": env.n, "seed_offset": seed_offset,
           "max_cycles": env.max_cycles}
    for key, _, _ in METRICS:
        row[key], row[key + "_ci95"] = ci95(np.concatenate([e[key] for e in eps]))
    steps = np.concatenate([e["steps_to_arrive"] for e in eps])
    row["steps_to_arrive_median"] = float(np.nanmedian(steps)) if np.isfinite(steps).any() else np.nan
    return row


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


def progress_bar(total: int, desc: str, enabled: bool = True):
    """A tqdm bar on stderr (rate and ETA) counting ``total`` steps, or None when disabled or
    tqdm is not installed (then nothing is shown). Used by ``tin-swarm run`` and ``tin-swarm eval``."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:  # pragma: no cover - tqdm is a core dependency
        return None
    # disable=None: no bar when stderr is not a terminal (logs, CI)
    return tqdm(total=total, desc=desc, unit="step", leave=False, dynamic_ncols=True, disable=None)
