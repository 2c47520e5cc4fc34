"""Options declared once (``apps/args.py``): each ``Args`` field's help and accepted range live beside
the field; ``--help`` shows both for every option; an ``Args`` built in code or from the command line
is checked before any work, naming ``--option``."""

from __future__ import annotations

import dataclasses

import pytest

from tin_swarm_env.apps.args import accepts, check_args, opt
from tin_swarm_env.apps.cli import build_parser, main
from tin_swarm_env.errors import ArgumentError


def test_train_help_explains_every_option():
    from tin_swarm_env.apps.train import Args  # the training library's, re-exported by the command

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["train"]
    helps = {a.dest: a.help for a in sub._actions}
    for f in dataclasses.fields(Args):
        assert helps.get(f.name), f"--{f.name} has no help"
        assert f.metadata["help"] in helps[f.name]
        if accepts(f) and not f.metadata.get("choices"):
            assert f"[{accepts(f)}]" in helps[f.name]


@pytest.mark.parametrize("argv, match", [
    (["--gamma", "2"], "--gamma must be a finite number > 0 and <= 1, got 2.0"),
    (["--timesteps", "-1"], "--timesteps must be an integer >= 0, got -1"),  # the option as `train` spells it
    (["--clip-range", "-1"], "--clip-range must be a finite number > 0"),
    (["--max-minutes", "-1"], "--max-minutes must be a finite number >= 0"),
    (["--eval-episodes", "0"], "--eval-episodes must be an integer >= 1"),
    (["--batch-size", "0"], "--batch-size must be an integer >= 2"),
    (["--n-steps", "0"], "--n-steps must be an integer >= 1"),
    (["--torch-threads", "0"], "--torch-threads must be an integer >= 1"),
    (["--net-arch", "abc"], "--net-arch 'abc': give hidden layer widths"),
    (["--net-arch", "0,0"], "--net-arch '0,0': give hidden layer widths"),
    (["--net-arch", "64,99999"], "--net-arch '64,99999'"),
    (["--shield", "magic"], "--shield must be one of none, safety_cut"),
    (["--learning-rate", "inf"], "--learning-rate must be a finite number > 0"),
    (["--batch-size", "4096", "--n-steps", "8", "--n-robots", "2", "--n-envs", "1"], "more than one rollout holds"),
])
def test_bad_train_options_stop_before_training(argv, match, capsys, tmp_path):
    assert main(["train", "flat", "--out-dir", str(tmp_path / "run"), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0], err
    assert not (tmp_path / "run").exists()  # nothing was started


@pytest.mark.parametrize("module, kw, match", [
    ("run", {"episodes": 0}, "--episodes must be an integer >= 1, got 0"),
    ("run", {"robots": 100_001}, "--robots must be an integer >= 1 and <= 100000"),
    ("run", {"render_width": 63}, "--render-width must be an integer >= 64 and <= 4096, got 63"),
    ("run", {"seed": -1}, "--seed must be an integer >= 0"),
    ("run", {"fields": "robot,wind"}, r"--fields 'robot,wind': unknown field\(s\) \['wind'\]"),
    ("run", {"fields": " , "}, "--fields ' , ': no field named"),
    ("run", {"mp4": "a.gif"}, "--mp4 'a.gif': the file name must end in .mp4"),
    ("run", {"quiet": "yes"}, "--quiet must be true or false"),
    ("explorer", {"robot": "x"}, "--robot 'x': give a robot index >= 0 or 'all'"),
    ("explorer", {"robot": "-2"}, "--robot '-2'"),
    ("explorer", {"steps": -1}, "--steps must be an integer >= 0"),
    ("build_tin", {"output": "t.tin", "method": "VIP"}, "--method must be one of vip, greedy, delaunay, robot"),
    ("build_tin", {"output": "t.tin", "max_slope_deg": 0}, "--max-slope-deg must be a finite number > 0 and < 90"),
    ("build_tin", {"output": "t.tin", "min_significance_m": float("inf")}, "--min-significance-m must be a finite"),
    ("build_tin", {"output": ""}, "--output '': is required"),
    ("scenarios", {"copy": ["ramp"]}, "--copy \\['ramp'\\]: give NAME DEST"),
])
def test_every_command_args_is_checked_when_built_in_code(module, kw, match):
    import importlib

    cls = importlib.import_module(f"tin_swarm_env.apps.{module}").Args
    with pytest.raises(ArgumentError, match=match):
        cls(**kw)


def test_command_args_accept_good_values():
    from tin_swarm_env.apps import build_tin, explorer, run, scenarios

    assert run.Args(fields=" robot, target ", robots=3).robots == 3
    assert explorer.Args(robot="ALL").robot_index is None and explorer.Args(robot=" 7").robot_index == 7
    assert build_tin.Args(output="t.tin", max_error_m=1).max_error_m == 1.0  # normalised to a float
    assert scenarios.Args(copy=["ramp", "x.toml"], force=True).force
    assert run.parse_fields(" robot, target ") == ("robot", "target") and run.parse_fields(None, "d") == "d"


@dataclasses.dataclass
class Words:
    names: str = opt("a", "names", nargs="+")
    tags: str = opt("", "tags", action="append")
    pair: list | None = opt(None, "two words", nargs=2)

    def __post_init__(self):
        check_args(self)


def test_a_str_field_given_as_several_words_or_a_repeated_option_holds_them_comma_joined():
    """The scripts' parser (``parse_dataclass``, e.g. agents/evaluate.py --scenarios) and the CLI both
    join the words of a ``str`` field; a ``list`` field keeps its list."""
    from tin_swarm_env.apps.args import parse_dataclass
    from tin_swarm_env.apps.evaluate import Args as EvalArgs

    w = parse_dataclass(Words, ["--names", "x", "y", "--tags", "p", "--tags", "q", "--pair", "m", "n"])
    assert (w.names, w.tags, w.pair) == ("x,y", "p,q", ["m", "n"])
    assert parse_dataclass(Words, []).names == "a"
    assert parse_dataclass(EvalArgs, ["--scenarios", "cliff_goal,generated"]).scenarios == "cliff_goal,generated"
