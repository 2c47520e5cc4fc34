"""Imitation of a teacher (APF, or the map-knowing GeodesicPolicy): behaviour cloning (BC) and
DAgger into an SB3 actor-critic.

    demos = collect(["cliff_goal", "ramp"], episodes=10, seed=0)                 # APF drives
    fit_actor(model.policy, demos.obs, demos.actions)                             # BC
    demos += collect(..., learner=TorchActor(model.policy))                      # DAgger: the learner drives
    fit_actor(model.policy, demos.obs, demos.actions); fit_value(model.policy, demos.obs, demos.returns)

**Labels.** Every step, the teacher (:class:`~tin_swarm_env.policies.APFPolicy` by default) is called on the
observations of *all* robots of the episode, whoever drives, and its action for each live robot is
the label of that robot's observation. APF has per-robot memory (its wall-following side, the
Pledge turn counter, a stall counter: :class:`~tin_swarm_env.policies.apf.BugMemory`), so it must
see the same observation stream as the robots, every step, in order: that is why the teacher runs
*alongside* the learner instead of being asked about isolated observations. Under DAgger the
learner's actions move the robots and the teacher's memory follows the learner's trajectory; the
label is "what APF would do now, having seen what this robot has seen". (A label is therefore
not always what APF would have done on its own trajectory: a robot the learner led into a dead
end gets APF's turn-back rule, which is the correction DAgger wants.)

**Teachers** (``teacher=``, :data:`TEACHERS`). ``"apf"`` (default): :class:`~tin_swarm_env.policies.APFPolicy`
with its default search (the chart search), which acts from the observation alone (what the student sees);
``"apf_bug"``: APF with the bug search (the default before; its boundary side is recorded behind each
label, :func:`teacher_side`). ``"geodesic"``:
:class:`~tin_swarm_env.policies.GeodesicPolicy`, a *privileged* teacher: it reads the map and the
world state (the terrain's cost-to-go toward each robot's target, the robot's position and
heading), so its label is the first leg of the shortest drivable path, which APF, trapped on
forks, mesas and long walls, does not know. The student still sees only the observation (the
samples are observations; only the labels come from the map). It labels the states the student
visits under DAgger exactly as under BC: it is called on every robot every step, and its action
for a robot depends on that robot's current state alone (its only memory is the per-target
field cache, dropped at each reset), so a label is "what the shortest path says here".
Symmetry with this teacher: the student should be mirror-equivariant by construction
(``--symmetry mirror``), not fitted on mirrored samples (:meth:`Demos.mirrored`, refused with
it in ``training/config.py``). A mirrored sample claims that the teacher, in the mirror-image world, would
act as the mirror image of its action; APF's bug search acts from the observation alone and is
mirror-equivariant on any observation, so that holds for it (the chart search, the default, only as a
swarm: each robot keeps to its own side of its way, so the mirrored label is another robot's).
GeodesicPolicy's action is a function of the map, not of the observation; it is equivariant only between a map and its
mirror image, and that mirror image is neither a map the robots drove on nor exactly the
reflection of what the teacher computed (the greedy TIN of a reflected DEM is not the reflected
TIN, and equal-length paths tie differently), so a mirrored label is a claim about a world nobody
ran. An equivariant student gets the symmetry without such labels: fitting ``pi(o) = a`` fits
``pi(M o) = M a`` with it, and where the map breaks the tie the observation history, not a
reflected label, has to say which way.
``"apf_student"``: :class:`~tin_swarm_env.training.apf_teacher.StudentAPF`, APF whose memory follows the
robots along whatever trajectory drove them (its odometry reads the command executed, not its own label)
and takes the side of a boundary the student drives along, so its labels follow the side the student
took (the rule: :mod:`tin_swarm_env.training.apf_teacher`). With ``"apf"`` the odometry reads APF's own label
even where the learner drove: kept as it was, for the shipped recipe's reproduction.
What a privileged teacher cannot give a memoryless student (measured:
``research/teacher_geodesic.md``): where the shortest way round is left on one map and right on
another that look the same to the robot (a cliff across the way, the pass out of sight), the labels
for one observation disagree, and a mean-squared-error fit learns their mean, for a mirror-equivariant
student ``vy = 0``: straight on, into the cliff. The teacher's choice is a function of the map, not
of anything the student sees; imitation can only give the student what the observation (and, for a
recurrent student, its history) determines.

**Returns.** Each sample also carries its discounted return-to-go (``gamma``) under the policy that
drove, for a short value warm-up (:func:`fit_value`) so that PPO fine-tuning starts from a critic
that is not random: a random critic's advantages would undo the cloned actor in the first updates.

**Seeds.** Episode ``k`` of a collection runs ``scenarios[k % len(scenarios)]`` from
``reset(seed + k)``; training code keeps these below :data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`
(evaluation seeds start there).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import ArgumentError

__all__ = ["Demos", "Sequence", "TEACHERS", "make_teacher", "collect", "fit_actor", "fit_value", "TorchActor",
           "actor_mean"]

TEACHERS = ("apf", "apf_bug", "geodesic", "apf_student")  # the labelling policies of collect(teacher=...) (module docstring)


def check_teacher(teacher: str, where: str = "teacher") -> str:
    """``teacher`` if it is one of :data:`TEACHERS`; else ArgumentError naming ``where`` and the value."""
    if teacher not in TEACHERS:
        raise ArgumentError(f"{where} {teacher!r} is not a teacher; choose from {', '.join(TEACHERS)}")
    return teacher


def make_teacher(teacher: str, env):
    """The labelling policy ``teacher`` (:data:`TEACHERS`) for ``env``: APFPolicy, GeodesicPolicy or
    :class:`~tin_swarm_env.training.apf_teacher.StudentAPF`."""
    from ..policies import APFPolicy, GeodesicPolicy
    from .apf_teacher import StudentAPF

    def apf_bug(e):
        return APFPolicy(e, search="bug")

    return {"apf": APFPolicy, "apf_bug": apf_bug, "geodesic": GeodesicPolicy,
            "apf_student": StudentAPF}[check_teacher(teacher)](env)


@dataclass
class Demos:
    """Labelled samples of live robots.

    obs      (N, d) float32  observations
    actions  (N, 2) float32  the teacher's action for each
    returns  (N,)   float32  discounted return-to-go from that step under the policy that drove
    arrived, fell: shares of the collected robot-episodes (the driving policy's), episodes: count
    sequences: the episodes as :class:`Sequence` (``collect(sequences=True)``, for a recurrent
               student; empty otherwise)
    """

    obs: np.ndarray
    actions: np.ndarray
    returns: np.ndarray
    arrived: float = 0.0
    fell: float = 0.0
    episodes: int = 0
    sequences: tuple = ()

    def __add__(self, other: Demos) -> Demos:
        n = self.episodes + other.episodes
        w = self.episodes / max(n, 1)
        return Demos(np.concatenate([self.obs, other.obs]), np.concatenate([self.actions, other.actions]),
                     np.concatenate([self.returns, other.returns]), w * self.arrived + (1 - w) * other.arrived,
                     w * self.fell + (1 - w) * other.fell, n, tuple(self.sequences) + tuple(other.sequences))

    def __len__(self) -> int:
        return len(self.obs)

    def mirrored(self, layout) -> Demos:
        """The mirror images of these samples (:meth:`~tin_swarm_env.env.observation.ObsLayout.mirror`,
        :func:`~tin_swarm_env.env.observation.mirror_action`): the teacher's action in the
        mirrored world, since the teacher is mirror-equivariant (APF's bug search is, memory included, on
        random observations and over an episode: tests/policies/test_symmetry.py; a teacher whose
        tie-breaks pick one side would not be, nor is the map-knowing geodesic teacher: module
        docstring; the chart search, APF's default, is only as a swarm: its A* ties break one way and
        each robot keeps to its own side of its way, :func:`~tin_swarm_env.policies.chart.robot_side`,
        so a mirrored label is the label of a robot of the other side). Returns equal; ``episodes`` 0,
        so ``demos + demos.mirrored(l)`` keeps the driving policy's shares and episode count."""
        from ..env.observation import mirror_action

        seqs = tuple(Sequence(layout.mirror(q.obs), mirror_action(q.labels), q.keep, q.live,
                              None if q.driven is None else mirror_action(q.driven),
                              None if q.aux is None else -q.aux) for q in self.sequences)
        return Demos(layout.mirror(self.obs), mirror_action(self.actions), self.returns.copy(), self.arrived,
                     self.fell, 0, seqs)


@dataclass
class Sequence:
    """One episode, every step of every robot, for a recurrent student (``T`` steps, ``n`` robots):

    obs     (T, n, d) float32  what each robot observed (after it ended: the env's zeros)
    labels  (T, n, 2) float32  the teacher's action
    keep    (T, n)    bool     the samples a fit learns from (live and not stalled: :func:`_episode`)
    live    (T, n)    bool     the robot was live (its memory runs over these steps)
    driven  (T, n, 2) float32  the action the driving file commanded, before the shield (the learner's
                               own, also on steps where DAgger's teacher drove; BC: the teacher's), the
                               feedback a recurrent file reads at the next step; None: not recorded
    aux     (T, n)    int8     the side the teacher follows a boundary on at that step, after labelling it
                               (APF's ``BugMemory.side``: +1 the boundary on the robot's right, -1 on its
                               left, 0 none; :func:`teacher_side`), the target of a recurrent student's side
                               read-out (training/recurrent_imitation.py); its mirror image is ``-aux``. None: the
                               teacher has no such memory (``"geodesic"``)
    """

    obs: np.ndarray
    labels: np.ndarray
    keep: np.ndarray
    live: np.ndarray
    driven: np.ndarray | None = None
    aux: np.ndarray | None = None


def teacher_side(teacher, n: int) -> np.ndarray | None:
    """``(n,)`` int8: the side each row's boundary search follows in ``teacher``'s memory now
    (:class:`~tin_swarm_env.policies.apf.BugMemory` ``side``, read through the teacher's ``memory``;
    rows the memory has not grown to, or APF with the break field off: 0). None: a teacher without
    that memory (GeodesicPolicy)."""
    from ..policies.bug import BugMemory

    mem = getattr(teacher, "memory", None)
    if not isinstance(mem, BugMemory):
        return None
    out = np.zeros(n, dtype=np.int8)
    m = min(n, len(mem.side))
    out[:m] = mem.side[:m]
    return out


def _discounted(rewards, live, gamma):
    """Returns-to-go ``(T, n)`` of per-step ``rewards (T, n)`` over the steps each robot was
    ``live (T, n)`` (rewards after a robot ended are 0, so the backward sum stops there)."""
    out = np.zeros_like(rewards)
    acc = np.zeros(rewards.shape[1])
    for t in range(len(rewards) - 1, -1, -1):
        acc = np.where(live[t], rewards[t] + gamma * acc, 0.0)
        out[t] = acc
    return out


STALL_EPS_M = 0.25  # a robot "makes progress" when its distance to go drops this much below its best


def _episode(env, teacher, learner, seed, gamma, beta=0.0, stall_steps=0, rng=None, shield=None,
             sequences=False):
    """One episode: ``(obs (N, d), labels (N, 2), returns (N,), reasons (n,), seq)`` over the kept
    live robot-steps. ``beta``: each live robot's action is the teacher's with this probability
    (per robot and step, drawn from ``rng``), else the learner's. ``stall_steps`` > 0: a robot's
    samples stop being kept once its distance to go (``env.distance_to_go()``) has not dropped
    :data:`STALL_EPS_M` below its best for that many steps (it is stuck; its steps would flood
    the data); it keeps driving and the teacher keeps seeing it. ``shield``: a callable
    ``(actions, obs) -> actions`` the learner's actions pass through (the policy-file shield).
    ``seq``: with ``sequences``, the episode as a :class:`Sequence` (every step of every robot, for
    a recurrent student); else None."""
    from ..world.state import Reason

    obs = env.reset_arrays(seed=seed)
    teacher.reset()
    if learner is not None and hasattr(learner, "reset"):
        learner.reset()
    n = env.n
    reasons = np.full(n, int(Reason.NONE), dtype=np.int8)
    best, since = env.distance_to_go(), np.zeros(n, dtype=np.int64)
    O, A, R, L, K, D, S = [], [], [], [], [], [], []
    live = env.live_mask
    while live.any():
        label = teacher.act_batch(obs)  # every row, every step: the teacher's memory sees the whole stream
        S.append(teacher_side(teacher, n))  # the side behind this label (before driven() may take the student's)
        act = label if learner is None else learner.act_batch(obs)
        D.append(np.asarray(act, dtype=np.float32))
        if learner is not None and shield is not None:
            act = shield(act, obs)
        if learner is not None and beta > 0:
            act = np.where((rng.random(n) < beta)[:, None], label, act)
        if hasattr(teacher, "driven"):  # a teacher whose memory follows what moved the robots (apf_teacher.py)
            teacher.driven(act)
        keep = live & ((since < stall_steps) if stall_steps > 0 else True)
        O.append(np.asarray(obs, dtype=np.float32))
        A.append(np.asarray(label, dtype=np.float32))
        obs, rew, term, trunc, why = env.step_arrays(act)
        R.append(np.where(live, rew, 0.0))
        L.append(live)
        K.append(keep)
        ended = term | trunc
        reasons[ended] = why[ended]
        d = env.distance_to_go()
        better = d < best - STALL_EPS_M
        best = np.where(better, d, best)
        since = np.where(better, 0, since + 1)
        live = env.live_mask
    O, A, L, K = np.stack(O), np.stack(A), np.stack(L), np.stack(K)  # (T, n, ...)
    ret = _discounted(np.asarray(R), L, gamma)[K]  # row-major: step by step, robot order
    aux = None if S[0] is None else np.stack(S)
    seq = Sequence(O, A, K, L, np.stack(D), aux) if sequences else None
    return O[K], A[K], ret.astype(np.float32), reasons, seq


def collect(scenarios, episodes: int, seed: int, *, n_robots=None, max_cycles=None, learner=None,
            gamma: float = 0.99, env_kwargs: dict | None = None, beta: float = 0.0, stall_steps: int = 0,
            shield: str = "none", teacher: str = "apf", sequences: bool = False) -> Demos:
    """Run ``episodes`` episodes (cycling over ``scenarios``; see the module docstring), driven by
    the teacher (``learner=None``: behaviour cloning data) or by ``learner`` (an object with
    ``act_batch(obs (n, d)) -> (n, 2)``: DAgger data), every live robot-step labelled with the
    teacher's action (``teacher``: one of :data:`TEACHERS`, checked before any episode runs).
    ``n_robots``/``max_cycles`` None: the scenario's. ``beta`` (DAgger's mixing: the teacher
    drives each robot-step with this probability; the draws come from ``default_rng(seed)``) and
    ``stall_steps`` (drop a stuck robot's later samples): see :func:`_episode`. ``shield="safety_cut"``:
    the learner acts through the policy-file shield (:mod:`tin_swarm_env.policies.learned`).
    ``sequences``: also keep each episode whole (``Demos.sequences``, for a recurrent student)."""
    from ..env import parallel_env
    from ..world.state import Reason

    check_teacher(teacher)
    if episodes < 1:
        raise ArgumentError(f"episodes must be >= 1, got {episodes}")
    if not 0.0 <= beta <= 1.0:
        raise ArgumentError(f"beta must be in [0, 1], got {beta}")
    rng = np.random.default_rng(seed)
    from ..scenario import ScenarioConfig

    # names, files or configs (a config carries its own observation layout)
    scenarios = [scenarios] if isinstance(scenarios, (str, os.PathLike, ScenarioConfig)) else list(scenarios)
    kw = dict(env_kwargs or {})
    if max_cycles:
        kw["max_cycles"] = max_cycles
    envs = [parallel_env(scenario=s, n_robots=n_robots or None, **kw) for s in scenarios]
    teachers = [make_teacher(teacher, e) for e in envs]
    from ..policies.base import make_shield

    shields = [make_shield(shield, e) for e in envs]
    parts, reasons, seqs = [], [], []
    for k in range(episodes):
        s = k % len(scenarios)
        o, a, r, why, q = _episode(envs[s], teachers[s], learner, seed + k, gamma, beta, stall_steps, rng, shields[s],
                                   sequences)
        parts.append((o, a, r))
        reasons.append(why)
        if q is not None:
            seqs.append(q)
    why = np.concatenate(reasons)
    return Demos(np.concatenate([p[0] for p in parts]).astype(np.float32),
                 np.concatenate([p[1] for p in parts]).astype(np.float32), np.concatenate([p[2] for p in parts]),
                 float(np.mean(why == Reason.ARRIVED)), float(np.mean(why == Reason.FELL)), episodes, tuple(seqs))


# -- fitting an SB3 ActorCriticPolicy (torch) -------------------------------------------------


def actor_mean(policy, obs_t):
    """The Gaussian mean of SB3 ``ActorCriticPolicy`` ``policy`` for a torch batch ``(B, d)``
    (averaged with the mirror image for a mirror-equivariant policy)."""
    if hasattr(policy, "mirror_mean_value"):
        return policy.mirror_mean_value(obs_t)[0]
    features = policy.extract_features(obs_t, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))


def _value(policy, obs_t):
    if hasattr(policy, "mirror_mean_value"):
        return policy.mirror_mean_value(obs_t)[1][:, 0]
    features = policy.extract_features(obs_t, policy.vf_features_extractor)
    return policy.value_net(policy.mlp_extractor.forward_critic(features))[:, 0]


def _fit(params, loss_of, n: int, epochs: int, batch_size: int, lr: float, seed: int) -> float:
    """Adam over ``params`` minimising ``loss_of(idx)`` on shuffled minibatches; the last epoch's mean loss."""
    import torch

    opt = torch.optim.Adam(params, lr=lr)
    gen = torch.Generator().manual_seed(seed)
    last = float("nan")
    for _ in range(max(epochs, 0)):
        perm = torch.randperm(n, generator=gen)
        tot = 0.0
        for i in range(0, n, batch_size):
            idx = perm[i:i + batch_size]
            loss = loss_of(idx)
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += loss.item() * len(idx)
        last = tot / max(n, 1)
    return last


def fit_actor(policy, obs, actions, *, epochs: int = 20, batch_size: int = 4096, lr: float = 1e-3, seed: int = 0,
              std: float | None = 0.3) -> float:
    """Behaviour cloning: fit the actor's mean (``policy.mlp_extractor``'s actor branch and
    ``policy.action_net``) to ``actions (N, 2)`` by mean squared error (the maximum-likelihood
    mean of a fixed-variance Gaussian), in batches; then set the policy's log-std to ``log(std)``
    (the exploration PPO starts from; None: leave it). Returns the final epoch's MSE."""
    import torch

    x = torch.as_tensor(np.asarray(obs, np.float32))
    y = torch.as_tensor(np.clip(np.asarray(actions, np.float32), -1, 1))
    params = list(policy.mlp_extractor.policy_net.parameters()) + list(policy.action_net.parameters())
    policy.set_training_mode(True)
    mse = _fit(params, lambda i: torch.mean((actor_mean(policy, x[i]) - y[i]) ** 2), len(x), epochs, batch_size,
               lr, seed)
    if std is not None and hasattr(policy, "log_std"):
        with torch.no_grad():
            policy.log_std.fill_(float(np.log(std)))
    policy.set_training_mode(False)
    return mse


def fit_value(policy, obs, returns, *, epochs: int = 10, batch_size: int = 4096, lr: float = 1e-3,
              seed: int = 0) -> float:
    """Value warm-up: regress the critic (``policy.mlp_extractor``'s value branch and
    ``policy.value_net``) on discounted returns-to-go ``(N,)``. Returns the final epoch's MSE."""
    import torch

    x = torch.as_tensor(np.asarray(obs, np.float32))
    y = torch.as_tensor(np.asarray(returns, np.float32))
    params = list(policy.mlp_extractor.value_net.parameters()) + list(policy.value_net.parameters())
    policy.set_training_mode(True)
    mse = _fit(params, lambda i: torch.mean((_value(policy, x[i]) - y[i]) ** 2), len(x), epochs, batch_size, lr,
               seed)
    policy.set_training_mode(False)
    return mse


class TorchActor:
    """An SB3 ``ActorCriticPolicy``'s deterministic action (its mean, clipped to [-1, 1]) as
    ``act_batch(obs (n, d)) -> (n, 2)``: the learner during DAgger collection."""

    def __init__(self, policy):
        self.policy = policy

    def act_batch(self, obs) -> np.ndarray:
        import torch

        with torch.no_grad():
            m = actor_mean(self.policy, torch.as_tensor(np.asarray(obs, np.float32)))
        return np.clip(m.numpy(), -1.0, 1.0).astype(np.float32)
