"""Every APF robot that does not arrive, classified by mechanism from its logged boundary-search
memory (:class:`~tin_swarm_env.policies.bug.BugMemory`) and its track. By hand:

    python research/apf_failures.py                  # fork, mesa, canyon, trap; 50 held-out seeds x 20 robots;
                                                  # writes research/apf_failures.md
    [--families fork,mesa] [--seeds 50] [--first 0] [--robots N] [--examples 3] [--out FILE] [--print]

Each episode runs through :func:`~tin_swarm_env.training.rollout.rollout` with the seeds ``bench/apf.py``
draws (``EVAL_SEED0 + k``), so a robot here is the same robot as in ``docs/figures/apf.md``. After
every step the script copies the memory of every robot; from two consecutive copies it reads the
rule that fired (:func:`events`). The episode's cost-to-go field of the robot's target (the map,
which the policy does not know) says whether the target was reachable and which side was the short
way round. The classes (:data:`CLASSES`, first match wins) are in :func:`classify`.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from apf import generated_family  # noqa: E402  (the one home of "the generated scenario, one family")

FIELDS = ("side", "first", "rec", "arc", "budget", "ended_first", "ended_other", "unreachable", "stall", "gap",
          "climb", "passed", "on_border", "probed", "far")

LOOP_WINDOW = 600  # (b) counts a loop in the robot's last this many steps (still circling when time ran out)
FLICKER = 5  # a leave taken up again within this many steps is a flicker (see classify)

#: the classes, in the order :func:`classify` tries them
CLASSES = {
    "fell": "fell",
    "c-false-unreachable": "(c) said unreachable, the map reaches the target from where it stands",
    "f-true-unreachable": "(f) said unreachable, and the map does not reach it either",
    "d-stalled": "(d) stalled: net under one body length in its last 100 steps",
    "b-loop": "(b) drives round a closed boundary: in its last 600 steps passes the same place the same way again, "
              "no turn or fresh search between",
    "a-late-turn": "(a) first side the long way round (the map's distance grows along it), turned back (border, "
                   "budget or stall), out of time",
    "a-no-turn": "(a) first side the long way round, never turned back (budget not spent), out of time",
    "a-right-side": "(a') first side the short way round, no loop, out of time",
    "e-other": "(e) never met a boundary, or other",
}


@dataclasses.dataclass
class Log:
    """One episode: ``pos (T + 1, n, 2)`` world positions (row 0 at the reset, row ``t`` after step
    ``t``), ``mem`` name (:data:`FIELDS`) -> ``(T + 1, n)`` copies of the memory after each step's
    action (row 0 the empty memory), ``out`` the :class:`~tin_swarm_env.training.rollout.Outcome`,
    ``fields`` the episode's cost-to-go fields (one per target) and ``targets (n,)`` each robot's."""

    pos: np.ndarray
    mem: dict
    out: object
    fields: tuple
    targets: np.ndarray


def run_episode(env, seed: int, policy=None) -> Log:
    """One episode of ``policy`` (default a fresh :class:`APFPolicy`) through ``rollout``, logged."""
    pol = policy if policy is not None else APFPolicy(env)
    n = env.n
    pos, snaps = [], []

    def snap():
        m = pol.memory.grow(n)
        snaps.append({k: np.array(getattr(m, k)[:n]) for k in FIELDS})
        pos.append(np.array(env.world_state.positions))

    class Logged:  # rollout calls reset() right after the env's reset: the first row
        def reset(self):
            pol.reset()
            snap()

        def act_batch(self, obs):
            return pol.act_batch(obs)

    out = rollout(env, Logged(), seed, on_step=lambda e, r: snap())
    mem = {k: np.stack([s[k] for s in snaps]) for k in FIELDS}
    return Log(np.stack(pos), mem, out, env.target_fields, np.array(env.target_assignment))


def events(log: Log, i: int, stall_steps: int) -> list[tuple]:
    """Robot ``i``'s rule firings ``(step, name, x, y)``, read from consecutive memory copies:
    ``fresh`` (a new search, rule 1), ``resume`` (meets again, not nearer: takes its search up),
    ``leave`` (rule 3), ``gap`` (drives through a gap), ``end-border`` / ``end-stall`` (rule 4,
    the side ended), ``budget`` (rule 4, the budget spent), ``unreachable-ends`` /
    ``unreachable-circuit`` (rule 5)."""
    m = log.mem
    out = []
    for t in range(1, len(log.pos)):
        s0, s1 = m["side"][t - 1, i], m["side"][t, i]
        x, y = log.pos[t, i]
        name = None
        if m["unreachable"][t, i] and not m["unreachable"][t - 1, i]:
            both = m["ended_first"][t, i] and m["ended_other"][t, i]
            name = "unreachable-ends" if both else "unreachable-circuit"
        elif s0 == 0 and s1 != 0:
            name = "fresh" if m["rec"][t, i] != m["rec"][t - 1, i] else "resume"
        elif s0 != 0 and s1 == 0:
            name = "leave"
        elif s0 != 0 and s1 == -s0:
            newly = (m["ended_first"][t, i] > m["ended_first"][t - 1, i]) or (
                m["ended_other"][t, i] > m["ended_other"][t - 1, i])
            if newly:
                name = "end-stall" if m["stall"][t - 1, i] >= stall_steps - 1 else "end-border"
            else:
                name = "budget"
        if m["gap"][t, i] == 1 and m["gap"][t - 1, i] == 0:
            out.append((t, "gap", float(x), float(y)))
        if name:
            out.append((t, name, float(x), float(y)))
    return out


def ctg(log: Log, i: int, xy) -> np.ndarray:
    """The map's distance to go from points ``xy (k, 2)`` to robot ``i``'s target (inf: unreachable)."""
    k = log.targets[i]
    if k < 0:
        return np.full(len(xy), np.inf)
    return log.fields[k].distance_at(np.asarray(xy, dtype=np.float64).reshape(-1, 2))


def _path(p):
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])


def loop_in_search(p, start: int, breaks=(), min_path: float = 25.0, near_m: float = 4.0):
    """The first step ``t > start`` at which the track ``p (T + 1, 2)`` comes back within ``near_m``
    of a point it passed at least ``min_path`` of driving earlier (after ``start``), moving the same
    way (positive dot product of the two steps), with none of the steps ``breaks`` (turns, fresh
    searches: a search that turns back retraces its way, and passes its places again on purpose)
    in between; ``(t, earlier step, path between)`` or None."""
    cuts = sorted({start, *[b for b in breaks if b > start], len(p) - 1})
    for a, b in zip(cuts[:-1], cuts[1:]):
        seg = p[a:b + 1]
        if len(seg) < 3:
            continue
        s = _path(seg)
        v = np.diff(seg, axis=0)
        for t in range(1, len(seg) - 1):
            ok = s[t] - s[:t] >= min_path
            if not ok.any():
                continue
            d = np.hypot(*(seg[:t] - seg[t]).T)
            hit = np.flatnonzero(ok & (d < near_m) & (np.sum(v[:t] * v[t], axis=-1) > 0))
            if len(hit):
                j = int(hit[-1])
                return a + t, a + j, float(s[t] - s[j])
    return None


def classify(log: Log, i: int, stall_steps: int) -> dict:
    """Robot ``i`` (did not arrive): its class (a key of :data:`CLASSES`) and the facts behind it."""
    m, p, out = log.mem, log.pos[:, i], log.out
    ev = events(log, i, stall_steps)
    T = len(p) - 1
    end = p[-1]
    fresh = [e for e in ev if e[1] == "fresh"]
    h_step = fresh[-1][0] if fresh else None
    rec = {"events": ev, "end": end, "steps": T, "ctg_end": float(ctg(log, i, end[None])[0]), "track": p,
           "mem": {k: v[:, i] for k, v in m.items()}}
    # the last search: where it met the boundary, the map's distance there, the side it took first
    if h_step is not None:
        h = p[h_step]
        rec["H"], rec["H_step"] = h, h_step
        rec["ctg_H"] = float(ctg(log, i, h[None])[0])
        s = _path(p[h_step:])
        k = int(np.searchsorted(s, 25.0))  # 25 m of boundary from H along the first side
        rec["ctg_H25"] = float(ctg(log, i, p[h_step + min(k, len(s) - 1)][None])[0])
        rec["first_right"] = rec["ctg_H25"] < rec["ctg_H"]
        rec["turns"] = [e for e in ev if e[0] > h_step and e[1] in ("end-border", "end-stall", "budget")]
        rec["budget"] = float(m["budget"][-1, i])
        rec["climb"] = float(m["climb"][-1, i])
    rec["side"] = int(m["side"][-1, i])
    rec["unreachable"] = bool(m["unreachable"][-1, i])
    rec["ended"] = (bool(m["ended_first"][-1, i]), bool(m["ended_other"][-1, i]))
    rec["gap"] = int(m["gap"][-1, i])
    rec["probed"] = bool(m["probed"][-1, i])
    # a leave taken up again within FLICKER steps: the clear view that proved wrong at once (it sets
    # probed: no second clear-view leave in this search)
    rec["flickers"] = [(a[0], b[0]) for a, b in zip(ev, ev[1:]) if a[1] == "leave" and b[1] == "resume"
                       and b[0] - a[0] <= FLICKER and (h_step is None or a[0] >= h_step)]
    p100 = p[-101:]
    rec["net100"] = float(np.hypot(*(p100[-1] - p100[0])))
    rec["path100"] = float(_path(p100)[-1])
    others = np.delete(log.pos[-1], i, axis=0)
    rec["nearest_robot"] = float(np.min(np.hypot(*(others - end).T))) if len(others) else np.inf
    if out.reasons[i] == Reason.FELL:
        cls = "fell"
    elif rec["unreachable"]:
        cls = "c-false-unreachable" if np.isfinite(rec["ctg_end"]) else "f-true-unreachable"
    elif out.stalled[i]:
        cls = "d-stalled"
    else:
        cuts = [e[0] for e in ev if e[1] in ("fresh", "end-border", "end-stall", "budget")]
        lp = loop_in_search(p, max(h_step or 0, T - LOOP_WINDOW), cuts)
        rec["loop"] = lp
        if lp is not None:
            cls = "b-loop"
            between = [e[1] for e in ev if h_step is not None and h_step < e[0] <= lp[1]]
            rec["sub"] = ("after driving through a gap (pass_gap)" if "gap" in between else
                          "after a leave taken up again" if "resume" in between else "on the boundary it met at H")
        elif h_step is None:
            cls = "e-other"
        elif not rec["first_right"]:
            cls = "a-late-turn" if rec["turns"] else "a-no-turn"
        else:
            cls = "a-right-side"
    rec["cls"] = cls
    return rec


def describe(fam, seed, i, r) -> str:
    """One example line: family, seed, robot and what happened, with positions and the rules that fired."""
    ev = r["events"]
    bits = [f"{fam} seed {seed} robot {i}"]
    if "H" in r:
        bits.append(f"H ({r['H'][0]:.0f}, {r['H'][1]:.0f}) step {r['H_step']}, map {r['ctg_H']:.0f} m to go "
                    f"({'first side the short way' if r['first_right'] else 'first side the long way'})")
    show = [e for e in ev if e[1] != "fresh" or e[0] == r.get("H_step")][-6:]
    if show:
        bits.append("; ".join(f"{n} {t} ({x:.0f}, {y:.0f})" for t, n, x, y in show))
    if r.get("loop"):
        t, j, s = r["loop"]
        bits.append(f"passes step {j}'s place again at step {t} after {s:.0f} m")
    if r.get("flickers"):
        bits.append(f"{len(r['flickers'])} leave(s) taken up again within {FLICKER} steps (first at step "
                    f"{r['flickers'][0][0]}); probed {int(r['probed'])}")
    bits.append(f"end ({r['end'][0]:.0f}, {r['end'][1]:.0f}) side {r['side']} ended {int(r['ended'][0])}"
                f"/{int(r['ended'][1])} gap {r['gap']} map {r['ctg_end']:.0f} m to go; last 100 steps "
                f"{r['path100']:.0f} m driven, {r['net100']:.1f} m net; nearest robot {r['nearest_robot']:.1f} m")
    return ": ".join(bits[:1]) + ": " + "; ".join(bits[1:])


def run(families, seeds, robots, stall_steps=None, log=print) -> dict:
    """``{family: [(seed, robot, record), ...]}`` over the robots that did not arrive, and the
    robot totals ``{family: n}`` under ``"_n"``."""
    res = {"_n": {}}
    for fam in families:
        env = generated_family(fam, robots)
        steps = stall_steps or APFPolicy(env).params.stall_steps
        rows, n = [], 0
        t0 = time.perf_counter()
        for seed in seeds:
            lg = run_episode(env, seed)
            n += lg.out.n_robots
            for i in np.flatnonzero(lg.out.reasons != Reason.ARRIVED):
                rows.append((seed, int(i), classify(lg, int(i), steps)))
        res[fam], res["_n"][fam] = rows, n
        log(f"# {fam}: {len(rows)} of {n} did not arrive ({time.perf_counter() - t0:.0f} s): "
            + ", ".join(f"{k} {v}" for k, v in Counter(r[2]["cls"] for r in rows).most_common()))
    return res


def tables(res, examples: int, emit):
    fams = [f for f in res if f != "_n"]
    emit("| class | " + " | ".join(fams) + " |")
    emit("|---|" + "---:|" * len(fams))
    counts = {f: Counter(r[2]["cls"] for r in res[f]) for f in fams}
    for k, text in CLASSES.items():
        if any(counts[f][k] for f in fams):
            emit(f"| {text} | " + " | ".join(f"{counts[f][k]} ({counts[f][k] / res['_n'][f]:.1%})" for f in fams)
                 + " |")
    subs = {f: Counter(r[2]["sub"] for r in res[f] if "sub" in r[2]) for f in fams}
    for k in sorted({k for f in fams for k in subs[f]}):
        emit(f"| ... (b) {k} | " + " | ".join(str(subs[f][k]) for f in fams) + " |")
    flick = {f: sum(bool(r[2].get("flickers")) for r in res[f]) for f in fams}
    emit(f"| of all these: a leave taken up again within {FLICKER} steps in the last search | "
         + " | ".join(str(flick[f]) for f in fams) + " |")
    emit("| did not arrive, all | " + " | ".join(f"{len(res[f])} ({len(res[f]) / res['_n'][f]:.1%})"
                                                for f in fams) + " |")
    emit("| robots | " + " | ".join(str(res["_n"][f]) for f in fams) + " |")
    emit("\nExamples per class (seeds are EVAL_SEED0 + k; positions in metres, world frame; each event is "
         "the rule that fired, its step and the robot's position; 'map' is the cost-to-go field's distance):\n")
    for k, text in CLASSES.items():
        ex = [(f, s, i, r) for f in fams for s, i, r in res[f] if r["cls"] == k]
        if not ex:
            continue
        emit(f"- **{text}**")
        # spread the examples over families and seeds
        picked, seen = [], set()
        for f, s, i, r in ex:
            if (f, s) not in seen and len(picked) < examples:
                picked.append((f, s, i, r))
                seen.add((f, s))
        for f, s, i, r in picked:
            emit(f"  - {describe(f, s - EVAL_SEED0, i, r)}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--families", default="fork,mesa,canyon,trap")
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--first", type=int, default=0, help="first held-out seed (k in EVAL_SEED0 + k)")
    ap.add_argument("--robots", type=int, default=None)
    ap.add_argument("--examples", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "research" / "apf_failures.md"))
    ap.add_argument("--print", action="store_true", help="print only, write no file")
    ap.add_argument("--save", default="", help="also pickle the per-robot records to this file")
    args = ap.parse_args(argv)
    fams = [f for f in args.families.split(",") if f]
    seeds = range(EVAL_SEED0 + args.first, EVAL_SEED0 + args.first + args.seeds)
    load0 = os.getloadavg()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
    res = run(fams, seeds, args.robots)
    if args.save:
        import pickle

        Path(args.save).write_bytes(pickle.dumps(res))
    lines = []
    cmd = "python research/apf_failures.py" + ("" if argv is None else " " + " ".join(argv))
    if argv is None:
        cmd = "python research/apf_failures.py " + " ".join(sys.argv[1:])
    lines.append(f"Measured with `{cmd.strip()}` at commit {commit.strip()}, "
                 f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average "
                 f"{load0[0]:.2f} / {load0[1]:.2f} / {load0[2]:.2f} at the start.\n")
    lines.append(f"APF robots that did not arrive, {args.seeds} held-out seeds per family (from EVAL_SEED0 + "
                 f"{args.first}), by mechanism (the classes: `CLASSES` and `classify` in research/apf_failures.py).\n")
    tables(res, args.examples, lines.append)
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.print:
        Path(args.out).write_text(text)
    return res


if __name__ == "__main__":
    main()
