"""Run a policy on a scenario for some episodes: the engine of ``tin-swarm run``.

Per episode it counts robots that arrived, fell, ran out of battery or were cut off by
``max_cycles``, collisions, the mean battery left and the steps taken (one
:func:`~.rollout.rollout` per episode), shows a progress bar and formats a Markdown table.
"""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass

import numpy as np

from ..env import parallel_env
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
    collisions: int
    mean_battery_left: float
    steps: int
    episode_return: float
    seconds: float

    @classmethod
    def from_outcome(cls, episode: int, o: Outcome) -> EpisodeStats:
        return cls(episode=episode, seed=o.seed, robots=o.n_robots, arrived=o.count(Reason.ARRIVED),
                   fell=o.count(Reason.FELL), battery_dead=o.count(Reason.BATTERY),
                   timed_out=o.count(Reason.TIMEOUT), collisions=int(o.collisions.sum()),
                   mean_battery_left=float(o.battery_left.mean()), steps=o.n_steps,
                   episode_return=float(o.returns.mean()), seconds=o.seconds)


class _Progress:
    """A one-line progress bar on stderr (plain lines when stderr is not a terminal); an
    ``on_step`` callback for :func:`~.rollout.rollout`."""

    def __init__(self, total, label):
        self.total, self.label, self.tty = total, label, sys.stderr.isatty()
        self.last = -1

    def __call__(self, env, reasons):
        if env.steps % 10 == 0 or not env.live_mask.any():
            self.update(env.steps, f"arrived {np.sum(reasons == Reason.ARRIVED)} "
                                   f"fell {np.sum(reasons == Reason.FELL)}")

    def update(self, k, extra=""):
        pct = int(100 * k / max(self.total, 1))
        if self.tty:
            bar = "#" * (pct // 4)
            sys.stderr.write(f"\r{self.label} [{bar:<25s}] {k}/{self.total} {extra}")
            sys.stderr.flush()
        elif pct // 25 != self.last // 25 or k == self.total:
            sys.stderr.write(f"{self.label} {k}/{self.total} {extra}\n")
        self.last = pct

    def close(self):
        if self.tty:
            sys.stderr.write("\n")


def run_episodes(scenario, policy="apf", robots=None, episodes=1, seed=0, fields=None, frames_every=0,
                 max_cycles=None, progress=True, render_width=640):
    """Run ``episodes`` episodes (seeds ``seed``, ``seed+1``...). Returns ``(stats list, frames)``;
    frames (the first episode's, every ``frames_every`` steps) only when ``frames_every > 0``."""
    env = parallel_env(scenario=scenario, n_robots=robots, max_cycles=max_cycles,
                       render_mode="rgb_array" if frames_every else None, render_width=render_width)
    pol = make_policy(env, policy, fields, seed)
    out, frames = [], []
    for ep in range(episodes):
        bar = _Progress(env.max_cycles, f"episode {ep + 1}/{episodes}") if progress else None
        o = rollout(env, pol, seed + ep, on_step=bar, frames_every=frames_every if ep == 0 else 0)
        if bar:
            bar.close()
        frames = frames or o.frames
        out.append(EpisodeStats.from_outcome(ep + 1, o))
    env.close()
    return out, frames


def format_table(stats) -> str:
    """A Markdown table of episode statistics, with a mean row when there are several."""
    hdr = ("| episode | seed | robots | arrived | fell | battery-dead | timed out | collisions | "
           "mean battery left | steps | return/robot |")
    lines = [hdr, "|" + "---:|" * 11]
    for s in stats:
        lines.append(f"| {s.episode} | {s.seed} | {s.robots} | {s.arrived} | {s.fell} | {s.battery_dead} | "
                     f"{s.timed_out} | {s.collisions} | {s.mean_battery_left:.1%} | {s.steps} | "
                     f"{s.episode_return:.1f} |")
    if len(stats) > 1:
        m = {k: np.mean([asdict(s)[k] for s in stats]) for k in asdict(stats[0])}
        lines.append(f"| mean | | {m['robots']:.0f} | {m['arrived']:.1f} | {m['fell']:.1f} | "
                     f"{m['battery_dead']:.1f} | {m['timed_out']:.1f} | {m['collisions']:.1f} | "
                     f"{m['mean_battery_left']:.1%} | {m['steps']:.0f} | {m['episode_return']:.1f} |")
    return "\n".join(lines)
