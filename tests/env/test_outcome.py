"""env/outcome.py: the env's one pass after sensing equals the three calls it fuses, bit for bit."""

import contextlib
import dataclasses

import numba
import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env import outcome as OC
from tin_swarm_env.env.observation import build_observations
from tin_swarm_env.env.reward import compute_rewards, distance_to_go
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.world import Reason


def _variant(name, base="cliff_goal"):
    cfg = load_scenario("containment" if name == "containment" else base)
    if name == "euclidean":
        cfg = cfg.replace(rewards=dataclasses.replace(cfg.rewards, progress="euclidean"))
    if name == "mobile":
        cfg = cfg.replace(targets=dataclasses.replace(cfg.targets, mobile=True))
    # every term weighted, so a term dropped or added in the wrong order changes the bits
    return cfg.replace(rewards=dataclasses.replace(cfg.rewards, collision=-0.37, energy_per_kj=-0.013))


def _three_calls(env, a):
    """The spec: the step as the three calls one after another (distance to go, rewards with the
    arrived robots retired before sensing, observations), on the env's current state; nothing
    in the env changes (the world's step is a pure function of the state)."""
    cfg, w, live, tidx = env.config, env.world, env.live_mask, env.target_assignment
    new, ev = w.step(env.world_state, np.where(live[:, None], a, 0.0))
    geodesic = cfg.rewards.progress == "geodesic" and not cfg.targets.mobile
    fields = env.target_fields if geodesic else (None,) * len(env.target_fields)
    dist = distance_to_go(new, tidx, fields)
    rew, term, why = compute_rewards(cfg, env.distance_to_go(), dist, new, ev, tidx, live)
    arrived = why == Reason.ARRIVED
    if arrived.any():
        new = w.retire(new, arrived)
    obs = build_observations(w, new, w.sense(new), tidx, live, env.layout)
    return obs, rew, term, why, dist


def _episode_against_the_spec(env, seed, steps):
    """Drive ``env`` ``steps`` steps (straight at each robot's target, blind to cliffs, plus noise:
    robots arrive, fall and collide) and check every step against :func:`_three_calls`; returns
    the reasons seen."""
    rng = np.random.default_rng(seed)
    obs = env.reset_arrays(seed=seed)
    seen = set()
    for _ in range(steps):
        a = obs[:, env.layout.own["target_dir"]] + rng.uniform(-0.5, 0.5, (env.n, 2))
        want = _three_calls(env, a)
        obs, rew, term, trunc, why = env.step_arrays(a)
        why = np.where(trunc, np.int8(Reason.NONE), why)  # the time limit is the env's, not the three calls'
        for got, exp in zip((obs, rew, term, why, env.distance_to_go()), want, strict=True):
            assert got.dtype == exp.dtype and got.shape == exp.shape
            assert got.tobytes() == exp.tobytes()
        seen |= set(why.tolist())
        if not env.live_mask.any():
            break
    return seen


@pytest.mark.parametrize(("variant", "base"), [(v, b) for v in ("geodesic", "euclidean", "mobile")
                                               for b in ("cliff_goal", "flat")] + [("containment", "")])
@pytest.mark.parametrize("threads", [1, 2])
def test_step_outcome_is_the_three_calls_bit_for_bit(variant, base, threads, monkeypatch):
    """Geodesic progress (the CostToGoStack in the pass), straight-line and mobile targets (the
    distances given), containment; robots fall (cliff_goal) and arrive (flat); above the serial
    threshold so 2 threads share the robots."""
    monkeypatch.setattr(OC, "OBS_SERIAL_BELOW", 8)
    cfg = _variant(variant, base)
    with pytest.warns(UserWarning, match="mobile targets") if variant == "mobile" else contextlib.nullcontext():
        env = tse.parallel_env(scenario=cfg, n_robots=40)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        seen = set()
        for seed in (0, 1):
            seen |= _episode_against_the_spec(env, seed, 250)
    finally:
        numba.set_num_threads(old)
    if variant in ("geodesic", "euclidean"):  # the cases the fused pass must get right were met
        assert int(Reason.FELL if base == "cliff_goal" else Reason.ARRIVED) in seen


def test_step_outcome_compiled_is_its_plain_loop(monkeypatch):
    """The compiled kernel against its Python loop (numba's ``py_func``) on the same arguments."""
    env = tse.parallel_env(scenario=_variant("geodesic"), n_robots=12)
    env.reset_arrays(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(5):
        env.step_arrays(rng.uniform(-1, 1, (12, 2)))
    w, s, live = env.world, env.world_state, env.live_mask
    new, ev = w.step(s, np.where(live[:, None], rng.uniform(-1, 1, (12, 2)), 0.0))
    rd = w.sense(new)
    args = (w, new, rd, env._stack, env.distance_to_go(), None, ev, env.target_assignment, live, env.layout, env._rw)
    outs = []
    for kernel in (OC._outcome, OC._outcome.py_func):
        monkeypatch.setattr(OC, "_outcome", kernel)
        d = np.empty(12)
        outs.append((*OC.step_outcome(*args[:5], d, *args[6:]), d))
    for a, b in zip(*outs, strict=True):
        assert a.tobytes() == b.tobytes()
    assert np.isfinite(outs[0][-1]).any() and outs[0][0].any()
