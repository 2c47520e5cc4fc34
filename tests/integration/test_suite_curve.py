"""agents/suite_curve.py: a run's snapshots and final policy, by training minutes, each played on the
suite's splits (its quick settings here), written as a table and a picture; bad arguments named."""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
import sys
from pathlib import Path

import pytest

from tin_swarm_env.errors import ArgumentError

ROOT = Path(__file__).resolve().parents[2]


def _module():
    spec = importlib.util.spec_from_file_location("suite_curve", ROOT / "agents" / "suite_curve.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclass looks its module up
    spec.loader.exec_module(mod)
    return mod


def test_a_run_s_points_are_played_and_written(tmp_path):
    mod = _module()
    run = tmp_path / "run"
    for d in ("snapshots/m010.0/policy", "snapshots/m005.0/policy", "policy"):
        shutil.copytree(ROOT / "agents" / "models" / "shared_mirror", run / d)
    (run / "run.json").write_text(json.dumps({"minutes": 12.5}))
    assert [m for m, _ in mod.points(run)] == [5.0, 10.0, 12.5]
    out = tmp_path / "c.png"
    rows = mod.main(["--runs", str(run), "--splits", "train_seeds,thesis", "--quick", "true", "--out", str(out)])
    assert [(r["minutes"], r["split"]) for r in rows] == [(m, k) for m in (5.0, 10.0, 12.5)
                                                          for k in ("train_seeds", "thesis")]
    assert all(0.0 <= r["arrived"] <= 1.0 and 0.0 <= r["fell"] <= 1.0 for r in rows)
    # the same file at every point: the same figures (the suite's seeds are fixed)
    assert len({(r["arrived"], r["fell"]) for r in rows if r["split"] == "thesis"}) == 1
    assert out.stat().st_size > 1000 and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = list(csv.DictReader(open(out.with_suffix(".csv"))))
    assert len(table) == 6 and table[0]["run"] == "run"


def test_bad_arguments_are_named(tmp_path):
    mod = _module()
    with pytest.raises(ArgumentError, match="--splits"):
        mod.main(["--runs", str(tmp_path), "--splits", "nope"])
    with pytest.raises(ArgumentError, match="--runs"):
        mod.main(["--runs", ""])
    with pytest.raises(ArgumentError, match="no snapshots"):
        mod.main(["--runs", str(tmp_path)])
