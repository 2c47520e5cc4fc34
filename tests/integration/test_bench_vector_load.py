"""bench/vector_load.py's counts (run by hand; its --quick run is in test_bench_quick.py): the sensing load
per robot is counted right, on a hand-built reading with exact answers and against a brute-force count of
the break segments within range on a generated terrain, and bad sizes are refused by name."""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.terrain.breaks import ANGLE, closest_on_segments

ROOT = Path(__file__).resolve().parents[2]


def _bench():
    mod = sys.modules.get("bench_vector_load")
    if mod is None:
        spec = importlib.util.spec_from_file_location("bench_vector_load", ROOT / "bench" / "vector_load.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules["bench_vector_load"] = mod
        spec.loader.exec_module(mod)
    return mod


BENCH = _bench()


def test_load_of_a_hand_built_reading():
    # 4 robots; robot 2 is not live. Robot contacts: 0 sees 1 and 3, 1 sees 0, 2 sees 3 (not counted: not live).
    readings = SimpleNamespace(
        robots=SimpleNamespace(observer=np.array([0, 0, 1, 2])),
        breaks=SimpleNamespace(observer=np.array([0, 0, 0, 3, 2]), break_idx=np.array([0, 1, 2, 1, 2])))
    danger = np.array([True, False, True])
    live = np.array([True, True, False, True])
    got = BENCH.load_of(readings, danger, live)
    assert got["robots"].tolist() == [2, 1, 0]
    assert got["breaks"].tolist() == [3, 0, 1]
    assert got["dangerous"].tolist() == [2, 0, 0]


def test_break_counts_match_a_brute_force_count_within_range():
    env = tse.parallel_env(scenario=BENCH.scenario_of("trap"), n_robots=6)
    env.reset_arrays(seed=3)
    world = env.world
    danger = np.asarray(world.breaks.kinds) != ANGLE
    live = np.asarray(env.live_mask)
    got = BENCH.load_of(world.sense(env.world_state), danger, live)
    seg = world.breaks.segments[:, :, :2]
    pos = np.asarray(env.world_state.positions)[:, None, :2]
    _, d = closest_on_segments(pos, seg[None, :, 0], seg[None, :, 1])
    near = d <= world.params.sensor.range_m
    assert got["breaks"].tolist() == near.sum(axis=1)[live].tolist()
    assert got["dangerous"].tolist() == (near & danger[None]).sum(axis=1)[live].tolist()
    assert got["breaks"].sum() > 0  # a trap: its robots have breaks in range, so the comparison means something


def test_scenario_of_restricts_the_generated_mix_to_one_family():
    assert BENCH.scenario_of("jacksboro") == "jacksboro"
    assert BENCH.scenario_of("generated") == "generated"
    cfg = BENCH.scenario_of("fork")
    assert tuple(cfg.terrain.families) == ("fork",)


@pytest.mark.parametrize("text", ["256", "0x4", "ax4", "4x-1"])
def test_bad_sizes_are_refused_by_name(text):
    with pytest.raises(argparse.ArgumentTypeError, match="--size"):
        BENCH._size(text)
