#!/usr/bin/env bash
# Reproduces the shipped policy (agents/models/shared) on 2 cores in under 60 minutes through the vector env,
# then its learning curve on the standard suite's held-out split.
#   bash agents/reproduce_shared.sh        # outputs in runs/shared (log: runs/shared.log)
# Recipe (agents/train_puffer.py: PufferLib's PPO on the vector env, 64 copies x 16 robots stepped by one call):
# * terrain: generated terrains of the training families and two opt-in ones
#   (agents/scenarios/train_generated_extra.toml: canyons, mesas, hills, bays (a U-shaped dead end across the
#   way) and rough (steep hillside with no cliff); a new seeded terrain per reset, training seeds below
#   EVAL_SEED0) on half of the copies, cliff_goal and ramp on the others; the held-out families (fork, trap, the
#   real-DEM crops), the held-out maps, hill and jacksboro stay out (tests/training/test_held_out.py);
# * the default observation layout (its 32-beam terrain scan);
# * a mirror-equivariant recurrent actor and critic (--symmetry mirror --cell gru: a GRU of 128 units runs over
#   the observations and, in a second stream, over their mirror images, so it remembers the walls it has met;
#   the action is (g(h) + M g(M h)) / 2 of the two streams' heads, exported as a recurrent "symmetry": "mirror"
#   file whose state runs over the whole episode; PuffeRL trains it over --horizon 128 steps at a time),
#   heads of two tanh layers of 128 units, trained behind the safety shield (safety_cut, the
#   default) and deployed behind the scan shield (--export-shield safety_cut_scan: also one body diameter off
#   where the scan's beams meet a dangerous break, which stops the falls on real hillside), the rewards scaled
#   by 0.01 (PuffeRL clips them to [-1, 1]);
# * PPO from scratch with the geodesic progress reward (the goal task's default) for MINUTES of wall clock
#   (snapshots every 5 minutes: the learning curve's points).
# agents/models/shared is runs/shared/policy of the shipped run (cp -r). The budget is wall clock, so a rerun
# stops after a different number of steps and does not give the same weights bit for bit; docs/learning.md
# gives the shipped run's and a rerun's figures.
set -e
cd "$(dirname "$0")/.."
mkdir -p runs
TRAIN=agents/scenarios/train_generated_extra.toml  # the training families and bay, rough: the held-out split stays out
PY=${PY:-python}
MINUTES=${MINUTES:-30}
$PY agents/train_puffer.py --scenario $TRAIN,$TRAIN,cliff_goal,ramp --symmetry mirror --cell gru --hidden 128 --horizon 128 \
  --export-shield safety_cut_scan \
  --max-minutes "$MINUTES" --seed 0 --out-dir runs/shared > runs/shared.log 2>&1
$PY agents/suite_curve.py --runs runs/shared --splits held_out --out runs/shared/curve_held_out.png >> runs/shared.log 2>&1
