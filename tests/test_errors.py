"""The error classes and checks (errors.py): ``check_range`` refuses NaN, inf, bool and strings and
names the key."""

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
