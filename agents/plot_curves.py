"""Training curves of one or more ``agents/train_sb3.py`` runs side by side.

    python agents/plot_curves.py runs/ppo_cliff_goal runs/ppo_ramp --out curves.png

Each panel: evaluation return per robot against training time (minutes, bottom axis) and
timesteps (top), with the share of robots that arrived and fell on the right axis. The return
axis starts at the 5th percentile so that the first random-policy evaluations do not flatten it.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np


def main(runs, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(6 * len(runs), 3.6), dpi=110, squeeze=False)
    for ax, run in zip(axes[0], runs):
        rows = list(csv.DictReader(open(Path(run) / "eval.csv")))
        mins = np.array([float(r["minutes"]) for r in rows])
        ret = np.array([float(r["return"]) for r in rows])
        ax.plot(mins, ret, ".-", label="return per robot")
        lo = np.percentile(ret, 5)
        ax.set_ylim(lo - 0.1 * (ret.max() - lo), ret.max() + 0.1 * (ret.max() - lo))
        ax.set_xlabel("training time (minutes, 2 CPU cores)")
        ax.set_ylabel("evaluation return per robot")
        ax.set_title(f"{Path(run).name}: {int(float(rows[-1]['timesteps'])):,} timesteps")
        ax2 = ax.twinx()
        ax2.plot(mins, [float(r["arrived"]) for r in rows], "g-", lw=1, label="arrived")
        ax2.plot(mins, [float(r["fell"]) for r in rows], "r:", lw=1, label="fell")
        ax2.set_ylim(0, 1)
        ax2.set_ylabel("share of robots")
    handles = [h for a in fig.axes for h in a.get_lines()]
    fig.legend(handles[:3], [h.get_label() for h in handles[:3]], loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+")
    p.add_argument("--out", default="curves.png")
    a = p.parse_args()
    main(a.runs, a.out)
