"""The standard evaluation suite: fixed maps, seeds, robots and steps in named splits, as Procgen
made train/test splits standard for generalisation, and one leaderboard row per policy.

    tin-swarm eval --suite standard --model shared=agents/models/shared [--model NAME=DIR ...]
    tin-swarm eval --suite standard --quick             # seconds: the first map of each split, 1 seed
    python bench/standard_suite.py [--model NAME=DIR ...]   # writes docs/figures/standard_suite.md

Every policy (random, APF, the geodesic reference, then each ``--model``) plays every map of
:data:`SPLITS` on the seeds ``EVAL_SEED0 .. EVAL_SEED0 + seeds - 1``
(:data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`; training uses the seeds below it). The shipped
policy (``agents/models/shared``, ``agents/reproduce_shared.sh``: a residual over APF, whose network was;
before it ``shared_gru_extra`` and ``shared_sb3``) trained on generated terrains of the canyon, mesa and
hills families (and of the opt-in ``bay`` and ``rough``,
:data:`~tin_swarm_env.scenario.generators.EXTRA_FAMILIES`, which no split plays) and on ``cliff_goal``
and ``ramp``; everything else is held out from it. The splits are
named for that policy: one trained on another mix has seen other kinds of terrain (the BenchMARL
MAPPO and RLlib PPO files, ``agents/models/mappo_benchmarl`` and ``ppo_rllib``, trained on every
generated family, fork and trap included; their seeds: docs/figures/ecosystem_training.md; so did the
mirror-equivariant ``agents/models/shared_mirror``, on training seeds: docs/figures/shared_mirror.md). The splits
(the table in the docs is :func:`splits_markdown` of :data:`SPLITS`):

- **train seeds**: the training families on seeds never trained on (a new terrain per seed);
- **held-out families**: the generated families no shipped policy saw (fork: dead ends; trap:
  walls round the spawn; realdem: crops of the real DEMs, where the ground the robots cannot drive is
  hillside too steep for their drawn slope limit, a family no training recipe names) and two
  scenario files of the repository (``scenarios/``): a 50 m canyon with one pass and a ridge on a DEM file;
- **thesis maps**: the thesis's figures 1.1, 4.2 and 4.3 (``cliff_goal`` and ``ramp`` were trained
  on; their seeds here are new spawn draws);
- **real DEM**: the Jacksboro fault DEM (30 x 32 km), 50 robots.

Every map is played twice: as it is and as its north-south mirror image (:data:`PLAYED`;
:func:`~tin_swarm_env.scenario.mirror.mirror_scenario`; a generated map mirrors every drawn
terrain), on the same seeds: a pass on the robots' left becomes a pass on their right (the
canyon's mirror image is ``scenarios/canyon_right.toml``). The mirror images are the *mirrored* split.

**Leaderboard** (one row per policy, :func:`leaderboard`). A split's figure is the mean over its
episodes of the share of robots (every episode weighs the same); the *mirrored* column is the mean
over the four splits of their mirror images' figures, *mirror gap* that minus the mean of the four
originals (points; a policy that prefers one side shows it here). *arrived*, *fell* and *stalled or
looping* (timed out without progress, :mod:`~tin_swarm_env.training.trajectory`) are the means over the
eight split figures (four splits, both ways); *median steps* is the median step of arrival over every
robot that arrived. *s* is the policy's wall-clock time for the whole suite (its environments built
and run in one process; :data:`BUDGET_S` is the budget on one core).

**Budget and determinism.** 92 episodes per policy (:func:`splits_markdown` counts them), sized so
that one policy's full suite takes at most 4 minutes (:data:`BUDGET_S`) on one core (measured:
``docs/figures/standard_suite.md``; a run that goes over says so). Seeds are
fixed, so a policy's results are the same on every run (the random policy draws from a generator
seeded with ``EVAL_SEED0`` for every map). ``--quick`` plays the first map of each split on one
seed with 3 robots for 60 steps: a check that the suite runs, not a measurement.

This module is the suite (its maps, how a policy plays them, the leaderboard);
``tin-swarm eval --suite`` is :func:`tin_swarm_env.apps.suite.run_suite`.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._atomic import stem_file
from ..errors import ArgumentError
from ..world.state import Reason
from .evaluation import EVAL_SEED0, MIRROR_AXIS

__all__ = ["Map", "Split", "SPLITS", "SUITES", "BUDGET_S", "MIRROR_AXIS", "PLAYED", "QUICK", "splits_markdown",
           "map_config", "scenario_path", "outputs", "play_policy", "leaderboard", "leaderboard_markdown",
           "maps_markdown", "pct", "header_line"]

REPO = Path(__file__).resolve().parents[2]  # scenario files of the repository (scenarios/) are read from here

BUDGET_S = 240.0  # one policy's full suite, one core

@dataclass(frozen=True)
class Map:
    """One map of a split.

    label       its name in the tables
    scenario    a built-in scenario name, or a scenario file of the repository (``scenarios/...``)
    families    generated terrains: the families drawn (a new terrain per seed)
    robots      robots per episode (0: the scenario's)
    max_cycles  steps per episode (0: the scenario's)
    seeds       episodes, on seeds ``EVAL_SEED0 ..`` (each played as built and mirrored)
    """

    label: str
    scenario: str
    families: tuple[str, ...] = ()
    robots: int = 0
    max_cycles: int = 0
    seeds: int = 3

@dataclass(frozen=True)
class Split:
    """A named group of maps; ``key`` names its columns."""

    key: str
    name: str
    why: str
    maps: tuple[Map, ...]

_BASE = (
    Split("train_seeds", "train seeds", "the shipped policy's training families, on seeds never trained on", (
        Map("generated canyon/mesa/hills", "generated", ("canyon", "mesa", "hills"), seeds=10),)),
    Split("held_out", "held-out families", "families and maps no shipped policy trained on", (
        Map("generated fork/trap", "generated", ("fork", "trap"), seeds=10),
        Map("generated realdem", "generated", ("realdem",), seeds=4),
        Map("canyon_left", "scenarios/canyon_left.toml", seeds=3),
        Map("valley", "scenarios/valley.toml", seeds=3))),
    Split("thesis", "thesis maps", "the thesis's figures 1.1, 4.2, 4.3", (
        Map("cliff_goal", "cliff_goal", seeds=4), Map("ramp", "ramp", seeds=4), Map("hill", "hill", seeds=4))),
    Split("dem", "real DEM", "matplotlib's Jacksboro fault DEM, 30 x 32 km", (
        Map("jacksboro", "jacksboro", robots=50, seeds=4),)),
)

SPLITS: tuple[Split, ...] = _BASE

PLAYED = ("", MIRROR_AXIS)  # every map as built and mirrored (scenario/mirror.py axes)

SUITES = {"standard": SPLITS}

QUICK = {"seeds": 1, "robots": 3, "max_cycles": 60}  # --quick: the first map of each split, these settings


def _robots_steps(m: Map) -> tuple[str, str]:
    from ..scenario import load_scenario

    cfg = load_scenario(scenario_path(m))
    return str(m.robots or cfg.robots.count), str(m.max_cycles or cfg.max_cycles)

def splits_markdown(splits=SPLITS) -> str:
    """The splits as a Markdown table (split, map, terrain, seeds, robots, steps): the docs' table."""
    lines = ["| split | what it holds | map | terrain | seeds | robots | steps |", "|---|---|---|---|---:|---:|---:|"]
    for s in splits:
        for i, m in enumerate(s.maps):
            robots, steps = _robots_steps(m)
            terrain = f"generated: {', '.join(m.families)}" if m.families else f"`{m.scenario}`"
            head = f"{s.name} | {s.why}" if i == 0 else " | "
            lines.append(f"| {head} | {m.label} | {terrain} | {m.seeds} | {robots} | {steps} |")
    eps = sum(m.seeds for s in splits for m in s.maps) * len(PLAYED)
    return "\n".join(lines) + (f"\n\nSeeds from {EVAL_SEED0} (`EVAL_SEED0`). Every map is played as built and "
                               f"as its north-south mirror image (`{MIRROR_AXIS}`, `tin_swarm_env.scenario.mirror`) "
                               f"on the same seeds: {eps} episodes per policy.\n")

def scenario_path(m: Map) -> str:
    if "/" not in m.scenario:
        return m.scenario
    p = REPO / m.scenario
    if not p.is_file():
        raise ArgumentError(f"--suite: map {m.label!r} reads {m.scenario} of the repository, not found at {p} "
                            "(the standard suite runs from a source checkout)")
    return str(p)

def map_config(m: Map, mirror: str = ""):
    """The :class:`~tin_swarm_env.scenario.ScenarioConfig` a map is played on, reflected by
    ``mirror`` (:func:`~tin_swarm_env.scenario.mirror.mirror_scenario`) when given."""
    from ..scenario import load_scenario, mirror_scenario

    cfg = load_scenario(scenario_path(m))
    if m.families:
        cfg = cfg.with_families(m.families)
    return mirror_scenario(cfg, mirror) if mirror else cfg

def outputs(out: Path) -> dict:
    """The files a suite run writes, by what they hold (OUT.md, OUT.csv, OUT_maps.csv)."""
    return {"md": stem_file(out, ".md"), "csv": stem_file(out, ".csv"), "maps csv": stem_file(out, "_maps.csv")}

def _play(env, pol, seeds: int) -> list[dict]:
    from .rollout import rollout

    eps = []
    for k in range(seeds):
        o = rollout(env, pol, EVAL_SEED0 + k)
        got = o.reasons == Reason.ARRIVED
        eps.append({"arrived": float(got.mean()), "fell": float((o.reasons == Reason.FELL).mean()),
                    "stuck": float((o.stalled | o.looping).mean()), "steps": o.steps[got].astype(float)})
    return eps

def play_policy(label: str, spec: str, path, splits, trust_pickle: bool = False) -> tuple[dict, list[dict]]:
    """Play one policy (a built-in name ``spec``, or the policy file ``path``) on every map of
    ``splits``: ``(leaderboard row, per-map rows)``."""
    from ..env import parallel_env
    from .policy_factory import make_policy, policy_scenario

    t0 = time.perf_counter()
    maps, by_split = [], {}
    for s in splits:
        for m in s.maps:
            for mirror in PLAYED:
                t1 = time.perf_counter()
                env = parallel_env(scenario=policy_scenario(map_config(m, mirror), spec if path is None else path,
                                                            trust_pickle), n_robots=m.robots or None,
                                   max_cycles=m.max_cycles or None)
                pol = make_policy(env, spec if path is None else path, seed=EVAL_SEED0,
                                  trust_pickle=trust_pickle)
                eps = _play(env, pol, m.seeds)
                env.close()
                steps = np.concatenate([e["steps"] for e in eps])
                maps.append({"policy": label, "split": s.key, "map": m.label, "mirror": mirror, "seeds": m.seeds,
                             "robots": env.n, "steps": env.max_cycles,
                             **{k: float(np.mean([e[k] for e in eps])) for k in ("arrived", "fell", "stuck")},
                             "median_steps": float(np.median(steps)) if len(steps) else float("nan"),
                             "seconds": round(time.perf_counter() - t1, 2)})
                by_split.setdefault((s.key, mirror), []).extend(eps)
    return leaderboard(label, splits, by_split, time.perf_counter() - t0), maps

def leaderboard(label: str, splits, by_split: dict, seconds: float) -> dict:
    """One leaderboard row from the episodes of each (split key, mirror) (see the module
    docstring for how the figures are averaged)."""
    base = [s.key for s in splits]

    def fig(key, mirror, what):
        eps = by_split.get((key, mirror), [])
        return float(np.mean([e[what] for e in eps])) if eps else float("nan")

    row = {"policy": label}
    both = {w: [fig(k, m, w) for k in base for m in PLAYED] for w in ("arrived", "fell", "stuck")}
    row.update({w: float(np.nanmean(v)) for w, v in both.items()})
    steps = np.concatenate([e["steps"] for eps in by_split.values() for e in eps] or [np.zeros(0)])
    row["median_steps"] = float(np.median(steps)) if len(steps) else float("nan")
    for k in base:
        row[k] = fig(k, "", "arrived")
    row["mirrored"] = float(np.nanmean([fig(k, MIRROR_AXIS, "arrived") for k in base]))
    row["mirror_gap"] = row["mirrored"] - float(np.nanmean([row[k] for k in base]))
    row["seconds"] = round(seconds, 1)
    return row

def pct(v) -> str:
    """A share as a percentage with one decimal, NaN as a dash."""
    return "–" if v != v else f"{100 * v:.1f}"

def leaderboard_markdown(rows: list[dict], splits=SPLITS) -> str:
    """The leaderboard table (percentages of robots; *mirror gap* in points)."""
    cols = list(splits)
    head = ("| policy | arrived % | fell % | stalled or looping % | median steps | "
            + " | ".join(f"{s.name} %" for s in cols) + " | mirrored % | mirror gap | s |")
    lines = [head, "|---|" + "---:|" * (len(cols) + 7)]
    for r in rows:
        med = "–" if r["median_steps"] != r["median_steps"] else f"{r['median_steps']:.0f}"
        gap = "–" if r["mirror_gap"] != r["mirror_gap"] else f"{100 * r['mirror_gap']:+.1f}"
        lines.append(f"| {r['policy']} | {pct(r['arrived'])} | {pct(r['fell'])} | {pct(r['stuck'])} | {med} | "
                     + " | ".join(pct(r[s.key]) for s in cols) + f" | {pct(r['mirrored'])} | {gap} | "
                     f"{r['seconds']:.0f} |")
    return "\n".join(lines)

def maps_markdown(maps: list[dict]) -> str:
    """The per-map table of a suite run (one row per policy, map and mirror)."""
    lines = ["| policy | split | map | mirror | seeds x robots | steps | arrived % | fell % | stalled or looping % "
             "| median steps | s |", "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in maps:
        med = "–" if r["median_steps"] != r["median_steps"] else f"{r['median_steps']:.0f}"
        lines.append(f"| {r['policy']} | {r['split']} | {r['map']} | {r['mirror'] or '–'} | {r['seeds']} x "
                     f"{r['robots']} | {r['steps']} | {pct(r['arrived'])} | {pct(r['fell'])} | {pct(r['stuck'])} "
                     f"| {med} | {r['seconds']:.1f} |")
    return "\n".join(lines)

def header_line(command: str | None = None) -> str:
    """``Measured with `COMMAND` at commit C, DATE UTC, load average a / b / c at the start (N cores).``"""
    prog = {"__main__.py": "python -m tin_swarm_env"}.get(Path(sys.argv[0]).name, Path(sys.argv[0]).name)
    cmd = command or " ".join([prog, *(shlex.quote(a) for a in sys.argv[1:])])
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    load = " / ".join(f"{x:.2f}" for x in os.getloadavg())
    when = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    return (f"Measured with `{cmd}`{f' at commit {commit}' if commit else ''}, {when} UTC, load average {load} at "
            f"the start ({os.cpu_count()} cores).")
