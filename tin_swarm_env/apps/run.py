"""Run a policy on a scenario for some episodes: the engine of ``tin-swarm run``.

Per episode it counts robots that arrived, fell, ran out of battery or were cut off by
``max_cycles`` (and of these the stalled and looping ones, :mod:`~.trajectory`), collisions, the
mean battery left and the steps taken (one :func:`~.rollout.rollout` per episode), shows a
progress bar and formats a Markdown table.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..env import parallel_env
from ..env.tin_swarm import DEFAULT_RENDER_WIDTH_PX
from ..world.state import Reason
from .policy_factory import make_policy
from .rollout import Outcome, rollout

__all__ = ["EpisodeStats", "run_episodes", "format_table"]


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


def progress_bar(total: int, desc: str, enabled: bool = True):
    """A tqdm bar on stderr (rate and ETA) counting ``total`` steps, or None when disabled or
    tqdm is not installed (then nothing is shown). Also used by ``tin-swarm eval``."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:  # pragma: no cover - tqdm is a core dependency
        return None
    # disable=None: no bar when stderr is not a terminal (logs, CI)
    return tqdm(total=total, desc=desc, unit="step", leave=False, dynamic_ncols=True, disable=None)


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
    env = parallel_env(scenario=scenario, n_robots=robots, max_cycles=max_cycles,
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
    hdr = ("| episode | seed | robots | arrived | fell | battery-dead | timed out | stalled | looping | collisions | "
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
