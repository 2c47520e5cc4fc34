"""Residual policies: a network's correction added to a classic controller's command.

A policy file with ``"prior": "apf"`` (:mod:`tin_swarm_env.policies.learned`) acts

    a = shield(clip(apf(o) + g(o), -1, 1))

with ``g`` the file's network before its clip (mirror-averaged with ``"symmetry": "mirror"``) and
``apf`` the default :class:`~tin_swarm_env.policies.APFPolicy` of the env the file is loaded for
(the chart search, its memory included), run beside the network on the same observations. The
executed command ``a`` (after the clip and the shield) is what APF's odometry integrates
(:meth:`APFPrior.driven`): APF dead-reckons its position and heading from the command it believes
moved the robot, and with a correction added that is no longer its own. This is residual policy
learning (Silver et al. 2018, Johannink et al. 2019): the network starts at ``g = 0`` (APF
itself) and learns what to add. Training runs the same prior inside the env
(:func:`~tin_swarm_env.adapters.puffer.make_puffer_env` ``prior="apf"``), so the actions PPO
samples are the corrections.

Mirror symmetry: the default APF is not exactly mirror-equivariant (its chart search breaks ties on a
grid, and its side preference, :attr:`~tin_swarm_env.policies.chart.ChartParams.side_cost`, gives a
fixed half of the robots one side), so a residual file over ``"apf"`` is not either, even with a
``"mirror"`` network. ``"prior": "apf_mirror"`` (:class:`MirrorAPFPrior`) is: two default APFs, one
fed the observations and one their mirror images (its commands mirrored back); where their commands
differ, a robot that has not yet chosen takes the one whose planned way to its target is shorter
(:func:`way_left`; equal: their mean, and it chooses later) and keeps it for the rest of its episode.
Both are told the executed command (the mirror stream its mirror image). Swapping the two streams
is what mirroring the observations does, and the choice is symmetric in them, so
``prior(M o) = M prior(o)`` over whole histories, exactly; with a ``"mirror"`` network the file is
exactly mirror-equivariant (``tests/policies/test_residual.py``).
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError

__all__ = ["PRIORS", "APFPrior", "MirrorAPFPrior", "make_prior", "add_prior", "way_left", "side_rows"]

PRIORS = ("none", "apf", "apf_mirror")  # "apf": the env's default APF; "apf_mirror": MirrorAPFPrior of two


class APFPrior:
    """The default APF of ``env`` as a residual policy's prior, over robot rows:
    ``prior(obs (n, d), rows) -> (n, 2)`` its commands (advancing its memory by ``obs``),
    :meth:`driven` (the commands executed), :meth:`reset`, :meth:`forget` (some rows only)."""

    def __init__(self, env):
        from .apf import APFPolicy

        self.apf = APFPolicy(env)

    def __call__(self, obs, rows=None) -> np.ndarray:
        return np.asarray(self.apf.act_batch(obs, rows), dtype=np.float64)

    def driven(self, act, rows=None) -> None:
        """Record the commands ``act (n, 2)`` that moved the robots ``rows`` (default ``0..n-1``)
        this step, after the last call: APF's odometry integrates them next step."""
        _record(self.apf, *_executed(act, rows, "APFPrior.driven"))

    def reset(self) -> None:
        self.apf.reset()

    def forget(self, rows) -> None:
        self.apf.forget(rows)


def _executed(act, rows, who: str) -> tuple[np.ndarray, np.ndarray]:
    """``act`` as ``(n, 2)`` float64 and its rows (default ``0..n-1``), checked against each other."""
    a = np.asarray(act, dtype=np.float64)
    rows = np.arange(len(a)) if rows is None else np.asarray(rows, dtype=np.int64)
    if a.shape != (len(rows), 2):
        raise ArgumentError(f"{who}: act must have shape ({len(rows)}, 2), one command per row, got {a.shape}")
    return a, rows


def _record(apf, a, rows) -> None:
    """APF's odometry integrates ``a`` as the last command of ``rows`` (no memory, the break field off:
    nothing integrates)."""
    if len(apf.memory.side):
        apf.memory.last_act[rows] = a


def way_left(apf, obs, rows) -> np.ndarray:
    """``(len(rows),)`` m: the length of the way each robot of ``rows`` has planned to its target on
    ``apf``'s chart (its route's cells from the one it is at, then straight from the route's last cell
    to the target; a robot with no route: its distance to go, read from ``obs``)."""
    from .base import decode

    ch = apf.charts
    rows = np.asarray(rows, dtype=np.int64)
    dist = decode(obs, apf.layout, apf.shield.range_m).dist
    if len(ch.cell) == 0:
        return np.asarray(dist, dtype=np.float64)
    C, L = ch.grid.shape[1], ch.route.shape[1]
    a, b = np.divmod(ch.route[rows].astype(np.int64), C)
    at, n = ch.route_at[rows], ch.route_len[rows]
    k = np.arange(L - 1)
    use = (k >= at[:, None]) & (k < n[:, None] - 1)
    path = np.sum(np.hypot(np.diff(a, axis=1), np.diff(b, axis=1)) * use, axis=1)
    end = np.clip(n - 1, 0, L - 1)[:, None]
    c0 = (C - 1) / 2
    tail = np.hypot(np.take_along_axis(a, end, 1)[:, 0] - c0, np.take_along_axis(b, end, 1)[:, 0] - c0)
    return np.where(n > 0, (path + tail) * ch.cell[rows], dist)


class MirrorAPFPrior:
    """The default APF made exactly mirror-equivariant (module docstring): ``prior(obs (n, d), rows)
    -> (n, 2)``, :meth:`driven`, :meth:`reset`, :meth:`forget`. ``choice``: per row, 1 the stream fed
    the observations, -1 the stream fed their mirror images, 0 not chosen yet (the two streams' mean)."""

    def __init__(self, env):
        from .apf import APFPolicy
        from .base import unwrap_env

        self.a, self.b = APFPolicy(env), APFPolicy(env)
        self.mirror = unwrap_env(env).layout.mirror
        self.choice = np.zeros(0, dtype=np.int8)

    def __call__(self, obs, rows=None) -> np.ndarray:
        from ..env.observation import mirror_action

        o = np.asarray(obs)
        rows = np.arange(len(o)) if rows is None else np.asarray(rows, dtype=np.int64)
        mo = self.mirror(o)
        xa = np.asarray(self.a.act_batch(o, rows), dtype=np.float64)
        xb = mirror_action(np.asarray(self.b.act_batch(mo, rows), dtype=np.float64))
        if len(self.choice) < int(rows.max(initial=-1)) + 1:
            self.choice = np.concatenate([self.choice, np.zeros(int(rows.max()) + 1 - len(self.choice), np.int8)])
        ch = self.choice[rows]
        new = (ch == 0) & np.any(xa != xb, axis=1)
        if new.any():  # the streams part: the one with the shorter way (equal: neither yet)
            i = np.flatnonzero(new)
            la, lb = way_left(self.a, o[i], rows[i]), way_left(self.b, mo[i], rows[i])
            ch[i] = np.where(la < lb, 1, np.where(lb < la, -1, 0))
            self.choice[rows[i]] = ch[i]
        c = ch[:, None]
        return np.where(c == 1, xa, np.where(c == -1, xb, (xa + xb) / 2))

    def driven(self, act, rows=None) -> None:
        """Tell both streams the executed commands ``act (n, 2)`` (the mirror stream their images)."""
        from ..env.observation import mirror_action

        a, rows = _executed(act, rows, "MirrorAPFPrior.driven")
        _record(self.a, a, rows)
        _record(self.b, mirror_action(a), rows)

    def reset(self) -> None:
        self.a.reset()
        self.b.reset()
        self.choice = np.zeros(0, dtype=np.int8)

    def forget(self, rows) -> None:
        self.a.forget(rows)
        self.b.forget(rows)
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        self.choice[rows[(rows >= 0) & (rows < len(self.choice))]] = 0


def make_prior(name: str, env, source: str = "make_prior") -> APFPrior | MirrorAPFPrior | None:
    """The prior ``name`` (one of :data:`PRIORS`) for ``env``; None for ``"none"``."""
    if name not in PRIORS:
        raise ArgumentError(f"{source}: prior {name!r} is not one of {list(PRIORS)}")
    if name == "none":
        return None
    if env is None:
        raise ArgumentError(f"{source}: a policy with a prior needs the env it acts in (load_policy(path, env))")
    return APFPrior(env) if name == "apf" else MirrorAPFPrior(env)


def add_prior(prior_act, g) -> np.ndarray:
    """``clip(prior_act + clip(g, -1, 1), -1, 1)`` as float32: the residual policy's command before the
    shield. The correction ``g`` is clipped to the action box first, as a trainer clips its samples
    to the action space before the env adds them to the prior (PuffeRL does)."""
    g = np.clip(np.asarray(g, dtype=np.float64), -1.0, 1.0)
    return np.clip(np.asarray(prior_act, dtype=np.float64) + g, -1.0, 1.0).astype(np.float32)


def side_rows(n_envs: int, n_robots: int) -> np.ndarray:
    """``(n_envs n_robots,)`` int64: a memory row for robot ``i`` of copy ``c`` (entry ``c n_robots + i``)
    whose side preference (:func:`~tin_swarm_env.policies.chart.robot_side`, a function of the row) is
    robot ``i``'s in an episode of its own (row ``i``), all rows distinct: so the APF of every copy of a
    vector env is the APF that acts for its robots when the file is deployed (rows ``0..n-1``)."""
    from .chart import robot_side

    n = n_envs * n_robots
    cand = np.arange(n_robots, 2 * n + 4 * n_robots + 8)  # copy 0 keeps rows 0..n_robots-1
    side = np.array([robot_side(int(r)) for r in cand])
    want = np.tile([robot_side(i) for i in range(n_robots)], n_envs)
    out = np.arange(n, dtype=np.int64)
    for s in (1.0, -1.0):  # the other copies' robots of side s take the free rows of side s, in order
        k = np.flatnonzero(want == s)
        k = k[k >= n_robots]
        out[k] = cand[side == s][:len(k)]
    return out
