"""tin-swarm build-tin."""

import subprocess
import sys

import numpy as np

from tin_swarm_env.apps.cli import main
from tin_swarm_env.env.tin_swarm import DEFAULT_RENDER_WIDTH_PX
from tin_swarm_env.terrain import load_tin


def test_build_tin_on_an_asc_file(tmp_path, capsys):
    rng = np.random.default_rng(0)
    z = rng.normal(100, 5, (20, 25)).round(2)
    lines = ["ncols 25", "nrows 20", "xllcorner 0", "yllcorner 0", "cellsize 30"]
    lines += [" ".join(map(str, r)) for r in z]
    (tmp_path / "d.asc").write_text("\n".join(lines) + "\n")
    out = tmp_path / "d.tin"
    assert main(["build-tin", str(tmp_path / "d.asc"), "-o", str(out), "--method", "greedy",
                 "--max-vertices", "120", "--png", str(tmp_path / "d.png")]) == 0
    text = capsys.readouterr().out
    assert "vertices   120" in text and "max error" in text and "rms error" in text and "build time" in text
    assert load_tin(out).n_vertices == 120
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_build_tin_errors_exit_2(tmp_path, capsys):
    assert main(["build-tin", str(tmp_path / "none.xyz"), "-o", str(tmp_path / "x.tin")]) == 2
    assert "no such DEM file" in capsys.readouterr().err
    assert not (tmp_path / "x.tin").exists()


def test_console_script_runs_on_the_sample(tmp_path):
    r = subprocess.run([sys.executable, "-m", "tin_swarm_env", "build-tin", "sample:jacksboro",
                        "-o", str(tmp_path / "j.npz"), "--max-vertices", "2000"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "triangles" in r.stdout
    assert load_tin(tmp_path / "j.npz").n_vertices == 2000


def test_scenarios_lists_the_builtins(capsys):
    assert main(["scenarios"]) == 0
    out = capsys.readouterr().out
    for name in ("flat", "ramp", "hill", "cliff_goal", "jacksboro", "containment"):
        assert name in out


def test_run_writes_table_summary_and_gif(tmp_path, capsys):
    gif, md = tmp_path / "run.gif", tmp_path / "run.md"
    assert main(["run", "flat", "--robots", "6", "--episodes", "2", "--seed", "3", "--gif", str(gif),
                 "--summary", str(md), "--max-cycles", "60", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "| episode | seed | robots | arrived | fell | battery-dead |" in out and "| mean |" in out
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
