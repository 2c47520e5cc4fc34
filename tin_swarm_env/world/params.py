"""Robot, sensor, battery and world parameters: frozen dataclasses, units in the names.

The thesis's robot (4.3) is a sensor model + a locomotion model + a battery model + its
location and containing triangle; the first three are these parameters, the last lives in
:class:`~tin_swarm_env.world.state.WorldState`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError, check_range
from ..terrain.breaks import BREAK_ANGLE_DEG, MAX_SLOPE_DEG

__all__ = ["RobotParams", "SensorParams", "BatteryParams", "WorldParams", "MAX_SPEED_MPS"]


MAX_VALUE = 1e12  # the largest value any model parameter takes (finite, and so is its square)


def _positive(obj, *names, caps=None):
    """Each named field a finite number > 0, then at most its cap (``caps``; default :data:`MAX_VALUE`)."""
    for n in names:
        check_range(type(obj).__name__, n, getattr(obj, n), 0, lo_open=True)
        check_range(type(obj).__name__, n, getattr(obj, n), hi=(caps or {}).get(n, MAX_VALUE))


def _non_negative(obj, *names):
    for n in names:
        check_range(type(obj).__name__, n, getattr(obj, n), 0)
        check_range(type(obj).__name__, n, getattr(obj, n), hi=MAX_VALUE)


MAX_RADIUS_M = 1000.0  # a robot's body radius
MAX_RANGE_M = 100_000.0  # a sensor's range (the sensing work grows with the robots within it)
MAX_DT_S = 3600.0  # one step

# speeds above this make positions overflow or robots skip whole triangles in one step
MAX_SPEED_MPS = 1000.0


@dataclass(frozen=True)
class RobotParams:
    """Locomotion model.

    radius_m          body radius; two robots closer than 2 radii have collided
    max_speed_mps     speed for a command of norm 1 on level ground
    turn_rate_dps     the heading turns toward the direction of motion at most this fast
    max_slope_deg     steepest traversable triangle; steeper ones block a robot going up into
                      them and make a robot going down into them fall (destroyed)
    max_climb_deg     uphill pitch at which the speed drops to zero; speed scales by
                      ``1 - pitch / max_climb_deg`` going uphill (downhill: no change)
    """

    radius_m: float = 0.5
    max_speed_mps: float = 2.0
    turn_rate_dps: float = 180.0
    max_slope_deg: float = MAX_SLOPE_DEG
    max_climb_deg: float = 45.0

    def __post_init__(self):
        _positive(self, "radius_m", "max_speed_mps", "turn_rate_dps", "max_slope_deg", "max_climb_deg",
                  caps={"max_speed_mps": MAX_SPEED_MPS, "radius_m": MAX_RADIUS_M})
        if self.max_slope_deg >= 90:
            raise ParameterError(f"RobotParams.max_slope_deg must be < 90, got {self.max_slope_deg}")
        if self.max_climb_deg < self.max_slope_deg:
            raise ParameterError(f"RobotParams.max_climb_deg ({self.max_climb_deg}) must be >= max_slope_deg "
                             f"({self.max_slope_deg}): a robot must be able to climb every traversable slope")


@dataclass(frozen=True)
class SensorParams:
    """Sensor model.

    range_m           sensing range (horizontal distance)
    fov_deg           horizontal field of view centred on the heading (360 = all round)
    height_m          sensor height above the ground; the sight line runs between sensors
    check_los         whether the terrain can block sight (thesis Algorithm 7)
    max_candidates    per observer, at most this many nearest robots (and as many nearest
                      threats/targets, and assets) within range are checked for field of view
                      and line of sight; farther ones are not seen. Bounds sensing memory and
                      work at robots x max_candidates at any density. Keep it well above the
                      observation's k_robots/k_targets (4x or more), so that robots behind or
                      hidden do not crowd visible ones out of the nearest slots.
    """

    range_m: float = 60.0
    fov_deg: float = 270.0
    height_m: float = 0.5
    check_los: bool = True
    max_candidates: int = 16

    def __post_init__(self):
        _positive(self, "range_m", "fov_deg", caps={"range_m": MAX_RANGE_M})
        _non_negative(self, "height_m")
        if not isinstance(self.check_los, (bool, np.bool_)):
            raise ParameterError(f"SensorParams.check_los must be true or false, got {self.check_los!r}")
        check_range("SensorParams", "max_candidates", self.max_candidates, 1, 4096, integer=True)
        if self.fov_deg > 360:
            raise ParameterError(f"SensorParams.fov_deg must be in (0, 360], got {self.fov_deg}")


@dataclass(frozen=True)
class BatteryParams:
    """Battery model: energy drawn each step (J)::

        idle_w * dt + sensing_w * dt + drive_j_per_m * distance + climb_j_per_m * max(dz, 0)

    At zero the robot stops for good (status ``Reason.BATTERY``). The step that empties the battery
    still moves the robot; the charge is clipped at 0 and never increases.

    capacity_j        charge of a full battery
    idle_w            power drawn while switched on
    sensing_w         power drawn by the sensor
    drive_j_per_m     energy per metre driven
    climb_j_per_m     energy per metre climbed (~ 20 kg * 9.81 m/s^2)
    """

    capacity_j: float = 50_000.0
    idle_w: float = 2.0
    sensing_w: float = 3.0
    drive_j_per_m: float = 20.0
    climb_j_per_m: float = 200.0

    def __post_init__(self):
        _positive(self, "capacity_j")
        _non_negative(self, "idle_w", "sensing_w", "drive_j_per_m", "climb_j_per_m")


@dataclass(frozen=True)
class WorldParams:
    """The world: robot models, time step, entity heights, the flat plane's size.

    dt_s              simulated seconds per step
    entity_height_m   height above ground of the point robots aim their sight at on a
                      threat/target or asset
    entity_speed_mps  speed of mobile threats/targets and assets (random walk)
    entity_turn_sd_deg  standard deviation of a mobile entity's heading change per step
    flat_size_m       (width, height) of the plane used when no TIN is given
    break_angle_deg   planes meeting at more than this angle form a terrain break
    """

    robot: RobotParams = field(default_factory=RobotParams)
    sensor: SensorParams = field(default_factory=SensorParams)
    battery: BatteryParams = field(default_factory=BatteryParams)
    dt_s: float = 0.5
    entity_height_m: float = 1.0
    entity_speed_mps: float = 0.5
    entity_turn_sd_deg: float = 20.0
    flat_size_m: tuple[float, float] = (500.0, 500.0)
    break_angle_deg: float = BREAK_ANGLE_DEG

    def __post_init__(self):
        _positive(self, "dt_s")
        check_range("WorldParams", "dt_s", self.dt_s, hi=MAX_DT_S)
        for k in ("robot", "sensor", "battery"):
            want = {"robot": RobotParams, "sensor": SensorParams, "battery": BatteryParams}[k]
            if not isinstance(getattr(self, k), want):
                raise ParameterError(f"WorldParams.{k} must be a {want.__name__}, got {getattr(self, k)!r}")
        _non_negative(self, "entity_height_m", "entity_speed_mps", "entity_turn_sd_deg")
        check_range("WorldParams", "entity_speed_mps", self.entity_speed_mps, hi=MAX_SPEED_MPS)
        if not isinstance(self.flat_size_m, (tuple, list)) or len(self.flat_size_m) != 2:
            raise ParameterError(f"WorldParams.flat_size_m must be (width, height) > 0, got {self.flat_size_m}")
        for v in self.flat_size_m:
            check_range("WorldParams", "flat_size_m", v, 0, lo_open=True)
            check_range("WorldParams", "flat_size_m", v, hi=1e7)
        check_range("WorldParams", "break_angle_deg", self.break_angle_deg, 0, 180)
