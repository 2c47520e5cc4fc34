"""World parameters (world/params.py): each dataclass checks its values and names the bad one."""

from __future__ import annotations

import re

import pytest

from tin_swarm_env.errors import ParameterError
from tin_swarm_env.world import BatteryParams, RobotParams, SensorParams, WorldParams


def test_max_candidates_must_be_a_positive_integer():
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="max_candidates"):
            SensorParams(max_candidates=bad)


@pytest.mark.parametrize("cls,kw,msg", [
    (RobotParams, {"radius_m": 0.0}, "RobotParams.radius_m must be a finite number > 0, got 0.0"),
    (RobotParams, {"max_speed_mps": 1001.0}, "RobotParams.max_speed_mps must be a finite number <= 1000, got 1001.0"),
    (RobotParams, {"max_slope_deg": 90.0, "max_climb_deg": 95.0}, "RobotParams.max_slope_deg must be < 90, got 90.0"),
    (RobotParams, {"max_slope_deg": 30.0, "max_climb_deg": 20.0}, "RobotParams.max_climb_deg (20.0) must be >="),
    (SensorParams, {"fov_deg": 361.0}, "SensorParams.fov_deg must be in (0, 360], got 361.0"),
    (SensorParams, {"height_m": -0.1}, "SensorParams.height_m must be a finite number >= 0, got -0.1"),
    (SensorParams, {"range_m": float("nan")}, "SensorParams.range_m must be a finite number > 0, got nan"),
    (BatteryParams, {"capacity_j": 0}, "BatteryParams.capacity_j must be a finite number > 0, got 0"),
    (BatteryParams, {"idle_w": -1.0}, "BatteryParams.idle_w must be a finite number >= 0, got -1.0"),
    (WorldParams, {"dt_s": 0.0}, "WorldParams.dt_s must be a finite number > 0, got 0.0"),
    (WorldParams, {"flat_size_m": (10.0,)}, "WorldParams.flat_size_m must be (width, height) > 0, got (10.0,)"),
    (WorldParams, {"flat_size_m": (10.0, -1.0)}, "WorldParams.flat_size_m must be a finite number > 0, got -1.0"),
    (WorldParams, {"break_angle_deg": 181.0}, "WorldParams.break_angle_deg must be a finite number >= 0 and <= 180"),
])
def test_each_parameter_is_checked_and_named(cls, kw, msg):
    with pytest.raises(ParameterError, match=re.escape(msg)):
        cls(**kw)


def test_the_limits_themselves_are_accepted():
    RobotParams(max_speed_mps=1000.0, max_slope_deg=89.9, max_climb_deg=89.9)
    SensorParams(fov_deg=360.0, height_m=0.0, max_candidates=4096)
    BatteryParams(idle_w=0.0, sensing_w=0.0, drive_j_per_m=0.0, climb_j_per_m=0.0)
    WorldParams(entity_speed_mps=0.0, break_angle_deg=180.0)
