"""No output overwrites an input, and no failed write reports success.

* every output option of every command pointed at each input of that command (the file itself,
  through a symbolic link, or inside an input directory) is refused naming the input, and no input
  changes a byte;
* each output kind (GIF, PNG, MP4, WebP, summary, CSV report, TIN, policy directory, checkpoint,
  copied scenario) written onto a full file system and over an existing file: the error names the
  file, the old file's bytes are unchanged and no partial file is left;
* a reader that goes away (``| head``) costs no traceback and no file.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.cli import main

ROOT = Path(__file__).resolve().parents[2]
QUIET = ["--robots", "2", "--max-cycles", "3", "--quiet"]
SCEN = ('name = "dem"\ntask = "goal"\nmax_cycles = 5\n[terrain]\nsource = "dem"\npath = "dem.xyz"\n'
        'method = "delaunay"\n[robots]\ncount = 2\nmin_separation_m = 1.0\n[targets]\npositions = [[20.0, 20.0]]\n')


def _dem(path: Path):
    xs, ys = np.meshgrid(np.arange(0.0, 50.0, 5.0), np.arange(0.0, 50.0, 5.0))
    np.savetxt(path, np.c_[xs.ravel(), ys.ravel(), 0.1 * xs.ravel()])


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    """A scenario that reads a DEM, a policy directory, a scenario named ``.md``/``.png`` (a TOML file
    may have any name) and symbolic links to them."""
    from tin_swarm_env.policies.learned import save_policy

    _dem(tmp_path / "dem.xyz")
    (tmp_path / "scen.toml").write_text(SCEN)
    (tmp_path / "scen.md").write_text(SCEN)
    (tmp_path / "scen.png").write_text(SCEN)
    layout = tse.parallel_env(scenario="flat", n_robots=2).layout
    save_policy(tmp_path / "pol", [(np.zeros((2, layout.size)), np.zeros(2))], layout=layout, scenario="flat")
    (tmp_path / "link.xyz").symlink_to(tmp_path / "dem.xyz")
    (tmp_path / "link.toml").symlink_to(tmp_path / "scen.toml")
    (tmp_path / "runs" / "policy").mkdir(parents=True)
    (tmp_path / "runs" / "policy" / "s.toml").write_text(SCEN.replace('"dem.xyz"', '"../../dem.xyz"'))
    (tmp_path / "runs2").mkdir()
    (tmp_path / "runs2" / "model.json").write_text(SCEN.replace('"dem.xyz"', '"../dem.xyz"'))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _snapshot(d: Path) -> dict:
    return {str(p.relative_to(d)): (p.read_bytes() if p.is_file() and not p.is_symlink() else os.readlink(p)
                                    if p.is_symlink() else None) for p in sorted(d.rglob("*"))}


# (command line, what the refusal says); "{d}" is the directory of the inputs
CASES = [
    # run: --summary, --gif, --mp4 against the scenario, the DEM it reads, the policy directory's files
    (["run", "{d}/scen.toml", "--summary", "{d}/scen.toml"], "is the input"),
    (["run", "{d}/scen.toml", "--summary", "{d}/dem.xyz"], "is the input"),
    (["run", "{d}/scen.toml", "--summary", "{d}/link.xyz"], "is the input"),
    (["run", "{d}/link.toml", "--summary", "{d}/scen.toml"], "is the input"),
    (["run", "flat", "--policy", "{d}/pol", "--summary", "{d}/pol/policy.json"], "lies inside the input"),
    (["run", "flat", "--policy", "{d}/pol", "--summary", "{d}/pol/weights.npz"], "lies inside the input"),
    (["run", "flat", "--policy", "{d}/pol", "--summary", "{d}/pol/notes.md"], "lies inside the input"),
    (["run", "{d}/scen.png", "--gif", "{d}/scen.png"], "is the input"),
    (["run", "{d}/scen.toml", "--gif", "{d}/dem.xyz"], "is the input"),
    (["run", "flat", "--policy", "{d}/pol", "--gif", "{d}/pol/a.gif"], "lies inside the input"),
    (["run", "flat", "--policy", "{d}/pol", "--mp4", "{d}/pol/a.mp4"], "lies inside the input"),
    # eval (and its suite): --out NAME writes NAME.md, .csv, .png
    (["eval", "{d}/scen.md", "--out", "{d}/scen", "--seeds", "1"], "is the input"),
    (["eval", "flat", "--model", "{d}/pol", "--out", "{d}/pol/report", "--seeds", "1"], "lies inside the input"),
    (["eval", "--suite", "standard", "--quick", "--model", "{d}/pol", "--out", "{d}/pol/suite"],
     "lies inside the input"),
    # build-tin: -o and --png against the DEM
    (["build-tin", "{d}/dem.xyz", "-o", "{d}/dem.xyz"], "is the input"),
    (["build-tin", "{d}/dem.xyz", "-o", "{d}/link.xyz"], "is the input"),
    (["build-tin", "{d}/link.xyz", "-o", "{d}/t.tin", "--png", "{d}/dem.xyz"], "is the input"),
    # explore: --png against the scenario and the DEM it reads
    (["explore", "{d}/scen.png", "--png", "{d}/scen.png", "--steps", "0"], "is the input"),
    # train: the run directory's files and directories against the scenario and its DEM
    (["train", "{d}/runs/policy/s.toml", "--out-dir", "{d}/runs", "--timesteps", "64"], "would write over the input"),
    (["train", "{d}/runs2/model.json", "--out-dir", "{d}/runs2", "--timesteps", "64"], "is the input"),
]


def _run_cli(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            rc = main(argv)
        except SystemExit as exc:
            rc = exc.code
    return rc, err.getvalue().strip().splitlines()


@pytest.mark.parametrize("argv,expect", CASES, ids=[" ".join(c[0]) for c in CASES])
def test_every_output_pointed_at_an_input_is_refused_and_inputs_stay(argv, expect, inputs):
    before = _snapshot(inputs)
    rc, err = _run_cli([a.replace("{d}", str(inputs)) for a in argv])
    assert rc == 2, err
    assert len(err) == 1 and expect in err[0], err
    assert _snapshot(inputs) == before


def test_scenarios_copy_onto_the_builtin_file_it_copies_is_refused():
    from tin_swarm_env.scenario.config import scenario_file

    src = scenario_file("ramp")
    before = src.read_bytes()
    rc, err = _run_cli(["scenarios", "--copy", "ramp", str(src), "--force"])
    assert rc == 2 and "is the input" in err[0], err
    assert src.read_bytes() == before


def test_the_check_compares_file_identity_not_only_names(tmp_path):
    """A hard link is the same file under another name; a directory reached through a link is the
    same directory (the one check behind every command)."""
    from tin_swarm_env._atomic import check_outputs
    from tin_swarm_env.errors import ArgumentError

    a = tmp_path / "a.txt"
    a.write_text("x")
    os.link(a, tmp_path / "hard.txt")
    with pytest.raises(ArgumentError, match="is the input"):
        check_outputs({"--out": tmp_path / "hard.txt"}, inputs=[a])
    (tmp_path / "d").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "d")
    with pytest.raises(ArgumentError, match="lies inside the input"):
        check_outputs({"--out": tmp_path / "alias" / "x.md"}, inputs=[tmp_path / "d"])
    (tmp_path / "d" / "in.toml").write_text("")
    with pytest.raises(ArgumentError, match="would write over the input"):
        check_outputs({}, inputs=[tmp_path / "d" / "in.toml"], dirs={"--out-dir": tmp_path / "alias"})
    check_outputs({"--out": tmp_path / "other.md"}, inputs=[a, tmp_path / "d"])  # not an input: fine


# -- full disk and existing files --------------------------------------------------------------

FSIZE_CHILD = """
import resource, sys
import numpy as np
from tin_swarm_env.apps.media import save_gif
frames = [np.random.default_rng(i).integers(0, 255, (120, 160, 3), dtype=np.uint8) for i in range(6)]
resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))  # a file system with 20 kB left
try:
    save_gif(frames, sys.argv[1])
except Exception as exc:
    print(type(exc).__name__, exc)
else:
    print("no error")
"""


@pytest.mark.parametrize("suffix", [".gif", ".png", ".mp4", ".webp"])
def test_media_onto_a_full_file_system_names_the_file_and_keeps_the_old_one(suffix, tmp_path):
    """The real encoders (Pillow, ffmpeg) writing into a file the system stops growing at 20 kB
    (RLIMIT_FSIZE: every write past it fails, in this process and in ffmpeg alike). ffmpeg exits
    without a Python error; its file is checked whole before it is renamed into place."""
    if suffix in (".mp4", ".webp"):
        pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / f"old{suffix}"
    out.write_bytes(b"the old file")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-c", FSIZE_CHILD, str(out)], capture_output=True, text=True, env=env,
                       timeout=300)
    line = r.stdout.strip().splitlines()[-1]
    assert line.startswith("OutputError") and str(out) in line and "not written" in line, (line, r.stderr[-2000:])
    assert out.read_bytes() == b"the old file"
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


class _FullDisk:
    """``open`` whose files refuse every write into a path under ``root`` with ENOSPC (a full disk)."""

    def __init__(self, root: Path, real):
        self.root, self.real = str(root), real

    def __call__(self, file, mode="r", *a, **k):
        fh = self.real(file, mode, *a, **k)
        if isinstance(file, (str, os.PathLike)) and str(file).startswith(self.root) and any(
                c in mode for c in "wax+"):
            def write(*_a, **_k):
                raise OSError(errno.ENOSPC, "No space left on device")
            try:
                fh.write = write
            except AttributeError:  # a C file object: wrap it
                return _Wrapped(fh, write)
        return fh


class _Wrapped:
    def __init__(self, fh, write):
        self._fh, self.write = fh, write

    def __getattr__(self, k):
        return getattr(self._fh, k)

    def __enter__(self):
        return self

    def __exit__(self, *a):
        self._fh.close()


@pytest.fixture
def full_disk(tmp_path, monkeypatch):
    """``(directory, fill)``: ``fill()`` makes every later write into the directory fail with ENOSPC."""
    import builtins

    (tmp_path / "out").mkdir()

    def fill():
        fake = _FullDisk(tmp_path / "out", builtins.open)
        monkeypatch.setattr(builtins, "open", fake)
        monkeypatch.setattr(io, "open", fake)

    return tmp_path / "out", fill


def _writers(d: Path):
    """``(name, path, write)``: one of each output kind the commands write, ``write()`` writing it."""
    from tin_swarm_env.policies.learned import save_policy
    from tin_swarm_env.terrain import build_tin, save_tin
    from tin_swarm_env.training.evaluation import write_csv

    dem = tse.terrain.sample_dem("jacksboro")
    layout = tse.parallel_env(scenario="flat", n_robots=2).layout

    def summary():
        return main(["run", "flat", "--summary", str(d / "s.md"), *QUIET])

    def gif():
        return main(["run", "flat", "--gif", str(d / "a.gif"), *QUIET])

    def tin():
        return save_tin(build_tin(dem, method="vip", max_vertices=50), d / "t.tin")

    def csv():
        return write_csv(d / "r.csv", [{"a": 1, "b": 2}])

    def policy():
        return save_policy(d / "pol", [(np.zeros((2, layout.size)), np.zeros(2))], layout=layout, scenario="flat")

    def copy():
        return main(["scenarios", "--copy", "ramp", str(d / "c.toml"), "--force"])

    def build_tin_cli():
        return main(["build-tin", "sample:jacksboro", "-o", str(d / "b.tin"), "--max-vertices", "50"])

    return [("summary", d / "s.md", summary), ("gif", d / "a.gif", gif), ("tin", d / "t.tin", tin),
            ("csv", d / "r.csv", csv), ("policy", d / "pol" / "policy.json", policy),
            ("scenarios --copy", d / "c.toml", copy), ("build-tin", d / "b.tin", build_tin_cli)]


@pytest.mark.parametrize("kind", ["summary", "gif", "tin", "csv", "policy", "scenarios --copy", "build-tin"])
def test_each_output_onto_a_full_disk_names_the_file_and_keeps_the_old_one(kind, full_disk, capsys):
    d, fill = full_disk
    name, path, write = next(w for w in _writers(d) if w[0] == kind)
    if kind == "policy":  # the old policy directory, written while the disk had room
        from tin_swarm_env.policies.learned import save_policy

        layout = tse.parallel_env(scenario="flat", n_robots=2).layout
        save_policy(path.parent, [(np.ones((2, layout.size)), np.ones(2))], layout=layout, scenario="flat")
        old = {p.name: p.read_bytes() for p in path.parent.iterdir()}
    else:
        path.write_bytes(b"the old file")
    listing = sorted(p.name for p in d.iterdir())
    fill()
    try:
        rc = write()
    except OSError as exc:  # a library call: the error itself names the file
        assert exc.filename == str(path.parent if kind == "policy" else path), exc
        assert "No space left on device" in str(exc)
    else:
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1, err
        assert str(path) in err[0] and "No space left on device" in err[0], err
    if kind == "policy":
        assert {p.name: p.read_bytes() for p in path.parent.iterdir()} == old
    else:
        assert path.read_bytes() == b"the old file"
    assert sorted(p.name for p in d.iterdir()) == listing  # no partial file beside it


def test_a_checkpoint_onto_a_full_disk_leaves_the_checkpoints_there(tmp_path, monkeypatch):
    """Writing a checkpoint fails: the error says which, the earlier checkpoint is untouched and no
    ``.part`` directory is left."""
    pytest.importorskip("stable_baselines3")
    import tin_swarm_env.training.checkpoint as C
    import tin_swarm_env.training.sb3 as T

    run = tmp_path / "run"
    calls = []
    real = C._save_npz

    def full(path, arrays):
        calls.append(path)
        if len(calls) > 2:  # the second checkpoint's policy.npz
            raise OSError(errno.ENOSPC, "No space left on device")  # as a write says it: no file named
        return real(path, arrays)

    monkeypatch.setattr(C, "_save_npz", full)
    with pytest.raises(OSError, match="No space left on device") as ei:
        T.train(T.Args(scenario="flat", n_robots=2, n_envs=1, max_cycles=20, total_timesteps=64, n_steps=32,
                       batch_size=32, n_epochs=1, net_arch="8", eval_every=0, checkpoint_every=32, out_dir=str(run),
                       progress_bar=False))
    assert ei.value.filename == str(run / "checkpoints" / "step_64" / "policy.npz")
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["step_32"]
    assert not (run / "model.zip").exists()


def test_a_reader_that_goes_away_costs_no_traceback_and_no_file(tmp_path, monkeypatch):
    """``tin-swarm run ... | head -1``: stdout breaks after the first line; the command still writes
    its --summary whole, prints no error and exits 0."""

    class Head(io.StringIO):
        def write(self, s):
            if self.getvalue().count("\n") >= 1:
                raise BrokenPipeError(errno.EPIPE, "Broken pipe")
            return super().write(s)

    head, err = Head(), io.StringIO()
    monkeypatch.setattr(sys, "stdout", head)
    with contextlib.redirect_stderr(err):
        rc = main(["run", "flat", "--summary", str(tmp_path / "s.md"), *QUIET])
    assert rc == 0 and err.getvalue() == ""
    assert head.getvalue().count("\n") == 1
    assert "| episode |" in (tmp_path / "s.md").read_text()
    assert sys.stdout is head  # put back as it was
