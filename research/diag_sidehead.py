"""Does a head that reads the side help? (research/teacher_multimodal.md, fifth run, "Next".) On the fixed
data set of research/diag_fit.py: a GRU whose action head also reads a side (one-hot over -1, 0, +1), fitted with
APF's side given (teacher forcing: ``Sequence.aux``) beside the side read-out's cross-entropy, and acting with the
read-out's own side (its argmax) in closed loop; against diag_fit's ``gru_aux1`` (the read-out fitted, the head
reading the GRU alone) and ``gru_chunk`` (no read-out). Each fitted student then drives ``--seeds`` held-out
episodes of each ``--drive`` scenario to their end, acting by the mode through the shield, labelled by
``apf_student``: the robots' arrival and :func:`diag_fit.side_stats` along their own way. Torch on 1 thread.

    python research/diag_sidehead.py --data runs/fitdiag6/data.npz --drive gen_canyon.toml,gen_mesa.toml --seeds 3

Not a policy file: the side-reading head is an experiment (the file format has no such input).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import diag_fit  # noqa: E402


def SideHeadGRU(obs_size: int, signs, classes, hidden: int = 64, width: int = 64, seed: int = 0,
                aux_weight: float = 1.0):
    """The GRU (reading the observation and the previous action) with a side read-out and an action head
    reading ``[GRU output, one-hot side]``, mirror-equivariant: the mirrored stream reads the mirrored
    observation, previous action and side (one-hot reversed); logits averaged with the classes permuted.
    ``forward_aux(x, prev, h0=None, side=None)`` -> ``(logits, side_logits, h)``; ``side`` ``(T, B)`` in
    -1/0/+1: the side the head reads (teacher forcing); None: the read-out's argmax."""
    import torch
    from torch import nn

    from tin_swarm_env.env.observation import ACTION_PARITY
    from tin_swarm_env.policies.heads import mirror_permutation

    class _M(nn.Module):
        def __init__(self):
            super().__init__()
            torch.manual_seed(seed)
            self.gru = nn.GRU(obs_size + 2, hidden)
            self.aux = nn.Linear(hidden, 3)
            self.head = nn.Sequential(nn.Linear(hidden + 3, width), nn.Tanh(), nn.Linear(width, len(classes)))
            self.classes = np.asarray(classes, dtype=np.float64)
            self.feedback = "action"
            self.aux_weight = aux_weight
            self.register_buffer("_signs", torch.tensor(np.array(signs, dtype=np.float32)))
            self.register_buffer("_parity", torch.as_tensor(ACTION_PARITY, dtype=torch.float32))
            self.perm = torch.as_tensor(mirror_permutation(classes))

        def forward_aux(self, x, prev, h0=None, side=None):
            x = torch.as_tensor(x, dtype=torch.float32)
            prev = torch.as_tensor(prev, dtype=torch.float32)
            b = x.shape[1]
            xx = torch.cat([torch.cat([x, x * self._signs], 1), torch.cat([prev, prev * self._parity], 1)], -1)
            y, h = self.gru(xx, h0)
            z = self.aux(y)
            z = (z[:, :b] + z[:, b:].flip(-1)) / 2
            idx = z.argmax(-1) if side is None else torch.as_tensor(np.asarray(side), dtype=torch.int64) + 1
            s = nn.functional.one_hot(idx, 3).float()
            out = self.head(torch.cat([y, torch.cat([s, s.flip(-1)], 1)], -1))
            return (out[:, :b] + out[:, b:][..., self.perm]) / 2, z, h

    return _M()


def fit_sidehead(model, seqs, epochs: int, lr: float = 1e-3, chunk: int = 64, seed: int = 0, log=print) -> float:
    """fit_sequences' truncated fit (pieces of ``chunk`` steps, the state carried), the head reading APF's side."""
    import torch

    from tin_swarm_env.policies.heads import nearest_class
    from tin_swarm_env.training.recurrent_imitation import GRAD_CLIP, previous_actions

    opt = torch.optim.Adam(model.parameters(), lr=lr)
    rng = np.random.default_rng(seed)
    ce = torch.nn.functional.cross_entropy
    last = float("nan")
    for ep in range(epochs):
        tot, cnt = 0.0, 0
        for i in rng.permutation(len(seqs)):
            q = seqs[i]
            T = int(np.flatnonzero(q.keep.any(axis=1)).max()) + 1
            prev = previous_actions(q, T, model.classes)
            h = None
            for s in range(0, T, chunk):
                e = min(s + chunk, T)
                k = q.keep[s:e]
                if not k.any():
                    with torch.no_grad():
                        h = model.forward_aux(q.obs[s:e], prev[s:e], h, q.aux[s:e])[2]
                    continue
                out, z, h = model.forward_aux(q.obs[s:e], prev[s:e], h, q.aux[s:e])
                kt = torch.as_tensor(k)
                y = torch.as_tensor(nearest_class(q.labels[s:e][k], model.classes))
                err = ce(out[kt], y, reduction="none") + model.aux_weight * ce(
                    z[kt], torch.as_tensor(q.aux[s:e][k].astype(np.int64) + 1), reduction="none")
                opt.zero_grad()
                err.mean().backward()
                torch.nn.utils.clip_grad_norm_(model.parameters(), GRAD_CLIP)
                opt.step()
                h = h.detach()
                tot += float(err.detach().sum())
                cnt += len(err)
        last = tot / max(cnt, 1)
        if (ep + 1) % 10 == 0:
            log(f"sidehead epoch {ep + 1}: train {last:.3f}")
    return last


class TorchLearner:
    """A torch student acting by the mode, its GRU state and previous command carried per robot (``reset`` at
    each episode): ``act_batch(obs (n, d)) -> (n, 2)`` class actions (the learner of ``collect``)."""

    def __init__(self, model):
        self.model = model
        self.reset()

    def reset(self):
        self.h, self.prev = None, None

    def act_batch(self, obs):
        import torch

        obs = np.asarray(obs, dtype=np.float32)
        prev = np.zeros((len(obs), 2), np.float32) if self.prev is None else self.prev
        with torch.no_grad():
            out, _, self.h = self.model.forward_aux(obs[None], prev[None], self.h)
        self.prev = self.model.classes[out[0].numpy().argmax(-1)].astype(np.float32)
        return self.prev


def main(argv=None) -> None:
    import torch

    from tin_swarm_env.env import parallel_env
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.evaluation import EVAL_SEED0
    from tin_swarm_env.training.imitation import collect
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="runs/fitdiag6/data.npz")
    ap.add_argument("--drive", required=True, help="scenarios, comma-separated")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--variants", default="sidehead,gru_aux1,gru_chunk")
    a = ap.parse_args(argv)
    torch.set_num_threads(1)
    data = diag_fit.load_sequences(a.data)
    train = list(data["train_bc"]) + list(data["train_dag"])
    layout = parallel_env(scenario="generated", n_robots=8).layout
    classes = categorical_classes()
    for name in a.variants.split(","):
        t0 = time.perf_counter()
        if name == "sidehead":
            st = SideHeadGRU(layout.size, layout.mirror_signs(), classes)
            fit_sidehead(st, train, a.epochs)
        else:
            v = diag_fit.VARIANTS[name]
            st = GRUStudent(layout.size, v["hidden"], v["head"], signs=layout.mirror_signs(), classes=classes,
                            feedback="action", aux_weight=v.get("aux_weight", 0.0))
            fit_sequences(st, train, epochs=a.epochs, lr=v["lr"], chunk=v["chunk"])
        st.eval()
        for g in ("val_bc", "val_dag"):
            s = diag_fit.side_stats(st, data[g])
            print(f"{name} {g} (read-out's side to the head): " + ", ".join(f"{k} {x:.3f}" for k, x in s.items()),
                  flush=True)
        print(f"{name}: fitted in {time.perf_counter() - t0:.0f} s", flush=True)
        for scen in [x for x in a.drive.split(",") if x]:
            d = collect(scen, a.seeds, EVAL_SEED0, learner=TorchLearner(st), teacher="apf_student",
                        shield="safety_cut", sequences=True)
            s = diag_fit.side_stats(st, list(d.sequences))
            print(f"{name} drives {scen}: arrived {d.arrived:.3f}, fell {d.fell:.3f}; "
                  + ", ".join(f"{k} {x:.3f}" for k, x in s.items()) + f" ({time.perf_counter() - t0:.0f} s)",
                  flush=True)


if __name__ == "__main__":
    main()
