#!/usr/bin/env bash
# Reproduces the shipped policy (agents/models/shared) on 2 cores in under 60 minutes through the vector env,
# then its learning curve on the standard suite's held-out split.
#   bash agents/reproduce_shared.sh        # outputs in runs/shared (log: runs/shared.log)
#   OUT=runs/x SEED=1 bash agents/reproduce_shared.sh   # elsewhere, and a seed that shares no draw with the first
# Recipe (agents/train_puffer.py: PufferLib's PPO on the vector env, 64 copies x 16 robots stepped by one call):
# * a residual policy over the mirror-equivariant APF (--prior apf_mirror; tin_swarm_env/policies/residual.py):
#   the robot drives shield(clip(apf(o) + clip(g(o)))), APF's command (two default APFs, one fed the mirror
#   images, one chosen per robot by the shorter planned way) plus a learned correction g; the env adds the
#   prior, so PPO's actions are the corrections; g starts near 0 (APF itself), its Gaussian's std at 0.2
#   (--init-logstd -1.6), and the actor's head waits 3 minutes while the critic learns (--critic-warmup-minutes);
# * terrain: generated terrains of the training families and two opt-in ones
#   (agents/scenarios/train_generated_extra.toml: canyons, mesas, hills, bays (a U-shaped dead end across the
#   way) and rough (steep hillside with no cliff); a new seeded terrain per reset, training seeds below
#   EVAL_SEED0) on half of the copies, cliff_goal and ramp on the others; the held-out families (fork, trap, the
#   real-DEM crops), the held-out maps, hill and jacksboro stay out (tests/training/test_held_out.py);
# * the default observation layout (its 32-beam terrain scan);
# * a mirror-equivariant actor and critic (--symmetry mirror: g is (g0(o) + M g0(M o)) / 2 of two tanh layers of
#   128 units; APF keeps the memory), so the file is exactly mirror-equivariant;
# * trained behind the safety shield (safety_cut, the default) and deployed behind the scan shield
#   (--export-shield safety_cut_scan: also one body diameter off where the scan's beams meet a dangerous break),
#   the rewards scaled by 0.01 (PuffeRL clips them to [-1, 1]);
# * PPO with the geodesic progress reward (the goal task's default) for MINUTES of wall clock
#   (snapshots every 10 minutes: the learning curve's points; each costs ~3 minutes on the held-out split).
# agents/models/shared is $OUT/policy of the shipped run (cp -r). The budget is wall clock, so a rerun
# stops after a different number of steps and does not give the same weights bit for bit; docs/learning.md
# gives the shipped run's and a rerun's figures.
set -e
cd "$(dirname "$0")/.."
mkdir -p runs
TRAIN=agents/scenarios/train_generated_extra.toml  # the training families and bay, rough: the held-out split stays out
PY=${PY:-python}
MINUTES=${MINUTES:-30}
OUT=${OUT:-runs/shared}
SEED=${SEED:-0}  # the seed of the copies' terrain streams and of torch
$PY agents/train_puffer.py --scenario $TRAIN,$TRAIN,cliff_goal,ramp --symmetry mirror --prior apf_mirror \
  --init-logstd -1.6 --critic-warmup-minutes 3 --export-shield safety_cut_scan --snapshot-minutes 10 \
  --max-minutes "$MINUTES" --seed "$SEED" --out-dir "$OUT" > "$OUT.log" 2>&1
$PY agents/suite_curve.py --runs "$OUT" --splits held_out --out "$OUT/curve_held_out.png" >> "$OUT.log" 2>&1
