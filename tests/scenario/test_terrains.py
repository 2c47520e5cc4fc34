"""Terrain recipes (scenario/terrains.py): each parameter checked by type and range, named in the error."""

from __future__ import annotations

import pytest


def test_recipe_parameters_are_checked_by_type_and_range():
    from tin_swarm_env.errors import ScenarioError
    from tin_swarm_env.scenario.terrains import make_dem

    assert make_dem("ridge", {"width": 20, "height": 10.0, "cell": 2}).z.shape == (6, 11)
    bad = [("hills", {"n_hills": 2.5}, "n_hills must be an integer"), ("hills", {"seed": -1}, "seed must be"),
           ("cliff_goal", {"hill_xy": [1.0]}, "hill_xy must be a list of 2"),
           ("cliff_goal", {"hill_sd_m": 0}, "hill_sd_m must be a finite number > 0"),
           ("ridge", {"ridge_m": float("nan")}, "ridge_m must be a finite"), ("ridge", {"cell": True}, "cell"),
           ("canyon", {"travel": 3}, "travel must be a string"), ("canyon", {"travel": "north"}, "east' or 'west"),
           ("ramp", {"ramp_end_x": 10.0}, "ramp_end_x > ramp_start_x")]
    for recipe, params, msg in bad:
        with pytest.raises(ScenarioError, match=msg):
            make_dem(recipe, params, "f.toml [terrain]")
