"""The env's front doors (``env/checks.py``): ``step``/``reset``/``parallel_env`` and the adapters'
keyword arguments refuse bad values with a TinSwarmError naming the argument or the agent; a
hypothesis test drives ``step`` and ``reset`` with arbitrary Python values."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tin_swarm_env as tse
from tin_swarm_env.env.checks import ENV_ARGS, signature_args
from tin_swarm_env.errors import ArgumentError, TinSwarmError

N = 3
pytestmark = pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning")  # reprs of big values


@pytest.fixture(scope="module")
def env():
    e = tse.parallel_env(scenario="flat", n_robots=N, max_cycles=100_000)
    e.reset(seed=0)
    return e


def test_env_args_list_matches_the_constructor():
    assert signature_args(tse.env.TinSwarmEnv) == ENV_ARGS


@pytest.mark.parametrize("actions, culprit", [
    ([1, 2], "actions must be a dict"), (None, "actions must be a dict"), ("abc", "actions must be a dict"),
    ({1, 2}, "actions must be a dict"), (np.zeros((N, 2)), "actions must be a dict"),
    ({"robot_0": np.array([1 + 2j, 0])}, "robot_0"), ({"robot_1": "ab"}, "robot_1"), ({"robot_2": None}, "robot_2"),
    ({"robot_0": [[0.1, 0.2]]}, "robot_0"), ({"robot_0": [True, False]}, "robot_0"), ({"robot_0": b"ab"}, "robot_0"),
    ({"robot_0": {"x": 1}}, "robot_0"), ({"robot_0": [0.1]}, "robot_0"), ({"robot_0": [0.1, 0.2, 0.3]}, "robot_0"),
    ({"robot_1": [np.nan, 0.0]}, "robot_1"), ({"robot_2": [0.0, np.inf]}, "robot_2"), ({"robot_0": [1, "a"]}, "robot_0"),
    ({"robot_9": [0.0, 0.0]}, "robot_9"), ({0: [0.0, 0.0]}, "unknown agent 0"), ({None: [0, 0]}, "unknown agent None"),
])
def test_step_refuses_bad_actions_naming_the_agent(env, actions, culprit):
    before = env.world_state.positions.copy()
    with pytest.raises(ArgumentError, match="step") as info:
        env.step(actions)
    assert culprit in str(info.value)
    assert np.array_equal(env.world_state.positions, before)  # nothing moved


def test_step_takes_lists_tuples_ints_and_float32(env):
    obs, rew, *_ = env.step({"robot_0": [1, 0], "robot_1": (0.5, -0.5), "robot_2": np.array([0, 1], np.float32)})
    assert set(rew) == {"robot_0", "robot_1", "robot_2"}


@pytest.mark.parametrize("seed", [-1, 1.5, "abc", True, [1], np.float64(2.0), 2 ** 70 * -1, object()])
def test_reset_refuses_bad_seeds(env, seed):
    with pytest.raises(ArgumentError, match=r"reset\(seed=\.\.\.\): seed must be None or an integer >= 0"):
        env.reset(seed=seed)


def test_reset_accepts_numpy_and_big_integer_seeds(env):
    a, _ = env.reset(seed=np.int64(5))
    b, _ = env.reset(seed=5)
    assert all(np.array_equal(a[k], b[k]) for k in a)
    env.reset(seed=2 ** 70)


@pytest.mark.parametrize("options, culprit", [
    ([1], "options must be None or a dict"), ("x", "options must be None or a dict"),
    ({"robot_positions": "x"}, "options['robot_positions']"), ({"robot_positions": [[1, 2]]}, "robot_positions"),
    ({"robot_positions": [[1, 2], [3, np.nan], [5, 6]]}, "finite"),
    ({"robot_positions": [[10, 10], [20, 20], [30, 30]], "headings": [1, "a", 2]}, "options['headings']"),
    ({"target_positions": [[1, 2, 3]]}, "options['target_positions']"), ({"target_positions": None}, "target"),
])
def test_reset_refuses_bad_options_naming_the_key(env, options, culprit):
    with pytest.raises(ArgumentError) as info:
        env.reset(seed=0, options=options)
    assert culprit in str(info.value)


@pytest.mark.parametrize("scenario", [None, 5, "", ["flat"], b"flat"])
def test_parallel_env_refuses_a_scenario_of_the_wrong_type(scenario):
    with pytest.raises(ArgumentError, match="scenario must be"):
        tse.parallel_env(scenario=scenario)


def test_views_and_adapters_name_unknown_keywords():
    import gymnasium

    for env_id in ("tin_swarm/TinSwarmSingle-v0", "tin_swarm/TinSwarmCentral-v0"):
        with pytest.raises(ArgumentError, match="unknown argument.*'colour'"):
            gymnasium.make(env_id, scenario="flat", colour=1)
    pytest.importorskip("stable_baselines3")
    with pytest.raises(ArgumentError, match="make_sb3_vec_env: unknown argument.*'foo'"):
        tse.adapters.make_sb3_vec_env("flat", n_robots=2, n_envs=1, foo=3)
    with pytest.raises(ArgumentError, match="n_envs must be an integer >= 1"):
        tse.adapters.make_sb3_vec_env("flat", n_robots=2, n_envs="2")
    with pytest.raises(ArgumentError, match="seed"):
        tse.adapters.make_sb3_vec_env("flat", n_robots=2, n_envs=1, seed=-3)


# -- arbitrary Python values ---------------------------------------------------------------------
_scalars = st.one_of(st.none(), st.booleans(), st.integers(-2 ** 80, 2 ** 80), st.floats(allow_nan=True),
                     st.complex_numbers(), st.text(max_size=5), st.binary(max_size=5))
_values = st.recursive(_scalars, lambda inner: st.one_of(st.lists(inner, max_size=4), st.tuples(inner, inner),
                                                         st.dictionaries(st.text(max_size=3), inner, max_size=3)),
                       max_leaves=8)
def _array(shape, dtype, fill):
    with np.errstate(invalid="ignore", over="ignore"):
        return np.full(shape, fill).astype(dtype)


_arrays = st.builds(_array,
                    st.sampled_from([(), (2,), (1, 2), (3,), (2, 2), (0,)]),
                    st.sampled_from([np.float64, np.float32, np.int64, np.bool_, np.complex128, object]),
                    st.sampled_from([0.0, 0.5, np.nan, np.inf, 1e308]))
_agents = st.one_of(st.sampled_from([f"robot_{i}" for i in range(N + 1)]), st.integers(0, 3), st.none(), st.text(max_size=8))


def _valid(act) -> bool:
    try:
        a = np.asarray(act)
    except Exception:  # noqa: BLE001
        return False
    return (isinstance(act, (list, tuple, np.ndarray)) and a.dtype.kind in "iuf" and a.shape == (2,)
            and bool(np.isfinite(a.astype(float)).all()))


@given(actions=st.one_of(_values, _arrays, st.dictionaries(_agents, st.one_of(_values, _arrays), max_size=4)))
def test_step_with_arbitrary_values_runs_or_names_the_culprit(env, actions):
    ok = isinstance(actions, dict) and all(k in env.agent_name_mapping and _valid(v) for k, v in actions.items())
    try:
        env.step(actions)
    except TinSwarmError as exc:
        assert not ok, f"valid actions refused: {exc}"
        msg = str(exc)
        assert "\n" not in msg and msg.startswith("step(actions)")
        if isinstance(actions, dict):
            bad = next(k for k, v in actions.items() if not (k in env.agent_name_mapping and _valid(v)))
            assert repr(bad) in msg or str(bad) in msg
        return
    assert ok, f"accepted {actions!r}"


@given(seed=st.one_of(_scalars, _values, st.integers(0, 2 ** 64)),
       options=st.one_of(st.none(), _values, st.dictionaries(
           st.sampled_from(["robot_positions", "headings", "target_positions", "colour"]),
           st.one_of(_values, _arrays), max_size=2)))
def test_reset_with_arbitrary_values_runs_or_names_the_culprit(env, seed, options):
    seed_ok = seed is None or (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # an unknown option key is a warning (Gymnasium's convention)
        try:
            env.reset(seed=seed, options=options)
        except TinSwarmError as exc:
            msg = str(exc)
            assert "\n" not in msg
            if not seed_ok:
                assert "seed" in msg
            elif not isinstance(options, dict):
                assert "options" in msg
            else:
                assert any(k in msg for k in ("robot_positions", "headings", "target")), msg
            return
    assert seed_ok and (options is None or isinstance(options, dict))
