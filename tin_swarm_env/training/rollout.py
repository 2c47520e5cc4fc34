"""The one episode loop: ``rollout(env, policy, seed) -> Outcome`` (per-robot results).

Used by ``tin-swarm run``, ``tin-swarm eval``, the training entry's evaluation and the bench
scripts. ``policy`` has ``act_batch(obs (n, d)) -> actions (n, 2)``; when it has a ``reset()``
method it is called right after the env resets (policies with per-robot memory).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..world.state import Reason
from .trajectory import Track

__all__ = ["Outcome", "rollout"]


@dataclass
class Outcome:
    """One episode, per robot (arrays over the ``n`` robots).

    reasons       (n,) int8   :class:`~tin_swarm_env.Reason` code of how it ended (TIMEOUT: cut
                              off by ``max_cycles``; NONE only if the episode was stopped early)
    steps         (n,) int64  the step at which it ended
    returns       (n,) float  sum of its rewards
    collisions    (n,) int64  collisions it was in
    battery_left  (n,) float  charge left at the end / capacity
    stalled       (n,) bool   timed out stalled, :mod:`~tin_swarm_env.training.trajectory`'s definition
    looping       (n,) bool   timed out looping (not stalled), the same module's definition
    seed, n_steps (the episode's length), seconds (wall clock); frames: rendered RGB frames
    when asked for.
    """

    seed: int | None
    reasons: np.ndarray
    steps: np.ndarray
    returns: np.ndarray
    collisions: np.ndarray
    battery_left: np.ndarray
    n_steps: int
    seconds: float
    frames: list = field(default_factory=list, repr=False)
    stalled: np.ndarray | None = None  # None: all False
    looping: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.reasons)
        self.stalled = np.zeros(n, dtype=bool) if self.stalled is None else np.asarray(self.stalled, dtype=bool)
        self.looping = np.zeros(n, dtype=bool) if self.looping is None else np.asarray(self.looping, dtype=bool)

    @property
    def n_robots(self) -> int:
        return len(self.reasons)

    def count(self, reason: Reason) -> int:
        """Robots whose episode ended for ``reason``."""
        return int(np.sum(self.reasons == reason))

    def share(self, reason: Reason) -> float:
        """Fraction of the robots whose episode ended for ``reason``."""
        return self.count(reason) / max(self.n_robots, 1)

    def counts(self) -> dict[str, int]:
        """``{"arrived": k, "fell": k, "battery": k, "max_cycles": k}``."""
        return {r.label: self.count(r) for r in (Reason.ARRIVED, Reason.FELL, Reason.BATTERY, Reason.TIMEOUT)}

    def shares(self) -> dict[str, float]:
        """Fractions of the robots: ``arrived``, ``fell``, ``battery``, ``timed_out`` (these four
        sum to 1 when the episode ran to its end) and, among the timed out, ``stalled`` and
        ``looping``."""
        n = max(self.n_robots, 1)
        out = {k: self.count(r) / n for k, r in (("arrived", Reason.ARRIVED), ("fell", Reason.FELL),
                                                  ("battery", Reason.BATTERY), ("timed_out", Reason.TIMEOUT))}
        out["stalled"], out["looping"] = float(self.stalled.sum()) / n, float(self.looping.sum()) / n
        return out

    def summary(self) -> str:
        """One line: how many robots arrived, fell, ran out of battery or timed out (of which stalled
        and looping), and the median step of arrival; also ``str(outcome)``."""
        c = self.counts()
        got = self.reasons == Reason.ARRIVED
        med = f"; median {int(np.median(self.steps[got]))} steps to arrive" if got.any() else ""
        return (f"{self.n_robots} robots in {self.n_steps} steps: {c['arrived']} arrived, {c['fell']} fell, "
                f"{c['battery']} battery-empty, {c['max_cycles']} timed out ({int(self.stalled.sum())} stalled, "
                f"{int(self.looping.sum())} looping){med}")

    __str__ = summary

    def steps_to_arrive(self) -> float:
        """Mean step of arrival over the robots that arrived (NaN when none did)."""
        got = self.reasons == Reason.ARRIVED
        return float(self.steps[got].mean()) if got.any() else float("nan")


def rollout(env, policy, seed: int | None, *, on_step=None, frames_every: int = 0, on_frame=None) -> Outcome:
    """Run one episode of ``env`` (a :class:`~tin_swarm_env.TinSwarmEnv`) from ``reset(seed)``
    until no robot is left. ``on_step(env, reasons (n,))`` is called after every step with the
    reasons so far; ``frames_every > 0`` keeps ``env.render()`` every that many steps and at
    the end (the env needs ``render_mode="rgb_array"``); with ``on_frame`` each such frame is
    handed to ``on_frame(frame)`` (e.g. written to disk) instead of kept in ``Outcome.frames``."""
    t0 = time.perf_counter()
    obs = env.reset_arrays(seed=seed)
    if hasattr(policy, "reset"):
        policy.reset()
    n = env.n
    reasons = np.zeros(n, dtype=np.int8)
    steps = np.zeros(n, dtype=np.int64)
    returns = np.zeros(n)
    frames = []
    keep = on_frame if on_frame is not None else frames.append
    live = env.live_mask
    track = Track(n)
    track.push(env.world_state.positions)
    while live.any():
        if frames_every and env.steps % frames_every == 0:
            keep(env.render())
        obs, rew, term, trunc, why = env.step_arrays(policy.act_batch(obs))
        returns += np.where(live, rew, 0.0)
        ended = term | trunc
        reasons[ended] = why[ended]
        steps[ended] = env.steps
        live = env.live_mask
        track.push(env.world_state.positions)
        if on_step is not None:
            on_step(env, reasons)
    if frames_every:
        keep(env.render())
    s = env.world_state
    stalled, looping = track.stalled_looping(2.0 * env.config.world.robot.radius_m, reasons == Reason.TIMEOUT)
    return Outcome(seed=seed, reasons=reasons, steps=steps, returns=returns, collisions=s.collisions.copy(),
                   battery_left=s.battery_j / env.config.world.battery.capacity_j, n_steps=env.steps,
                   seconds=time.perf_counter() - t0, frames=frames, stalled=stalled, looping=looping)
