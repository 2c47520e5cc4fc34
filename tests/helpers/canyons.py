"""Canyon test terrains the APF baseline never saw while it was written.

400 x 400 m, 2 m cells: a 50 m plateau whose near-vertical north-south cliff has one 20 m wide
pass at one end; 20 robots on the plateau, the target on the floor beyond the cliff. Four
variants: the pass on the robots' left or right, travelling east or west; and the same with a
trench cut into the plateau leading onto a causeway (two breaks meet where the trench walls
meet the cliff and the causeway's sides).
"""

from __future__ import annotations

from tin_swarm_env.scenario import scenario_from_dict

VARIANTS = [(side, travel) for travel in ("east", "west") for side in ("left", "right")]
SIZE_M, CLIFF_X = 400.0, 200.0


def pass_band(side: str, travel: str) -> tuple[float, float]:
    """The pass's y band: near the north end when it lies on the robots' left going east (or
    right going west), near the south end otherwise."""
    north = (side == "left") == (travel == "east")
    return (330.0, 350.0) if north else (50.0, 70.0)


def canyon_config(side: str = "left", travel: str = "east", trench: bool = False, robots: int = 20,
                  max_cycles: int = 1500):
    """A :class:`~tin_swarm_env.scenario.ScenarioConfig` for one canyon variant."""
    if side not in ("left", "right") or travel not in ("east", "west"):
        raise ValueError(f"side must be left/right and travel east/west, got {side!r}, {travel!r}")
    params = {"pass_y": list(pass_band(side, travel)), "travel": travel, "cliff_x": CLIFF_X}
    if trench:
        params.update(ramp_in_m=80.0, ramp_out_m=80.0)

    def x(v):  # mirror for westward travel
        return v if travel == "east" else SIZE_M - v

    x0, x1 = sorted((x(40.0), x(130.0)))
    return scenario_from_dict({
        "name": f"canyon_{'trench_' if trench else ''}{side}_{travel}", "task": "goal", "max_cycles": max_cycles,
        "terrain": {"source": "procedural", "recipe": "canyon", "method": "delaunay",
                    "params": params},
        "robots": {"count": robots, "spawn_region": [x0, 160.0, x1, 240.0], "max_slope_deg": 30.0},
        "targets": {"positions": [[x(330.0), 200.0]], "arrival_radius_m": 8.0},
    }, source=f"tests/helpers/canyons.py ({side}, {travel}{', trench' if trench else ''})")
