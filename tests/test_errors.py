"""The error classes and checks (errors.py): the class hierarchy, ``check_range`` (NaN, inf, bool and
strings refused, open and closed ends, the key named), ``check_fields`` and ``require``."""

from __future__ import annotations

import re

import numpy as np
import pytest


def test_check_range_refuses_nan_inf_bool_and_strings():
    from tin_swarm_env.errors import ParameterError, check_range

    assert check_range("X", "a", 3, 0, 5) == 3
    for v in (float("nan"), float("inf"), -float("inf"), True, "3", None, -1, 6):
        with pytest.raises(ParameterError, match=re.escape("X.a must be a finite number >= 0 and <= 5")):
            check_range("X", "a", v, 0, 5)
    with pytest.raises(ParameterError, match="must be an integer > 0"):
        check_range("X", "k", 2.5, 0, lo_open=True, integer=True)
    assert check_range("X", "k", np.int64(4), 0, integer=True) == 4


def test_every_error_is_a_tin_swarm_error_and_bad_values_are_value_errors():
    import tin_swarm_env.errors as E

    classes = [c for c in vars(E).values()
               if isinstance(c, type) and issubclass(c, Exception) and c.__module__ == E.__name__]
    assert E.ArgumentError in classes and all(issubclass(c, E.TinSwarmError) for c in classes)
    for c in classes:
        if c not in (E.TinSwarmError, E.MissingExtraError, E.OutputError):
            assert issubclass(c, ValueError), c
    assert issubclass(E.MissingExtraError, ImportError) and not issubclass(E.MissingExtraError, ValueError)
    # a write that failed (full disk, broken pipe) is no bad value: an OSError naming the file
    assert issubclass(E.OutputError, OSError) and not issubclass(E.OutputError, ValueError)
    assert E.OutputError(28, "No space left on device", "x.gif").filename == "x.gif"


def test_range_ends_open_closed_and_the_exception_class():
    from tin_swarm_env.errors import ArgumentError, ParameterError, check_range

    assert check_range("W", "x", 0.0, 0.0) == 0.0  # a closed end takes its bound
    with pytest.raises(ParameterError, match=re.escape("W.x must be a finite number > 0, got 0.0")):
        check_range("W", "x", 0.0, 0.0, lo_open=True)
    with pytest.raises(ParameterError, match=re.escape("W.x must be a finite number < 1, got 1")):
        check_range("W", "x", 1, hi=1.0, hi_open=True)
    with pytest.raises(ParameterError, match=re.escape("W.x must be a finite number, got nan")):
        check_range("W", "x", float("nan"))  # no bounds to state
    with pytest.raises(ArgumentError, match="--seeds"):
        check_range("cli", "--seeds", -1, 1, exc=ArgumentError)


def test_check_fields_names_the_dataclass_and_the_field():
    from dataclasses import dataclass

    from tin_swarm_env.errors import ParameterError, check_fields

    @dataclass
    class Robot:
        speed: float = 1.0
        count: int = 3

    limits = {"speed": {"lo": 0, "lo_open": True}, "count": {"lo": 1, "integer": True}}
    check_fields(Robot(), limits)
    with pytest.raises(ParameterError, match=re.escape("Robot.count must be an integer >= 1, got 0")):
        check_fields(Robot(count=0), limits)
    with pytest.raises(ParameterError, match=re.escape("Robot.speed must be a finite number > 0, got -2.0")):
        check_fields(Robot(speed=-2.0), limits)


def test_require_imports_a_present_module_and_names_the_extra_for_a_missing_one():
    from tin_swarm_env.errors import MissingExtraError, require

    assert require("json", "none", "reading") is __import__("json")
    with pytest.raises(MissingExtraError, match=re.escape(
            "GeoTIFF needs the optional package 'tse_no_such_mod', which is not installed; "
            "install it with: pip install 'tin_swarm_env[geo]'")):
        require("tse_no_such_mod", "geo", "GeoTIFF")
