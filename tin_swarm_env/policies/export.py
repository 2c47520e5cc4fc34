"""Export another library's trained actor to a pickle-free policy file, and check the export.

A Gaussian actor's deterministic action is its mean, passed through the library's action
transform; each library maps that mean to our ``[-1, 1]^2`` action box in one of two ways:

* ``squash="clip"``: the mean, clipped to the box. RLlib's PPO (new API stack; its
  ``normalize_actions=True`` unsquashes ``a`` to ``low + (a + 1) (high - low) / 2`` and clips, the
  identity plus a clip on ``[-1, 1]``) and SB3's ``predict(deterministic=True)``. This is the policy
  file's own ``"action_transform": "clip"``.
* ``squash="tanh"``: ``tanh`` of the mean, as torchrl's ``TanhNormal`` (BenchMARL's MAPPO and
  IPPO with ``use_tanh_normal=True``, their default; its deterministic sample is ``tanh(loc)``,
  rescaled to ``[low, high]``, the identity on ``[-1, 1]``). The file format has no tanh on the
  output, but it applies the network's activation after every layer but the last, so for a
  ``tanh`` network ``tanh(W_L h + b_L)`` is written exactly as one more layer, the identity
  ``(I, 0)``, after it (``layer_sizes`` ends ``..., 2, 2``; ``training["action_squash"]`` says so).

``layers`` are ``[(W (out, in), b (out,)), ...]`` of the actor's mean network alone (the rows of
the last layer that give the mean; a library whose head also outputs a log-std keeps those rows
out). :func:`max_action_gap` is the check every exporter runs after writing: the largest
difference between the loaded file's actions and the library's own deterministic actions on a
batch of real observations.
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError
from .learned import ACTION_SIZE, load_policy, save_policy

__all__ = ["SQUASHES", "export_actor", "max_action_gap", "real_observations"]

SQUASHES = ("clip", "tanh")


def export_actor(path, layers, activation: str, *, squash: str, layout, scenario: str, extra: dict | None = None,
                 shield: str = "none", symmetry: str = "none", prior: str = "none"):
    """Write the mean network ``layers`` with hidden ``activation`` and the library's action
    ``squash`` (see the module docstring) as a policy directory ``path`` (``shield``: the file's
    shield, for an actor trained behind it; ``symmetry``: ``"mirror"`` for an actor whose mean is
    ``(g(o) + M g(M o)) / 2``, ``layers`` being ``g``; ``prior``: ``"apf"`` or ``"apf_mirror"`` for a residual
    actor whose mean is added to APF's command, :mod:`~tin_swarm_env.policies.residual`); returns the path."""
    if squash not in SQUASHES:
        raise ArgumentError(f"squash must be one of {list(SQUASHES)}, got {squash!r}")
    layers = [(np.asarray(W, dtype=np.float64), np.asarray(b, dtype=np.float64)) for W, b in layers]
    if not layers or layers[-1][0].shape[0] != ACTION_SIZE:
        raise ArgumentError(f"the mean network's last layer must have {ACTION_SIZE} outputs (the action), got "
                            f"{layers[-1][0].shape[0] if layers else 'no layers'}")
    extra = {**(extra or {}), "action_squash": squash}
    if squash == "tanh":
        if activation != "tanh":
            raise ArgumentError(f"squash='tanh' is written as a tanh activation before an identity layer, so the "
                                f"hidden activation must be 'tanh' too, got {activation!r}")
        layers.append((np.eye(ACTION_SIZE), np.zeros(ACTION_SIZE)))
        extra["action_squash"] = "tanh (the last layer is the identity after the network's tanh)"
    return save_policy(path, layers, activation, layout=layout, scenario=scenario, action_transform="clip",
                       extra=extra, shield=shield, symmetry=symmetry, prior=prior)


def real_observations(env, policy=None, *, seeds=(0,), steps: int = 60, every: int = 5) -> np.ndarray:
    """``(n, d)`` observations of live robots from short episodes of ``env`` (a tin_swarm
    PettingZoo parallel env) driven by ``policy`` (``act(obs dict) -> action dict``; None: the
    scenario's APF, which reaches cliffs, slopes and neighbours): every ``every``-th step of
    ``steps`` from each of ``seeds``."""
    from .apf import APFPolicy

    pol = policy if policy is not None else APFPolicy(env)
    rows = []
    for s in seeds:
        obs, _ = env.reset(seed=int(s))
        if hasattr(pol, "reset"):
            pol.reset()
        for t in range(steps):
            if not obs:
                break
            if t % every == 0:
                rows.extend(np.asarray(o, dtype=np.float64) for o in obs.values())
            obs, *_ = env.step(pol.act(obs))
    if not rows:
        raise ArgumentError("no live robot to observe: every episode ended at once")
    return np.stack(rows)


def max_action_gap(path, env, torch_actions, obs) -> float:
    """Largest ``|a_file - a_library|`` over the batch ``obs (n, d)``: ``a_file`` from the policy
    directory ``path`` loaded for ``env``, ``a_library = torch_actions(obs)`` ``(n, 2)`` (the
    library's deterministic action)."""
    pol = load_policy(path, env)
    mine = pol.act_batch(obs).astype(np.float64)
    theirs = np.asarray(torch_actions(np.asarray(obs, dtype=np.float32)), dtype=np.float64)
    if theirs.shape != mine.shape:
        raise ArgumentError(f"the library's actions have shape {theirs.shape}, the file's {mine.shape}")
    return float(np.abs(mine - theirs).max())
