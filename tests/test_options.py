"""Options declared once (tin_swarm_env/options.py): ``opt`` fields carry their help and what they
accept, and ``check_args`` refuses a value of the wrong type, out of range or not among the
choices, naming ``--field-name``, and normalises numbers."""

from __future__ import annotations

import dataclasses

import pytest

from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.options import accepts, check_args, opt, option_name


@dataclasses.dataclass
class Toy:
    rate: float = opt(0.5, "a rate", lo=0, lo_open=True, hi=1)
    count: int = opt(3, "a count", lo=1)
    mode: str = opt("a", "a mode", choices=("a", "b"))
    maybe: int | None = opt(None, "optional", lo=0)
    arch: str = opt("8", "widths", check=lambda v: None if v.isdigit() else "digits only")

    def __post_init__(self):
        check_args(self)


@pytest.mark.parametrize("kw, match", [
    ({"rate": 0}, r"--rate must be a finite number > 0 and <= 1, got 0"),
    ({"rate": 1.5}, r"--rate must be a finite number > 0 and <= 1, got 1.5"),
    ({"rate": float("nan")}, r"--rate must be a finite number > 0 and <= 1, got nan"),
    ({"rate": "0.5"}, r"--rate must be a finite number"),
    ({"count": 0}, r"--count must be an integer >= 1, got 0"), ({"count": 2.0}, "--count must be an integer"),
    ({"count": True}, "--count must be an integer"), ({"mode": "c"}, "--mode must be one of a, b, got 'c'"),
    ({"maybe": -1}, "--maybe must be an integer >= 0"), ({"arch": "x"}, "--arch 'x': digits only"),
])
def test_check_args_names_the_option_and_what_it_accepts(kw, match):
    with pytest.raises(ArgumentError, match=match):
        Toy(**kw)


def test_check_args_normalises_numbers():
    t = Toy(rate=1, maybe=None)
    assert t.rate == 1.0 and type(t.rate) is float
    assert accepts(dataclasses.fields(Toy)[0]) == "> 0 and <= 1"


def test_opt_refuses_an_option_without_help():
    for text in ("", "   ", None):
        with pytest.raises(TypeError, match="help text"):
            opt(1, text)


def test_option_name_is_the_command_line_spelling():
    assert option_name("total_timesteps") == "--total-timesteps" and option_name("seed") == "--seed"
