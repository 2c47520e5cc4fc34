"""APF as the DAgger teacher along the student's trajectory (tin_swarm_env/training/apf_teacher.py): its
odometry follows the command that moved the robot, it takes the side of a boundary the student drives
along, it is APF exactly when the student is APF, and it is mirror-equivariant over an episode."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import mirror_action
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.training.apf_teacher import ADOPT, StudentAPF
from tin_swarm_env.training.imitation import collect

R = 60.0
CLIFF = (5.0, 0.0, -1.0, 0.0, 50.0)  # a cliff edge 5 m ahead, running across the way


@pytest.fixture(scope="module")
def env1():
    return tse.parallel_env(scenario="cliff_goal", n_robots=1)


def test_the_label_follows_the_side_the_student_took(env1, obs_row):
    # step 1: target ahead-left beyond the cliff: APF follows it on the right, turning left (+y)
    lay = env1.layout
    o1 = obs_row(lay, R, (100.0, 30.0), [CLIFF])
    teach, plain = StudentAPF(env1), APFPolicy(env1, search="bug")
    l1 = teach.act_batch(o1)
    np.testing.assert_array_equal(l1, plain.act_batch(o1))
    assert teach.memory.side[0] == 1 and l1[0, 1] > 0.5
    # the student turned right instead (-y, along the cliff with it on its left) and moved 1 m
    stu = np.array([[0.0, -1.0]])
    assert teach.driven(stu).tolist() == [True] and teach.adopted == 1
    plain.memory.last_act[:] = stu  # the plain APF told the same command: it keeps its own side
    o2 = obs_row(lay, R, (100.0, 31.0), [CLIFF])
    l2, p2 = teach.act_batch(o2), plain.act_batch(o2)
    assert teach.memory.side[0] == -1 and plain.memory.side[0] == 1
    assert l2[0, 1] < -0.5 and p2[0, 1] > 0.5  # "go on to the right" against "turn back left"
    # exactly the label of an APF that chose the right-hand side itself (target ahead-right at the meeting)
    ref = APFPolicy(env1, search="bug")
    ref.act_batch(obs_row(lay, R, (100.0, -30.0), [CLIFF]))
    assert ref.memory.side[0] == -1
    np.testing.assert_array_equal(l2, ref.act_batch(o2))


def test_no_side_is_taken_slowly_along_apfs_way_or_toward_an_ended_side(env1, obs_row):
    lay = env1.layout
    o1 = obs_row(lay, R, (100.0, 30.0), [CLIFF])
    for cmd in ([0.0, 1.0], [0.3, 0.5], [1.0, 0.0], [0.0, -0.9 * ADOPT]):  # with APF, square off, or too slow
        teach = StudentAPF(env1)
        teach.act_batch(o1)
        assert teach.driven(np.array([cmd])).tolist() == [False] and teach.memory.side[0] == 1, cmd
        np.testing.assert_array_equal(teach.memory.last_act[0], cmd)  # the odometry reads it all the same
    # APF's own label runs against its side's tangent (as through a gap or round a corner): a student doing
    # the same has taken no side
    teach = StudentAPF(env1)
    teach.act_batch(o1)
    teach.memory.last_act[:] = [0.0, -1.0]
    assert teach.driven(np.array([[0.0, -1.0]])).tolist() == [False] and teach.memory.side[0] == 1
    # the border ahead ended the left-hand side: APF turned right itself; a student heading back left
    # gets no new side (its label keeps saying "turn round")
    teach = StudentAPF(env1)
    teach.act_batch(o1)
    teach.driven(np.array([[0.0, 1.0]]))
    teach.act_batch(obs_row(lay, R, (100.0, 30.0), [CLIFF, (0.0, 6.0, 0.0, -1.0, 0.0)]))
    assert teach.memory.side[0] == -1 and teach.memory.ended_first[0]
    assert teach.driven(np.array([[0.0, 1.0]])).tolist() == [False] and teach.memory.side[0] == -1
    # adopt=None: the odometry alone
    teach = StudentAPF(env1, adopt=None)
    teach.act_batch(o1)
    assert teach.driven(np.array([[0.0, -1.0]])).tolist() == [False] and teach.memory.side[0] == 1
    for bad in (-0.1, 1.5):
        with pytest.raises(ArgumentError, match="adopt"):
            StudentAPF(env1, adopt=bad)


def test_driven_refuses_commands_of_the_wrong_shape(env1, obs_row):
    """One command per row of the last act_batch: a (2,) command, an (n, 3) array or too many rows are
    refused by name (a (2,) command used to be broadcast into every row's odometry, silently)."""
    teach = StudentAPF(env1)
    teach.act_batch(obs_row(env1.layout, R, (100.0, 30.0), [CLIFF]))
    before = teach.memory.last_act.copy()
    for bad in (np.array([0.0, -1.0]), np.zeros((1, 3)), np.zeros((2, 2)), [["a", "b"]]):
        with pytest.raises(ArgumentError, match=r"StudentAPF.driven: act must"):
            teach.driven(bad)
    np.testing.assert_array_equal(teach.memory.last_act, before)  # nothing written
    assert teach.driven(np.array([[0.0, 1.0]])).tolist() == [False]


def _drive(env, seed, steps, student, teacher):
    """``steps`` steps of an episode: ``student(obs, label) -> command`` moves the robots, ``teacher``
    (StudentAPF) labels every step and is told the command. Returns (obs, commands, labels) per step."""
    obs = env.reset_arrays(seed=seed)
    teacher.reset()
    O, C, L = [], [], []
    for _ in range(steps):
        lab = teacher.act_batch(obs)
        cmd = np.asarray(student(obs, lab), dtype=np.float32)
        teacher.driven(cmd)
        O.append(obs)
        C.append(cmd)
        L.append(lab)
        obs, *_ = env.step_arrays(cmd)
        if not env.live_mask.any():
            break
    return O, C, L


@pytest.mark.parametrize("scenario", ["ramp", "generated"])
def test_a_student_that_is_apf_gets_apfs_own_actions_bit_for_bit(scenario):
    # behaviour cloning (APF drives): the labels and the trajectory are plain APF's, over a whole episode;
    # seed 0 of both has APF's label leave its side's tangent (a gap, a corner) while it follows
    kw = {"n_robots": 8}
    a = collect(scenario, 1, seed=0, teacher="apf_student", **kw)
    b = collect(scenario, 1, seed=0, teacher="apf_bug", **kw)
    assert len(a) == len(b) > 1000
    np.testing.assert_array_equal(a.obs, b.obs)
    np.testing.assert_array_equal(a.actions, b.actions)


def _contrary(obs, lab):
    """Robots 0, 2, 4 steer APF's command mirrored (vy negated): the other side, at the same speed."""
    out = np.array(lab, dtype=np.float64)
    out[0::2, 1] *= -1
    return out


def test_the_odometry_follows_the_robot_the_student_drove():
    # psi, the heading APF integrates from the command it is told moved the robot, equals the true
    # heading change when it is told the student's command; a plain APF, left at its own label, drifts
    env = tse.parallel_env(scenario="cliff_goal", n_robots=6)
    teach, plain = StudentAPF(env), APFPolicy(env, search="bug")
    obs = env.reset_arrays(seed=1)
    h0 = env.world_state.headings.copy()
    for _ in range(150):
        lab = teach.act_batch(obs)
        plain.act_batch(obs)
        cmd = _contrary(obs, lab).astype(np.float32)
        teach.driven(cmd)
        obs, *_ = env.step_arrays(cmd)
    teach.act_batch(obs)
    plain.act_batch(obs)
    live = env.live_mask
    turned = env.world_state.headings - h0

    def err(p):
        return np.abs((p.memory.psi - turned + np.pi) % (2 * np.pi) - np.pi)[live]

    assert live.sum() >= 3 and np.abs(turned[live]).max() > 0.1
    assert err(teach).max() < 1e-4 and err(plain).max() > 0.1


def test_labels_of_a_mirrored_episode_are_the_mirrored_labels():
    # the student takes the other side on half the robots (so the teacher takes sides); a fresh teacher
    # fed the mirror images of the observations and of the commands labels as the mirror image
    env = tse.parallel_env(scenario="cliff_goal", n_robots=6)
    a = StudentAPF(env)
    prev = np.zeros(6)

    def other_way(obs, lab):  # robots 0, 2, 4 set off the other way round where the teacher meets a boundary
        nonlocal prev
        met = (prev == 0) & (a.memory.side != 0)
        met[1::2] = False
        prev = a.memory.side.copy()
        return np.where(met[:, None], mirror_action(lab), lab)

    O, C, L = _drive(env, 2, 200, other_way, a)
    b = StudentAPF(env)
    lay = env.layout
    for o, c, lab in zip(O, C, L):
        np.testing.assert_allclose(b.act_batch(lay.mirror(o)), mirror_action(lab), atol=1e-6)
        b.driven(mirror_action(c))
    assert a.adopted >= 2 and b.adopted == a.adopted


class _OtherWay:
    """A learner: APF, except that where its own APF meets a boundary it sets off the other way round
    (that step's command mirrored); its own APF then steers it back (a student that dithers)."""

    def __init__(self, env):
        self.apf = APFPolicy(env, search="bug")

    def reset(self):
        self.apf.reset()
        self.prev = None

    def act_batch(self, obs):
        a = self.apf.act_batch(obs)
        side = self.apf.memory.side.copy()
        met = (side != 0) & (self.prev == 0) if self.prev is not None else side != 0
        self.prev = side
        return np.where(met[:, None], mirror_action(a), a).astype(np.float32)


def test_collect_labels_with_the_teacher_told_what_drove():
    """collect(teacher="apf_student") with a learner driving: the labels of a plain loop in which a
    StudentAPF labels each step and is told the learner's command (no shield: the command as given)."""
    kw = {"n_robots": 4, "max_cycles": 150}
    env = tse.parallel_env(scenario="cliff_goal", **kw)
    demos = collect("cliff_goal", 1, seed=2, teacher="apf_student", learner=_OtherWay(env), **kw)
    learner, teach = _OtherWay(env), StudentAPF(env)
    learner.reset()
    O, C, L = _drive(env, 2, 10 ** 6, lambda o, lab: learner.act_batch(o), teach)
    assert teach.adopted >= 2
    env.reset_arrays(seed=2)
    keep = []
    for c in C:  # the live rows of each step, as collect keeps them
        keep.append(env.live_mask.copy())
        env.step_arrays(c)
    np.testing.assert_array_equal(demos.obs, np.concatenate([o[k] for o, k in zip(O, keep)]))
    np.testing.assert_array_equal(demos.actions, np.concatenate([lab[k] for lab, k in zip(L, keep)]))
    plain = collect("cliff_goal", 1, seed=2, teacher="apf_bug", learner=_OtherWay(env), **kw)
    assert len(plain) == len(demos) and not np.array_equal(plain.actions, demos.actions)  # told its own labels
