"""APF as the DAgger teacher along the student's own trajectory: ``teacher="apf_student"`` of
:func:`~tin_swarm_env.training.imitation.collect` (``tin-swarm train --teacher apf_student``).

**Why.** The map-knowing teacher (GeodesicPolicy) labels each state with the map's shortest way on;
where both ways round a cliff look alike to the robot, which way that is cannot be told from what the
robot has seen, so a student that has committed to one side keeps getting labels that say "go the other
way", and dithers (measured: ``research/teacher_multimodal.md``). A teacher whose labels follow the
side the student has taken gives the student nothing it cannot see: APF decides its side from the
observation when it meets a boundary and then keeps it in its memory
(:class:`~tin_swarm_env.policies.apf.BugMemory`; the rules: :mod:`tin_swarm_env.policies.apf`).

**The rule** (:class:`StudentAPF`, one :class:`~tin_swarm_env.policies.APFPolicy` used through its
API), each step of an episode, for every robot row:

1. *Label*: APF's action on the observation the robot reached (``act_batch``), which advances APF's
   memory by that observation, whoever drove there.
2. *What drove* (:meth:`StudentAPF.driven`, called with the command the robot executed, after the
   shield and DAgger's mixing):

   a. *Odometry*: APF's record of its last command (``BugMemory.last_act``) becomes the executed
      command. APF integrates its heading and its position relative to its target from the command
      it believes moved the robot (:func:`~tin_swarm_env.policies.bug.odometry`); left at its own
      label, it would integrate a path the robot never drove as soon as the student disagrees.
   b. *The side*: a robot that APF follows a boundary with on side ``s`` (+1 the boundary on its
      right) whose executed command runs along that boundary the other way (its component along the
      followed break's tangent ``s * t_right`` below ``-adopt``) while APF's own label runs along it
      on side ``s`` (component > 0: not through a gap or round a corner, where APF's command itself
      leaves the tangent) has turned: APF's memory takes the
      student's side as one of its own turn-backs (rule 4 of the APF rules): side ``-s``, the
      search's bookkeeping as after a turn (not yet back past ``H``, the budget's climb and the
      stall counter reset; budget, hit point and ended sides kept). Not toward a side APF has found
      ended (the terrain's border or a stall there): there its label keeps saying "turn round".

   From the next step on, APF's label follows the boundary on the side the student is on. Under
   behaviour cloning APF drives itself and both steps change nothing: its own command, and a command
   equal to its label never runs against the label (``tests/training/test_apf_teacher.py``, bit for bit).

**Mirror symmetry, exact.** APF is mirror-equivariant, memory included; the adoption compares the
command with the followed tangent, and reflecting the observations and the commands reflects both
(the tangent and the side change sign together), so the labels of a mirrored episode are the mirrored
labels (``tests/training/test_apf_teacher.py``). Mirrored samples (``--mirror-samples``) are valid with
this teacher, as with ``"apf"``.
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError

__all__ = ["StudentAPF", "ADOPT"]

ADOPT = 0.25  # along-boundary speed (share of top speed) against APF's side at which the student's side is taken


class StudentAPF:
    """APF labelling along the student's trajectory (module docstring): ``act_batch(obs (n, d))``
    (the labels), :meth:`driven` (what moved the robots), :meth:`reset`. ``adopt``: the along-wall
    speed against APF's side at which the student's side is taken (None: never, the odometry alone)."""

    def __init__(self, env, adopt: float | None = ADOPT, **apf_kwargs):
        from ..policies import APFPolicy

        if adopt is not None and not 0.0 <= adopt <= 1.0:
            raise ArgumentError(f"StudentAPF: adopt must be in [0, 1] or None, got {adopt!r}")
        self.apf = APFPolicy(env, **{"search": "bug", **apf_kwargs})  # the labels follow the bug search's side
        self.adopt = adopt
        self.adopted = 0  # robot-steps at which APF took the student's side (this episode)

    def reset(self):
        """Forget every robot's memory (after each environment reset)."""
        self.apf.reset()
        self.adopted = 0

    @property
    def memory(self):
        return self.apf.memory

    def act_batch(self, obs) -> np.ndarray:
        """APF's labels for ``obs (n, d)`` (rows are robots), advancing its memory by them."""
        return self.apf.act_batch(obs)

    def driven(self, act) -> np.ndarray:
        """Tell APF the commands ``act (n, 2)`` that moved the robots this step (after the last
        :meth:`act_batch`): its odometry follows them and, where a command runs along the followed
        boundary against APF's side, APF takes that side. Returns ``(n,)`` bool: the rows whose side
        was taken."""
        mem = self.apf.memory
        try:
            a = np.asarray(act, dtype=np.float64)
        except (TypeError, ValueError):
            raise ArgumentError(f"StudentAPF.driven: act must be an (n, 2) array of real numbers (the executed "
                                f"commands), got {type(act).__name__}") from None
        if a.ndim != 2 or a.shape[1] != 2 or (len(mem.side) and len(a) != len(mem.side)):
            rows = len(mem.side) if len(mem.side) else "n"
            raise ArgumentError(f"StudentAPF.driven: act must have shape ({rows}, 2), one command per row of the "
                                f"last act_batch, got shape {a.shape}")
        m = min(len(a), len(mem.side))
        took = np.zeros(len(a), dtype=bool)
        if m == 0:  # no memory (the break field off): APF acts from the observation alone
            return took
        a = a[:m]
        label = mem.last_act[:m].copy()  # APF's own command this step (act_batch wrote it)
        mem.last_act[:m] = a
        if self.adopt is None:
            return took
        s = mem.side[:m].astype(np.int64)
        ang = mem.wall[:m] - mem.psi[:m]  # direction from the followed break to the robot, body frame
        t_right = np.stack([np.sin(ang), -np.cos(ang)], axis=-1)  # the tangent with the break on the right
        along = np.sum(a * t_right, axis=-1) * s
        own = np.sum(label * t_right, axis=-1) * s  # > 0: APF's label runs along its side (no gap, no corner)
        to_first = -s == mem.first[:m]
        ended = np.where(to_first, mem.ended_first[:m], mem.ended_other[:m])
        turn = (s != 0) & mem.has_pt[:m] & ~mem.unreachable[:m] & ~ended & (along < -self.adopt) & (own > 0)
        r = np.flatnonzero(turn)
        if len(r):
            mem.side[r] = -mem.side[r]
            mem.fside[r] = mem.side[r]
            mem.passed[r] = False
            mem.climb[r] = 0.0
            mem.stall[r] = 0
            took[r] = True
            self.adopted += len(r)
        return took
