"""Run a policy on a scenario for some episodes: ``tin-swarm run`` (:class:`Args`, :func:`run`).

Per episode it counts robots that arrived, fell, ran out of battery or were cut off by
``max_cycles`` (and of these the stalled and looping ones, :mod:`~.trajectory`), collisions, the
mean battery left and the steps taken (one :func:`~.rollout.rollout` per episode), shows a
progress bar and formats a Markdown table. :class:`Args` holds every option of ``tin-swarm run``
(its help text and what it accepts, checked when it is built); :func:`run` does the command: it
checks the policy and the output paths before the first step, prints the table, writes the
``--summary`` file and streams the first episode's frames to ``--gif``/``--mp4``.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass

import numpy as np

from ..env import parallel_env
from ..env.tin_swarm import DEFAULT_RENDER_WIDTH_PX, RENDER_WIDTH_PX
from ..scenario.config import MAX_ROBOTS
from ..training.evaluation import progress_bar
from ..training.policy_factory import make_policy, policy_scenario
from ..training.rollout import Outcome, rollout
from ..world.fields import FIELDS
from ..world.state import Reason
from .args import check_args, opt
from .media import FRAME_EVERY, GIF_WIDTH_PX

__all__ = ["Args", "run", "EpisodeStats", "run_episodes", "format_table", "parse_fields", "fields_problem"]


def fields_problem(spec: str | None) -> str | None:
    """What is wrong with a ``--fields`` value (comma-separated APF field names), or None."""
    if spec is None:
        return None
    names = [f.strip() for f in spec.split(",") if f.strip()]
    if not names:
        return f"no field named; choose from {','.join(FIELDS)} (leave the option out for all of them)"
    bad = sorted(set(names) - set(FIELDS))
    if bad:
        return f"unknown field(s) {bad}; choose from {','.join(FIELDS)}"
    return None


def parse_fields(spec: str | None, default=None):
    """``"robot,target"`` -> ``("robot", "target")``; ``default`` when ``spec`` is None (a value
    :func:`fields_problem` refuses raises ``ArgumentError`` naming ``--fields``)."""
    from ..errors import ArgumentError

    if spec is None:
        return default
    msg = fields_problem(spec)
    if msg:
        raise ArgumentError(f"--fields {spec!r}: {msg}")
    return tuple(f.strip() for f in spec.split(",") if f.strip())


def _mp4_problem(path: str | None) -> str | None:
    return None if path is None or path.lower().endswith(".mp4") else "the file name must end in .mp4"


@dataclass
class Args:
    """``tin-swarm run``: every option, its help and what it accepts (checked when built)."""

    scenario: str = opt("flat", "built-in scenario name (tin-swarm scenarios) or a .toml path")
    robots: int | None = opt(None, "number of robots (default: the scenario's)", lo=1, hi=MAX_ROBOTS)
    policy: str = opt("apf", "apf, apf-chart (APF with the chart search), random, geodesic (the map-knowing "
                      "reference; any case), a pickle-free policy directory, or an SB3 .zip with --trust-pickle")
    trust_pickle: bool = opt(False, "allow --policy MODEL.zip: SB3 files are pickles and loading one runs any code "
                             "it holds", flag=True)
    episodes: int = opt(1, "episodes to run (seeds SEED, SEED+1, ...)", lo=1)
    seed: int = opt(0, "seed of the first episode", lo=0)
    fields: str | None = opt(None, "APF fields to use, comma-separated, e.g. robot,target,height (default: all of "
                             + ",".join(FIELDS) + ")", check=fields_problem)
    gif: str | None = opt(None, "write the first episode as a GIF (one fixed palette); the suffix picks the format: "
                          ".gif, .png (the last frame), .mp4 or .webp (these two: the [video] extra)")
    mp4: str | None = opt(None, "write the first episode as an MP4 video (the [video] extra)", check=_mp4_problem)
    frame_every: int = opt(FRAME_EVERY, "steps between GIF/MP4 frames (the defaults keep a 200-robot, 900-step "
                           "jacksboro GIF under 10 MB: docs/figures/media.md)", lo=1)
    render_width: int = opt(GIF_WIDTH_PX, "width of GIF/MP4 frames in pixels", lo=RENDER_WIDTH_PX[0],
                            hi=RENDER_WIDTH_PX[1])
    max_cycles: int | None = opt(None, "steps per episode (default: the scenario's)", lo=1)
    summary: str | None = opt(None, "also write the table to this Markdown file (.md or .txt)")
    quiet: bool = opt(False, "no progress bar", flag=True)

    def __post_init__(self):
        check_args(self)


@dataclass
class EpisodeStats:
    episode: int
    seed: int
    robots: int
    arrived: int
    fell: int
    battery_dead: int
    timed_out: int
    stalled: int
    looping: int
    collisions: int
    mean_battery_left: float
    steps: int
    episode_return: float
    seconds: float

    @classmethod
    def from_outcome(cls, episode: int, o: Outcome) -> EpisodeStats:
        return cls(episode=episode, seed=o.seed, robots=o.n_robots, arrived=o.count(Reason.ARRIVED),
                   fell=o.count(Reason.FELL), battery_dead=o.count(Reason.BATTERY),
                   timed_out=o.count(Reason.TIMEOUT), stalled=int(o.stalled.sum()), looping=int(o.looping.sum()),
                   collisions=int(o.collisions.sum()),
                   mean_battery_left=float(o.battery_left.mean()), steps=o.n_steps,
                   episode_return=float(o.returns.mean()), seconds=o.seconds)


def _on_step(bar):
    """A :func:`~.rollout.rollout` ``on_step`` callback advancing ``bar`` with the arrivals/falls."""
    def on_step(env, reasons):
        bar.update(1)
        if env.steps % 10 == 0 or not env.live_mask.any():
            bar.set_postfix(arrived=int(np.sum(reasons == Reason.ARRIVED)), fell=int(np.sum(reasons == Reason.FELL)),
                            refresh=False)
    return on_step


def run_episodes(scenario, policy="apf", robots=None, episodes=1, seed=0, fields=None, frames_every=0,
                 max_cycles=None, progress=True, render_width=DEFAULT_RENDER_WIDTH_PX, on_frame=None,
                 trust_pickle=False):
    """Run ``episodes`` episodes (seeds ``seed``, ``seed+1``...). Returns ``(stats list, frames)``;
    frames (the first episode's, every ``frames_every`` steps) only when ``frames_every > 0``;
    with ``on_frame`` each frame goes to ``on_frame(frame)`` as it is drawn instead (the list is
    then empty: nothing accumulates in memory). ``policy``: see :func:`~.policy_factory.make_policy`."""
    env = parallel_env(scenario=policy_scenario(scenario, policy, trust_pickle), n_robots=robots, max_cycles=max_cycles,
                       render_mode="rgb_array" if frames_every else None, render_width=render_width)
    pol = make_policy(env, policy, fields, seed, trust_pickle=trust_pickle)
    out, frames = [], []
    for ep in range(episodes):
        bar = progress_bar(env.max_cycles, f"episode {ep + 1}/{episodes}", progress)
        try:
            o = rollout(env, pol, seed + ep, on_step=_on_step(bar) if bar is not None else None,
                        frames_every=frames_every if ep == 0 else 0, on_frame=on_frame)
        finally:
            if bar is not None:
                bar.close()
        frames = frames or o.frames
        out.append(EpisodeStats.from_outcome(ep + 1, o))
    env.close()
    return out, frames


def format_table(stats) -> str:
    """A Markdown table of episode statistics, with a mean row when there are several."""
    hdr = ("| episode | seed | robots | arrived | fell | battery-empty | timed out | stalled | looping | collisions | "
           "mean battery left | steps | return/robot |")
    lines = [hdr, "|" + "---:|" * 13]
    for s in stats:
        lines.append(f"| {s.episode} | {s.seed} | {s.robots} | {s.arrived} | {s.fell} | {s.battery_dead} | "
                     f"{s.timed_out} | {s.stalled} | {s.looping} | {s.collisions} | {s.mean_battery_left:.1%} | "
                     f"{s.steps} | {s.episode_return:.1f} |")
    if len(stats) > 1:
        m = {k: np.mean([asdict(s)[k] for s in stats]) for k in asdict(stats[0])}
        lines.append(f"| mean | | {m['robots']:.0f} | {m['arrived']:.1f} | {m['fell']:.1f} | "
                     f"{m['battery_dead']:.1f} | {m['timed_out']:.1f} | {m['stalled']:.1f} | {m['looping']:.1f} | "
                     f"{m['collisions']:.1f} | "
                     f"{m['mean_battery_left']:.1%} | {m['steps']:.0f} | {m['episode_return']:.1f} |")
    return "\n".join(lines)


def run(a: Args) -> int:
    """``tin-swarm run``: check the policy and every output path, run ``a.episodes`` episodes,
    print the table (and write ``--summary``), stream the first episode to ``--gif``/``--mp4``."""
    from contextlib import ExitStack

    from .._atomic import atomic_path, check_outputs, check_suffix
    from ..training.policy_factory import check_policy_spec
    from .media import FrameWriter, check_animation

    fields = parse_fields(a.fields)
    check_policy_spec(a.policy, a.trust_pickle)
    check_outputs({"--summary": a.summary, "--gif": a.gif, "--mp4": a.mp4},
                  inputs=(a.policy,) if os.path.exists(a.policy) else (), scenarios=(a.scenario,))
    check_suffix("--summary", a.summary, (".md", ".txt"))
    if a.gif or a.mp4:
        from ..scenario.config import load_scenario

        cfg = load_scenario(a.scenario)
        check_animation(a.robots or cfg.robots.count, a.max_cycles or cfg.max_cycles, a.frame_every,
                        "--gif" if a.gif else "--mp4")
    with ExitStack() as stack:  # frames go to disk as they are drawn; .part files removed on any error
        writers = [stack.enter_context(FrameWriter(p)) for p in (a.gif, a.mp4) if p]

        def on_frame(frame):
            for w in writers:
                w.add(frame)

        stats, _ = run_episodes(a.scenario, policy=a.policy, robots=a.robots, episodes=a.episodes, seed=a.seed,
                                fields=fields, frames_every=a.frame_every if writers else 0, max_cycles=a.max_cycles,
                                progress=not a.quiet, render_width=a.render_width, on_frame=on_frame,
                                trust_pickle=a.trust_pickle)
        table = format_table(stats)
        print(f"scenario {a.scenario}, policy {a.policy}" + (f", fields {','.join(fields)}" if fields else ""))
        print(table)
        if a.summary:
            with atomic_path(a.summary) as tmp, open(tmp, "w") as fh:
                fh.write(f"# tin-swarm run {a.scenario} ({a.policy})\n\n{table}\n")
            print(f"wrote {a.summary}")
    for w in writers:
        print(f"wrote {w.path} ({w.n_frames} frames)")
    return 0
