"""Running episodes (apps/run.py, ``tin-swarm run``): the table, summary and GIF, errors exit 2 and write
nothing, 200 robots on jacksboro, frames handed to a writer as they come."""

from __future__ import annotations

import subprocess
import sys

from tin_swarm_env.apps.cli import main
from tin_swarm_env.env.tin_swarm import DEFAULT_RENDER_WIDTH_PX


def test_run_hands_frames_to_the_writer_without_keeping_them(tmp_path):
    from tin_swarm_env.apps.run import run_episodes

    got = []
    stats, frames = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False,
                                 render_width=64, on_frame=lambda f: got.append(f.shape))
    assert frames == [] and len(got) == 4 and got[0][1] == 64  # steps 0, 2, 4 and the end
    _, kept = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False, render_width=64)
    assert len(kept) == 4


def test_run_writes_table_summary_and_gif(tmp_path, capsys):
    gif, md = tmp_path / "run.gif", tmp_path / "run.md"
    assert main(["run", "flat", "--robots", "6", "--episodes", "2", "--seed", "3", "--gif", str(gif),
                 "--summary", str(md), "--max-cycles", "60", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "| episode | seed | robots | arrived | fell | battery-empty |" in out and "| mean |" in out
    from PIL import Image

    im = Image.open(gif)
    assert im.n_frames >= 2 and im.size[0] == DEFAULT_RENDER_WIDTH_PX
    assert "| 2 | 4 | 6 |" in md.read_text()
    assert main(["run", "flat", "--robots", "2", "--max-cycles", "5", "--gif", str(tmp_path / "last.png"),
                 "--quiet"]) == 0
    assert Image.open(tmp_path / "last.png").size[0] == DEFAULT_RENDER_WIDTH_PX


def test_run_errors_exit_2(tmp_path, capsys):
    assert main(["run", "atlantis", "--quiet"]) == 2
    assert "unknown scenario 'atlantis'" in capsys.readouterr().err
    assert main(["run", "flat", "--fields", "robot,wind", "--quiet"]) == 2
    assert "unknown field" in capsys.readouterr().err
    assert main(["run", "flat", "--gif", str(tmp_path / "no" / "x.gif"), "--max-cycles", "3", "--quiet"]) == 2
    assert not (tmp_path / "no").exists()
    assert main(["run", "flat", "--gif", str(tmp_path / "x.avi"), "--max-cycles", "3", "--quiet"]) == 2
    assert "'.avi'" in capsys.readouterr().err and not list(tmp_path.iterdir())  # the suffix picks the format


def test_run_summary_writes_only_a_markdown_or_text_file(tmp_path, capsys):
    """``--summary t.tin`` (a typo, or another kind of file) is refused before any episode, naming the
    option and the suffix; the file there is left as it was."""
    other = tmp_path / "t.tin"
    other.write_text("a TIN file")
    assert main(["run", "flat", "--robots", "2", "--max-cycles", "3", "--summary", str(other), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--summary" in err and "'.tin'" in err and ".md or .txt" in err
    assert other.read_text() == "a TIN file"
    assert main(["run", "flat", "--robots", "2", "--max-cycles", "3", "--summary", str(tmp_path / "s.md"),
                 "--quiet"]) == 0
    assert (tmp_path / "s.md").read_text().startswith("|") or "arrived" in (tmp_path / "s.md").read_text()


def test_run_jacksboro_with_200_robots_finishes_and_writes_a_gif(tmp_path):
    gif = tmp_path / "jacksboro.gif"
    r = subprocess.run([sys.executable, "-m", "tin_swarm_env", "run", "jacksboro", "--robots", "200",
                        "--gif", str(gif), "--frame-every", "30"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    row = next(line for line in r.stdout.splitlines() if line.startswith("| 1 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    arrived, fell, dead, timed_out = map(int, cells[3:7])
    assert arrived + fell + dead + timed_out == 200 and arrived > 0
    assert gif.stat().st_size > 10_000
