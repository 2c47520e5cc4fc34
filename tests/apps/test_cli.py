"""The command line (apps/cli.py): help and defaults on every option, --version, --debug,
``scenarios --copy``, ``build-tin`` and the train options."""

import argparse
import dataclasses
import subprocess
import sys

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.args import accepts
from tin_swarm_env.apps.cli import COMMANDS, build_parser, main
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


def test_cli_train_exposes_the_imitation_options():
    ns = build_parser().parse_args(["train", "cliff_goal,ramp", "--bc-episodes", "3", "--dagger-rounds", "2",
                                    "--recurrent", "false", "--timesteps", "0"])
    got = (ns.scenario, ns.bc_episodes, ns.dagger_rounds, ns.recurrent, ns.total_timesteps)
    assert got == ("cliff_goal,ramp", 3, 2, False, 0)


def _subparsers(p):
    act = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    return act.choices


SUBCOMMANDS = ("run", "scenarios", "explore", "train", "eval", "build-tin")


def test_the_parser_has_every_subcommand_and_shows_defaults():
    p = build_parser()
    assert tuple(_subparsers(p)) == SUBCOMMANDS == tuple(COMMANDS)
    assert issubclass(p.formatter_class, argparse.ArgumentDefaultsHelpFormatter)


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_every_option_has_help_and_help_runs(name, capsys):
    """For each subcommand, read off the parser: every argument has a non-empty help text, every
    non-empty default is shown, and ``tin-swarm NAME --help`` exits 0 listing every option."""
    sp = _subparsers(build_parser())[name]
    assert issubclass(sp.formatter_class, argparse.ArgumentDefaultsHelpFormatter), name
    text = " ".join(sp.format_help().split())
    actions = [a for a in sp._actions if not isinstance(a, argparse._HelpAction)]
    assert actions
    for a in actions:
        assert isinstance(a.help, str) and a.help.strip() and a.help != argparse.SUPPRESS, (name, a.dest)
        if not (a.default is None or a.default is False or a.default in ([], "")) and a.option_strings:
            assert f"(default: {a.default})" in text, (name, a.dest)
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: tin-swarm {name} ")
    for a in actions:
        for s in a.option_strings or [a.dest]:
            assert s in out, (name, s)


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_options_are_generated_from_the_args_dataclass(name):
    """No hand-written option: a subcommand's arguments are exactly the fields of its ``Args``, each
    with the field's help text (and what it accepts)."""
    cmd = COMMANDS[name]
    fields = {f.name: f for f in dataclasses.fields(cmd.load(cmd.args))}
    actions = {a.dest: a for a in _subparsers(build_parser())[name]._actions if not isinstance(a, argparse._HelpAction)}
    assert set(actions) == set(fields)
    for dest, a in actions.items():
        f = fields[dest]
        assert a.help.startswith(f.metadata["help"]), (name, dest)
        if accepts(f) and not f.metadata.get("choices"):
            assert f"[{accepts(f)}]" in a.help, (name, dest)
        assert callable(cmd.load(cmd.run))


def test_version_and_debug(capsys, monkeypatch):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"tin-swarm {tse.__version__}"
    assert main(["run", "atlantis", "--quiet"]) == 2
    with pytest.raises(tse.errors.ScenarioError):
        main(["--debug", "run", "atlantis", "--quiet"])
    monkeypatch.setenv("TIN_SWARM_DEBUG", "1")
    with pytest.raises(tse.errors.ScenarioError):
        main(["run", "atlantis", "--quiet"])


def test_scenarios_copy_writes_the_builtin_and_refuses_to_overwrite(tmp_path, capsys):
    from tin_swarm_env.scenario.config import SCENARIO_DIR, load_scenario

    ramp = (SCENARIO_DIR / "ramp.toml").read_bytes()
    assert main(["scenarios", "--copy", "ramp", str(tmp_path)]) == 0  # into a directory: ramp.toml
    assert (tmp_path / "ramp.toml").read_bytes() == ramp
    dest = tmp_path / "mine.toml"
    dest.write_text("keep me")
    assert main(["scenarios", "--copy", "ramp", str(dest)]) == 2
    assert dest.read_text() == "keep me" and "--force" in capsys.readouterr().err
    assert main(["scenarios", "--copy", "ramp", str(dest), "--force"]) == 0
    assert dest.read_bytes() == ramp
    assert load_scenario(dest).name == "mine"  # the name comes from the file (no name key in the built-ins)
