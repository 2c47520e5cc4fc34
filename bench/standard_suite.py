"""The standard evaluation suite's leaderboard for the docs: random, APF, the geodesic reference, the
shipped policy (agents/models/shared) and every extra ``--model NAME=DIR``, written to
docs/figures/standard_suite.md (its first line: the exact command, commit, date and load average),
.csv (the leaderboard) and _maps.csv (per map). The suite itself is tin_swarm_env/training/suite.py.

    flock /tmp/heavy.lock python bench/standard_suite.py
    python bench/standard_suite.py --quick      # seconds: one map per split, 1 seed; written to a temporary directory
    flock /tmp/heavy.lock python bench/standard_suite.py --model mappo=agents/models/mappo_benchmarl \\
        --model ppo_rllib=agents/models/ppo_rllib
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import tempfile
from pathlib import Path

from tin_swarm_env.apps.evaluate import Args
from tin_swarm_env.apps.suite import run_suite

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "agents" / "models" / "shared"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", action="append", default=[], metavar="NAME=DIR",
                   help="another policy directory to rank (repeatable)")
    p.add_argument("--out", default=None, help="writes OUT.md, OUT.csv and OUT_maps.csv (default "
                   "docs/figures/standard_suite; with --quick a temporary directory)")
    p.add_argument("--quick", action="store_true", help="the seconds-long version (a check, not a measurement)")
    a = p.parse_args(argv)
    models = [f"shared={os.path.relpath(SHIPPED)}", *a.model]
    command = " ".join(["python", os.path.relpath(__file__), *(shlex.quote(x) for x in (argv or sys.argv[1:]))])
    with tempfile.TemporaryDirectory() as tmp:
        out = a.out or (str(Path(tmp) / "standard_suite") if a.quick
                        else os.path.relpath(ROOT / "docs" / "figures" / "standard_suite"))
        run_suite(Args(scenarios="", suite="standard", models=",".join(models), out=out, quick=a.quick),
                  command=command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
