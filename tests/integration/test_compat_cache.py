"""Python 3.10 compatibility (tomllib -> tomli) and the TIN cache keyed by file mtime and size."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np

from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.build import build_tin_for

ROOT = Path(__file__).resolve().parents[2]


def test_scenario_config_imports_without_tomllib_using_tomli():
    """On Python 3.10 there is no tomllib: the scenario loader must fall back to tomli."""
    code = textwrap.dedent("""
        import sys, tomllib
        sys.modules["tomli"] = tomllib      # stands in for the PyPI package
        sys.modules["tomllib"] = None       # as on Python 3.10: import tomllib fails
        from tin_swarm_env.scenario import config
        assert config.tomllib is sys.modules["tomli"]
        cfg = config.load_scenario("flat")
        print("ok", cfg.name)
    """)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ok flat")


def test_pyproject_declares_tomli_for_old_pythons():
    import tomllib

    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    tomli = [d for d in deps if d.replace(" ", "").startswith("tomli>=")]
    assert tomli and "python_version<'3.11'" in tomli[0].replace(" ", "").replace('"', "'")


def _write_dem(path: Path, height_m: float):
    xs, ys = np.meshgrid(np.arange(0.0, 50.0, 5.0), np.arange(0.0, 50.0, 5.0))
    zs = height_m * xs / 50.0
    np.savetxt(path, np.c_[xs.ravel(), ys.ravel(), zs.ravel()])


def test_an_edited_dem_is_re_read_by_the_next_environment(tmp_path):
    dem = tmp_path / "dem.xyz"
    _write_dem(dem, 5.0)
    scen = tmp_path / "s.toml"
    scen.write_text('name = "edited"\n[terrain]\nsource = "dem"\npath = "dem.xyz"\nmethod = "delaunay"\n'
                    "[robots]\ncount = 2\nmin_separation_m = 1.0\n[targets]\npositions = [[20.0, 20.0]]\n")
    z1 = build_tin_for(load_scenario(scen)).vertices[:, 2].max()
    _write_dem(dem, 20.0)  # same path, new content (and size)
    st = dem.stat()
    os.utime(dem, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    z2 = build_tin_for(load_scenario(scen)).vertices[:, 2].max()
    assert np.isclose(z1, 5.0 * 45 / 50) and np.isclose(z2, 20.0 * 45 / 50)


def test_an_unchanged_file_is_served_from_the_cache(tmp_path):
    dem = tmp_path / "dem.xyz"
    _write_dem(dem, 5.0)
    scen = tmp_path / "s.toml"
    scen.write_text('name = "same"\n[terrain]\nsource = "dem"\npath = "dem.xyz"\nmethod = "delaunay"\n'
                    "[robots]\ncount = 2\nmin_separation_m = 1.0\n[targets]\npositions = [[20.0, 20.0]]\n")
    assert build_tin_for(load_scenario(scen)) is build_tin_for(load_scenario(scen))
