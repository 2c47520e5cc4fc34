"""Scenarios: TOML files -> typed config -> world and initial state (the generators)."""

from .build import assignments, build_tin_for, build_world, initial_state
from .config import (
    SCENARIO_DIR,
    EntitiesSpec,
    ObservationSpec,
    RewardWeights,
    RobotsSpec,
    ScenarioConfig,
    ScenarioError,
    TerrainSpec,
    list_scenarios,
    load_scenario,
    scenario_from_dict,
)

__all__ = [
    "SCENARIO_DIR", "EntitiesSpec", "ObservationSpec", "RewardWeights", "RobotsSpec", "ScenarioConfig",
    "ScenarioError", "TerrainSpec", "assignments", "build_tin_for", "build_world", "initial_state",
    "list_scenarios", "load_scenario", "scenario_from_dict",
]
