"""Re-export a pickle-free policy directory with ``"symmetry": "mirror"`` (or back to ``"none"``):
the same weights, acting as ``clip((g(o) + M g(M o)) / 2)`` (:mod:`tin_swarm_env.policies.symmetry`).

    python agents/mirror_policy.py agents/models/shared_sb3 runs/shared_mirror
    python agents/mirror_policy.py runs/shared_mirror runs/shared_plain --symmetry none

The training metadata is kept; ``training.symmetry_added`` records that the option was switched
on after training (no retraining).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.policies import save_policy
from tin_swarm_env.policies.learned import POLICY_JSON, WEIGHTS, read_weights, validate_policy
from tin_swarm_env.policies.symmetry import SYMMETRIES


def main(a):
    src = Path(a.src)
    meta = json.loads((src / POLICY_JSON).read_text(encoding="utf-8"))
    layers = validate_policy(meta, read_weights(src / WEIGHTS), str(src / POLICY_JSON), str(src / WEIGHTS))
    if meta["network"].get("type", "mlp") != "mlp":
        raise SystemExit(f"{src}: only MLP policy files are re-exported here (network.type {meta['network']['type']!r})")
    ObsLayout.from_dict(meta["observation"]["layout"])  # the mirror needs a layout this version reads
    extra = dict(meta.get("training", {}))
    if a.symmetry != "none":
        extra["symmetry_added"] = f"{a.symmetry} (re-exported from {src} by agents/mirror_policy.py)"
    net = meta["network"]
    out = save_policy(a.dst, layers, net["activation"], layout=meta["observation"]["layout"],
                      scenario=meta["scenario"], action_transform=net["action_transform"], extra=extra,
                      shield=meta.get("shield", "none"), symmetry=a.symmetry)
    print(f"wrote {out} (symmetry {a.symmetry!r})")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("src")
    p.add_argument("dst")
    p.add_argument("--symmetry", choices=SYMMETRIES, default="mirror")
    main(p.parse_args())
