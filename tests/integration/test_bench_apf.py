"""bench/apf.py's reporting (run by hand): the false-unreachable count, on exact small cases."""

import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[2]


def _bench():
    spec = importlib.util.spec_from_file_location("bench_apf", ROOT / "bench" / "apf.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("bench_apf", mod)  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def test_verdicts_count_timed_out_robots_that_said_unreachable_and_those_the_map_reaches():
    bench = _bench()
    env = tse.parallel_env(scenario="cliff_goal", n_robots=4)
    env.reset_arrays(seed=0)
    field = env.target_fields[0]
    assert np.all(np.isfinite(field.distance_at(env.world_state.positions)))  # every spawn reaches the target
    reasons = np.array([Reason.TIMEOUT, Reason.TIMEOUT, Reason.ARRIVED, Reason.TIMEOUT], dtype=np.int8)
    out = SimpleNamespace(n_robots=4, reasons=reasons)
    pol = SimpleNamespace(unreachable=np.array([True, True, True, False]))
    # robots 0 and 1 timed out saying so (2 arrived: not counted; 3 did not say so); both reachable
    assert bench._verdicts(env, pol, out) == (2, 2)
    env.world_state.positions[1] = env.world_state.targets.positions[0] * 0 - 1e6  # off the map: not reachable
    assert bench._verdicts(env, pol, out) == (2, 1)
    assert bench._verdicts(env, SimpleNamespace(), out) == (0, 0)  # a policy without the flag


def test_verdicts_of_a_policy_whose_memory_saw_fewer_rows():
    bench = _bench()
    env = tse.parallel_env(scenario="cliff_goal", n_robots=3)
    env.reset_arrays(seed=0)
    out = SimpleNamespace(n_robots=3, reasons=np.full(3, Reason.TIMEOUT, dtype=np.int8))
    assert bench._verdicts(env, SimpleNamespace(unreachable=np.zeros(0, dtype=bool)), out) == (0, 0)
    assert bench._verdicts(env, SimpleNamespace(unreachable=np.array([False, True])), out) == (1, 1)


def test_generated_rows_take_another_held_out_set_and_episode_length():
    bench = _bench()
    from tin_swarm_env.training.evaluation import EVAL_SEED0

    args = SimpleNamespace(generated=3, seed_offset=100, max_cycles=3000, robots=2, only=["generated: fork"],
                           seeds=1, jacksboro_seeds=1, k_scan=0)
    (row,) = bench._rows(args)
    assert row.seeds == range(EVAL_SEED0 + 100, EVAL_SEED0 + 103)
    env = row.make()
    assert env.unwrapped.config.max_cycles == 3000 and env.unwrapped.config.terrain.families == ("fork",)
    assert env.unwrapped.layout.k_scan == 0


def test_every_kind_of_row_takes_the_scan():
    bench = _bench()
    args = SimpleNamespace(generated=1, seed_offset=0, max_cycles=None, robots=2, seeds=1, jacksboro_seeds=1,
                           k_scan=24, only=["cliff_goal", "valley.toml", "canyon, pass left, going east",
                                            "generated: trap"])
    rows = bench._rows(args)
    assert [r.label for r in rows] == ["cliff_goal", "valley.toml", "canyon, pass left, going east", "generated: trap"]
    for r in rows:
        lay = r.make().unwrapped.layout
        assert lay.k_scan == 24 and lay.k_breaks == 3, r.label


def test_bad_seed_offset_and_episode_length_are_refused_by_name(capsys):
    bench = _bench()
    for argv, name in ((["--seed-offset", "-1"], "--seed-offset"), (["--max-cycles", "0"], "--max-cycles"),
                       (["--k-scan", "-3"], "--k-scan")):
        try:
            bench.main(["--quick", *argv])
        except SystemExit as exc:
            assert exc.code == 2
        else:
            raise AssertionError(f"{argv} was accepted")
        assert name in capsys.readouterr().err
