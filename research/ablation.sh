#!/usr/bin/env bash
# The ablation table (docs/figures/ablation.md) (run by hand, one after the other, ~35 min
# on 2 cores; agents/reproduce_shared.sh gives the BC+DAgger and BC+DAgger+PPO rows):
#   bash research/ablation.sh            # outputs in runs/ablation/*
# * ppo_geodesic:  PPO from scratch, geodesic progress reward, the shared policy's terrain mix
# * ppo_euclidean: the same with the straight-line progress reward (research/scenarios/*_euclid.toml)
# * bc_fixed:      BC + DAgger (the shared recipe's imitation) on the fixed maps cliff_goal and ramp only
# Each PPO run gets MINUTES (default 12) of wall clock; the same network, shield and PPO settings as
# agents/reproduce_shared.sh.
set -e
cd "$(dirname "$0")/.."
mkdir -p runs/ablation
TRAIN=agents/scenarios/train_generated.toml  # the training families only: the held-out split stays out
PY=${PY:-python}
MINUTES=${MINUTES:-12}
PPO="--n-robots 8 --n-envs 2 --net-arch 256,256 --shield safety_cut --learning-rate 1e-4 --n-steps 256 \
  --batch-size 1024 --n-epochs 5 --gamma 0.995 --ent-coef 0.0 --eval-every 200000 --eval-episodes 2 \
  --checkpoint-every 1000000 --seed 0 --progress-bar false"
$PY agents/train_sb3.py --scenario $TRAIN,$TRAIN,cliff_goal,ramp $PPO --total-timesteps 50000000 \
  --max-minutes "$MINUTES" --out-dir runs/ablation/ppo_geodesic > runs/ablation/ppo_geodesic.log 2>&1
E=research/scenarios
$PY agents/train_sb3.py --scenario $E/generated_euclid.toml,$E/generated_euclid.toml,$E/cliff_goal_euclid.toml,$E/ramp_euclid.toml \
  $PPO --total-timesteps 50000000 --max-minutes "$MINUTES" --out-dir runs/ablation/ppo_euclidean \
  > runs/ablation/ppo_euclidean.log 2>&1
$PY agents/train_sb3.py --scenario cliff_goal,ramp $PPO --bc-episodes 40 --dagger-rounds 2 --dagger-episodes 20 \
  --dagger-beta 0.5 --stall-steps 60 --bc-epochs 30 --total-timesteps 0 --out-dir runs/ablation/bc_fixed \
  > runs/ablation/bc_fixed.log 2>&1
