"""Imitation into a recurrent student: a GRU (torch, one layer) before an MLP head, fitted by BC
and DAgger on whole episodes per robot, and exported as a recurrent policy file.

    demos = collect(scen, 20, seed, teacher="geodesic", sequences=True)     # apps/imitation.py
    student = GRUStudent(layout.size, hidden=64, head=(64,), signs=layout.mirror_signs())
    fit_sequences(student, demos.sequences)                                  # BC on whole episodes
    demos += collect(..., learner=student.policy(layout), sequences=True)   # DAgger: the numpy file drives
    student.export("runs/gru/policy", layout, scenario="generated")          # policies/recurrent.py

``tin-swarm train --student gru`` runs it (:func:`~tin_swarm_env.apps.train.train_student`).

**The network** is the recurrent policy file's (:mod:`tin_swarm_env.policies.recurrent`, cell
``"gru"``): ``torch.nn.GRU`` with one layer (its weights in torch's layout are the file's
``cell_*`` arrays, gates reset, update, new), then ``Linear``-``tanh``-...-``Linear`` to the two
action components, the deterministic action ``clip(head(h), -1, 1)``. With ``signs`` (the
layout's mirror signs) it is the file's ``"symmetry": "mirror"``: two streams per robot through
the same cell, one fed the observations and one their mirror images, their head outputs averaged
with ``vy`` of the mirrored one negated, so the student is mirror-equivariant over whole histories.

**Memory per robot, as in the file.** A robot's hidden state starts at zero at the episode's first
step and runs over every step of the episode (:class:`~tin_swarm_env.apps.imitation.Sequence`);
the loss is the mean squared error of the head's output (before the clip) against the teacher's
label clipped to [-1, 1], over the kept steps only (live and not stalled). Gradients flow back
through the whole episode (no truncation: episodes are at most ``max_cycles`` steps), clipped to
norm :data:`GRAD_CLIP`; each minibatch is one episode (all its robots).

**A categorical head** (``classes``, the file's ``"head"``: :mod:`tin_swarm_env.policies.heads`):
the head gives one logit per class action, mirror-averaged with the mirrored stream's classes
permuted; the loss is the cross-entropy of the (averaged) logits against the class nearest to the
teacher's label (:func:`~tin_swarm_env.policies.heads.nearest_class`), i.e. the likelihood of the
teacher's choices under the policy that ships. A mean-squared-error fit of one action learns the
mean of labels that disagree ("left" on one map, "right" on another that looks the same); the
likelihood fit keeps both. ``cell=None``: no memory (the head reads the observation: an MLP
policy file), fitted the same way.

**DAgger** drives with :meth:`GRUStudent.policy`, the numpy
:class:`~tin_swarm_env.policies.recurrent.RecurrentPolicy` built from the current weights: the
learner that collects is the file that ships (its memory reset with every episode), and the
teacher labels the states it visits (apps/imitation.py).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, require

__all__ = ["GRUStudent", "fit_sequences", "GRAD_CLIP"]

GRAD_CLIP = 1.0  # the gradient norm each step of fit_sequences is clipped to


def _torch():
    return require("torch", "train", "The recurrent student")


def GRUStudent(obs_size: int, hidden: int = 64, head=(64,), signs=None, seed: int = 0, *, classes=None,
               cell: str | None = "gru", acting: str = "mode"):
    """A fresh student (module docstring): ``obs_size`` inputs, a GRU of ``hidden`` units, a head of
    hidden widths ``head`` then 2 outputs; ``signs`` ``(obs_size,)`` (the layout's mirror signs):
    mirror-equivariant. Weights drawn from ``torch.manual_seed(seed)``. A ``torch.nn.Module`` with
    ``forward(x (T, B, d)) -> (T, B, 2)`` (the head's output before the clip, every step from a
    zero state), :meth:`policy` and :meth:`export`. ``classes`` ``(K, 2)`` (e.g.
    :func:`~tin_swarm_env.policies.heads.categorical_classes`): a categorical head, ``forward``
    gives ``(T, B, K)`` logits and the file acts by ``acting``; ``cell=None``: no GRU (an MLP)."""
    torch = _torch()
    nn = torch.nn
    from ..env.observation import ACTION_PARITY

    if hidden < 1 or any(int(w) < 1 for w in head):
        raise ArgumentError(f"GRUStudent: hidden {hidden} and head widths {list(head)} must be positive")
    if signs is not None and len(signs) != obs_size:
        raise ArgumentError(f"GRUStudent: signs has {len(signs)} entries for {obs_size} observations")
    if cell not in ("gru", None):
        raise ArgumentError(f"GRUStudent: cell must be 'gru' or None, got {cell!r}")
    from ..policies.heads import categorical_head, mirror_permutation

    head_entry = None if classes is None else categorical_head(classes, acting)
    n_out = 2 if classes is None else len(classes)
    perm = None
    if classes is not None and signs is not None:
        perm = mirror_permutation(classes)
        if perm is None:
            raise ArgumentError("GRUStudent: classes are not closed under the mirror (vy -> -vy)")

    class _Student(nn.Module):
        def __init__(self):
            super().__init__()
            torch.manual_seed(seed)
            self.gru = nn.GRU(obs_size, hidden, num_layers=1) if cell else None
            self.classes = None if classes is None else np.asarray(classes, dtype=np.float64)
            self.head_entry = head_entry
            widths = [hidden if cell else obs_size, *[int(w) for w in head], n_out]
            mods = []
            for i in range(len(widths) - 1):
                mods.append(nn.Linear(widths[i], widths[i + 1]))
                if i < len(widths) - 2:
                    mods.append(nn.Tanh())
            self.head = nn.Sequential(*mods)
            self.signs = None if signs is None else [float(s) for s in signs]
            self.register_buffer("_signs", torch.tensor(np.ones(obs_size) if signs is None else np.array(signs),
                                                        dtype=torch.float32))
            self.register_buffer("_parity", torch.as_tensor(ACTION_PARITY, dtype=torch.float32))
            self.perm = None if perm is None else torch.as_tensor(perm)

        def _net(self, x):
            return self.head(self.gru(x)[0] if self.gru is not None else x)

        def forward(self, x):
            x = torch.as_tensor(x, dtype=torch.float32)
            if self.signs is None:
                return self._net(x)
            b = x.shape[1]
            out = self._net(torch.cat([x, x * self._signs], dim=1))
            if self.perm is not None:
                return (out[:, :b] + out[:, b:][..., self.perm]) / 2
            return (out[:, :b] + out[:, b:] * self._parity) / 2

        def _arrays(self):
            layers = [(m.weight.detach().double().numpy(), m.bias.detach().double().numpy()) for m in self.head
                      if isinstance(m, nn.Linear)]
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

            cell, layers = self._arrays()
            sym = "none" if self.signs is None else "mirror"
            if cell is None:
                return MLPPolicy(layers, "tanh", layout=layout.to_dict(), shield=shield, env=env, symmetry=sym,
                                 source="<GRUStudent>", head=self.head_entry)
            return RecurrentPolicy("gru", cell, layers, "tanh", layout=layout.to_dict(), shield=shield, env=env,
                                   symmetry=sym, source="<GRUStudent>", head=self.head_entry)

        def export(self, path, layout, *, scenario: str = "", shield: str = "none", extra: dict | None = None):
            """Write the recurrent policy directory ``path`` (:func:`~tin_swarm_env.policies.save_policy`)."""
            from ..policies.learned import save_policy

            cell, layers = self._arrays()
            return save_policy(path, layers, "tanh", layout=layout, scenario=scenario, extra=extra, shield=shield,
                               symmetry="none" if self.signs is None else "mirror",
                               cell=None if cell is None else ("gru", cell), head=self.head_entry)

    return _Student()


def fit_sequences(student, sequences, *, epochs: int = 10, lr: float = 1e-3, seed: int = 0) -> float:
    """Fit ``student`` (:func:`GRUStudent`) to the teacher's labels of ``sequences``
    (:class:`~tin_swarm_env.apps.imitation.Sequence`; module docstring): Adam, one episode per step,
    episodes shuffled each epoch. Returns the last epoch's mean squared error per kept sample (with
    a categorical head: the mean cross-entropy, nats per kept sample)."""
    torch = _torch()
    seqs = [q for q in sequences if q.keep.any()]
    if not seqs:
        raise ArgumentError("fit_sequences: no kept sample in the sequences (every robot ended or stalled at once)")
    classes = getattr(student, "classes", None)
    if classes is not None:
        from ..policies.heads import nearest_class
    opt = torch.optim.Adam(student.parameters(), lr=lr)
    rng = np.random.default_rng(seed)
    last = float("nan")
    student.train()
    for _ in range(max(int(epochs), 0)):
        tot, cnt = 0.0, 0
        for i in rng.permutation(len(seqs)):
            q = seqs[i]
            T = int(np.flatnonzero(q.keep.any(axis=1)).max()) + 1  # nothing after the last kept step is needed
            x = torch.as_tensor(q.obs[:T])
            k = torch.as_tensor(q.keep[:T])
            if classes is None:
                y = torch.as_tensor(np.clip(q.labels[:T], -1.0, 1.0))
                err = ((student(x) - y) ** 2).sum(-1)[k] / 2  # the mean over the 2 components, as fit_actor's MSE
            else:
                lab = q.labels[:T][q.keep[:T]]
                y = torch.as_tensor(nearest_class(lab, classes))
                err = torch.nn.functional.cross_entropy(student(x)[k], y, reduction="none")
            loss = err.mean()
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(student.parameters(), GRAD_CLIP)
            opt.step()
            tot += float(err.detach().sum())
            cnt += int(k.sum())
        last = tot / max(cnt, 1)
    student.eval()
    return last

