"""Every parameter dataclass checks itself when it is made: NaN, inf, a negative
value, zero where it means nothing, a fraction for a count, a boolean for a number and a size past
its documented limit are each refused with a :class:`~tin_swarm_env.errors.ParameterError` (a
ValueError) naming the class and the field, before anything is allocated."""

from __future__ import annotations

import dataclasses

import pytest

from tin_swarm_env.errors import ParameterError
from tin_swarm_env.policies.bug import BugParams
from tin_swarm_env.policies.chart import MAX_CHART_CELLS, ChartParams
from tin_swarm_env.world.fields import FieldParams
from tin_swarm_env.world.params import BatteryParams, RobotParams, SensorParams, WorldParams

CLASSES = [ChartParams, BugParams, FieldParams, RobotParams, SensorParams, BatteryParams, WorldParams]
# fields where 0 means something (a switched-off gain, no power drawn, a sensor on the ground...)
ZERO_OK = {("FieldParams", k) for k in ("robot_gain", "target_gain", "break_gain", "height_gain", "asset_gain")} | {
    ("BatteryParams", k) for k in ("idle_w", "sensing_w", "drive_j_per_m", "climb_j_per_m")} | {
    ("SensorParams", "height_m"), ("WorldParams", "entity_height_m"), ("WorldParams", "entity_speed_mps"),
    ("WorldParams", "entity_turn_sd_deg"), ("WorldParams", "break_angle_deg"), ("ChartParams", "inset"),
    ("ChartParams", "side_cost"), ("ChartParams", "side_margin"),
    ("ChartParams", "side_leave_m"), ("ChartParams", "unseen_gap")}
# (ChartParams' zeros: no side preference; no free band; a side kept; no gap left out for being unseen)
HUGE = {("ChartParams", "cells"): 10 ** 6}  # 10**6 cells a side: a 1 TB chart per robot


def _numeric_fields(cls):
    out = []
    for f in dataclasses.fields(cls):
        d = f.default
        if isinstance(d, (int, float)) and not isinstance(d, bool):
            out.append((f.name, isinstance(d, int)))
    return out


def _cases():
    for cls in CLASSES:
        for name, is_int in _numeric_fields(cls):
            bad = {"nan": float("nan"), "inf": float("inf"), "-inf": float("-inf"), "negative": -1,
                   "bool": True, "string": "1", "huge": HUGE.get((cls.__name__, name), 10 ** 300 if is_int else 1e300)}
            if (cls.__name__, name) not in ZERO_OK:
                bad["zero"] = 0
            if is_int:
                bad["fraction"] = 2.5
            for what, v in bad.items():
                yield pytest.param(cls, name, v, id=f"{cls.__name__}.{name}={what}")


@pytest.mark.parametrize("cls,name,value", list(_cases()))
def test_each_parameter_dataclass_refuses_a_bad_number_naming_class_and_field(cls, name, value):
    with pytest.raises(ParameterError, match=rf"{cls.__name__}\.{name}\b"):
        cls(**{name: value})


@pytest.mark.parametrize("cls", CLASSES, ids=[c.__name__ for c in CLASSES])
def test_the_defaults_and_the_limits_themselves_are_accepted(cls):
    cls()
    if cls is ChartParams:
        assert ChartParams(cells=MAX_CHART_CELLS, stall_steps=1).cells == MAX_CHART_CELLS
        with pytest.raises(ParameterError, match="ChartParams.cells"):
            ChartParams(cells=MAX_CHART_CELLS + 1)


def test_the_non_numeric_fields_are_checked_too():
    with pytest.raises(ParameterError, match="SensorParams.check_los"):
        SensorParams(check_los="no")
    with pytest.raises(ParameterError, match="FieldParams.fields"):
        FieldParams(fields=("robot", 3))
    with pytest.raises(ParameterError, match="WorldParams.robot"):
        WorldParams(robot={"radius_m": 1.0})
    with pytest.raises(ParameterError, match="WorldParams.flat_size_m"):
        WorldParams(flat_size_m=(float("inf"), 1.0))


def test_every_parameter_dataclass_of_the_package_is_in_this_test():
    """A new ``*Params`` dataclass in policies/ or world/ must join :data:`CLASSES`."""
    import importlib
    import pkgutil

    import tin_swarm_env.policies as P
    import tin_swarm_env.world as W

    found = set()
    for pkg in (P, W):
        for m in pkgutil.iter_modules(pkg.__path__):
            mod = importlib.import_module(f"{pkg.__name__}.{m.name}")
            for k, v in vars(mod).items():
                if k.endswith("Params") and dataclasses.is_dataclass(v) and v.__module__ == mod.__name__:
                    found.add(v)
    assert found <= set(CLASSES), found - set(CLASSES)
