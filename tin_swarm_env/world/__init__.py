"""Layer 1: pure models over numpy arrays (robots, sensing, locomotion, battery, entities).
Imports ``terrain`` only; knows nothing of PettingZoo, Gymnasium or torch."""

from .locomotion import BLOCKED_BORDER, BLOCKED_STEEP, FELL_INTO, MOVED
from .params import BatteryParams, RobotParams, SensorParams, WorldParams
from .sensing import BreakContacts, Contacts, SensorReadings, nearest_k
from .spawn import spawn_positions
from .state import Entities, Reason, WorldState
from .world import StepEvents, World, flat_tin

__all__ = [
    "BLOCKED_BORDER", "BLOCKED_STEEP", "FELL_INTO", "MOVED", "Reason",

    "BatteryParams", "BreakContacts", "Contacts", "Entities", "RobotParams", "SensorParams", "SensorReadings",
    "StepEvents", "World", "WorldParams", "WorldState", "flat_tin", "nearest_k", "spawn_positions",
]
