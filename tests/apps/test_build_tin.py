"""``tin-swarm build-tin`` (apps/build_tin.py): a DEM file and the sample reduced and written, errors exit 2
and write nothing."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from tin_swarm_env.apps.build_tin import VIP_DEFAULT_VERTICES, Args, build_tin
from tin_swarm_env.apps.cli import main
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


def _plane(tmp_path, rows=5, cols=6):
    x, y = np.meshgrid(np.arange(cols), np.arange(rows))
    np.savez(tmp_path / "p.npz", z=2.0 * x + 3.0 * y)
    return str(tmp_path / "p.npz")


def test_a_plane_is_kept_exactly(tmp_path, capsys):
    """A plane: greedy with no error allowed has zero vertical error; with no limit given the
    default is VIP with its vertex budget, more than the 30 cells, so every cell becomes a vertex
    and the 5 x 6 grid gives 2 * 4 * 5 triangles."""
    dem = _plane(tmp_path)
    assert build_tin(Args(dem=dem, output=str(tmp_path / "g.tin"), max_error_m=0)) == 0
    out = capsys.readouterr().out
    assert "method     greedy" in out and "max error  0.00 m" in out and "rms error  0.00 m" in out
    assert load_tin(tmp_path / "g.tin").n_vertices < 30
    assert VIP_DEFAULT_VERTICES > 30
    assert build_tin(Args(dem=dem, output=str(tmp_path / "v.npz"))) == 0
    out = capsys.readouterr().out
    assert "method     vip" in out and "vertices   30" in out and "triangles  40" in out
    tin = load_tin(tmp_path / "v.npz")
    assert (tin.n_vertices, tin.n_triangles) == (30, 40)
    np.testing.assert_allclose(tin.vertices[:, 2], 2 * tin.vertices[:, 0] + 3 * tin.vertices[:, 1])
