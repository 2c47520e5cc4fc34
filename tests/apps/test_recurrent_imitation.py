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


@pytest.mark.parametrize("cell", ["gru", None])
def test_categorical_file_acts_as_the_torch_student_over_a_whole_episode(tmp_path, cell):
    """A categorical, mirror-equivariant student (GRU or memoryless): the file's logits equal the
    torch model's at every step of every robot, and its actions are the class of the torch
    model's largest logit (wherever the top two are not within float32 rounding)."""
    from tin_swarm_env.apps.recurrent_imitation import GRUStudent, fit_sequences
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.heads import categorical_classes

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    classes = categorical_classes()
    demos = collect("cliff_goal", 2, seed=1, teacher="geodesic", sequences=True, **SMALL)
    st = GRUStudent(lay.size, 12, (8,), signs=lay.mirror_signs(), seed=3, classes=classes, cell=cell)
    fit_sequences(st, demos.sequences, epochs=2)
    st.export(tmp_path / "p", lay, scenario="cliff_goal")
    pol = load_policy(tmp_path / "p", env)
    assert pol.head is not None and pol.symmetry == "mirror" and hasattr(pol, "cell") == (cell is not None)
    compared = 0
    for q in demos.sequences:
        with torch.no_grad():
            ref = st(q.obs).double().numpy()
        pol.reset()
        z = np.stack([pol.logits(q.obs[t])[0] if cell else pol.logits(q.obs[t]) for t in range(len(q.obs))])
        assert z.shape == ref.shape == (len(q.obs), SMALL["n_robots"], len(classes))
        assert np.abs(z - ref).max() < 1e-4
        pol.reset()
        mine = np.stack([pol.act_batch(q.obs[t]) for t in range(len(q.obs))])
        top2 = np.sort(ref, axis=-1)[..., -2:]
        clear = top2[..., 1] - top2[..., 0] > 1e-4
        np.testing.assert_array_equal(mine[clear], classes[ref.argmax(-1)][clear].astype(np.float32))
        compared += int(clear.sum())
        assert len(np.unique(mine.reshape(-1, 2), axis=0)) > 1  # not one constant action
    assert compared > 0.95 * sum(q.obs.shape[0] * q.obs.shape[1] for q in demos.sequences)


def test_likelihood_fit_keeps_both_sides_where_mse_learns_their_mean():
    """The hypothesis in miniature: one observation that is its own mirror image, labelled "left"
    for half the robots and "right" for the other half. The mirror-equivariant MSE student
    outputs vy = 0 exactly (straight on); the categorical student puts nearly all probability on
    the two labels' classes, equally, so its mode is a side and not their mean."""
    from tin_swarm_env.apps.recurrent_imitation import GRUStudent, fit_sequences
    from tin_swarm_env.policies.heads import categorical_classes, nearest_class, softmax

    lay = tse.parallel_env(scenario="cliff_goal", **SMALL).layout
    signs = lay.mirror_signs()
    rng = np.random.default_rng(0)
    T, n = 4, 16
    o = rng.normal(0, 1, lay.size).astype(np.float32) * (signs > 0)
    obs = np.broadcast_to(o, (T, n, lay.size)).copy()
    labels = np.zeros((T, n, 2), np.float32)
    labels[..., 0] = 0.7
    labels[:, : n // 2, 1], labels[:, n // 2:, 1] = 0.7, -0.7
    seqs = [Sequence(obs, labels, np.ones((T, n), bool), np.ones((T, n), bool))]
    classes = categorical_classes()
    for cell in ("gru", None):
        mse = GRUStudent(lay.size, 8, (16,), signs=signs, seed=0, cell=cell)
        fit_sequences(mse, seqs, epochs=100, lr=1e-2)
        with torch.no_grad():
            out = mse(obs).numpy()
        assert np.all(out[..., 1] == 0) and np.all(out[..., 0] > 0.5)  # straight on, exactly
        cat = GRUStudent(lay.size, 8, (16,), signs=signs, seed=0, cell=cell, classes=classes)
        ce = fit_sequences(cat, seqs, epochs=100, lr=1e-2)
        with torch.no_grad():
            p = softmax(cat(obs).double().numpy().reshape(-1, len(classes)))
        left, right = nearest_class(labels[0, [0, -1]], classes)
        assert classes[left, 1] > 0 > classes[right, 1]
        assert np.all(p[:, left] + p[:, right] > 0.95) and np.allclose(p[:, left], p[:, right], atol=1e-6)
        assert ce < np.log(2) + 0.05  # the entropy of a fair coin: the best any policy can do here
        assert set(np.argmax(p, axis=1)) == {min(left, right)}  # the mode is a side (the documented tie-break)


def test_head_options_are_checked_by_name():
    with pytest.raises(ArgumentError, match="--head must be one of"):
        Args(head="mixture")
    with pytest.raises(ArgumentError, match="--head categorical learns by imitation only"):
        check_args(Args(head="categorical", bc_episodes=1, total_timesteps=1000))
    with pytest.raises(ArgumentError, match="--head categorical cannot be combined with --recurrent"):
        check_args(Args(head="categorical", bc_episodes=1, total_timesteps=0, recurrent=True))
    with pytest.raises(ArgumentError, match="--head-acting must be one of"):
        Args(head_acting="greedy")


def test_train_head_categorical_runs_and_exports_an_mlp_file(tmp_path, capsys):
    from tin_swarm_env.apps.train import train
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.learned import MLPPolicy

    path = train(Args(scenario="cliff_goal", n_robots=3, max_cycles=20, total_timesteps=0, bc_episodes=1,
                      dagger_rounds=1, dagger_beta=0.5, bc_epochs=2, teacher="geodesic", symmetry="mirror",
                      student="mlp", head="categorical", head_acting="sample", net_arch="8", eval_episodes=1,
                      out_dir=str(tmp_path / "m"), progress_bar=False))
    log = capsys.readouterr().out
    assert "BC (MLP student (categorical))" in log and "cross-entropy" in log
    pol = load_policy(path, tse.parallel_env(scenario="cliff_goal", n_robots=3))
    assert isinstance(pol, MLPPolicy) and pol.head.acting == "sample" and len(pol.head.actions) == 33
    assert pol.training["imitation"]["head"] == "categorical"
