"""Scenarios: TOML files -> typed config -> world and initial state (the generators)."""

from .build import (
    Stage,
    assignments,
    build_stage,
    build_tin_for,
    build_world,
    initial_state,
    place_entities,
    reaches_region,
    spawn_reachable,
    target_field,
)
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
from .mirror import mirror_scenario

__all__ = [
    "SCENARIO_DIR", "EntitiesSpec", "ObservationSpec", "RewardWeights", "RobotsSpec", "ScenarioConfig",
    "ScenarioError", "Stage", "TerrainSpec", "assignments", "build_stage", "build_tin_for", "build_world",
    "initial_state", "list_scenarios", "place_entities", "spawn_reachable", "load_scenario", "mirror_scenario",
    "reaches_region", "scenario_from_dict", "target_field",
]
