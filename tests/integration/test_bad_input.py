"""Bad input, as a new user would give it: every case gets a one-line error naming the culprit
(or, for the few inputs that are fine, a normal run), never a traceback, never exit 0 on
nonsense, never a silent NaN.

The documentation's bad-input table (docs/figures/bad_input.md) is generated from :data:`CASES` by
:func:`test_docs_table_is_current`; after changing a message, regenerate it with

    TIN_SWARM_WRITE_DOCS=1 python -m pytest tests/integration/test_bad_input.py -k docs_table
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.cli import main
from tin_swarm_env.errors import TinSwarmError
from tin_swarm_env.policies.bug import BugParams
from tin_swarm_env.policies.chart import ChartParams
from tin_swarm_env.world.fields import FieldParams
from tin_swarm_env.world.params import SensorParams

FLAT = ["--robots", "2", "--max-cycles", "3", "--quiet"]


def _scenario(tmp, text: str, name="bad.toml") -> str:
    """A flat scenario file with ``text`` appended (tables and keys that override the base)."""
    p = tmp / name
    p.write_text(text)
    return str(p)


BASE = """task = "goal"
max_cycles = 5
[terrain]
source = "flat"
size_m = [100.0, 100.0]
"""
GOAL = "[targets]\npositions = [[90.0, 50.0]]\n"


def toml(body: str, targets: str = GOAL) -> str:
    return BASE + body + ("\n" + targets if targets else "")


# (label shown in the docs table, kind, what, expected fragment of the message or "exit 0")
# kind "cli": argv (strings, "{d}" is a temporary directory); "load": a scenario file's text, loaded;
# "env": a scenario file's text, made into an env and reset; "call": a function of the temp dir
CASES = [
    ("`run flat --policy APF` (any case)", "cli", ["run", "flat", "--policy", "APF", *FLAT], "exit 0"),
    ("`run flat --policy apff`", "cli", ["run", "flat", "--policy", "apff", *FLAT], "give apf, apf-bug, apf-chart, random"),
    ("`run flat --policy model.zip` (no --trust-pickle)", "cli", ["run", "flat", "--policy", "{d}/model.zip", *FLAT],
     "without --trust-pickle"),
    ("`eval flat --model missing/`", "cli", ["eval", "flat", "--model", "{d}/missing", "--seeds", "1"],
     "no such file or directory"),
    ("`eval flat --seeds 0`", "cli", ["eval", "flat", "--seeds", "0"], "--seeds must be an integer >= 1"),
    ("`eval flat --policies apf,ppo`", "cli", ["eval", "flat", "--policies", "apf,ppo"], "unknown ['ppo']"),
    ("`run flat --fields ''`", "cli", ["run", "flat", "--fields", "", *FLAT], "no field named"),
    ("`run flat --fields robot,wind`", "cli", ["run", "flat", "--fields", "robot,wind", *FLAT], "unknown field"),
    ("`run flat --episodes 0`", "cli", ["run", "flat", "--episodes", "0", "--quiet"],
     "--episodes must be an integer >= 1, got 0"),
    ("`run flat --robots 1000000`", "cli", ["run", "flat", "--robots", "1000000", "--quiet"],
     "--robots must be an integer >= 1 and <= 100000, got 1000000"),
    ("`run flat --render-width 0`", "cli", ["run", "flat", "--render-width", "0", "--gif", "{d}/a.gif", *FLAT],
     "--render-width must be an integer >= 64 and <= 4096, got 0"),
    ("`run flat --seed -1`", "cli", ["run", "flat", "--seed", "-1", *FLAT], "--seed must be an integer >= 0, got -1"),
    ("`run flat --frame-every 0`", "cli", ["run", "flat", "--frame-every", "0", "--gif", "{d}/a.gif", *FLAT],
     "--frame-every must be an integer >= 1, got 0"),
    ("`run flat --max-cycles 0`", "cli", ["run", "flat", "--max-cycles", "0", "--quiet"],
     "--max-cycles must be an integer >= 1, got 0"),
    ("`run flat --robots two`", "cli", ["run", "flat", "--robots", "two", "--quiet"],
     "argument --robots: expected an integer, got 'two'"),
    ("`run flat --mp4 out.gif`", "cli", ["run", "flat", "--mp4", "{d}/out.gif", *FLAT],
     "the file name must end in .mp4"),
    ("`run flat --summary s.gif --gif s.gif`", "cli",
     ["run", "flat", "--summary", "{d}/s.gif", "--gif", "{d}/s.gif", *FLAT], "are the same file"),
    ("`run flat --gif DIR/` (a directory)", "cli", ["run", "flat", "--gif", "{d}", *FLAT], "is a directory"),
    ("`run flat --gif no/such/dir/x.gif`", "cli", ["run", "flat", "--gif", "{d}/no/x.gif", *FLAT],
     "does not exist"),
    ("`run my.toml --summary my.toml`", "cli", ["run", "{d}/ok.toml", "--summary", "{d}/ok.toml", *FLAT],
     "is the input"),
    ("`build-tin X.npz -o X.npz`", "cli", ["build-tin", "{d}/dem.npz", "-o", "{d}/dem.npz"], "is the input"),
    ("`build-tin X.npz` (no -o)", "cli", ["build-tin", "{d}/dem.npz"], "the following arguments are required: -o"),
    ("`build-tin X.npz -o t.tin --method magic`", "cli", ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--method",
                                                          "magic"], "--method must be one of vip, greedy"),
    ("`build-tin X.npz -o t.tin --max-vertices 3`", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--max-vertices", "3"], "--max-vertices must be an integer >= 4"),
    ("`build-tin X.npz -o t.tin --max-error-m -1`", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--max-error-m", "-1"],
     "--max-error-m must be a finite number >= 0, got -1.0"),
    ("`build-tin X.npz -o t.tin --max-error-m nan`", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--max-error-m", "nan"], "--max-error-m must be a finite number"),
    ("`build-tin X.npz -o t.tin --method robot --max-slope-deg 90`", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--method", "robot", "--max-slope-deg", "90"],
     "--max-slope-deg must be a finite number > 0 and < 90, got 90.0"),
    ("`build-tin X.npz -o t.tin --method vip --max-error-m 1`", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--method", "vip", "--max-error-m", "1"],
     "--max-error-m applies to --method 'greedy'"),
    ("`build-tin X.npz -o t.tin --method robot` (no --max-slope-deg)", "cli",
     ["build-tin", "{d}/dem.npz", "-o", "{d}/t.tin", "--method", "robot"], "--max-slope-deg must be"),
    ("`build-tin sample:atlantis -o t.tin`", "cli", ["build-tin", "sample:atlantis", "-o", "{d}/t.tin"],
     "DEM 'sample:atlantis': unknown sample DEM; known: sample:jacksboro"),
    ("`explore flat --robot 999`", "cli", ["explore", "flat", "--robot", "999", "--png", "{d}/e.png"],
     "the scenario has robots 0..19"),
    ("`explore flat --robot -1`", "cli", ["explore", "flat", "--robot", "-1", "--png", "{d}/e.png"],
     "--robot '-1': give a robot index >= 0 or 'all'"),
    ("`explore flat --steps -5`", "cli", ["explore", "flat", "--steps", "-5", "--png", "{d}/e.png"],
     "--steps must be an integer >= 0 and <= 1e+07, got -5"),
    ("`explore flat --steps 100000000000`", "cli", ["explore", "flat", "--steps", "100000000000", "--png", "{d}/e.png"],
     "--steps must be an integer >= 0 and <= 1e+07, got 100000000000"),
    ("`run flat --summary t.tin` (not a table's suffix)", "cli",
     ["run", "flat", "--summary", "{d}/t.tin", "--max-cycles", "3"],
     "the suffix '.tin'; this option writes .md or .txt"),
    ("`eval flat --out DIR` (an existing directory)", "cli", ["eval", "flat", "--out", "{d}", "--seeds", "1"],
     "is a directory; give a file stem"),
    ("`explore flat --png e.pdf`", "cli", ["explore", "flat", "--png", "{d}/e.pdf"],
     "the picture is written as PNG: give a .png path"),
    ("`scenarios --copy ramp EXISTING.toml`", "cli", ["scenarios", "--copy", "ramp", "{d}/ok.toml"], "--force"),
    ("`scenarios --force` (no --copy)", "cli", ["scenarios", "--force"], "--force applies to --copy only"),
    ("`scenarios --copy atlantis x.toml`", "cli", ["scenarios", "--copy", "atlantis", "{d}/x.toml"],
     "--copy: unknown built-in scenario 'atlantis'; built-in: cliff_goal"),
    ("disk full while writing `--summary`", "cli", ["run", "flat", "--summary", "{d}/full.md", *FLAT],
     "No space left on device"),
    ("Ctrl-C during `run`", "cli", ["run", "flat", *FLAT], "interrupted"),
    ("an unexpected error (a bug) in `run`", "cli", ["run", "flat", "--summary", "{d}/bug.md", *FLAT],
     "rerun with --debug"),
    ("`[rewards] fall = nan`", "load", toml("[rewards]\nfall = nan\n"), "RewardWeights.fall must be a finite"),
    ("`[rewards] arrival = inf`", "load", toml("[rewards]\narrival = inf\n"), "RewardWeights.arrival"),
    ("`[targets] standoff_m = nan` (containment)", "load",
     toml('[targets]\npositions = [[50.0, 50.0]]\nstandoff_m = nan\n', targets="").replace('"goal"',
                                                                                          '"containment"'),
     "EntitiesSpec.standoff_m"),
    ("`[targets] arrival_radius_m = -1`", "load", toml("", "[targets]\npositions = [[9.0, 9.0]]\n"
                                                          "arrival_radius_m = -1\n"), "arrival_radius_m must be"),
    ("`[robots] min_separation_m = nan`", "load", toml("[robots]\nmin_separation_m = nan\n"), "min_separation_m"),
    ("`[robots] max_speed_mps = 1e308`", "load", toml("[robots]\nmax_speed_mps = 1e308\n"), "<= 1000"),
    ("`[robots] count = 1000000000`", "load", toml("[robots]\ncount = 1000000000\n"), "<= 100000"),
    ("`[robots] count = -1`", "load", toml("[robots]\ncount = -1\n"), "RobotsSpec.count must be"),
    ("`seed = -1`", "load", "seed = -1\n" + toml(""), "ScenarioConfig.seed must be an integer >= 0"),
    ("`[observation] k_robots = -1`", "load", toml("[observation]\nk_robots = -1\n"), "k_robots must be"),
    ("`[observation] k_robots = 100000`", "load", toml("[observation]\nk_robots = 100000\n"), "<= 256"),
    ("`[sensor] max_candidates = 2` (< k_robots 4)", "load", toml("[sensor]\nmax_candidates = 2\n"),
     "max_candidates (2) must be >="),
    ("`[terrain] size_m = [0, 100]`", "load", toml("").replace("[100.0, 100.0]", "[0.0, 100.0]"), "size_m[0]"),
    ("recipe param of the wrong type (`cell = \"2\"`)", "env",
     toml("").replace('source = "flat"', 'source = "procedural"\nrecipe = "ridge"\nparams = {cell = "2"}').replace(
         "size_m = [100.0, 100.0]\n", ""),
     "params.cell must be a finite number"),
    ("recipe `cell = 0`", "env",
     toml("").replace('source = "flat"', 'source = "procedural"\nrecipe = "ridge"\nparams = {cell = 0}').replace(
         "size_m = [100.0, 100.0]\n", ""),
     "params.cell must be a finite number > 0"),
    ("recipe `cell = 0.001` (too many cells)", "env",
     toml("").replace('source = "flat"', 'source = "procedural"\nrecipe = "ridge"\nparams = {cell = 0.001}').replace(
         "size_m = [100.0, 100.0]\n", ""),
     "grid cells"),
    ("`parallel_env(n_robots=10**9)`", "call", lambda d: tse.parallel_env(scenario="flat", n_robots=10**9),
     "n_robots must be an integer >= 1 and <= 100000"),
    ("`parallel_env(render_width=100000)`", "call",
     lambda d: tse.parallel_env(scenario="flat", render_width=100_000), "render_width must be"),
    ("`parallel_env(max_cycles=2.5)`", "call", lambda d: tse.parallel_env(scenario="flat", max_cycles=2.5),
     "max_cycles must be an integer"),
    ("`parallel_env(scenario=None)`", "call", lambda d: tse.parallel_env(scenario=None),
     "scenario must be a built-in scenario name"),
    ("`env.step([1, 2])` (not a dict)", "call", lambda d: _env().step([1, 2]), "actions must be a dict"),
    ("`env.step(None)`", "call", lambda d: _env().step(None), "actions must be a dict"),
    ("`env.step` with a complex action", "call", lambda d: _step_all(np.array([1 + 1j, 0])),
     "the action of robot_0 must be 2 real numbers"),
    ("`env.step` with a NaN action", "call", lambda d: _step_all(np.array([np.nan, 0.0])),
     "the action of robot_0 is not finite"),
    ("`env.step({'robot_99': ...})`", "call", lambda d: _env().step({"robot_99": np.zeros(2)}),
     "unknown agent 'robot_99'"),
    ("`env.reset(seed=-1)`", "call", lambda d: tse.parallel_env(scenario="flat", n_robots=2).reset(seed=-1),
     "seed must be None or an integer >= 0"),
    ("`env.reset(seed=1.5)`", "call", lambda d: tse.parallel_env(scenario="flat", n_robots=2).reset(seed=1.5),
     "seed must be None or an integer >= 0"),
    ("`env.reset(seed=\"abc\")`", "call", lambda d: tse.parallel_env(scenario="flat", n_robots=2).reset(seed="abc"),
     "seed must be None or an integer >= 0"),
    ("`train flat --gamma 2`", "cli", ["train", "flat", "--gamma", "2"], "--gamma must be a finite number > 0"),
    ("`train flat --clip-range -1`", "cli", ["train", "flat", "--clip-range", "-1"], "--clip-range must be"),
    ("`train flat --max-minutes -1`", "cli", ["train", "flat", "--max-minutes", "-1"], "--max-minutes must be"),
    ("`train flat --eval-episodes 0`", "cli", ["train", "flat", "--eval-episodes", "0"],
     "--eval-episodes must be an integer >= 1"),
    ("`train flat --batch-size 0`", "cli", ["train", "flat", "--batch-size", "0"], "--batch-size must be"),
    ("`train flat --net-arch abc`", "cli", ["train", "flat", "--net-arch", "abc"], "--net-arch 'abc'"),
    # checkpoints are data (tin-swarm train --resume)
    ("`train flat --resume DIR`, args.json nested 100000 deep", "cli", ["train", "flat", "--resume", "{d}/run_deep"],
     "nested 100000 levels deep; at most 32"),
    ("`train flat --resume DIR`, args.json `n_robots: \"eight\"`", "cli",
     ["train", "flat", "--resume", "{d}/run_type"], "--n-robots must be an integer"),
    ("`train flat --resume DIR`, args.json with an unknown key", "cli", ["train", "flat", "--resume", "{d}/run_key"],
     "key 'colour': found an unknown argument"),
    ("`train ramp --resume DIR` (a run on flat)", "cli", ["train", "ramp", "--resume", "{d}/run_type"],
     "key 'scenario': found 'flat', expected 'ramp'"),
    ("`train flat --resume DIR`, a truncated state.json", "cli", ["train", "flat", "--resume", "{d}/run_state"],
     "state.json: not valid JSON"),
    ("`train flat --resume DIR`, a checkpoint of another observation layout", "cli",
     ["train", "flat", "--resume", "{d}/run_layout"], "key 'run.obs_size': found 1, expected"),
    ("`train flat --resume DIR`, an older checkpoint's model.zip (a pickle)", "cli",
     ["train", "flat", "--resume", "{d}/run_pickle"], "refused without --trust-pickle"),
    # no output overwrites an input
    ("`run dem.toml --summary dem.xyz` (the DEM the scenario reads)", "cli",
     ["run", "{d}/dem.toml", "--summary", "{d}/dem.xyz", *FLAT], "is the input"),
    ("`run flat --policy pol --summary pol/notes.md`", "cli",
     ["run", "flat", "--policy", "{d}/pol", "--summary", "{d}/pol/notes.md", *FLAT], "lies inside the input"),
    ("`build-tin dem.xyz -o link.xyz` (a link to the DEM)", "cli", ["build-tin", "{d}/dem.xyz", "-o", "{d}/link.xyz"],
     "is the input"),
    ("`eval dem.toml --out DIR/...` (the scenario's own name)", "cli",
     ["eval", "{d}/dem.md", "--out", "{d}/dem", "--seeds", "1"], "is the input"),
    ("`train pol/s.toml --out-dir .` (a scenario inside the run's policy/)", "cli",
     ["train", "{d}/run_out/policy/s.toml", "--out-dir", "{d}/run_out"], "would write over the input"),
    # writes are atomic and checked
    ("disk full while writing `--gif`", "cli", ["run", "flat", "--gif", "{d}/full.gif", *FLAT],
     "full.gif: No space left on device; not written"),
    ("`run flat | head -1` (the reader goes away)", "cli", ["run", "flat", "--summary", "{d}/head.md", *FLAT],
     "exit 0"),
    # options that do not apply, parameters checked where they are defined
    ("`eval flat --by-family`", "cli", ["eval", "flat", "--by-family", "--seeds", "1"],
     "--by-family: no scenario of ['flat'] is generated"),
    ("`ChartParams(reach=inf)`", "call", lambda d: ChartParams(reach=float("inf")),
     "ChartParams.reach must be a finite number"),
    ("`ChartParams(stall_steps=0.5)`", "call", lambda d: ChartParams(stall_steps=0.5),
     "ChartParams.stall_steps must be an integer"),
    ("`ChartParams(cells=10**6)` (a 1 TB chart)", "call", lambda d: ChartParams(cells=10**6),
     "ChartParams.cells must be an integer >= 4 and <= 2048"),
    ("`BugParams(stall_crowded=True)`", "call", lambda d: BugParams(stall_crowded=True),
     "BugParams.stall_crowded must be an integer"),
    ("`FieldParams(break_gain=nan)`", "call", lambda d: FieldParams(break_gain=float("nan")),
     "FieldParams.break_gain must be a finite number"),
    ("`SensorParams(range_m=1e300)`", "call", lambda d: SensorParams(range_m=1e300), "SensorParams.range_m"),
    ("`robots = 5` (not a table)", "load", "robots = 5\n" + BASE + GOAL, "'robots' must be a table"),
    ("`[terrain] method = \"magic\"`", "load",
     'task = "goal"\n[terrain]\nsource = "procedural"\nrecipe = "cliff_goal"\nmethod = "magic"\n',
     "TerrainSpec.method must be one of"),
    ("`[terrain] families = []`", "load", 'task = "goal"\n[terrain]\nsource = "generated"\nfamilies = []\n',
     "'families' is empty"),
    ("a generated terrain 90 km wide", "load",
     'task = "goal"\n[terrain]\nsource = "generated"\nfamilies = ["fork"]\nranges = {fork = {size_m = [90000, 90000]}}\n',
     "fork.size_m: range [90000, 90000] must have lo <= hi within"),
]


def _env():
    env = tse.parallel_env(scenario="flat", n_robots=2)
    env.reset(seed=0)
    return env


def _step_all(action):
    env = _env()
    return env.step({a: action for a in env.agents})


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A temporary directory with the files some cases name (an SB3-looking .zip, a DEM, a scenario)."""
    (tmp_path / "model.zip").write_bytes(b"PK\x05\x06" + bytes(18))
    np.savez(tmp_path / "dem.npz", z=np.zeros((4, 4)))
    (tmp_path / "ok.toml").write_text(toml(""))
    _inputs(tmp_path)
    _run_dirs(tmp_path)
    monkeypatch.chdir(tmp_path)
    return tmp_path


DEM_SCEN = ('task = "goal"\nmax_cycles = 5\n[terrain]\nsource = "dem"\npath = "dem.xyz"\nmethod = "delaunay"\n'
            "[robots]\ncount = 2\nmin_separation_m = 1.0\n[targets]\npositions = [[20.0, 20.0]]\n")


def _inputs(d: Path):
    """A scenario reading a DEM (also named dem.md: a TOML file may have any name), a link to the DEM,
    a policy directory, a scenario inside a run directory's policy/."""
    from tin_swarm_env.policies.learned import save_policy

    xs, ys = np.meshgrid(np.arange(0.0, 50.0, 5.0), np.arange(0.0, 50.0, 5.0))
    np.savetxt(d / "dem.xyz", np.c_[xs.ravel(), ys.ravel(), 0.1 * xs.ravel()])
    (d / "dem.toml").write_text(DEM_SCEN)
    (d / "dem.md").write_text(DEM_SCEN)
    (d / "link.xyz").symlink_to(d / "dem.xyz")
    layout = tse.parallel_env(scenario="flat", n_robots=2).layout
    save_policy(d / "pol", [(np.zeros((2, layout.size)), np.zeros(2))], layout=layout, scenario="flat")
    (d / "run_out" / "policy").mkdir(parents=True)
    (d / "run_out" / "policy" / "s.toml").write_text(DEM_SCEN.replace('"dem.xyz"', '"../../dem.xyz"'))


def _run_dirs(d: Path):
    """Run directories of ``train flat`` (default arguments), each damaged in one way."""
    import dataclasses
    import json

    from tin_swarm_env.training import checkpoint as C
    from tin_swarm_env.training import config as T

    args = {k: v for k, v in dataclasses.asdict(T.Args(scenario="flat")).items() if k != "trust_pickle"}
    for name, a in (("run_deep", None), ("run_type", {**args, "n_robots": "eight"}),
                    ("run_key", {**args, "colour": "red"}), ("run_state", args), ("run_layout", args),
                    ("run_pickle", args)):
        (d / name).mkdir()
        (d / name / "args.json").write_text("[" * 100_000 + "]" * 100_000 if a is None else json.dumps(a))
    ck = d / "run_state" / "checkpoints" / "step_64"
    ck.mkdir(parents=True)
    (ck / "state.json").write_text('{"num_timesteps": 64, "rng": ')
    state = {"num_timesteps": 64, "rng": C._rng_state(), "env_rng": [None, None], "eval_rows": [], "minutes": 0.0,
             "next_eval": 0, "imitation": None}
    rng = np.zeros(5056, np.uint8)
    try:  # torch's own state when torch is here (its length is torch's)
        import torch

        rng = torch.get_rng_state().numpy()
    except ImportError:  # pragma: no cover
        pass
    for name, st in (("run_pickle", state),
                     ("run_layout", {**state, "format": C.FORMAT, "version": 1, "n_updates": 0,
                                     "run": {"scenario": "flat", "n_robots": 8, "n_copies": 2, "obs_size": 1,
                                             "layout": {}, "net_arch": [64, 64], "policy": "mlp", "lstm_hidden": 0,
                                             "shield": "none"}})):
        ck = d / name / "checkpoints" / "step_64"
        ck.mkdir(parents=True)
        (ck / "state.json").write_text(json.dumps(st))
        np.save(ck / "torch_rng.npy", rng)
    (d / "run_pickle" / "checkpoints" / "step_64" / "model.zip").write_bytes(b"PK\x05\x06" + bytes(18))


def _patch_for(label: str, monkeypatch):
    """The few cases that need a fault injected (disk full, Ctrl-C, a bug)."""
    import tin_swarm_env.apps.run as run

    real = run.format_table
    if label.startswith("disk full while writing `--gif`"):
        import tin_swarm_env.apps.media as media

        def full_gif(self, frame):
            raise OSError(28, "No space left on device")  # as a write says it: no file named

        monkeypatch.setattr(media.GifStream, "add", full_gif)
    elif label.startswith("disk full"):
        import types

        import tin_swarm_env._atomic as atomic

        def full(*a, **k):
            raise OSError(28, "No space left on device", "full.md")

        monkeypatch.setattr(atomic, "os", types.SimpleNamespace(**{**vars(os), "replace": full}))
    elif "head -1" in label:
        import sys

        class Head:
            def __init__(self):
                self.lines = 0

            def write(self, s):
                if self.lines >= 1:
                    raise BrokenPipeError(32, "Broken pipe")
                self.lines += s.count("\n")
                return len(s)

            def flush(self):
                pass

        monkeypatch.setattr(sys, "stdout", Head())
    elif label.startswith("Ctrl-C"):
        def stop(*a, **k):
            raise KeyboardInterrupt

        monkeypatch.setattr(run, "rollout", stop)
    elif label.startswith("an unexpected error"):
        monkeypatch.setattr(run, "format_table", lambda stats: real(stats) + 1)  # TypeError: a bug
    return monkeypatch


def outcome(label, kind, what, d: Path, capsys, monkeypatch) -> tuple[int | None, str]:
    """Run one case: ``(exit status or None for an API call, the one-line result)``."""
    if kind == "cli":
        _patch_for(label, monkeypatch)
        argv = [a.replace("{d}", str(d)) for a in what]
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own errors (exit 2, usage + one line)
            code = exc.code
        monkeypatch.undo()
        monkeypatch.chdir(d)
        cap = capsys.readouterr()
        assert "Traceback" not in cap.err, cap.err
        lines = [ln for ln in cap.err.splitlines() if ln.strip() and not ln.startswith(("usage:", "  "))]
        if code == 0:
            return code, "exit 0, runs"
        assert len(lines) == 1, cap.err
        return code, f"exit {code}: `{lines[0]}`"
    try:
        if kind == "call":
            what(d)
        else:
            path = _scenario(d, what)
            if kind == "load":
                tse.scenario.load_scenario(path)
            else:
                tse.parallel_env(scenario=path).reset(seed=0)
    except TinSwarmError as exc:
        return None, f"{type(exc).__name__}: `{' '.join(str(exc).split())}`"
    raise AssertionError(f"{label}: accepted")


def _table(results) -> str:
    rows = ["| input | what you get |", "|---|---|"]
    for label, res in results:
        res = res.replace("|", "\\|")
        if len(res) > 190:
            res = res[:186].rstrip() + "…`"
        rows.append(f"| {label} | {res} |")
    return "\n".join(rows)


def _normalise(text: str, d: Path) -> str:
    return text.replace(str(d), "DIR")


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_each_bad_input_gets_one_clear_line(case, workdir, capsys, monkeypatch):
    label, kind, what, expect = case
    code, line = outcome(label, kind, what, workdir, capsys, monkeypatch)
    if expect == "exit 0":
        assert code == 0, line
        return
    assert code != 0
    assert expect in line, line
    if label.startswith("Ctrl-C"):
        assert code == 130
    elif code is not None and not label.startswith("an unexpected"):
        assert code == 2


def test_no_partial_files_are_left(workdir, capsys, monkeypatch):
    """After the disk-full and Ctrl-C cases nothing but the inputs is left in the directory."""
    before = sorted(os.listdir(workdir))
    for label, kind, what, _ in CASES:
        if label.startswith(("disk full", "Ctrl-C")):
            outcome(label, kind, what, workdir, capsys, monkeypatch)
    assert sorted(os.listdir(workdir)) == before


def test_docs_table_is_current(workdir, capsys, monkeypatch, generated_doc):
    results = []
    for label, kind, what, _ in CASES:
        _, line = outcome(label, kind, what, workdir, capsys, monkeypatch)
        results.append((label, _normalise(line, workdir)))
    generated_doc("docs/figures/bad_input.md", _table(results) + "\n")
