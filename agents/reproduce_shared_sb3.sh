#!/usr/bin/env bash
# Reproduces the policy shipped until 2026-12-04 (agents/models/shared_sb3, SB3, the old observation layout without
# the terrain scan; docs/figures/shipped_policy.md) on 2 cores in under 60 minutes, then its evaluation table.
#   bash agents/reproduce_shared_sb3.sh    # outputs in runs/shared_sb3 (log: runs/shared_sb3.log)
# The shipped policy's recipe is now agents/reproduce_shared.sh (PufferLib through the vector env); this one is the
# SB3 route (bench/train.py times its PPO). Its run trained on the old default layout; rerun today it trains on the
# default layout of the day.
# Recipe (all through agents/train_sb3.py):
# * terrain: generated terrains (a new seeded terrain per reset: canyons, mesas, hills; training seeds
#   below EVAL_SEED0 (tin_swarm_env.training.evaluation), evaluation seeds from it, so the table's "generated" rows are terrains never trained on),
#   half of the episodes, plus cliff_goal and ramp; hill, valley, the canyon files and jacksboro stay
#   held out;
# * behaviour cloning from APF (40 episodes), two DAgger rounds of 20 episodes with beta-mixing (APF
#   drives each robot-step with probability 0.5, then 0.25) and stalled robots' samples dropped after
#   60 steps without progress;
# * the learner acts through the policy-file shield (--shield safety_cut: APF's last cut, from the
#   observation) in DAgger, in PPO's environment and in the exported file;
# * PPO fine-tuning with the geodesic progress reward (the goal task's default), to 40 minutes in all
#   (the shipped run: imitation 12.6 min, then 3.49 M PPO timesteps; 40.2 min on the idle 2-core machine).
# runs/shared_sb3/policy_imitation is the policy before PPO (the "BC+DAgger" row), runs/shared_sb3/policy after.
set -e
cd "$(dirname "$0")/.."
mkdir -p runs
TRAIN=agents/scenarios/train_generated.toml  # the training families only: the held-out split stays out
PY=${PY:-python}
MINUTES=${MINUTES:-40}
$PY agents/train_sb3.py --scenario $TRAIN,$TRAIN,cliff_goal,ramp --n-robots 8 --n-envs 2 --net-arch 256,256 \
  --bc-episodes 40 --dagger-rounds 2 --dagger-episodes 20 --dagger-beta 0.5 --stall-steps 60 \
  --bc-epochs 30 --bc-std 0.3 --value-epochs 10 --shield safety_cut \
  --learning-rate 1e-4 --n-steps 256 --batch-size 1024 --n-epochs 5 --gamma 0.995 --ent-coef 0.0 \
  --total-timesteps 50000000 --max-minutes "$MINUTES" --eval-every 200000 --eval-episodes 2 --checkpoint-every 400000 \
  --seed 0 --out-dir runs/shared_sb3 --progress-bar false > runs/shared_sb3.log 2>&1
# agents/models/shared_sb3 is runs/shared_sb3/policy of that run (cp -r). The budget is wall clock, so a rerun
# stops after a different number of PPO steps and does not give the same weights bit for bit; the table of
# docs/figures/shipped_policy.md says which of the issue's numbers the shipped file meets.
$PY agents/evaluate.py --scenarios cliff_goal,ramp,hill,generated,scenarios/canyon_left.toml,scenarios/canyon_right.toml,scenarios/valley.toml,jacksboro \
  --seeds 20 --robots 20 --models "shared_sb3=runs/shared_sb3/policy,bc+dagger=runs/shared_sb3/policy_imitation" --out runs/eval_shared_sb3
