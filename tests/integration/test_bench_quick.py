"""Every maintained benchmark stays runnable: each ``bench/*.py`` (found by glob, so a new one is covered
without editing this file) runs with ``--quick`` (tiny sizes, seconds) in a fresh process from the
repository root, exits 0, prints its figures, and writes nothing into the repository's figure folders
(``--quick`` prints; a picture it draws goes to a temporary directory)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCHES = sorted((ROOT / "bench").glob("*.py"))
WATCHED = ("docs/figures", "bench/figures", "research")  # where a bench script writes by default


def _snapshot() -> dict[str, tuple[int, int]]:
    """``relpath -> (size, mtime_ns)`` of every file under the folders a benchmark writes to."""
    out = {}
    for folder in WATCHED:
        for p in (ROOT / folder).rglob("*"):
            if p.is_file() and "__pycache__" not in p.parts:
                st = p.stat()
                out[p.relative_to(ROOT).as_posix()] = (st.st_size, st.st_mtime_ns)
    return out


def test_the_glob_finds_the_maintained_benchmarks():
    names = {p.name for p in BENCHES}
    assert {"apf.py", "apf_unseen.py", "env.py", "world.py", "terrain.py", "train.py", "standard_suite.py"} <= names
    assert not names & {"jacksboro_bound.py", "sensing_bound.py", "apf_failures.py"}  # studies: research/


@pytest.mark.parametrize("script", BENCHES, ids=[p.name for p in BENCHES])
def test_bench_runs_quick(script, tmp_path):
    before = _snapshot()
    env = {**os.environ, "MPLBACKEND": "Agg", "TMPDIR": str(tmp_path), "PYTHONDONTWRITEBYTECODE": "1"}
    r = subprocess.run([sys.executable, str(script.relative_to(ROOT)), "--quick"], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, f"{script.name} --quick exited {r.returncode}:\n{r.stdout[-2000:]}\n{r.stderr[-4000:]}"
    printed = [ln for ln in r.stdout.splitlines() if ln.strip()]
    assert len(printed) >= 2, f"{script.name} --quick printed too little:\n{r.stdout}\n{r.stderr[-2000:]}"
    assert any(ch.isdigit() for ln in printed for ch in ln)  # figures, not only headings
    changed = sorted(k for k, v in _snapshot().items() if before.get(k) != v)
    assert changed == [], f"{script.name} --quick wrote into the repository: {changed}"
