"""``python -m tin_swarm_env`` (__main__.py) runs the ``tin-swarm`` command line and exits with its code."""

from __future__ import annotations

import subprocess
import sys

import tin_swarm_env as tse


def _run(*args):
    return subprocess.run([sys.executable, "-m", "tin_swarm_env", *args], capture_output=True, text=True,
                          timeout=120)


def test_python_dash_m_is_the_command_line():
    r = _run("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"tin-swarm {tse.__version__}"
    r = _run("run", "atlantis", "--quiet")  # an unknown scenario: the CLI's exit code 2 and its message
    assert r.returncode == 2 and "atlantis" in r.stderr
