"""Run a policy on a scenario for some episodes: the engine of ``tin-swarm run``.

Per episode it counts robots that arrived, fell, ran out of battery or were cut off by
``max_cycles``, collisions, the mean battery left and the steps taken, and optionally keeps
rendered frames for a GIF.
"""

from __future__ import annotations

import sys
import time
from dataclasses import asdict, dataclass

import numpy as np

from .env import parallel_env
from .errors import MissingExtraError

__all__ = ["EpisodeStats", "make_policy", "run_episodes", "format_table", "save_gif", "save_mp4"]


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


def make_policy(env, policy: str, fields=None, seed: int | None = None):
    """``"apf"``, ``"random"`` or a path to a saved Stable-Baselines3 model (``.zip``)."""
    from .policies import APFPolicy, RandomPolicy
    from .world.fields import FIELDS

    if policy == "apf":
        return APFPolicy(env, fields=tuple(fields) if fields else FIELDS)
    if policy == "random":
        return RandomPolicy(env, seed=seed)
    return _SB3Policy(policy)


class _SB3Policy:
    """A saved SB3 model used as a shared policy over the batched observations."""

    def __init__(self, path):
        try:
            from stable_baselines3 import PPO
        except ImportError as exc:
            raise MissingExtraError(
                f"loading the learned policy {path!r} needs stable-baselines3; install it with: "
                "pip install 'tin_swarm_env[train]'") from exc
        self.model = PPO.load(path, device="cpu")

    def act_batch(self, obs):
        a, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(a, dtype=np.float32)


class _Progress:
    """A one-line progress bar on stderr (plain lines when stderr is not a terminal)."""

    def __init__(self, total, label):
        self.total, self.label, self.tty = total, label, sys.stderr.isatty()
        self.last = -1

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
    cap = env.config.world.battery.capacity_j
    for ep in range(episodes):
        t0 = time.perf_counter()
        obs = env.reset_arrays(seed=seed + ep)
        bar = _Progress(env.max_cycles, f"episode {ep + 1}/{episodes}") if progress else None
        counts = np.zeros(4, dtype=np.int64)
        ret = 0.0
        while env.live.any():
            if frames_every and ep == 0 and env.steps % frames_every == 0:
                frames.append(env.render())
            act = pol.act_batch(obs)
            obs, rew, term, trunc, reasons = env.step_arrays(act)
            ret += float(rew.sum())
            counts += np.bincount(reasons[term], minlength=4)[:4]
            counts[0] += int(trunc.sum())
            if bar and (env.steps % 10 == 0 or not env.live.any()):
                bar.update(env.steps, f"arrived {counts[1]} fell {counts[2]}")
        if bar:
            bar.close()
        if frames_every and ep == 0:
            frames.append(env.render())
        s = env.wstate
        out.append(EpisodeStats(episode=ep + 1, seed=seed + ep, robots=env.n, arrived=int(counts[1]),
                                fell=int(counts[2]), battery_dead=int(counts[3]), timed_out=int(counts[0]),
                                collisions=int(s.collisions.sum()),
                                mean_battery_left=float(np.mean(s.battery_j) / cap), steps=env.steps,
                                episode_return=ret / env.n, seconds=time.perf_counter() - t0))
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


def save_gif(frames, path, fps=10):
    """Write frames ``(H, W, 3) uint8`` as an animated GIF (Pillow, which matplotlib ships
    with), or a single PNG when the path ends in .png (the last frame)."""
    from PIL import Image

    from ._atomic import atomic_path

    if not frames:
        raise ValueError("no frames to write")
    png = str(path).lower().endswith(".png")
    with atomic_path(path) as tmp:  # never a half-written picture
        if png:
            Image.fromarray(frames[-1]).save(tmp, format="PNG")
        else:
            imgs = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=128) for f in frames]
            imgs[0].save(tmp, format="GIF", save_all=True, append_images=imgs[1:], duration=int(1000 / fps),
                         loop=0)


def save_mp4(frames, path, fps=10):
    """Write frames as an H.264 MP4 through imageio and the ffmpeg binary its imageio-ffmpeg
    package ships (``pip install 'tin_swarm_env[video]'``), atomically."""
    from ._atomic import atomic_path
    from .errors import require

    iio = require("imageio.v2", "video", "Writing MP4 video")
    require("imageio_ffmpeg", "video", "Writing MP4 video")
    if not frames:
        raise ValueError("no frames to write")
    h, w = frames[0].shape[:2]
    frames = [f[: h - h % 2, : w - w % 2] for f in frames]  # H.264 wants even sizes
    with atomic_path(path) as tmp:
        iio.mimwrite(tmp, frames, fps=fps, format="FFMPEG", codec="libx264", macro_block_size=1)
