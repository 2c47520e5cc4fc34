"""The command line (apps/cli.py): every subcommand, help and defaults on every option, options generated
from each command's Args, --version, --debug, and the train options. Each command's own behaviour is
tested with its module (tests/apps/test_run.py, test_build_tin.py, test_scenarios.py, ...)."""

import argparse
import dataclasses

import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.args import accepts
from tin_swarm_env.apps.cli import COMMANDS, build_parser, main


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
