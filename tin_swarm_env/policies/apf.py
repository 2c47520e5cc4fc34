"""Artificial Potential Field policy: acts from the observation alone, for all robots at once.

The observation (see :class:`~tin_swarm_env.env.observation.ObsLayout`) is egocentric, so the
four fields of :mod:`tin_swarm_env.world.fields` are evaluated in the body frame and their sum is
the commanded body-frame velocity, full speed once the force reaches ``speed_saturation``:
``action = F / max(|F|, speed_saturation)``.
What the policy takes from the environment is static: the observation layout, the sensor range
and the task's standoff distance, never the world state.
"""

from __future__ import annotations

import numpy as np

from ..world.fields import (
    FIELDS,
    FieldParams,
    break_field,
    height_field,
    robot_field,
    slide_field,
    target_field,
)

__all__ = ["APFPolicy", "RandomPolicy", "apf_forces"]


def _unwrap(env):
    e = env
    for _ in range(10):
        if hasattr(e, "layout") and hasattr(e, "config"):
            return e
        e = getattr(e, "env", None) or getattr(e, "unwrapped", None)
        if e is None:
            break
    raise TypeError("the policy needs a tin_swarm_env environment (or a wrapper of one)")


def apf_forces(obs, layout, range_m, standoff_m, params: FieldParams):
    """Per-field body-frame forces for observations ``obs (n, d)``: a dict name -> ``(n, 2)``
    (``robot``, ``target``, ``break``, ``slide``, ``height``; fields switched off are zeros)."""
    obs = np.asarray(obs, dtype=np.float64)
    n = obs.shape[0]
    R = range_m
    zero = np.zeros((n, 2))
    out = {k: zero for k in ("robot", "target", "break", "slide", "height")}
    has_t = layout.field(obs, "own", "target_valid")[:, 0] > 0.5
    rel_t = layout.field(obs, "own", "target_dir") * layout.target_distance_m(obs, R)[:, None]
    if params.on("target"):
        f, _ = target_field(rel_t, standoff_m, params.target_gain, params.target_range_m)
        out["target"] = np.where(has_t[:, None], f, 0.0)
    if params.on("height"):
        dz = layout.target_dz_m(obs)
        slope = np.radians(layout.field(obs, "own", "slope")[:, 0] * 90.0)
        grad_z = np.tan(slope)[:, None] * layout.field(obs, "own", "uphill")
        f, _ = height_field(grad_z, dz, params.height_gain)
        out["height"] = np.where(has_t[:, None], f, 0.0)
    if params.on("robot") and layout.k_robots:
        out["robot"], _ = robot_field(layout.vectors(obs, "robots") * R, layout.field(obs, "robots", "valid"),
                                      params.robot_gain, params.robot_range_m)
    if params.on("break") and layout.k_breaks:
        rel, nrm = layout.vectors(obs, "breaks") * R, layout.vectors(obs, "breaks", "nx", "ny")
        danger = layout.field(obs, "breaks", "valid") * layout.field(obs, "breaks", "danger")
        out["break"], _ = break_field(rel, nrm, danger, params.break_gain, params.break_range_m,
                                      params.break_decay_m)
        pull = out["target"] + out["height"]
        out["slide"] = slide_field(pull, rel, nrm, danger, params.break_range_m, params.slide_decay_m,
                                   params.slide_full_m)
    return out


class APFPolicy:
    """The thesis's potential-field controller as a policy: ``act(obs_dict) -> action_dict``
    and ``act_batch(obs (n, d)) -> actions (n, 2)``.

    ``fields``: any subset of ``("robot", "target", "break", "height")``; ``params``: gains and
    ranges (:class:`~tin_swarm_env.world.fields.FieldParams`), ``fields`` overriding its own.
    Without ``params``, the containment task widens the robot field's range to 1.1 times the
    arc between robots evenly spread on the standoff ring (from the scenario's robot and threat
    counts), so that robots spread around each threat instead of bunching where they arrive.
    """

    def __init__(self, env, fields=FIELDS, params: FieldParams | None = None):
        base = _unwrap(env)
        cfg = base.config
        self.range_m = cfg.world.sensor.range_m
        self.standoff_m = cfg.targets.standoff_m if cfg.task == "containment" else 0.0
        if params is None:
            params = FieldParams()
            n_threats = len(cfg.targets.positions)
            if cfg.task == "containment" and n_threats and self.standoff_m > 0:
                # spread around the ring: robots repel out to the arc spacing of an even ring
                per_ring = -(-cfg.robots.count // n_threats)
                spacing = 2 * np.pi * self.standoff_m / max(per_ring, 1)
                params = FieldParams(robot_range_m=max(params.robot_range_m, 1.1 * spacing))
        self.params = FieldParams(**{**params.__dict__, "fields": tuple(fields)})
        self.layout = base.layout

    def forces(self, obs):
        return apf_forces(obs, self.layout, self.range_m, self.standoff_m, self.params)

    def act_batch(self, obs) -> np.ndarray:
        f = sum(self.forces(obs).values())
        mag = np.sqrt(np.sum(f * f, axis=-1, keepdims=True))
        return (f / np.maximum(mag, self.params.speed_saturation)).astype(np.float32)

    def act(self, obs: dict) -> dict:
        if not obs:
            return {}
        keys = list(obs)
        a = self.act_batch(np.stack([obs[k] for k in keys]))
        return {k: a[i] for i, k in enumerate(keys)}


class RandomPolicy:
    """Uniform random body-frame velocities (its own generator, seeded)."""

    def __init__(self, env=None, seed: int | None = None):
        self.rng = np.random.default_rng(seed)

    def act_batch(self, obs) -> np.ndarray:
        return self.rng.uniform(-1, 1, (len(obs), 2)).astype(np.float32)

    def act(self, obs: dict) -> dict:
        keys = list(obs)
        a = self.act_batch(keys)
        return {k: a[i] for i, k in enumerate(keys)}
