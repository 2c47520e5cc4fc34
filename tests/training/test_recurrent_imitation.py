"""The recurrent student (training/recurrent_imitation.py): its policy file acts as the torch model
over whole episodes, it learns what needs memory, and `train --student gru` is checked and runs.
Tiny budgets only."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies.symmetry import mirror_map
from tin_swarm_env.training.config import Args, check_args
from tin_swarm_env.training.imitation import Sequence, collect

torch = pytest.importorskip("torch")

SMALL = {"n_robots": 4, "max_cycles": 50}


def _mirror(lay) -> dict:
    """GRUStudent's mirror arguments for ``lay``: the signs and the permutation of the scan's beams."""
    perm, signs = mirror_map(lay)
    return {"signs": signs, "obs_perm": perm}


@pytest.mark.parametrize("mirror", [False, True])
def test_exported_file_acts_as_the_torch_student_over_a_whole_episode(tmp_path, mirror):
    """The file (numpy, memory per robot) and the torch model fed the whole episode at once give
    the same actions at every step of every robot; a second episode after reset() too."""
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.recurrent import RecurrentPolicy
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    demos = collect("cliff_goal", 2, seed=1, teacher="geodesic", sequences=True, **SMALL)
    st = GRUStudent(lay.size, 12, (8,), **(_mirror(lay) if mirror else {}), seed=3)
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


def test_a_mirror_student_with_scan_beams_is_equivariant_and_exports_to_the_same_actions(tmp_path):
    """GRUStudent with obs_perm (a layout with a terrain scan: the mirror permutes the beams): the
    torch model is equivariant over a whole history, and its file acts as it does."""
    import dataclasses

    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.symmetry import mirror_map
    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.training.recurrent_imitation import GRUStudent

    cfg = load_scenario("cliff_goal")
    env = tse.parallel_env(scenario=cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=6)), **SMALL)
    lay = env.layout
    perm, signs = mirror_map(lay)
    st = GRUStudent(lay.size, 12, (8,), signs=signs, seed=3, obs_perm=perm)
    x = np.random.default_rng(0).uniform(-1, 1, (10, 3, lay.size)).astype(np.float32)
    with torch.no_grad():
        a, am = st(x).numpy(), st(lay.mirror(x)).numpy()
        wrong = GRUStudent(lay.size, 12, (8,), signs=signs, seed=3)  # the same weights, beams not permuted
        wa, wam = wrong(x).numpy(), wrong(lay.mirror(x)).numpy()
    np.testing.assert_allclose(am, mirror_action(a), atol=1e-5)
    assert np.abs(wam - mirror_action(wa)).max() > 1e-3
    st.export(tmp_path / "p", lay, scenario="cliff_goal")
    pol = load_policy(tmp_path / "p", env)
    mine = np.stack([pol.act_batch(x[t]) for t in range(len(x))])
    np.testing.assert_allclose(mine, np.clip(a, -1, 1), atol=1e-5)
    with pytest.raises(ArgumentError, match="obs_perm"):
        GRUStudent(lay.size, 4, (4,), signs=signs, obs_perm=perm[:-1])
    # the student without the beam permutation is not the layout's mirror: refused by export and policy()
    for call in (lambda: wrong.export(tmp_path / "w", lay), lambda: wrong.policy(lay)):
        with pytest.raises(ArgumentError, match="not the mirror map of the layout"):
            call()
    assert not (tmp_path / "w").exists()
    assert "obs_perm" in dict(st.named_buffers())  # moves with .to() and is in state_dict
    np.testing.assert_array_equal(st.state_dict()["obs_perm"].numpy(), perm)


def test_student_learns_what_only_memory_can_tell():
    """Each robot sees a +-1 cue at its first step, then zeros; the label at every step is the
    cue's sign (times 0.5) in vy. A memoryless policy sees the same zeros after step 0 whatever
    the cue, so its MSE after step 0 is at least the labels' variance there (1/8 per component
    mean); the GRU must get far below it."""
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

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
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.training.sb3 import train

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
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    classes = categorical_classes()
    demos = collect("cliff_goal", 2, seed=1, teacher="geodesic", sequences=True, **SMALL)
    st = GRUStudent(lay.size, 12, (8,), **_mirror(lay), seed=3, classes=classes, cell=cell)
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
    from tin_swarm_env.policies.heads import categorical_classes, nearest_class, softmax
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    lay = ObsLayout(k_scan=0)  # no scan: the mirror is a sign flip, so the +1 part of the signs is self-mirror
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
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.learned import MLPPolicy
    from tin_swarm_env.training.sb3 import train

    path = train(Args(scenario="cliff_goal", n_robots=3, max_cycles=20, total_timesteps=0, bc_episodes=1,
                      dagger_rounds=1, dagger_beta=0.5, bc_epochs=2, teacher="geodesic", symmetry="mirror",
                      student="mlp", head="categorical", head_acting="sample", net_arch="8", eval_episodes=1,
                      out_dir=str(tmp_path / "m"), progress_bar=False))
    log = capsys.readouterr().out
    assert "BC (MLP student (categorical))" in log and "cross-entropy" in log
    pol = load_policy(path, tse.parallel_env(scenario="cliff_goal", n_robots=3))
    assert isinstance(pol, MLPPolicy) and pol.head.acting == "sample" and len(pol.head.actions) == 33
    assert pol.training["imitation"]["head"] == "categorical"


@pytest.mark.parametrize("categorical", [False, True])
def test_feedback_file_acts_as_the_torch_student_over_a_whole_episode(tmp_path, categorical):
    """A GRU with feedback, mirror-equivariant (categorical: sampling): the file drives a DAgger
    episode (recording what it commanded, ``Sequence.driven``); replayed, the file's outputs equal
    the torch model's fed the whole episode and the commands shifted one step (previous_actions),
    at every step of every robot, and the replay commands what drove."""
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences, previous_actions

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    classes = categorical_classes() if categorical else None
    bc = collect("cliff_goal", 1, seed=1, teacher="geodesic", sequences=True, **SMALL)
    st = GRUStudent(lay.size, 12, (8,), **_mirror(lay), seed=3, classes=classes, feedback="action",
                    acting="sample")  # a draw per robot and step: reset() restarts the streams for the replay
    fit_sequences(st, bc.sequences, epochs=2)
    st.export(tmp_path / "p", lay, scenario="cliff_goal")
    pol = load_policy(tmp_path / "p", env)
    assert pol.feedback == "action" and pol.symmetry == "mirror"
    dag = collect("cliff_goal", 2, seed=5, teacher="geodesic", sequences=True, learner=pol, **SMALL)
    for q in dag.sequences:
        T = len(q.obs)
        prev = previous_actions(q, T, classes)
        with torch.no_grad():
            ref = st(q.obs, prev).double().numpy()
        pol.reset()
        if categorical:
            outs, cmds = [], []
            for t in range(T):
                z, _ = pol.logits(q.obs[t])
                a = pol.head.act(z)
                pol.remember(a)
                outs.append(z)
                cmds.append(a)
            out, cmd = np.stack(outs), np.stack(cmds).astype(np.float32)
        else:
            cmd = np.stack([pol.net_batch(q.obs[t]) for t in range(T)])
            out, ref = cmd, np.clip(ref, -1, 1)
        assert np.abs(out - ref).max() < 1e-4
        np.testing.assert_array_equal(cmd, q.driven)  # the replay is the episode that was driven
        assert np.abs(prev[1:] - cmd[:-1]).max() < 1e-6 and not prev[0].any()
        assert len(np.unique(cmd.reshape(-1, 2), axis=0)) > 1


def test_previous_actions_shift_clip_and_snap_to_classes():
    from tin_swarm_env.training.recurrent_imitation import previous_actions

    drv = np.array([[[0.875, 0.25]], [[2.0, -0.25]], [[0.0, 0.0]]], np.float32)  # (T=3, n=1, 2)
    q = Sequence(np.zeros((3, 1, 4), np.float32), np.zeros((3, 1, 2), np.float32), np.ones((3, 1), bool),
                 np.ones((3, 1), bool), drv)
    np.testing.assert_array_equal(previous_actions(q, 3), [[[0, 0]], [[0.875, 0.25]], [[1.0, -0.25]]])
    classes = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.5], [0.5, -0.5]])
    np.testing.assert_array_equal(previous_actions(q, 3, classes), [[[0, 0]], [[1.0, 0.0]], [[1.0, 0.0]]])
    np.testing.assert_array_equal(previous_actions(q, 2, classes), [[[0, 0]], [[1.0, 0.0]]])
    with pytest.raises(ArgumentError, match="record 'driven'"):
        previous_actions(Sequence(q.obs, q.labels, q.keep, q.live), 3)


def test_feedback_lets_the_gru_keep_the_side_it_drew():
    """The observations are all zeros; the label at each step is the side of the action commanded
    at the step before (a random side per robot and step): only the fed-back action tells it. A
    GRU without feedback sees the same zeros whatever was drawn (its MSE is at least the labels'
    variance); with feedback it must get far below."""
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    rng = np.random.default_rng(0)
    T, n, d = 8, 32, 3
    seqs = []
    for _ in range(4):
        drv = np.zeros((T, n, 2), np.float32)
        drv[:, :, 0] = 0.5
        drv[:, :, 1] = rng.choice([-0.5, 0.5], (T, n))
        labels = np.zeros((T, n, 2), np.float32)
        labels[1:, :, 1] = drv[:-1, :, 1]
        seqs.append(Sequence(np.zeros((T, n, d), np.float32), labels, np.ones((T, n), bool), np.ones((T, n), bool),
                             drv))
    floor = 0.25 / 2 * (T - 1) / T  # variance 0.25 in vy, 0 in vx, over steps 1..T-1
    fb = fit_sequences(GRUStudent(d, 8, (8,), seed=0, feedback="action"), seqs, epochs=60, lr=1e-2)
    blind = fit_sequences(GRUStudent(d, 8, (8,), seed=0), seqs, epochs=60, lr=1e-2)
    assert fb < 0.1 * floor and blind > 0.9 * floor


def test_feedback_options_are_checked_by_name():
    from tin_swarm_env.training.recurrent_imitation import GRUStudent

    with pytest.raises(ArgumentError, match="--feedback action needs --student gru"):
        check_args(Args(feedback="action", head="categorical", bc_episodes=1, total_timesteps=0))
    with pytest.raises(ArgumentError, match="--feedback must be one of"):
        Args(feedback="reward")
    with pytest.raises(ArgumentError, match="feedback must be one of"):
        GRUStudent(5, cell=None, feedback="action")
    with pytest.raises(ArgumentError, match="needs prev"):
        GRUStudent(5, feedback="action")(np.zeros((2, 1, 5), np.float32))


def _cue_sequences(T, n, d, count, seed=0):
    """Each robot sees a +-1 cue at its first step, then zeros; the label at every step is the cue's
    sign (times 0.5) in vy: after step 0 only memory tells it."""
    rng = np.random.default_rng(seed)
    seqs = []
    for _ in range(count):
        cue = rng.choice([-1.0, 1.0], n)
        obs = np.zeros((T, n, d), np.float32)
        obs[0, :, 0] = cue
        labels = np.zeros((T, n, 2), np.float32)
        labels[:, :, 1] = 0.5 * cue
        seqs.append(Sequence(obs, labels, np.ones((T, n), bool), np.ones((T, n), bool),
                             np.tile(np.float32([0.5, 0.25]), (T, n, 1))))
    return seqs


@pytest.mark.parametrize("categorical", [False, True])
def test_forward_in_pieces_from_the_carried_state_is_the_whole_forward(categorical):
    """forward_state over consecutive pieces, each from the state the last ended in, gives the whole
    episode's forward at every step (mirror streams and feedback included)."""
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, previous_actions

    d = 4
    signs = np.array([1.0, -1.0, 1.0, -1.0])
    q = _cue_sequences(9, 3, d, 1)[0]
    q.obs[1:] = np.random.default_rng(1).normal(size=q.obs[1:].shape)
    st = GRUStudent(d, 6, (5,), signs=signs, seed=2, feedback="action",
                    classes=categorical_classes() if categorical else None)
    prev = previous_actions(q, 9, st.classes)
    with torch.no_grad():
        whole = st(q.obs, prev).numpy()
        h, parts = None, []
        for s, e in ((0, 4), (4, 5), (5, 9)):
            out, h = st.forward_state(q.obs[s:e], prev[s:e], h)
            parts.append(out.numpy())
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-6)
    assert np.abs(whole[-1] - whole[0]).max() > 1e-3


def test_a_chunk_as_long_as_the_episode_is_the_whole_episode_fit_bit_for_bit():
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    seqs = _cue_sequences(6, 8, 3, 3)
    a, b = GRUStudent(3, 8, (8,), seed=0), GRUStudent(3, 8, (8,), seed=0)
    la = fit_sequences(a, seqs, epochs=3, lr=1e-2, chunk=0)
    lb = fit_sequences(b, seqs, epochs=3, lr=1e-2, chunk=6)
    assert la == lb
    for pa, pb in zip(a.parameters(), b.parameters()):
        assert torch.equal(pa, pb)


def test_truncated_fit_carries_the_state_from_piece_to_piece():
    """Pieces of 2 steps over 8-step episodes: the cue is seen only in the first piece, so the labels
    of the three later pieces are told by the state carried into them alone. A fit that restarted each
    piece from a zero state would see zeros there whatever the cue: its loss at least the labels'
    variance on those 6 of 8 steps; the carried state must take it far below."""
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    T = 8
    seqs = _cue_sequences(T, 32, 3, 4)
    losses = []
    mse = fit_sequences(GRUStudent(3, 8, (8,), seed=0), seqs, epochs=150, lr=1e-2, chunk=2,
                        callback=lambda ep, loss: losses.append((ep, loss)))
    restarted = 0.25 / 2 * (T - 2) / T  # variance 0.25 in vy, 0 in vx, over steps 2..T-1
    assert mse < 0.1 * restarted
    assert [e for e, _ in losses] == list(range(150)) and losses[-1][1] == mse


def test_fit_sequences_refuses_a_bad_chunk_by_name():
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    seqs = _cue_sequences(4, 2, 3, 1)
    for bad in (-1, 2.5, True, "64"):
        with pytest.raises(ArgumentError, match="fit_sequences: chunk must be an integer >= 0"):
            fit_sequences(GRUStudent(3, 4, (4,)), seqs, epochs=1, chunk=bad)


def _side_sequences(T, n, d, count, seed=0):
    """The cue sequences with the side to keep as ``aux``: +-1 (the cue) from step 1 on, 0 at step 0."""
    seqs = _cue_sequences(T, n, d, count, seed)
    for q in seqs:
        q.aux = np.zeros((T, n), np.int8)
        q.aux[1:] = np.sign(q.obs[0, :, 0]).astype(np.int8)
    return seqs


def test_side_readout_learns_the_side_only_memory_tells():
    """The action labels are all equal (straight on), so the action head has nothing to learn about the
    cue; the side read-out must carry it from step 0 to the end: after the fit its argmax is the side at
    every step of every robot (step 0: none), and the loss is the action's plus aux_weight times the
    side's, exactly."""
    from tin_swarm_env.training.recurrent_imitation import SIDES, GRUStudent, fit_sequences, sequence_loss, side_logits

    seqs = _side_sequences(6, 32, 3, 4)
    for q in seqs:
        q.labels[:] = np.float32([0.5, 0.0])
    st = GRUStudent(3, 8, (8,), seed=0, aux_weight=0.5)
    fit_sequences(st, seqs, epochs=150, lr=1e-2)
    for q in seqs:
        pred = np.asarray(SIDES)[side_logits(st, q).argmax(-1)]
        np.testing.assert_array_equal(pred, q.aux)
        with torch.no_grad():
            act, side, _ = sequence_loss(st, q, parts=True)
            tot, _ = sequence_loss(st, q)
        assert torch.equal(tot, act + 0.5 * side) and float(side.mean()) < 0.05
    plain = seqs[0]
    no_aux = Sequence(plain.obs, plain.labels, plain.keep, plain.live, plain.driven)
    with torch.no_grad():
        act2, side2, _ = sequence_loss(st, no_aux, parts=True)
        assert side2 is None and torch.equal(sequence_loss(st, no_aux)[0], act2)  # nothing to fit: no term


@pytest.mark.parametrize("categorical", [False, True])
def test_side_readout_is_mirror_equivariant_and_not_in_the_file(tmp_path, categorical):
    """With the mirror, the read-out of the mirrored history is the read-out with left and right
    swapped (random observations over a history, feedback on); the exported file is the same as the
    file of a student without a read-out that has the same cell and head weights, and acts as the torch
    student's action output."""
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, previous_actions, side_logits

    env = tse.parallel_env(scenario="cliff_goal", **SMALL)
    lay = env.layout
    classes = categorical_classes() if categorical else None
    kw = dict(**_mirror(lay), seed=3, classes=classes, feedback="action")
    st = GRUStudent(lay.size, 12, (8,), aux_weight=1.0, **kw)
    rng = np.random.default_rng(4)
    T = 7
    q = Sequence(rng.uniform(-1, 1, (T, 3, lay.size)).astype(np.float32), np.zeros((T, 3, 2), np.float32),
                 np.ones((T, 3), bool), np.ones((T, 3), bool), rng.uniform(-1, 1, (T, 3, 2)).astype(np.float32))
    m = Sequence(lay.mirror(q.obs).astype(np.float32), q.labels, q.keep, q.live, mirror_action(q.driven))
    z, zm = side_logits(st, q), side_logits(st, m)
    np.testing.assert_allclose(zm, z[..., ::-1], atol=1e-5)
    assert np.abs(z[..., 0] - z[..., 2]).max() > 1e-3  # not trivially symmetric
    twin = GRUStudent(lay.size, 12, (8,), **kw)
    twin.load_state_dict({k: v for k, v in st.state_dict().items() if not k.startswith("aux.")})
    st.export(tmp_path / "a", lay, scenario="cliff_goal")
    twin.export(tmp_path / "b", lay, scenario="cliff_goal")
    for f in sorted(p.name for p in (tmp_path / "a").iterdir()):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    pol = load_policy(tmp_path / "a", env)
    demos = collect("cliff_goal", 1, seed=1, teacher="apf", sequences=True, learner=pol, **SMALL)
    qq = demos.sequences[0]
    with torch.no_grad():
        ref = st(qq.obs, previous_actions(qq, len(qq.obs), classes)).double().numpy()
    pol.reset()
    if categorical:
        out = []
        for t in range(len(qq.obs)):
            zt, _ = pol.logits(qq.obs[t])
            pol.remember(pol.head.act(zt))
            out.append(zt)
        out = np.stack(out)
    else:
        out, ref = np.stack([pol.net_batch(qq.obs[t]) for t in range(len(qq.obs))]), np.clip(ref, -1, 1)
    assert np.abs(out - ref).max() < 1e-4


def test_side_readout_options_and_targets_are_checked_by_name():
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences, side_logits

    for bad in (-0.5, float("nan"), True, "1"):
        with pytest.raises(ArgumentError, match="GRUStudent: aux_weight must be a finite number >= 0"):
            GRUStudent(3, aux_weight=bad)
    with pytest.raises(ArgumentError, match=r"> 0 only with a cell"):
        GRUStudent(3, cell=None, aux_weight=1.0)
    with pytest.raises(ArgumentError, match="side_logits: the student has no side read-out"):
        side_logits(GRUStudent(3, 4, (4,)), _cue_sequences(4, 2, 3, 1)[0])
    q = _side_sequences(4, 2, 3, 1)[0]
    q.aux[2, 1] = 2
    with pytest.raises(ArgumentError, match=r"fit_sequences: a sequence's aux must be .* sides in \[-1, 0, 1\]"):
        fit_sequences(GRUStudent(3, 4, (4,), aux_weight=1.0), [q], epochs=1)
    q.aux = np.zeros((3, 2), np.int8)
    with pytest.raises(ArgumentError, match="got shape"):
        fit_sequences(GRUStudent(3, 4, (4,), aux_weight=1.0), [q], epochs=1)
