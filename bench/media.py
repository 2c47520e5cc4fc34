"""The size of ``tin-swarm run jacksboro --robots 200`` videos with the default frame stride and
width (:data:`tin_swarm_env.apps.media.FRAME_EVERY`, :data:`~tin_swarm_env.apps.media.GIF_WIDTH_PX`).
Run by hand (a few seconds of CPU per run; under ``flock /tmp/heavy.lock`` on the shared machine):

    python bench/media.py [--write]     # --write: the table to docs/figures/media.md
    python bench/media.py --quick       # a smoke run (seconds): 20 robots, 30 steps; prints only

It runs the CLI as a user does (900 steps, a frame every FRAME_EVERY steps), once writing a GIF and
an MP4 and once a WebP, into a temporary directory, and prints each file's frames and size. The
issue's bound: the GIF <= 10 MB (``tests/apps/test_media.py`` checks a size model of it in the suite).
"""

from __future__ import annotations

import os
import shlex
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tin_swarm_env.apps.media import FRAME_EVERY, GIF_WIDTH_PX

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "figures" / "media.md"
RUNS = (("--gif", "jacksboro.gif", "--mp4", "jacksboro.mp4"), ("--gif", "jacksboro.webp"))


def _header(argv) -> str:
    try:
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "?"
    load = " / ".join(f"{x:.2f}" for x in os.getloadavg())
    cmd = shlex.join(["python", "bench/media.py", *argv])  # quoted: the line can be run as it stands
    return (f"Measured with `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"load average {load} at the start ({os.cpu_count()} cores, shared).")


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    header = _header(argv)
    quick = "--quick" in argv  # a smoke run: 20 robots, 30 steps, printed only
    size = ["--robots", "20", "--max-cycles", "30"] if quick else ["--robots", "200"]
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for run in RUNS:
            args = [a if a.startswith("--") else str(Path(d) / a) for a in run]
            cmd = [sys.executable, "-m", "tin_swarm_env", "run", "jacksboro", *size, *args, "--quiet"]
            t = time.perf_counter()
            r = subprocess.run(cmd, capture_output=True, text=True, check=True)
            s = time.perf_counter() - t
            shown = "tin-swarm run jacksboro " + " ".join([*size, *run])
            for line in r.stdout.splitlines():
                m = re.match(r"wrote (\S+) \((\d+) frames\)", line)
                if m:
                    p = Path(m.group(1))
                    rows.append((shown, p.suffix, int(m.group(2)), p.stat().st_size, s))
    table = ["| command | file | frames | bytes | MB | s (the run) |", "|---|---|---:|---:|---:|---:|"]
    table += [f"| `{c}` | {suffix} | {n} | {b:,} | {b / 1e6:.2f} | {s:.0f} |" for c, suffix, n, b, s in rows]
    text = (f"{header}\n\nDefaults: a frame every {FRAME_EVERY} steps, {GIF_WIDTH_PX} px wide (900 steps: "
            f"{900 // FRAME_EVERY + 1} frames). The GIF has one fixed palette and stores per frame only the "
            f"rectangle that changed; the WebP is lossless. Before the fixed palette (an adaptive palette per "
            f"whole frame) the same GIF was 45.7 MB (issue 28).\n\n" + "\n".join(table) + "\n")
    print(text)
    if "--write" in argv and not quick:
        OUT.write_text(text)
        print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
