"""From a plain (non-editable) install, outside the repository, `tin-swarm train` and `tin-swarm
eval` work: the CLI needs nothing from a source checkout (agents/ is not loaded by path)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _can_build_offline() -> bool:
    """pip --no-build-isolation builds with this environment's setuptools: bdist_wheel is built into
    setuptools >= 70.1, older ones need the wheel package."""
    import importlib.util

    import setuptools

    major, minor = (int(x) for x in setuptools.__version__.split(".")[:2])
    return (major, minor) >= (70, 1) or importlib.util.find_spec("wheel") is not None


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    if not _can_build_offline():
        pytest.skip("building the package offline needs setuptools >= 70.1 or wheel in this environment")
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    src.mkdir()
    for f in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / f, src / f)
    shutil.copytree(ROOT / "tin_swarm_env", src / "tin_swarm_env",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    target = tmp / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                        "--target", str(target), str(src)], capture_output=True, text=True, timeout=300, cwd=tmp)
    assert r.returncode == 0, r.stderr[-2000:]
    work = tmp / "work"
    work.mkdir()
    # the kernels run as plain Python here: this test is about packaging (the compiled kernels are
    # tested against their references elsewhere), and compiling them afresh for a new install
    # path would double its time
    return target, work, {**os.environ, "PYTHONPATH": str(target), "NUMBA_DISABLE_JIT": "1"}


def test_train_and_eval_run_from_a_plain_install_outside_the_repo(installed):
    pytest.importorskip("stable_baselines3", reason="the train extra")
    target, work, env = installed
    r = subprocess.run([sys.executable, "-c", "import tin_swarm_env.apps.cli as c; print(c.__file__)"],
                       capture_output=True, text=True, env=env, cwd=work, timeout=120)
    assert r.returncode == 0 and r.stdout.strip().startswith(str(target)), (r.stdout, r.stderr)
    exe = target / "bin" / "tin-swarm"
    r = subprocess.run([str(exe), "train", "flat", "--timesteps", "128", "--n-robots", "2", "--n-envs", "1",
                        "--n-steps", "32", "--batch-size", "32", "--n-epochs", "1", "--eval-every", "0",
                        "--eval-episodes", "1", "--max-cycles", "20", "--out-dir", "run", "--progress-bar", "false"],
                       capture_output=True, text=True, env=env, cwd=work, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (work / "run" / "model.zip").exists() and (work / "run" / "model.json").exists()
    assert (work / "run" / "policy" / "policy.json").exists()  # the pickle-free export beside the .zip
    r = subprocess.run([str(exe), "eval", "flat", "--seeds", "1", "--robots", "2", "--policies", "apf",
                        "--model", "run/policy", "--model", "run/model.zip", "--trust-pickle", "--out", "ev"],
                       capture_output=True, text=True, env=env, cwd=work, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    md = (work / "ev.md").read_text()
    assert "| flat | apf |" in md and "| flat | run |" in md and "| flat | run (zip) |" in md


def test_a_wheel_user_copies_a_scenario_and_runs_it(installed):
    target, work, env = installed
    exe = target / "bin" / "tin-swarm"
    r = subprocess.run([str(exe), "--version"], capture_output=True, text=True, env=env, cwd=work, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "tin-swarm 0.1.0", (r.stdout, r.stderr)
    r = subprocess.run([str(exe), "scenarios", "--copy", "ramp", "my.toml"], capture_output=True, text=True,
                       env=env, cwd=work, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (work / "my.toml").read_bytes() == (ROOT / "tin_swarm_env/scenario/builtin/ramp.toml").read_bytes()
    r = subprocess.run([str(exe), "scenarios", "--copy", "ramp", "my.toml"], capture_output=True, text=True,
                       env=env, cwd=work, timeout=120)
    assert r.returncode == 2 and "--force" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([str(exe), "run", "my.toml", "--robots", "2", "--max-cycles", "4", "--quiet"],
                       capture_output=True, text=True, env=env, cwd=work, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "scenario my.toml" in r.stdout and "| 1 | 0 | 2 |" in r.stdout


def test_the_wheel_ships_license_py_typed_and_project_urls(installed):
    target, _, _ = installed
    assert (target / "tin_swarm_env" / "py.typed").exists()
    (dist,) = target.glob("tin_swarm_env-*.dist-info")
    licenses = [p for p in dist.rglob("LICENSE*") if p.is_file()]
    assert licenses and "MIT License" in licenses[0].read_text()
    meta = (dist / "METADATA").read_text()
    assert "Project-URL: Repository, https://" in meta
    assert "](bench/figures" not in meta  # no relative image links in the long description


def _requirement_closure(names) -> set[str]:
    """Every distribution ``names`` need, transitively, read from the installed metadata (markers
    evaluated for this interpreter, no extras); normalised names."""
    import importlib.metadata as md
    import re

    from packaging.requirements import Requirement

    norm = lambda n: re.sub(r"[-_.]+", "-", n).lower()  # noqa: E731
    seen, todo = set(), [Requirement(n) for n in names]
    while todo:
        req = todo.pop()
        if req.marker is not None and not req.marker.evaluate({"extra": ""}):
            continue
        if norm(req.name) in seen:
            continue
        seen.add(norm(req.name))
        try:
            todo += [Requirement(r) for r in md.requires(req.name) or []]
        except md.PackageNotFoundError:
            pass
    return seen


LEARNING = {"torch", "torchrl", "stable-baselines3", "sb3-contrib", "ray", "benchmarl", "tensordict"}


def _pyproject() -> dict:
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_core_install_has_no_torch():
    """``pip install -e .`` (the core dependencies and all they need) brings no torch and no learning
    library; those come with the extras."""
    core = _pyproject()["project"]["dependencies"]
    needed = _requirement_closure(core)
    assert {"numpy", "numba", "llvmlite", "pettingzoo", "gymnasium", "matplotlib"} <= needed  # followed transitively
    assert not needed & LEARNING, sorted(needed & LEARNING)
    extras = _pyproject()["project"]["optional-dependencies"]
    assert "torch" in _requirement_closure(extras["train"])  # the walk does see torch where it is


def test_the_cpu_torch_command_is_the_test_command_with_the_pinned_cpu_wheel_first():
    """docs/quickstart.md's CPU-only route installs the torch version constraints.txt pins from the
    PyTorch CPU index, then runs the README's test command unchanged."""
    import re

    (pin,) = re.findall(r"^torch==(\S+)$", (ROOT / "constraints.txt").read_text(), flags=re.M)
    readme = (ROOT / "README.md").read_text()
    tests = readme.split("--8<-- [start:tests] -->\n", 1)[1].split("```bash\n", 1)[1].split("\n```", 1)[0]
    venv = "python3 -m venv .venv && "
    assert tests.startswith(venv)
    cpu = (venv + f".venv/bin/pip install -q torch=={pin} --index-url https://download.pytorch.org/whl/cpu && "
           + tests[len(venv):])
    quick = (ROOT / "docs" / "quickstart.md").read_text()
    assert f"```bash\n{cpu}\n```" in quick
    assert f"pip install torch=={pin} --index-url https://download.pytorch.org/whl/cpu\n" in quick
