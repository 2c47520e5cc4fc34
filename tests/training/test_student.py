"""Imitation's rounds and the student trained by imitation only (training/student.py): mirrored
samples double the fit set, behaviour cloning then DAgger fit on everything so far, and a tiny GRU
student is exported as a policy file that loads."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.training.config import Args


def test_mirror_samples_add_the_mirror_image_of_every_sample():
    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.training.imitation import Demos
    from tin_swarm_env.training.student import fit_set

    lay = ObsLayout()
    rng = np.random.default_rng(0)
    d = Demos(rng.uniform(-1, 1, (5, lay.size)).astype(np.float32), rng.uniform(-1, 1, (5, 2)).astype(np.float32),
              rng.normal(size=5).astype(np.float32), arrived=0.75, fell=0.1, episodes=3)
    m = d.mirrored(lay)
    np.testing.assert_array_equal(m.obs, lay.mirror(d.obs))  # the default layout: its scan beams permuted
    np.testing.assert_array_equal(m.actions, d.actions * [1, -1])
    np.testing.assert_array_equal(m.returns, d.returns)
    assert fit_set(d, Args(), lay) is d
    both = fit_set(d, Args(mirror_samples=True), lay)
    assert len(both) == 10 and (both.arrived, both.fell, both.episodes) == (0.75, 0.1, 3)
    np.testing.assert_array_equal(both.obs[5:], m.obs)


def test_bc_then_dagger_fits_on_every_sample_so_far():
    from tin_swarm_env.policies import APFPolicy
    from tin_swarm_env.training.student import bc_dagger

    args = Args(scenario="flat", bc_episodes=1, dagger_rounds=2, dagger_episodes=1, dagger_beta=0.5, total_timesteps=0)
    fits, logs = [], []

    def fit_on(demos, seed):
        fits.append((len(demos), seed))
        return 0.5 / len(fits)

    kw = {"n_robots": 2, "max_cycles": 8, "gamma": 0.99, "stall_steps": 0, "shield": "none", "teacher": "apf"}
    env_policy = {}

    def learner():
        import tin_swarm_env as tse

        env_policy["pol"] = APFPolicy(tse.parallel_env(scenario="flat", n_robots=2))
        return env_policy["pol"]

    demos, info = bc_dagger(args, ["flat"], kw, fit_on, learner, logs.append)
    assert [s for _, s in fits] == [0, 1, 2]  # the seed of each fit: args.seed, then + round
    sizes = [n for n, _ in fits]
    assert sizes[0] > 0 and sizes[0] < sizes[1] < sizes[2] == len(demos)  # each fit on all samples so far
    assert info["bc_samples"] == sizes[0] and len(info["rounds"]) == 3
    assert [r["mse"] for r in info["rounds"]] == [0.5, 0.25, 0.5 / 3]
    assert logs[0].startswith("BC: ") and logs[1].startswith("DAgger round 1 (beta 0.50)")
    assert logs[2].startswith("DAgger round 2 (beta 0.25)")


def test_train_student_exports_a_gru_policy_file_that_loads(tmp_path):
    pytest.importorskip("torch")
    import tin_swarm_env as tse
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.recurrent import RecurrentPolicy
    from tin_swarm_env.training.student import train_student

    args = Args(scenario="flat", n_robots=2, max_cycles=8, total_timesteps=0, bc_episodes=1, bc_epochs=1,
                student="gru", gru_hidden=4, net_arch="8", eval_every=0)
    (tmp_path / "s").mkdir()  # the run directory, made and checked by train() before any work
    path = train_student(args, tmp_path / "s", log=lambda msg: None)
    assert path == tmp_path / "s" / "policy" and (tmp_path / "s" / "model.json").is_file()
    pol = load_policy(path, tse.parallel_env(scenario="flat", n_robots=2))
    assert isinstance(pol, RecurrentPolicy) and pol.hidden_size == 4
