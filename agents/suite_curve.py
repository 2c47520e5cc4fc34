"""Learning curves on the standard suite: arrived % on its splits against training minutes.

    python agents/suite_curve.py runs/ppo_puffer runs/mappo_benchmarl --out docs/figures/learning_curves.png

A run directory (``agents/train_puffer.py``, ``agents/train_benchmarl.py``) holds
``snapshots/mMMM.M/policy`` (the actor every ``--snapshot-minutes``, MMM.M its training minutes)
and ``policy`` (the final actor, at ``run.json``'s minutes). Each is played on the standard
suite's splits (``--splits``, default the train seeds and the held-out families:
:data:`~tin_swarm_env.training.suite.SPLITS`, as ``tin-swarm eval --suite standard`` plays them,
every map as built and mirrored, the evaluation seeds). A split's figure is the mean over its
episodes of the share of robots that arrived (fell), as the suite's leaderboard averages.

Writes the picture ``--out`` (one panel per split, one line per run; the falls dotted) and the
table beside it (``.csv``: run, minutes, split, arrived, fell). ``--quick``: the suite's quick
settings (one seed, 3 robots, 60 steps), a check that it runs.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

from tin_swarm_env.apps.args import opt, parse_dataclass


@dataclass
class Args:
    runs: str = opt("", "run directories, comma-separated")
    out: str = opt("runs/learning_curves.png", "the picture (its table: the same name, .csv)")
    splits: str = opt("train_seeds,held_out", "the suite's splits played, comma-separated keys")
    quick: bool = opt(False, "the suite's quick settings: a check, not a measurement")


def points(run: Path) -> list[tuple[float, Path]]:
    """``(minutes, policy dir)`` of a run's snapshots and final policy, by minutes."""
    pts = [(float(d.name[1:]), d / "policy") for d in (run / "snapshots").glob("m*") if (d / "policy").is_dir()]
    if (run / "policy").is_dir():
        meta = json.loads((run / "run.json").read_text()) if (run / "run.json").is_file() else {}
        pts.append((float(meta.get("minutes", max([m for m, _ in pts], default=0.0))), run / "policy"))
    return sorted(pts)


def play(policy: Path, splits, quick: bool) -> dict:
    """``{split key: (arrived, fell)}``: the episode-weighted means over the split's maps, both ways."""
    from tin_swarm_env.training.suite import QUICK, play_policy

    if quick:
        splits = [dataclasses.replace(s, maps=(dataclasses.replace(s.maps[0], seeds=QUICK["seeds"], robots=QUICK[
            "robots"], max_cycles=QUICK["max_cycles"]),)) for s in splits]
    _, maps = play_policy(policy.parent.name, "", str(policy), splits)
    out = {}
    for s in splits:
        rows = [r for r in maps if r["split"] == s.key]
        n = sum(r["seeds"] for r in rows)
        out[s.key] = tuple(sum(r["seeds"] * r[k] for r in rows) / n for k in ("arrived", "fell"))
    return out


def main(argv=None) -> list[dict]:
    args = parse_dataclass(Args, argv, description=__doc__.splitlines()[0])
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.training.suite import SPLITS

    keys = [k for k in args.splits.split(",") if k]
    by_key = {s.key: s for s in SPLITS}
    bad = [k for k in keys if k not in by_key]
    if bad or not keys:
        raise ArgumentError(f"--splits: unknown split {bad or keys}; the suite's are {list(by_key)}")
    runs = [Path(r) for r in args.runs.split(",") if r]
    if not runs:
        raise ArgumentError("--runs: name at least one run directory")
    rows = []
    for run in runs:
        pts = points(run)
        if not pts:
            raise ArgumentError(f"--runs: {run} has no snapshots/m*/policy nor policy")
        for minutes, pol in pts:
            for k, (arrived, fell) in play(pol, [by_key[k] for k in keys], args.quick).items():
                rows.append({"run": run.name, "minutes": minutes, "split": k, "arrived": arrived, "fell": fell})
                print(rows[-1], flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, keys, {k: by_key[k].name for k in keys}, out)
    print(f"wrote {out} and {out.with_suffix('.csv')}")
    return rows


def plot(rows: list[dict], keys: list[str], names: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(keys), figsize=(5 * len(keys), 3.6), dpi=110, squeeze=False)
    for ax, k in zip(axes[0], keys):
        for i, run in enumerate(dict.fromkeys(r["run"] for r in rows)):
            rr = [r for r in rows if r["run"] == run and r["split"] == k]
            mins = [r["minutes"] for r in rr]
            c = f"C{i}"
            ax.plot(mins, [100 * r["arrived"] for r in rr], ".-", color=c, label=f"{run}: arrived")
            ax.plot(mins, [100 * r["fell"] for r in rr], ":", color=c, label=f"{run}: fell")
        ax.set_ylim(0, 100)
        ax.set_xlabel("training time (minutes, 2 CPU cores)")
        ax.set_ylabel("% of robots")
        ax.set_title(f"{names[k]} (standard suite)")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


if __name__ == "__main__":
    main()
