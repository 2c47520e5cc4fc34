"""What the jacksboro bar of issue #22 (>= 95% arrived within 1800 steps, 0 fell; >= 72% within 900)
asks of APF's boundary search: how much a side rule can buy, and how much wrong-way driving the bar
tolerates. Writes ``research/jacksboro_bound.md``:

    python research/jacksboro_bound.py [--seeds 3] [--mirror-seeds 2] [--north-steps 6000] [--out FILE]

The APF robots that never arrive on jacksboro are the ones assigned target 1 (67 of 200), see
``research/apf_notes.md``. Every variant below is :class:`~tin_swarm_env.policies.APFPolicy`
with one thing changed, the side a *fresh* search starts on (``bug._start_side``, swapped in for
the run) and/or the turn-back budget (:class:`~tin_swarm_env.policies.bug.BugParams`):

* ``rule``: APF as it is (the side whose tangent points more toward the target);
* ``oracle``: the side the map prefers: the sign of the followed break's tangent along the first
  leg of the shortest drivable path from the robot (:meth:`GeodesicPolicy.directions`). It reads
  the world state: a bound, not a policy. ``anti``: the other side (the way the map does not take);
* ``keep``: a fresh search after the first one keeps the side of the search before it (Bug2's
  fixed direction; the first search takes ``rule``'s side);
* ``split``: even robot rows take ``rule``'s side, odd rows the other (the swarm goes both ways);
* budgets: ``as is`` (``first_budget`` 2, ``min_budget`` 6), ``small`` (0.5 and 1: the first leg
  is half the distance to go, at least one sensor range of distance-to-go growth), ``none`` (never
  turn back on budget; a boundary that ends still turns the robot).

Every episode is one :func:`~tin_swarm_env.training.rollout.rollout` of ``max_cycles`` 1800 (the
shares at 900 are of the same episode). ``--mirror-seeds`` runs the key variants on the
north-south and east-west mirror images (:func:`~tin_swarm_env.scenario.mirror.mirror_scenario`).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.policies import APFPolicy, GeodesicPolicy
from tin_swarm_env.policies import bug as bug_mod
from tin_swarm_env.policies.bug import BugParams
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.mirror import mirror_scenario
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
HARD = 1  # the target whose robots APF loses (research/apf_notes.md)
BUDGETS = {"as is": BugParams(), "small": BugParams(first_budget=0.5, min_budget=1.0),
           "none": BugParams(first_budget=1e9)}
VARIANTS = [("rule", "as is"), ("rule", "small"), ("oracle", "as is"), ("oracle", "none"), ("keep", "as is"),
            ("keep", "small"), ("keep", "none"), ("split", "as is"), ("split", "small"), ("split", "none")]
MIRROR_VARIANTS = [("rule", "as is"), ("oracle", "as is"), ("oracle", "none"), ("split", "none")]
_ORIG = bug_mod._start_side


def _side_rule(kind: str, env, pol):
    """A stand-in for ``bug._start_side`` choosing the side of a fresh search by ``kind``."""
    geo = GeodesicPolicy(env)

    def start(s, pull, rows, split):
        kb, side = _ORIG(s, pull, rows, split)
        rows = np.asarray(rows)
        if kind in ("oracle", "anti"):
            u, _ = geo.directions(rows)
            h = env.world_state.headings[rows]
            c, sn = np.cos(h), np.sin(h)
            ub = np.stack([c * u[:, 0] + sn * u[:, 1], -sn * u[:, 0] + c * u[:, 1]], axis=-1)
            eb = s["e"][np.arange(len(rows)), kb]
            score = eb[:, 1] * ub[:, 0] - eb[:, 0] * ub[:, 1]  # tangent with the break on the right . u
            side = np.where(score >= 0, 1, -1) * (1 if kind == "oracle" else -1)
        elif kind == "keep":
            m = pol.memory
            side = np.where(np.isfinite(m.rec[rows]) & (m.fside[rows] != 0), m.fside[rows], side)
        elif kind == "split":
            side = np.where(rows % 2 == 0, side, -side)
        return kb, side

    return start


@contextlib.contextmanager
def _swapped(start):
    bug_mod._start_side = start
    try:
        yield
    finally:
        bug_mod._start_side = _ORIG


def episode(cfg, kind: str, budget: str, seed: int, steps: int = 1800) -> dict:
    """One episode; per robot: target, step it arrived (-1 not), first break contact (step, position),
    the shortest drivable path from there (m), the boundary driven out before its first turn (m)."""
    env = tse.parallel_env(scenario=cfg, max_cycles=steps)
    pol = APFPolicy(env, bug=BUDGETS[budget])
    n = env.n
    first_t, first_xy = np.full(n, -1), np.zeros((n, 2))
    out_m, last_side, clock = np.full(n, np.nan), np.zeros(n, np.int8), [0]

    def on_step(e, reasons):
        clock[0] += 1
        m = pol.memory
        side = m.side[:n]
        new = (side != 0) & (first_t < 0)
        first_t[new] = clock[0]
        first_xy[new] = e.world_state.positions[new]
        turned = (side != 0) & (side == -last_side) & np.isnan(out_m)
        out_m[turned] = np.abs(m.arc[:n][turned])  # arc is reset when it passes H: read it at the turn
        last_side[:] = side

    with _swapped(_side_rule(kind, env, pol) if kind != "rule" else _ORIG):
        out = rollout(env, pol, seed, on_step=on_step)
    tg = env.target_assignment.copy()
    geo, targets = GeodesicPolicy(env), env.world_state.targets.positions
    d_hit = np.full(n, np.nan)
    for k in range(len(targets)):
        sel = np.flatnonzero((tg == k) & (first_t >= 0))
        if len(sel):
            d_hit[sel] = geo.field(k, targets[k])[0].distance_at(first_xy[sel])
    arrived = out.reasons == Reason.ARRIVED
    return {"target": tg, "arrive": np.where(arrived, out.steps, -1), "fell": out.count(Reason.FELL),
            "first_t": first_t, "d_hit": d_hit, "out_m": out_m, "n": n,
            "step_m": cfg.world.robot.max_speed_mps * cfg.world.dt_s, "secs": out.seconds}


def _share(eps, by, hard=False):
    a = np.concatenate([e["arrive"][e["target"] == HARD] if hard else e["arrive"] for e in eps])
    return np.mean((a > 0) & (a <= by))


def _median_hard(eps):
    a = np.concatenate([e["arrive"][e["target"] == HARD] for e in eps])
    return f"{np.median(a[a > 0]):.0f}" if (a > 0).any() else "-"


def _header(argv) -> str:
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip() or "?"
    cmd = " ".join(["python research/jacksboro_bound.py", *argv])
    return (f"Measured with `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"load average {_load()} at the start ({os.cpu_count()} cores, shared).")


def _load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--mirror-seeds", type=int, default=2)
    p.add_argument("--north-steps", type=int, default=6000, help="episode length of the way-round-north run")
    p.add_argument("--out", default=str(ROOT / "research" / "jacksboro_bound.md"))
    args = p.parse_args(argv)
    lines = [_header(argv), ""]

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    base = load_scenario("jacksboro")
    cfgs = {"": base, "ns": mirror_scenario(base, "ns"), "ew": mirror_scenario(base, "ew")}
    emit(f"jacksboro, 200 robots, 1800-step episodes, seeds 0..{args.seeds - 1} (mirror images: seeds "
         f"0..{args.mirror_seeds - 1}); the variants are in the module docstring of `research/jacksboro_bound.py`. "
         f"Target-{HARD} robots: the robots assigned the target APF loses (67 of 200). s: seconds per row.\n")
    emit("| map | side of a fresh search | budget | arrived by 900 | by 1800 | fell | target-1 robots arrived by "
         "1800 | their median step | s |")
    emit("|---|---|---|---:|---:|---:|---:|---:|---:|")
    runs = {}
    for mirror, cfg in cfgs.items():
        seeds = range(args.seeds if not mirror else args.mirror_seeds)
        for kind, budget in (VARIANTS if not mirror else MIRROR_VARIANTS):
            if not seeds:
                continue
            t = time.perf_counter()
            eps = [episode(cfg, kind, budget, sd) for sd in seeds]
            runs[(mirror, kind, budget)] = eps
            fell = sum(e["fell"] for e in eps) / sum(e["n"] for e in eps)
            emit(f"| {mirror or 'as is'} | {kind} | {budget} | {_share(eps, 900):.1%} | {_share(eps, 1800):.1%} | "
                 f"{fell:.1%} | {_share(eps, 1800, True):.1%} | {_median_hard(eps)} | "
                 f"{time.perf_counter() - t:.0f} |")

    # how much wrong-way driving the bar tolerates
    emit(f"\ntarget-{HARD} robots: the wrong-way driving (out, then back) each could afford and still arrive by "
         "step 1800 (or 900), in metres out: with the shortest drivable path from its first break contact at top "
         "speed (`geodesic`), and with its own arrival step under the map's side and no budget (`oracle, none`: "
         "APF's boundary following as it drives). Against it: how far out APF as it is drives before its "
         "first turn.")
    emit("| map | seed | geodesic: by 1800, median (min..max) | by 900: share >= 0 | oracle, none: by 1800, median "
         "(min..max) | share >= 1 sensor range | oracle, none: steps from contact / shortest path's (median) "
         "| APF as is: out before its first turn, median (min..max) |")
    emit("|---|---:|---:|---:|---:|---:|---:|---:|")
    for mirror in cfgs:
        if (mirror, "oracle", "none") not in runs or (mirror, "rule", "as is") not in runs:
            continue
        for sd, (eo, er) in enumerate(zip(runs[(mirror, "oracle", "none")], runs[(mirror, "rule", "as is")],
                                          strict=True)):
            h = (eo["target"] == HARD) & (eo["first_t"] >= 0)
            sm = eo["step_m"]
            geo_t = eo["first_t"][h] + eo["d_hit"][h] / sm
            g1800, g900 = (1800 - geo_t) * sm / 2, (900 - geo_t) * sm / 2
            a = eo["arrive"][h]
            o1800 = np.where(a > 0, (1800 - a) * sm / 2, np.nan)
            hr = er["target"] == HARD
            out = er["out_m"][hr]
            out = out[np.isfinite(out)]
            rng = base.world.sensor.range_m
            o_txt = (f"{np.nanmedian(o1800):.0f} ({np.nanmin(o1800):.0f}..{np.nanmax(o1800):.0f})"
                     if np.isfinite(o1800).any() else "-")
            ratio = np.median(((a - eo["first_t"][h]) / (eo["d_hit"][h] / sm))[a > 0]) if (a > 0).any() else np.nan
            emit(f"| {mirror or 'as is'} | {sd} | {np.median(g1800):.0f} ({g1800.min():.0f}..{g1800.max():.0f}) | "
                 f"{np.mean(g900 >= 0):.0%} | {o_txt} | {np.mean(np.nan_to_num(o1800, nan=-1) >= rng):.0%} | "
                 f"{ratio:.2f} | "
                 + (f"{np.median(out):.0f} ({out.min():.0f}..{out.max():.0f}) |" if len(out) else "- |"))

    # the other way round
    if args.north_steps:
        t = time.perf_counter()
        e = episode(base, "anti", "none", 0, steps=args.north_steps)
        h = e["target"] == HARD
        a = e["arrive"][h]
        emit(f"\nthe other way round (seed 0, `anti` side, no budget, {args.north_steps}-step episode): "
             f"{np.mean(a > 0):.0%} of the target-{HARD} robots arrive"
             + (f", median step {np.median(a[a > 0]):.0f} (min {a[a > 0].min()})" if (a > 0).any() else "")
             + f"; {time.perf_counter() - t:.0f} s.")
    emit(f"\nLoad average at the end: {_load()}.")
    if args.out:
        tmp = Path(args.out).with_suffix(".md.tmp")
        tmp.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(args.out)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
