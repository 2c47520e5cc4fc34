"""research/diag_fit.py (run by hand, research/teacher_multimodal.md): its data file round-trips
exactly, refuses pickles, and its "near a side switch" split is the hand-computed one."""

import numpy as np
import pytest

from tin_swarm_env.training.imitation import Sequence

torch = pytest.importorskip("torch")


def _seq(T, n, d, rng):
    return Sequence(rng.normal(size=(T, n, d)).astype(np.float32), rng.normal(size=(T, n, 2)).astype(np.float32),
                    rng.random((T, n)) < 0.8, np.ones((T, n), bool), rng.normal(size=(T, n, 2)).astype(np.float32),
                    rng.integers(-1, 2, (T, n)).astype(np.int8))


@pytest.fixture
def diag(repo_script):
    return repo_script("research/diag_fit.py")


def test_sequences_round_trip_exactly_in_order(diag, tmp_path):
    rng = np.random.default_rng(0)
    groups = {"train_bc": [_seq(5, 2, 3, rng) for _ in range(11)], "val_dag": [_seq(7, 2, 3, rng)]}
    diag.save_sequences(tmp_path / "d.npz", groups)
    back = diag.load_sequences(tmp_path / "d.npz")
    assert sorted(back) == sorted(groups) and [p.name for p in tmp_path.iterdir()] == ["d.npz"]
    no_aux = [Sequence(q.obs, q.labels, q.keep, q.live, q.driven) for q in groups["val_dag"]]
    diag.save_sequences(tmp_path / "e.npz", {"val_dag": no_aux})  # a teacher without a side: no aux arrays
    assert diag.load_sequences(tmp_path / "e.npz")["val_dag"][0].aux is None
    for g, seqs in groups.items():
        assert len(back[g]) == len(seqs)
        for q, r in zip(seqs, back[g]):  # episode 10 after 9, not after 1
            for f in diag.FIELDS:
                a, b = getattr(q, f), getattr(r, f)
                assert a.dtype == b.dtype and np.array_equal(a, b)


def test_a_pickled_array_is_refused(diag, tmp_path):
    np.savez(tmp_path / "bad.npz", train_bc_0_obs=np.array([object()], dtype=object))
    with pytest.raises(ValueError, match="allow_pickle"):
        diag.load_sequences(tmp_path / "bad.npz")


def test_near_a_side_switch_is_the_hand_computed_window(diag):
    """One robot, labels' vy sides + + + 0 + - - - - - - - (classes nearest): one change of side, between
    steps 4 and 5 (the 0 at step 3 is no side); with near=2 steps 3..7 are near it: 5 of 12. The two
    parts' means weigh back to the mean."""
    from tin_swarm_env.training.recurrent_imitation import GRUStudent
    from tin_swarm_env.policies.heads import categorical_classes

    vy = np.array([1, 1, 1, 0, 1, -1, -1, -1, -1, -1, -1, -1], np.float32) * 0.7
    labels = np.stack([np.full(12, 0.7, np.float32), vy], -1)[:, None, :]
    q = Sequence(np.random.default_rng(1).normal(size=(12, 1, 4)).astype(np.float32), labels,
                 np.ones((12, 1), bool), np.ones((12, 1), bool))
    st = GRUStudent(4, 4, (4,), cell=None, classes=categorical_classes())
    mean, near, elsewhere, share = diag.held_out(st, [q], near=2)
    assert share == 5 / 12
    assert near * 5 / 12 + elsewhere * 7 / 12 == pytest.approx(mean, rel=1e-6)
    assert near != elsewhere
    from tin_swarm_env.training.recurrent_imitation import sequence_loss

    with torch.no_grad():
        err = sequence_loss(st, q)[0].numpy()
    assert near == pytest.approx(err[3:8].mean(), rel=1e-6) and elsewhere == pytest.approx(
        np.r_[err[:3], err[8:]].mean(), rel=1e-6)


def test_side_flips_skip_no_side_and_unkept_steps(diag):
    """Robot 0: + 0 + - - 0 + (kept everywhere): 2 changes (+ to -, - to +); robot 1: + - + with the
    middle step not kept: + + -> 0 changes, then - at the end: 1."""
    side = np.array([[1, 1], [0, -1], [1, 1], [-1, -1], [-1, 0], [0, 0], [1, 0]])
    keep = np.ones((7, 2), bool)
    keep[1, 1] = False
    assert diag.flips(side, keep) == 2 + 1
    assert diag.flips(side[:, :1], keep[:, :1]) == 2 and diag.flips(side[:, 1:], keep[:, 1:]) == 1


def test_side_stats_count_the_readout_against_the_teachers_side(diag):
    """A student whose read-out is fitted on a cue task: side_stats' accuracy and flips are the ones
    counted by hand from side_logits."""
    from tin_swarm_env.training.recurrent_imitation import SIDES, GRUStudent, fit_sequences, side_logits
    from tin_swarm_env.policies.heads import categorical_classes

    rng = np.random.default_rng(0)
    seqs = []
    for _ in range(2):
        T, n = 6, 4
        obs = rng.normal(size=(T, n, 3)).astype(np.float32)
        labels = rng.uniform(-1, 1, (T, n, 2)).astype(np.float32)
        aux = rng.integers(-1, 2, (T, n)).astype(np.int8)
        seqs.append(Sequence(obs, labels, np.ones((T, n), bool), np.ones((T, n), bool), labels.copy(), aux))
    st = GRUStudent(3, 4, (4,), classes=categorical_classes(), feedback="action", aux_weight=1.0)
    fit_sequences(st, seqs, epochs=2)
    s = diag.side_stats(st, seqs)
    preds = [np.asarray(SIDES)[side_logits(st, q).argmax(-1)] for q in seqs]
    ok = sum(int((p == q.aux).sum()) for p, q in zip(preds, seqs))
    assert s["side acc"] == ok / 48
    fol = sum(int(((p == q.aux) & (q.aux != 0)).sum()) for p, q in zip(preds, seqs))
    assert s["acc following"] == fol / sum(int((q.aux != 0).sum()) for q in seqs)
    assert s["read-out flips"] == 100 * sum(diag.flips(p, q.keep) for p, q in zip(preds, seqs)) / 48
    assert s["teacher side flips"] == 100 * sum(diag.flips(q.aux, q.keep) for q in seqs) / 48


def test_drive_records_the_mode_the_student_commanded_and_apfs_side(diag):
    """diag_fit.drive: the file (acting by the mode, whatever the student's own acting) drives; each recorded
    command is the class of the torch student's largest logit on the replayed history (its feedback
    included), and APF's side is recorded (aux)."""
    import tin_swarm_env as tse
    from tin_swarm_env.env.observation import ObsLayout
    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, previous_actions
    from tin_swarm_env.policies.heads import categorical_classes

    old = load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0))  # the study's layout: no scan (sign-flip mirror)
    lay = tse.parallel_env(scenario=old, n_robots=3).layout
    classes = categorical_classes()
    st = GRUStudent(lay.size, 8, (8,), signs=lay.mirror_signs(), seed=1, classes=classes, feedback="action",
                    aux_weight=1.0, acting="sample")
    seqs = diag.drive(st, lay, old, 1, 12)
    assert len(seqs) == 1 and st.head_entry["acting"] == "sample"  # the student's own acting is left as it was
    q = seqs[0]
    assert q.aux is not None and q.aux.shape == q.keep.shape and len(q.obs) == 12
    with torch.no_grad():
        z = st(q.obs, previous_actions(q, len(q.obs), classes)).double().numpy()
    top2 = np.sort(z, axis=-1)[..., -2:]
    clear = (top2[..., 1] - top2[..., 0] > 1e-4) & q.live
    assert clear.sum() > 0.9 * q.live.sum()
    np.testing.assert_array_equal(q.driven[clear], classes[z.argmax(-1)][clear].astype(np.float32))
