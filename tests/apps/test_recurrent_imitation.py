"""The recurrent student (apps/recurrent_imitation.py): its policy file acts as the torch model
over whole episodes, it learns what needs memory, and `train --student gru` is checked and runs.
Tiny budgets only."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.imitation import Sequence, collect
from tin_swarm_env.apps.train import Args, check_args
from tin_swarm_env.errors import ArgumentError

torch = pytest.importorskip("torch")

SMALL = {"n_robots": 4, "max_cycles": 50}


@pytest.mark.parametrize("mirror", [False, True])
def test_exported_file_acts_as_the_torch_student_over_a_whole_episode(tmp_path, mirror):
    """The file (numpy, memory per robot) and the torch model fed the whole episode at once give
    the same actions at every step of every robot; a second episode after reset() too."""
    from tin_swarm_env.apps.recurrent_imitation import GRUStudent, fit_sequences
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.recurrent import RecurrentPolicy

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    demos = collect("cliff_goal", 2, seed=1, teacher="geodesic", sequences=True, **SMALL)
    st = GRUStudent(lay.size, 12, (8,), signs=lay.mirror_signs() if mirror else None, seed=3)
    fit_sequences(st, demos.sequences, epochs=2)
    st.export(tmp_path / "p", lay, scenario="cliff_goal")
    pol = load_policy(tmp_path / "p", env)
    assert isinstance(pol, RecurrentPolicy) and pol.cell == "gru" and pol.symmetry == ("mirror" if mirror else "none")
    for q in demos.sequences:
        with torch.no_grad():
            ref = np.clip(st(q.obs).numpy(), -1, 1)
        pol.reset()
        mine = np.stack([pol.act_batch(q.obs[t]) for t in range(len(q.obs))])
        assert mine.shape == ref.shape and np.abs(mine - ref).max() < 1e-5
        assert np.abs(ref[-1] - ref[0]).max() > 1e-3  # the episode moved the actions: not a trivial comparison


def test_student_learns_what_only_memory_can_tell():
    """Each robot sees a +-1 cue at its first step, then zeros; the label at every step is the
    cue's sign (times 0.5) in vy. A memoryless policy sees the same zeros after step 0 whatever
    the cue, so its MSE after step 0 is at least the labels' variance there (1/8 per component
    mean); the GRU must get far below it."""
    from tin_swarm_env.apps.recurrent_imitation import GRUStudent, fit_sequences

    rng = np.random.default_rng(0)
    T, n, d = 6, 32, 3
    seqs = []
    for _ in range(4):
        cue = rng.choice([-1.0, 1.0], n)
        obs = np.zeros((T, n, d), np.float32)
        obs[0, :, 0] = cue
        labels = np.zeros((T, n, 2), np.float32)
        labels[:, :, 1] = 0.5 * cue
        seqs.append(Sequence(obs, labels, np.ones((T, n), bool), np.ones((T, n), bool)))
    st = GRUStudent(d, 8, (8,), seed=0)
    mse = fit_sequences(st, seqs, epochs=150, lr=1e-2)
    memoryless = 0.25 / 2 * (T - 1) / T  # variance 0.25 in vy, 0 in vx, over steps 1..T-1
    assert mse < 0.1 * memoryless
    with torch.no_grad():
        out = st(seqs[0].obs).numpy()
    assert np.all(np.sign(out[-1, :, 1]) == np.sign(seqs[0].labels[-1, :, 1]))


def test_sequences_are_the_flat_samples_in_step_robot_order():
    demos = collect("cliff_goal", 2, seed=2, sequences=True, stall_steps=5, **SMALL)
    flat = np.concatenate([q.obs[q.keep] for q in demos.sequences])
    labels = np.concatenate([q.labels[q.keep] for q in demos.sequences])
    assert np.array_equal(flat, demos.obs) and np.array_equal(labels, demos.actions)
    q = demos.sequences[0]
    assert q.obs.shape[:2] == q.keep.shape == q.live.shape and not (q.keep & ~q.live).any()
    assert collect("cliff_goal", 1, seed=2, **SMALL).sequences == ()


def test_student_gru_options_are_checked_by_name():
    with pytest.raises(ArgumentError, match="--student must be one of mlp, gru, got 'lstm'"):
        Args(student="lstm")
    with pytest.raises(ArgumentError, match="--student gru learns by imitation"):
        check_args(Args(student="gru", total_timesteps=1000, bc_episodes=0))
    with pytest.raises(ArgumentError, match="--student gru has no PPO stage"):
        check_args(Args(student="gru", bc_episodes=1))
    with pytest.raises(ArgumentError, match="--gru-hidden must be"):
        Args(gru_hidden=0)


def test_train_student_gru_runs_bc_and_dagger_and_exports_a_recurrent_file(tmp_path, capsys):
    from tin_swarm_env.apps.train import train
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy

    path = train(Args(scenario="cliff_goal", n_robots=3, max_cycles=20, total_timesteps=0, bc_episodes=1,
                      dagger_rounds=1, dagger_beta=0.5, bc_epochs=2, teacher="geodesic", symmetry="mirror",
                      student="gru", gru_hidden=8, net_arch="8", eval_episodes=1, out_dir=str(tmp_path / "g"),
                      progress_bar=False, shield="safety_cut"))
    assert path == tmp_path / "g" / "policy"
    log = capsys.readouterr().out
    assert "BC (GRU student)" in log and "DAgger round 1" in log and "arrived" in log
    env = tse.parallel_env(scenario="cliff_goal", n_robots=3)
    pol = load_policy(path, env)
    assert (pol.cell, pol.symmetry, pol.shield) == ("gru", "mirror", "safety_cut")
    assert pol.training["imitation"]["teacher"] == "geodesic" and len(pol.training["imitation"]["rounds"]) == 2
    pol2 = load_policy(path, env)
    o = np.random.default_rng(0).uniform(-1, 1, (7, env.layout.size))
    for _ in range(3):  # the network alone (no shield) is equivariant over a history
        np.testing.assert_array_equal(pol2.net_batch(env.layout.mirror(o)), mirror_action(pol.net_batch(o)))
