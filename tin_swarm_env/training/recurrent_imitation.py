"""Imitation into a recurrent student: a GRU (torch, one layer) before an MLP head, fitted by BC
and DAgger on whole episodes per robot, and exported as a recurrent policy file.

    demos = collect(scen, 20, seed, teacher="geodesic", sequences=True)     # training/imitation.py
    student = GRUStudent(layout.size, hidden=64, head=(64,), signs=layout.mirror_signs())
    fit_sequences(student, demos.sequences)                                  # BC on whole episodes
    demos += collect(..., learner=student.policy(layout), sequences=True)   # DAgger: the numpy file drives
    student.export("runs/gru/policy", layout, scenario="generated")          # policies/recurrent.py

``tin-swarm train --student gru`` runs it (:func:`~tin_swarm_env.training.student.train_student`).

**The network** is the recurrent policy file's (:mod:`tin_swarm_env.policies.recurrent`, cell
``"gru"``): ``torch.nn.GRU`` with one layer (its weights in torch's layout are the file's
``cell_*`` arrays, gates reset, update, new), then ``Linear``-``tanh``-...-``Linear`` to the two
action components, the deterministic action ``clip(head(h), -1, 1)``. With ``signs`` (the
layout's mirror signs) it is the file's ``"symmetry": "mirror"``: two streams per robot through
the same cell, one fed the observations and one their mirror images, their head outputs averaged
with ``vy`` of the mirrored one negated, so the student is mirror-equivariant over whole histories.

**Memory per robot, as in the file.** A robot's hidden state starts at zero at the episode's first
step and runs over every step of the episode (:class:`~tin_swarm_env.training.imitation.Sequence`);
the loss is the mean squared error of the head's output (before the clip) against the teacher's
label clipped to [-1, 1], over the kept steps only (live and not stalled). Each minibatch is a piece of
:data:`CHUNK` consecutive steps of one episode (all its robots), started from the state the episode's
previous piece ended in: the state runs over the whole episode, as in the file, while the gradient
reaches back at most :data:`CHUNK` steps (truncated backpropagation through time), clipped to norm
:data:`GRAD_CLIP`. Why pieces and not whole episodes (``chunk=0``, one update per episode, as the
first three runs of research/teacher_multimodal.md were fitted): with whole episodes a fit makes
a few dozen updates per epoch and is still far above what the network can fit after tens of epochs;
on one fixed data set of APF's labels (``research/diag_fit.py``, the fourth run there) the GRU fitted in
pieces of 64 steps reaches in 12 epochs the held-out cross-entropy on APF's own trajectories that the
whole-episode fit reaches in 30 (0.42 nats), and on the student's trajectories 1.46 nats against its 2.46.

**A categorical head** (``classes``, the file's ``"head"``: :mod:`tin_swarm_env.policies.heads`):
the head gives one logit per class action, mirror-averaged with the mirrored stream's classes
permuted; the loss is the cross-entropy of the (averaged) logits against the class nearest to the
teacher's label (:func:`~tin_swarm_env.policies.heads.nearest_class`), i.e. the likelihood of the
teacher's choices under the policy that ships. A mean-squared-error fit of one action learns the
mean of labels that disagree ("left" on one map, "right" on another that looks the same); the
likelihood fit keeps both. ``cell=None``: no memory (the head reads the observation: an MLP
policy file), fitted the same way.

**Feedback** (``feedback="action"``, the file's ``"network.feedback"``): the GRU also reads the
action the file commanded at the robot's previous step (``(0, 0)`` at the first), so a sampled
side can be kept. ``forward(x, prev)`` takes it as ``prev (T, B, 2)``; :func:`fit_sequences`
builds it from :attr:`Sequence.driven <tin_swarm_env.training.imitation.Sequence>` shifted one step
(the command that drove step ``t - 1``; with a categorical head snapped to the nearest class, as the
file only ever commands a class: the teacher's actions in BC data are not classes). With ``signs``
the mirrored stream reads the mirrored previous action (``vy`` negated), so equivariance over whole
histories still holds exactly.

**An auxiliary output: the teacher's side** (``aux_weight`` > 0, with a cell). APF keeps in its memory
which side of a boundary it follows (:class:`~tin_swarm_env.policies.apf.BugMemory` ``side``: -1, 0, +1),
and that memory decides when it turns back; the action's likelihood only says what to do this step. A
student with ``aux_weight`` has a second, linear read-out of the GRU's output: 3 logits for the side the
teacher follows at that step (:attr:`Sequence.aux <tin_swarm_env.training.imitation.Sequence>`, recorded by
:func:`~tin_swarm_env.training.imitation.collect` from APF's memory), fitted by cross-entropy beside the
action, the loss per kept sample ``action loss + aux_weight * side cross-entropy``. The side must then be
linearly readable from the state the head reads, so the GRU is taught to carry it. With ``signs`` the
mirrored stream's side logits are taken in reverse order (the mirror swaps left and right), so the side
read-out is mirror-equivariant too. The read-out is not part of the policy file: :meth:`policy` and
:meth:`export` write the cell and the action head only, so the exported file acts exactly as the torch
student's action output (``tests/training/test_recurrent_imitation.py``); the auxiliary loss changes the
file only through the weights it trained. A sequence without ``aux`` (a teacher without that memory)
adds nothing to the loss.

**DAgger** drives with :meth:`GRUStudent.policy`, the numpy
:class:`~tin_swarm_env.policies.recurrent.RecurrentPolicy` built from the current weights: the
learner that collects is the file that ships (its memory reset with every episode), and the
teacher labels the states it visits (training/imitation.py).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, require

__all__ = ["GRUStudent", "fit_sequences", "sequence_loss", "previous_actions", "side_logits", "GRAD_CLIP", "CHUNK",
           "SIDES", "AUX_WEIGHT"]

GRAD_CLIP = 1.0  # the gradient norm each step of fit_sequences is clipped to
CHUNK = 64  # fit_sequences' default piece length, steps (module docstring; 0: whole episodes)
AUX_WEIGHT = 0.0  # GRUStudent's default aux_weight (read at the call; research/train_multimodal.py sets it per variant)
SIDES = (-1, 0, 1)  # the auxiliary read-out's classes, in logit order: the teacher's BugMemory.side


def _torch():
    return require("torch", "train", "The recurrent student")


def _check_student_args(obs_size, hidden, head, signs, obs_perm, cell, feedback, aux_weight) -> tuple[int, float]:
    """:func:`GRUStudent`'s arguments, each refused naming it; returns ``(n_fb, aux_weight)``: the
    feedback's inputs per step and the side read-out's weight (None: :data:`AUX_WEIGHT`, read now)."""
    if hidden < 1 or any(int(w) < 1 for w in head):
        raise ArgumentError(f"GRUStudent: hidden {hidden} and head widths {list(head)} must be positive")
    if signs is not None and len(signs) != obs_size:
        raise ArgumentError(f"GRUStudent: signs has {len(signs)} entries for {obs_size} observations")
    if obs_perm is not None and (signs is None or sorted(int(j) for j in obs_perm) != list(range(obs_size))):
        raise ArgumentError(f"GRUStudent: obs_perm must be a permutation of 0..{obs_size - 1}, with signs")
    if cell not in ("gru", None):
        raise ArgumentError(f"GRUStudent: cell must be 'gru' or None, got {cell!r}")
    from ..policies.recurrent import FEEDBACKS

    if feedback not in FEEDBACKS or (feedback != "none" and cell is None):
        raise ArgumentError(f"GRUStudent: feedback must be one of {list(FEEDBACKS)} (not 'none' only with a cell), "
                            f"got {feedback!r} with cell {cell!r}")
    aux_weight = AUX_WEIGHT if aux_weight is None else aux_weight
    if isinstance(aux_weight, bool) or not isinstance(aux_weight, (int, float)) or not np.isfinite(aux_weight) \
            or aux_weight < 0 or (aux_weight > 0 and cell is None):
        raise ArgumentError(f"GRUStudent: aux_weight must be a finite number >= 0 (> 0 only with a cell), got "
                            f"{aux_weight!r} with cell {cell!r}")
    return FEEDBACKS[feedback], aux_weight


class _StudentFiles:
    """What a :func:`GRUStudent` writes: its numpy policy and its policy directory (the torch module's
    weights as arrays), for a layout whose mirror map is the student's own."""

    def _check_layout(self, layout):
        """A mirror-equivariant student acts as its file only with the layout's own mirror map."""
        if self.signs is None:
            return
        from ..policies.symmetry import check_mirror_map

        check_mirror_map(layout, None if self.obs_perm is None else self.obs_perm.cpu().numpy(), self.signs,
                         "GRUStudent")

    def _arrays(self):
        linear = _torch().nn.Linear
        layers = [(m.weight.detach().double().numpy(), m.bias.detach().double().numpy()) for m in self.head
                  if isinstance(m, linear)]
        if self.gru is None:
            return None, layers
        g = {k: getattr(self.gru, f"{k}_l0").detach().double().numpy()
             for k in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")}
        cell = {"cell_W_ih": g["weight_ih"], "cell_W_hh": g["weight_hh"], "cell_b_ih": g["bias_ih"],
                "cell_b_hh": g["bias_hh"]}
        return cell, layers

    def policy(self, layout, *, shield: str = "none", env=None):
        """The numpy :class:`~tin_swarm_env.policies.recurrent.RecurrentPolicy` (an
        :class:`~tin_swarm_env.policies.MLPPolicy` without a cell) of the current weights (what
        :meth:`export` writes), for ``layout`` (an ObsLayout)."""
        from ..policies.learned import MLPPolicy
        from ..policies.recurrent import RecurrentPolicy

        self._check_layout(layout)
        cell, layers = self._arrays()
        sym = "none" if self.signs is None else "mirror"
        if cell is None:
            return MLPPolicy(layers, "tanh", layout=layout.to_dict(), shield=shield, env=env, symmetry=sym,
                             source="<GRUStudent>", head=self.head_entry)
        return RecurrentPolicy("gru", cell, layers, "tanh", layout=layout.to_dict(), shield=shield, env=env,
                               symmetry=sym, source="<GRUStudent>", head=self.head_entry, feedback=self.feedback)

    def export(self, path, layout, *, scenario: str = "", shield: str = "none", extra: dict | None = None):
        """Write the recurrent policy directory ``path`` (:func:`~tin_swarm_env.policies.save_policy`)."""
        from ..policies.learned import save_policy

        self._check_layout(layout)
        cell, layers = self._arrays()
        return save_policy(path, layers, "tanh", layout=layout, scenario=scenario, extra=extra, shield=shield,
                           symmetry="none" if self.signs is None else "mirror",
                           cell=None if cell is None else ("gru", cell), head=self.head_entry,
                           feedback=self.feedback)


def GRUStudent(obs_size: int, hidden: int = 64, head=(64,), signs=None, seed: int = 0, *, classes=None,
               cell: str | None = "gru", acting: str = "mode", feedback: str = "none", aux_weight: float | None = None,
               obs_perm=None):
    """A fresh student (module docstring): ``obs_size`` inputs, a GRU of ``hidden`` units, a head of
    hidden widths ``head`` then 2 outputs; ``signs`` ``(obs_size,)`` (the layout's mirror signs):
    mirror-equivariant, the mirror image of ``x`` being ``x[..., obs_perm] * signs`` (``obs_perm, signs =
    mirror_map(layout)``, :func:`~tin_swarm_env.policies.symmetry.mirror_map`; ``obs_perm`` None: the
    identity, a layout without scan beams). Weights drawn from ``torch.manual_seed(seed)``. A ``torch.nn.Module`` with
    ``forward(x (T, B, d)) -> (T, B, 2)`` (the head's output before the clip, every step from a
    zero state), :meth:`policy` and :meth:`export`. ``classes`` ``(K, 2)`` (e.g.
    :func:`~tin_swarm_env.policies.heads.categorical_classes`): a categorical head, ``forward``
    gives ``(T, B, K)`` logits and the file acts by ``acting``; ``cell=None``: no GRU (an MLP);
    ``feedback="action"``: the GRU also reads the previous commanded action (module docstring);
    ``aux_weight`` > 0 (needs a cell): the side read-out and its weight in the loss (module docstring; None:
    :data:`AUX_WEIGHT`, read at the call)."""
    torch = _torch()
    nn = torch.nn
    from ..env.observation import ACTION_PARITY

    n_fb, aux_weight = _check_student_args(obs_size, hidden, head, signs, obs_perm, cell, feedback, aux_weight)
    from ..policies.heads import categorical_head, mirror_permutation

    head_entry = None if classes is None else categorical_head(classes, acting)
    n_out = 2 if classes is None else len(classes)
    perm = None
    if classes is not None and signs is not None:
        perm = mirror_permutation(classes)
        if perm is None:
            raise ArgumentError("GRUStudent: classes are not closed under the mirror (vy -> -vy)")

    class _Student(_StudentFiles, nn.Module):
        def __init__(self):
            super().__init__()
            torch.manual_seed(seed)
            self.gru = nn.GRU(obs_size + n_fb, hidden, num_layers=1) if cell else None
            self.feedback = feedback
            self.classes = None if classes is None else np.asarray(classes, dtype=np.float64)
            self.head_entry = head_entry
            widths = [hidden if cell else obs_size, *[int(w) for w in head], n_out]
            mods = []
            for i in range(len(widths) - 1):
                mods.append(nn.Linear(widths[i], widths[i + 1]))
                if i < len(widths) - 2:
                    mods.append(nn.Tanh())
            self.head = nn.Sequential(*mods)
            self.aux_weight = float(aux_weight)
            self.aux = nn.Linear(hidden, len(SIDES)) if aux_weight > 0 else None  # the side read-out (not exported)
            self.signs = None if signs is None else [float(s) for s in signs]
            self.register_buffer("_signs", torch.tensor(np.ones(obs_size) if signs is None else np.array(signs),
                                                        dtype=torch.float32))
            self.register_buffer("_parity", torch.as_tensor(ACTION_PARITY, dtype=torch.float32))
            self.perm = None if perm is None else torch.as_tensor(perm)
            self.register_buffer("obs_perm", None if obs_perm is None else
                                 torch.as_tensor([int(j) for j in obs_perm], dtype=torch.long))

        def _net(self, x, h0=None):
            if self.gru is None:
                return self.head(x), None, None
            y, h = self.gru(x, h0)
            return self.head(y), None if self.aux is None else self.aux(y), h

        def forward(self, x, prev=None):
            return self.forward_state(x, prev)[0]

        def forward_state(self, x, prev=None, h0=None):
            """``forward`` from the cell state ``h0`` (None: zero; else what a previous call returned),
            and the state after the last step: ``(outputs, h)`` (``h`` None without a cell). Feeding
            an episode's steps in pieces, each from the last one's state, gives ``forward`` of the
            whole episode (truncated backpropagation: :func:`fit_sequences`'s ``chunk``)."""
            out, _, h = self.forward_aux(x, prev, h0)
            return out, h

        def forward_aux(self, x, prev=None, h0=None):
            """:meth:`forward_state` with the side read-out: ``(outputs, side_logits, h)``,
            ``side_logits`` ``(T, B, 3)`` in :data:`SIDES` order (None without ``aux_weight``)."""
            x = torch.as_tensor(x, dtype=torch.float32)
            if n_fb:
                if prev is None:
                    raise ArgumentError("GRUStudent: feedback 'action' needs prev (T, B, 2), the previous actions")
                prev = torch.as_tensor(prev, dtype=torch.float32)
            if self.signs is None:
                return self._net(torch.cat([x, prev], dim=-1) if n_fb else x, h0)
            b = x.shape[1]
            xm = x if self.obs_perm is None else x[..., self.obs_perm]
            xx = torch.cat([x, xm * self._signs], dim=1)
            if n_fb:
                xx = torch.cat([xx, torch.cat([prev, prev * self._parity], dim=1)], dim=-1)
            out, z, h = self._net(xx, h0)
            if z is not None:  # the mirror swaps the sides: the mirrored stream's logits in reverse order
                z = (z[:, :b] + z[:, b:].flip(-1)) / 2
            if self.perm is not None:
                return (out[:, :b] + out[:, b:][..., self.perm]) / 2, z, h
            return (out[:, :b] + out[:, b:] * self._parity) / 2, z, h

    return _Student()


def previous_actions(q, T: int, classes=None) -> np.ndarray:
    """``(T, n, 2)`` float32: the feedback of a :class:`~tin_swarm_env.training.imitation.Sequence`'s
    first ``T`` steps, ``q.driven`` shifted one step (zero at step 0), clipped to [-1, 1] and, with
    ``classes``, snapped to the nearest class action (module docstring)."""
    if q.driven is None:
        raise ArgumentError("fit_sequences: a student with feedback needs sequences that record 'driven' "
                            "(collect(..., sequences=True))")
    d = np.clip(np.asarray(q.driven[:T - 1], dtype=np.float64), -1.0, 1.0)
    if classes is not None and d.size:
        from ..policies.heads import nearest_class

        d = np.asarray(classes)[nearest_class(d.reshape(-1, 2), classes)].reshape(d.shape)
    out = np.zeros((T, *q.driven.shape[1:]), dtype=np.float32)
    out[1:] = d
    return out


def _aux_target(q):
    """``q.aux`` as class indices into :data:`SIDES` (``(T, n)`` int64), checked; None if not recorded."""
    a = getattr(q, "aux", None)
    if a is None:
        return None
    a = np.asarray(a)
    if a.shape != q.keep.shape or not np.isin(a, SIDES).all():
        raise ArgumentError(f"fit_sequences: a sequence's aux must be ({q.keep.shape}) sides in {list(SIDES)}, "
                            f"got shape {a.shape} with values {np.unique(a)[:5].tolist()}")
    return a.astype(np.int64) + 1


def sequence_loss(student, q, T: int | None = None, h0=None, start: int = 0, parts: bool = False):
    """The per-sample loss of ``student`` on steps ``start .. start + T`` of a
    :class:`~tin_swarm_env.training.imitation.Sequence` from the cell state ``h0``: ``(err, h)``, ``err`` the
    kept samples' losses (squared error over the 2 components / 2, or the cross-entropy of the class
    nearest the label; with the side read-out and ``q.aux``, plus ``aux_weight`` times the side's
    cross-entropy) in step-robot order, ``h`` the state after the last step. ``parts``: ``(act, side,
    h)`` instead, the action's loss and the side's cross-entropy (None without read-out or ``q.aux``)."""
    torch = _torch()
    stop = len(q.obs) if T is None else min(start + T, len(q.obs))
    classes = getattr(student, "classes", None)
    x = torch.as_tensor(q.obs[start:stop])
    k = torch.as_tensor(q.keep[start:stop])
    prev = None
    if getattr(student, "feedback", "none") != "none":
        prev = previous_actions(q, stop, classes)[start:stop]
    if hasattr(student, "forward_aux"):
        out, z, h = student.forward_aux(x, prev, h0)
    else:
        (out, h), z = student.forward_state(x, prev, h0), None
    if classes is None:
        y = torch.as_tensor(np.clip(q.labels[start:stop], -1.0, 1.0))
        err = ((out - y) ** 2).sum(-1)[k] / 2  # the mean over the 2 components, as fit_actor's
    else:
        from ..policies.heads import nearest_class

        y = torch.as_tensor(nearest_class(q.labels[start:stop][q.keep[start:stop]], classes))
        err = torch.nn.functional.cross_entropy(out[k], y, reduction="none")
    side = None
    target = None if z is None else _aux_target(q)
    if target is not None:
        side = torch.nn.functional.cross_entropy(z[k], torch.as_tensor(target[start:stop][q.keep[start:stop]]),
                                                 reduction="none")
    if parts:
        return err, side, h
    return (err if side is None else err + student.aux_weight * side), h


def side_logits(student, q) -> np.ndarray:
    """``(T, n, 3)`` float64: ``student``'s side read-out (:data:`SIDES` order) over the whole
    :class:`~tin_swarm_env.training.imitation.Sequence` ``q`` from a zero state (every step, kept or not)."""
    torch = _torch()
    if getattr(student, "aux", None) is None:
        raise ArgumentError("side_logits: the student has no side read-out (GRUStudent(aux_weight=...) > 0)")
    prev = None
    if student.feedback != "none":
        prev = previous_actions(q, len(q.obs), student.classes)
    with torch.no_grad():
        return student.forward_aux(torch.as_tensor(q.obs), prev)[1].double().numpy()


def fit_sequences(student, sequences, *, epochs: int = 10, lr: float = 1e-3, seed: int = 0,
                  chunk: int | None = None, callback=None) -> float:
    """Fit ``student`` (:func:`GRUStudent`) to the teacher's labels of ``sequences``
    (:class:`~tin_swarm_env.training.imitation.Sequence`; module docstring): Adam, episodes shuffled each
    epoch. ``chunk`` None: :data:`CHUNK` (read at the call); 0: one step per episode, the gradient
    through the whole episode; > 0 (truncated backpropagation): the episode's steps in consecutive
    pieces of ``chunk`` steps, one Adam step per piece that holds a kept sample, each piece started
    from the state the previous one ended in (detached), so the state runs over the whole episode as
    in the file while the gradient reaches back at most ``chunk`` steps (without a cell: minibatches
    of ``chunk`` steps). ``callback(epoch, loss)``: called after each epoch. Returns the last
    epoch's mean squared error per kept sample (with a categorical head: the mean cross-entropy,
    nats per kept sample)."""
    torch = _torch()
    chunk = CHUNK if chunk is None else chunk
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 0:
        raise ArgumentError(f"fit_sequences: chunk must be an integer >= 0 (0: whole episodes), got {chunk!r}")
    seqs = [q for q in sequences if q.keep.any()]
    if not seqs:
        raise ArgumentError("fit_sequences: no kept sample in the sequences (every robot ended or stalled at once)")
    opt = torch.optim.Adam(student.parameters(), lr=lr)
    rng = np.random.default_rng(seed)
    last = float("nan")
    student.train()
    for ep in range(max(int(epochs), 0)):
        tot, cnt = 0.0, 0
        for i in rng.permutation(len(seqs)):
            q = seqs[i]
            T = int(np.flatnonzero(q.keep.any(axis=1)).max()) + 1  # nothing after the last kept step is needed
            step = T if chunk == 0 else int(chunk)
            h = None
            for s in range(0, T, step):
                n = min(step, T - s)
                if not q.keep[s:s + n].any():  # nothing to learn here: only carry the state on
                    with torch.no_grad():
                        h = sequence_loss(student, q, n, h, s)[1]
                    continue
                err, h = sequence_loss(student, q, n, h, s)
                loss = err.mean()
                opt.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(student.parameters(), GRAD_CLIP)
                opt.step()
                h = None if h is None else h.detach()
                tot += float(err.detach().sum())
                cnt += len(err)
        last = tot / max(cnt, 1)
        if callback is not None:
            callback(ep, last)
    student.eval()
    return last
