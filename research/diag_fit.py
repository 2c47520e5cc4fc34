"""Why the GRU student underfits APF's labels (research/teacher_multimodal.md, "Fourth run"): small
fits of the students of research/train_multimodal.py on one fixed data set, each until its loss stops
falling, with the cross-entropy on held-out episodes after every epoch.

    python research/diag_fit.py collect --out runs/fitdiag/data.npz      # once: the fixed data set
    python research/diag_fit.py fit --data runs/fitdiag/data.npz --variants gru,gru_chunk,mlp --epochs 30

``collect``: the recipe's scenarios (``generated, generated, cliff_goal, ramp``, 8 robots), labelled by
``apf_student`` (tin_swarm_env/training/apf_teacher.py): ``--bc`` episodes APF drove (as BC) and ``--dagger``
episodes a categorical MLP student drove by a seeded draw (the states DAgger adds; the student is fitted
first on the BC episodes, ``--student-epochs``), then ``--val`` more of each on other seeds, held out. The
file is a plain ``.npz`` (no pickle): per episode ``<split>_<kind>_<k>_<field>``, the fields of
:class:`~tin_swarm_env.training.imitation.Sequence`.

``fit``: each variant (:data:`VARIANTS`: the network, learning rate, and ``chunk``, the truncated
backpropagation of :func:`~tin_swarm_env.training.recurrent_imitation.fit_sequences`) is fitted on the
training episodes from the same seed; after every epoch it prints the training loss (the epoch's running
mean, as ``fit_sequences`` returns it) and the held-out cross-entropy on APF's own trajectories (``val_bc``)
and on the student's (``val_dag``), and at the end the held-out cross-entropy split by where the label's
side (sign of ``vy`` of its class) changes within ``--near`` steps (``near switch``) or not. Torch on
1 thread.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

SCENARIOS = ["generated", "generated", "cliff_goal", "ramp"]
FIELDS = ("obs", "labels", "keep", "live", "driven", "aux")  # aux: absent from a file written before it
VARIANTS = {  # name -> GRUStudent / fit options (train_multimodal.py: gru_apf is "gru", mlp_apf "mlp")
    "mlp": dict(cell=None, hidden=64, head=(128, 128), lr=1e-3, chunk=0),
    "gru": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=0),
    "gru_lr3": dict(cell="gru", hidden=64, head=(64,), lr=3e-3, chunk=0),
    "gru_big": dict(cell="gru", hidden=128, head=(128, 128), lr=1e-3, chunk=0),
    "gru_chunk": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=64),
    "gru_big_chunk": dict(cell="gru", hidden=128, head=(128, 128), lr=1e-3, chunk=64),
    "mlp_chunk": dict(cell=None, hidden=64, head=(128, 128), lr=1e-3, chunk=64),
    "gru_nofb_chunk": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=64, feedback="none"),
    # session 27: APF's side (BugMemory.side) as an auxiliary output of the GRU (recurrent_imitation.py)
    "gru_aux03": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=64, aux_weight=0.3),
    "gru_aux1": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=64, aux_weight=1.0),
    "gru_aux3": dict(cell="gru", hidden=64, head=(64,), lr=1e-3, chunk=64, aux_weight=3.0),
}


def save_sequences(path: Path, groups: dict) -> None:
    """``groups``: ``{"train_bc": [Sequence, ...], ...}`` -> one ``.npz`` (module docstring)."""
    arrays = {}
    for g, seqs in groups.items():
        for k, q in enumerate(seqs):
            for f in FIELDS:
                if getattr(q, f) is not None:
                    arrays[f"{g}_{k}_{f}"] = getattr(q, f)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **arrays)
    tmp.replace(path)


def load_sequences(path) -> dict:
    from tin_swarm_env.training.imitation import Sequence

    z = np.load(path, allow_pickle=False)
    groups: dict = {}
    for key in z.files:
        g, k, f = key.rsplit("_", 2)
        groups.setdefault(g, {}).setdefault(int(k), {})[f] = z[key]
    return {g: [Sequence(**d[k]) for k in sorted(d)] for g, d in groups.items()}


def collect_cmd(a) -> None:
    import torch

    from tin_swarm_env.env import parallel_env
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.imitation import collect
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    kw = dict(n_robots=8, teacher="apf_student", shield="safety_cut", sequences=True, gamma=0.995)
    layout = parallel_env(scenario="generated", n_robots=8).layout
    bc = collect(SCENARIOS, a.bc + a.val, 0, **kw)
    print(f"BC: {bc.episodes} episodes, APF arrived {bc.arrived:.0%} ({time.perf_counter() - t0:.0f} s)", flush=True)
    st = GRUStudent(layout.size, 64, (128, 128), signs=layout.mirror_signs(), classes=categorical_classes(),
                    cell=None, acting="sample")
    ce = fit_sequences(st, bc.sequences[:a.bc], epochs=a.student_epochs)
    print(f"the driving MLP: cross-entropy {ce:.3f} ({time.perf_counter() - t0:.0f} s)", flush=True)
    dag = collect(SCENARIOS, a.dagger + a.val, 500, learner=st.policy(layout), **kw)
    print(f"DAgger: {dag.episodes} episodes, the student arrived {dag.arrived:.0%} ({time.perf_counter() - t0:.0f} s)",
          flush=True)
    save_sequences(Path(a.out), {"train_bc": bc.sequences[:a.bc], "val_bc": bc.sequences[a.bc:],
                                 "train_dag": dag.sequences[:a.dagger], "val_dag": dag.sequences[a.dagger:]})
    print(f"wrote {a.out}")


def held_out(student, seqs, near: int = 0) -> tuple[float, float, float, float]:
    """Mean cross-entropy of the action (not the side read-out's) over the kept samples of ``seqs``; and split
    by whether the label's side changes within ``near`` steps of the sample (nan without ``near``), and the
    share of samples near one."""
    import torch

    from tin_swarm_env.policies.heads import nearest_class
    from tin_swarm_env.training.recurrent_imitation import sequence_loss

    tot, cnt, sw, ns = 0.0, 0, [], []
    with torch.no_grad():
        for q in seqs:
            err = sequence_loss(student, q, parts=True)[0].numpy()  # the action's cross-entropy alone
            tot += float(err.sum())
            cnt += len(err)
            if near:
                c = student.classes[nearest_class(q.labels.reshape(-1, 2), student.classes)].reshape(q.labels.shape)
                side = np.sign(c[..., 1])  # (T, n)
                flip = np.zeros(side.shape, dtype=bool)
                for j in range(side.shape[1]):  # a change of side between consecutive non-zero sides
                    nz = np.flatnonzero(side[:, j] != 0)
                    ch = nz[1:][side[nz[1:], j] != side[nz[:-1], j]]
                    for t in ch:
                        flip[max(t - near, 0):t + near + 1, j] = True
                f = flip[q.keep]
                sw.append(err[f])
                ns.append(err[~f])
    if not near:
        return tot / max(cnt, 1), float("nan"), float("nan"), float("nan")
    sw, ns = np.concatenate(sw), np.concatenate(ns)
    return (tot / max(cnt, 1), float(sw.mean()) if len(sw) else float("nan"),
            float(ns.mean()) if len(ns) else float("nan"), len(sw) / max(len(sw) + len(ns), 1))


def flips(side: np.ndarray, keep: np.ndarray) -> int:
    """Changes of side along each robot's kept steps: ``side`` and ``keep`` ``(T, n)``; zeros (no side)
    are skipped, so + 0 + is no change and + 0 - is one."""
    out = 0
    for j in range(side.shape[1]):
        s = side[keep[:, j], j]
        s = s[s != 0]
        out += int((s[1:] != s[:-1]).sum())
    return out


def side_stats(student, seqs) -> dict:
    """How ``student`` keeps a side on ``seqs`` (fed the recorded observations, its state from zero):
    over the kept samples, the side read-out's accuracy against the teacher's side (``Sequence.aux``;
    all samples, those where the teacher follows a boundary, and those where it does not; nan without a
    read-out), the read-out's side flips and the teacher's per 100 kept robot-steps (:func:`flips`), and
    the flips of the side of the action head's mode (sign of ``vy`` of the likeliest class) and of the
    teacher's label (of its nearest class)."""
    import torch

    from tin_swarm_env.policies.heads import nearest_class
    from tin_swarm_env.training.recurrent_imitation import SIDES, previous_actions

    classes = student.classes
    acc, acc_f, acc_0, f_pred, f_true, f_mode, f_label, steps = 0, 0, 0, 0, 0, 0, 0, 0
    n_f = n_0 = n_all_f = 0
    for q in seqs:
        prev = previous_actions(q, len(q.obs), classes) if student.feedback != "none" else None
        with torch.no_grad():
            out, z, _ = student.forward_aux(torch.as_tensor(q.obs), prev)
        mode = np.sign(classes[out.numpy().argmax(-1)][..., 1])
        lab = np.sign(classes[nearest_class(q.labels.reshape(-1, 2), classes)][:, 1]).reshape(q.keep.shape)
        k = q.keep
        steps += int(k.sum())
        f_mode += flips(mode, k)
        f_label += flips(lab, k)
        if q.aux is not None:
            f_true += flips(q.aux, k)
            n_all_f += int(((q.aux != 0) & k).sum())
        if z is not None and q.aux is not None:
            pred = np.asarray(SIDES)[z.numpy().argmax(-1)]
            ok = (pred == q.aux) & k
            fol = (q.aux != 0) & k
            acc += int(ok.sum())
            acc_f += int((ok & fol).sum())
            acc_0 += int((ok & ~fol).sum())
            n_f += int(fol.sum())
            n_0 += int((k & ~fol).sum())
            f_pred += flips(pred, k)
    nan = float("nan")
    has = n_f + n_0 > 0
    return {"side acc": acc / steps if has else nan, "acc following": acc_f / max(n_f, 1) if has else nan,
            "acc not following": acc_0 / max(n_0, 1) if has else nan, "following share": n_all_f / max(steps, 1),
            "read-out flips": 100 * f_pred / steps if has else nan, "teacher side flips": 100 * f_true / steps,
            "mode flips": 100 * f_mode / steps, "label flips": 100 * f_label / steps}


def drive(student, layout, scenario: str, seeds: int, steps: int) -> list:
    """Closed loop: ``student``'s file, acting by the mode through the shield, drives ``seeds`` held-out
    episodes (from :data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`, ``steps`` steps) of ``scenario``,
    labelled by ``apf_student``; the episodes as Sequences (APF's side in ``aux``), for :func:`side_stats`
    (the student fed what it saw and commanded: its read-out along its own way)."""
    from tin_swarm_env.policies.heads import categorical_head
    from tin_swarm_env.training.evaluation import EVAL_SEED0
    from tin_swarm_env.training.imitation import collect

    entry = student.head_entry
    student.head_entry = categorical_head(student.classes, "mode")
    try:
        pol = student.policy(layout)
    finally:
        student.head_entry = entry
    return list(collect(scenario, seeds, EVAL_SEED0, learner=pol, teacher="apf_student", shield="safety_cut",
                        sequences=True, max_cycles=steps).sequences)


def fit_cmd(a) -> None:
    import torch

    from tin_swarm_env.env import parallel_env
    from tin_swarm_env.policies.heads import categorical_classes
    from tin_swarm_env.training.recurrent_imitation import GRUStudent, fit_sequences

    torch.set_num_threads(1)
    data = load_sequences(a.data)
    train = list(data["train_bc"]) + (list(data["train_dag"]) if a.with_dagger else [])
    layout = parallel_env(scenario="generated", n_robots=8).layout
    n_train = sum(int(q.keep.sum()) for q in train)
    print(f"{a.data}: {len(train)} training episodes ({n_train} kept samples), held out "
          f"{len(data['val_bc'])} + {len(data['val_dag'])}", flush=True)
    for name in a.variants.split(","):
        v = {**VARIANTS[name]}
        if a.chunk is not None and v["chunk"]:
            v["chunk"] = a.chunk
        st = GRUStudent(layout.size, v["hidden"], v["head"], signs=layout.mirror_signs(), seed=a.seed,
                        classes=categorical_classes(), cell=v["cell"], acting="sample",
                        feedback=v.get("feedback", "action" if v["cell"] else "none"),
                        aux_weight=v.get("aux_weight", 0.0))
        t0 = time.perf_counter()

        def log(ep, loss, st=st, name=name, t0=t0):
            if (ep + 1) % a.every == 0:
                vb, vd = held_out(st, data["val_bc"])[0], held_out(st, data["val_dag"])[0]
                st.train()
                print(f"{name} epoch {ep + 1}: train {loss:.3f} val_bc {vb:.3f} val_dag {vd:.3f} "
                      f"({time.perf_counter() - t0:.0f} s)", flush=True)

        fit_sequences(st, train, epochs=a.epochs, lr=v["lr"], chunk=v["chunk"], callback=log, seed=a.seed)
        for g in ("val_bc", "val_dag", "train_bc"):
            m, s, o, share = held_out(st, data[g], a.near)
            print(f"{name} {g}: {m:.3f} (near switch {s:.3f} on {share:.0%} of the samples, elsewhere {o:.3f})",
                  flush=True)
            st_ = side_stats(st, data[g])
            print(f"{name} {g} sides: " + ", ".join(f"{k} {x:.3f}" for k, x in st_.items()), flush=True)
        for scen in [x for x in a.drive.split(",") if x]:
            st_ = side_stats(st, drive(st, layout, scen, a.drive_seeds, a.drive_steps))
            print(f"{name} drives {scen} (mode): " + ", ".join(f"{k} {x:.3f}" for k, x in st_.items()), flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect")
    c.add_argument("--out", default="runs/fitdiag/data.npz")
    c.add_argument("--bc", type=int, default=12)
    c.add_argument("--dagger", type=int, default=8)
    c.add_argument("--val", type=int, default=4)
    c.add_argument("--student-epochs", type=int, default=10)
    f = sub.add_parser("fit")
    f.add_argument("--data", default="runs/fitdiag/data.npz")
    f.add_argument("--variants", default="mlp,gru")
    f.add_argument("--epochs", type=int, default=30)
    f.add_argument("--every", type=int, default=2)
    f.add_argument("--near", type=int, default=5)
    f.add_argument("--chunk", type=int, default=None, help="override the chunked variants' chunk")
    f.add_argument("--with-dagger", type=int, default=1)
    f.add_argument("--seed", type=int, default=0, help="the weights' and the episode order's seed")
    f.add_argument("--drive", default="", help="scenarios (comma-separated) each fitted student then drives (mode)")
    f.add_argument("--drive-seeds", type=int, default=2)
    f.add_argument("--drive-steps", type=int, default=400)
    a = ap.parse_args(argv)
    collect_cmd(a) if a.cmd == "collect" else fit_cmd(a)


if __name__ == "__main__":
    main()
